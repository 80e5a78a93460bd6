//! The cascaded flight controller of the paper, equations (1)–(5).
//!
//! Inputs: the reference (guidance), the measured position and velocity in the mocap's NED frame,
//! and the attitude estimate `Rot<Body, MocapNav>` *after* removing the estimated marker offset —
//! so the offset enters C_n^b, X₁, T_w⁻¹ and F_T,com through one place, the attitude estimate.
//!
//! ```text
//! (1)  ΔX^b = C_n^b·(X_com − X_meas)
//! (2)  [u̇ v̇ ẇ]_com = a_ff^b + K_V·(K_X·ΔX^b + v_ff^b − [u v w])        (feed-forward added)
//!      φ_com = arcsin(X₁),  X₁ = v̇_com/(g·cos θ_m) clamped to [−1, 1]
//!      θ_com = arcsin(X₂),  X₂ = u̇_com/(−g)        clamped to [−1, 1]
//!      |φ_com| ≤ φ_c,max,   |θ_com| ≤ θ_c,max
//! (3)  [p q r]_com = T_w⁻¹(φ_m, θ_m)·[K_φ(φ_com − φ_m), K_θ(θ_com − θ_m), K_ψ·wrap(ψ_com − ψ_m) + ψ̇_ff]
//! (4)  T_w⁻¹ = [[1, 0, −sin θ], [0, cos φ, cos θ·sin φ], [0, −sin φ, cos θ·cos φ]]
//! (5)  F_T,com = m·(ẇ_com − g·cos φ_m·cos θ_m),  thrust T = −F_T,com clipped to [0, F_T,max]
//! ```
//!
//! The paper's approximations (the ≈ forms, without the p, q, r coupling terms) are used, as the
//! paper does. [u v w] = C_n^b·Ẋ_meas. The yaw-calibration flight (6) replaces the lateral loop by
//! φ_com = 0 ([`LateralMode::RollZero`]).
//!
//! The output carries both what a rate-mode vehicle needs (p, q, r of (3)) and what an
//! attitude-mode vehicle needs (φ_com, θ_com and the heading rate ψ̇_com, the third row of (3)
//! before T_w⁻¹); the radio sends the one the vehicle's [`crate::vehicle::OnboardMode`] tracks. In
//! attitude mode (3)'s roll and pitch rows and (4) run onboard, on the vehicle's own angles.

use crate::frames::{Body, Euler, MocapNav, Rot, Vec3, t_w_inv, t_w_inv_sc, wrap_pi};
use crate::vehicle::params::GRAVITY;
use nalgebra::Vector3;

/// The cascaded controller's gains and limits.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Gains {
    /// K_X: position → velocity (1/s), per body axis.
    pub k_x: [f64; 3],
    /// K_V: velocity → acceleration (1/s), per body axis.
    pub k_v: [f64; 3],
    /// K_φ, K_θ, K_ψ: angle → Euler-rate (1/s).
    pub k_att: [f64; 3],
    /// φ_c,max, θ_c,max (rad).
    pub max_tilt: [f64; 2],
    /// F_T,max (N).
    pub thrust_max_n: f64,
    /// The vehicle mass the controller assumes (kg).
    pub mass_kg: f64,
}

/// Whether the lateral axis is closed or held at φ_com = 0.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum LateralMode {
    /// Normal closed-loop position control on all axes.
    Closed,
    /// Equation (6): φ_com = 0, the lateral axis open loop (yaw-offset flight).
    RollZero,
}

/// What guidance asks for, in the mocap's NED frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Reference {
    /// Position set point (m).
    pub pos: Vec3<MocapNav>,
    /// Velocity feed-forward (m/s).
    pub vel: Vec3<MocapNav>,
    /// Acceleration feed-forward (m/s²).
    pub acc: Vec3<MocapNav>,
    /// Heading set point ψ_com (rad).
    pub yaw: f64,
    /// Heading rate feed-forward (rad/s).
    pub yaw_rate: f64,
    /// Closed, or (6)'s φ_com = 0.
    pub lateral: LateralMode,
    /// Motors off (on the floor before take-off and after landing).
    pub motors_off: bool,
}

/// The controller's output and the intermediate quantities worth logging.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ControlOutput {
    /// p_com, q_com, r_com (rad/s).
    pub rates: Vec3<Body>,
    /// Collective thrust magnitude −F_T,com (N).
    pub thrust_n: f64,
    /// φ_com, θ_com, ψ_com.
    pub angles_com: Euler,
    /// ψ̇_com = K_ψ·wrap(ψ_com − ψ_m) + ψ̇_ff, the third Euler rate of (3) (rad/s): what the
    /// radio's heading channel carries in attitude mode.
    pub yaw_rate_com: f64,
    /// [u̇ v̇ ẇ]_com (m/s²).
    pub accel_com: Vec3<Body>,
}

/// (sin φ, cos φ) and (sin θ, cos θ) of an attitude, read off C_b^n itself instead of calling the
/// trigonometric functions on its Euler angles: R₃₁ = −sin θ, R₃₂ = sin φ·cos θ,
/// R₃₃ = cos φ·cos θ (cos θ ≥ 0 for the Z-Y-X angles, |θ| ≤ π/2). At θ = ±π/2 exactly, φ is
/// not defined by R and the angles' own sines are used.
fn roll_pitch_sin_cos<A: crate::frames::Frame, B: crate::frames::Frame>(
    att: &Rot<A, B>,
    e: &Euler,
) -> ((f64, f64), (f64, f64)) {
    let r = att.matrix();
    let ct = (r[(2, 1)] * r[(2, 1)] + r[(2, 2)] * r[(2, 2)]).sqrt();
    if ct > 0.0 { ((r[(2, 1)] / ct, r[(2, 2)] / ct), (-r[(2, 0)], ct)) } else { (e.roll.sin_cos(), e.pitch.sin_cos()) }
}

/// One evaluation of (1)–(5).
pub fn control(
    g: &Gains,
    r: &Reference,
    pos: Vec3<MocapNav>,
    vel: Vec3<MocapNav>,
    att: Rot<Body, MocapNav>,
) -> ControlOutput {
    let e = att.euler();
    let (roll_sc, pitch_sc) = roll_pitch_sin_cos(&att, &e);
    let c_n_b = att.inverse();
    let dx_b = c_n_b.apply(r.pos - pos); // (1)
    let v_b = c_n_b.apply(vel);
    let vff_b = c_n_b.apply(r.vel);
    let aff_b = c_n_b.apply(r.acc);
    let acc = aff_b + (dx_b.component_mul(&g.k_x) + vff_b - v_b).component_mul(&g.k_v); // (2)
    let x1 = (acc.y() / (GRAVITY * pitch_sc.1)).clamp(-1.0, 1.0);
    let x2 = (acc.x() / -GRAVITY).clamp(-1.0, 1.0);
    let mut roll_com = x1.asin().clamp(-g.max_tilt[0], g.max_tilt[0]);
    if r.lateral == LateralMode::RollZero {
        roll_com = 0.0; // (6)
    }
    let pitch_com = x2.asin().clamp(-g.max_tilt[1], g.max_tilt[1]);
    let euler_rates = Vector3::new(
        g.k_att[0] * (roll_com - e.roll),
        g.k_att[1] * (pitch_com - e.pitch),
        g.k_att[2] * wrap_pi(r.yaw - e.yaw) + r.yaw_rate,
    );
    let pqr = t_w_inv_sc(roll_sc, pitch_sc) * euler_rates; // (3), (4)
    let f_t = g.mass_kg * (acc.z() - GRAVITY * roll_sc.1 * pitch_sc.1); // (5)
    let thrust = if r.motors_off { 0.0 } else { (-f_t).clamp(0.0, g.thrust_max_n) };
    ControlOutput {
        rates: if r.motors_off { Vec3::zeros() } else { Vec3::from_raw(pqr) },
        thrust_n: thrust,
        angles_com: Euler::new(roll_com, pitch_com, r.yaw),
        yaw_rate_com: if r.motors_off { 0.0 } else { euler_rates.z },
        accel_com: acc,
    }
}

/// The failsafe law, used when the mocap has been silent for longer than the timeout: level
/// attitude (φ_com = θ_com = 0, the last yaw held) through the attitude loop of (3)–(4) on the
/// dead-reckoned attitude, and a thrust of `fraction`·m·g/(cos φ·cos θ), whose vertical part is
/// `fraction`·m·g: the vehicle sinks with (1 − fraction)·g (0.29 m/s² for 0.97). `motors_off`
/// cuts the thrust (after landing).
pub fn failsafe(g: &Gains, att: Rot<Body, MocapNav>, yaw_hold: f64, fraction: f64, motors_off: bool) -> ControlOutput {
    let e = att.euler();
    let euler_rates = Vector3::new(g.k_att[0] * -e.roll, g.k_att[1] * -e.pitch, g.k_att[2] * wrap_pi(yaw_hold - e.yaw));
    let tilt = (e.roll.cos() * e.pitch.cos()).max(0.5);
    let thrust = if motors_off { 0.0 } else { (fraction * g.mass_kg * GRAVITY / tilt).clamp(0.0, g.thrust_max_n) };
    ControlOutput {
        rates: if motors_off { Vec3::zeros() } else { Vec3::from_raw(t_w_inv(e.roll, e.pitch) * euler_rates) },
        thrust_n: thrust,
        angles_com: Euler::new(0.0, 0.0, yaw_hold),
        yaw_rate_com: if motors_off { 0.0 } else { euler_rates.z },
        accel_com: Vec3::new(0.0, 0.0, (1.0 - fraction) * GRAVITY),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn failsafe_levels_and_sinks_slowly() {
        let g = gains();
        // rolled right 10°: roll rate command to the left, thrust holds 97 % of the weight vertically
        let att: Rot<Body, MocapNav> = Rot::from_euler(Euler::from_degrees(10.0, 0.0, 30.0));
        let out = failsafe(&g, att, 30f64.to_radians(), 0.97, false);
        assert!(out.rates.x() < 0.0 && out.rates.z().abs() < 1e-12);
        assert!((out.thrust_n * 10f64.to_radians().cos() - 0.97 * 0.68 * GRAVITY).abs() < 1e-12);
        assert_eq!(failsafe(&g, att, 0.0, 0.97, true).thrust_n, 0.0);
    }

    /// The failsafe law by hand, rolled, pitched and off its held yaw, with a gain per axis: Euler
    /// rates (−k_φ·φ, −k_θ·θ, k_ψ·(ψ_hold − ψ)) mapped to body rates by ω = φ̇·x̂ + R_x(φ)ᵀ·(θ̇·ŷ +
    /// R_y(θ)ᵀ·ψ̇·ẑ) (derived independently of `t_w_inv`), and thrust f·m·g/(cos φ·cos θ); with the
    /// motors off, no rates and no thrust. A bug it catches: the roll term k_φ/(−φ) (the test above
    /// checked only the roll rate's sign).
    #[test]
    fn failsafe_rates_and_thrust_by_hand_off_level() {
        let g = Gains { k_att: [6.0, 5.0, 3.0], ..gains() };
        let (phi, theta, psi, hold) = (0.17_f64, -0.09_f64, 0.5_f64, 0.7_f64);
        let att: Rot<Body, MocapNav> = Rot::from_euler(Euler::new(phi, theta, psi));
        let out = failsafe(&g, att, hold, 0.97, false);
        let euler_rates = Vector3::new(-6.0 * phi, -5.0 * theta, 3.0 * (hold - psi));
        let omega = body_rates_by_hand(phi, theta, euler_rates);
        assert!((out.rates.raw() - omega).norm() < 1e-12, "{:?} vs {omega:?}", out.rates);
        assert!((out.thrust_n - 0.97 * 0.68 * GRAVITY / (phi.cos() * theta.cos())).abs() < 1e-12, "{}", out.thrust_n);
        // the sink the law expects, (1 − 0.97)·9.81 m/s² down the body z axis (a bug it catches: (1
        // − f)·g as (1 − f) + g, (1 − f)/g and (1 + f)·g)
        assert!((out.accel_com.raw() - Vector3::new(0.0, 0.0, 0.2943)).norm() < 1e-12, "{:?}", out.accel_com);
        let off = failsafe(&g, att, hold, 0.97, true);
        assert_eq!((off.rates, off.thrust_n), (Vec3::zeros(), 0.0));
    }

    fn gains() -> Gains {
        Gains {
            k_x: [1.0; 3],
            k_v: [2.0, 2.0, 3.0],
            k_att: [6.0, 6.0, 3.0],
            max_tilt: [0.35, 0.35],
            thrust_max_n: 24.0,
            mass_kg: 0.68,
        }
    }

    fn hold(p: Vec3<MocapNav>) -> Reference {
        Reference {
            pos: p,
            vel: Vec3::zeros(),
            acc: Vec3::zeros(),
            yaw: 0.0,
            yaw_rate: 0.0,
            lateral: LateralMode::Closed,
            motors_off: false,
        }
    }

    #[test]
    fn level_hover_on_the_spot_commands_weight_and_no_rates() {
        let p = Vec3::new(1.0, 2.0, -1.0);
        let out = control(&gains(), &hold(p), p, Vec3::zeros(), Rot::identity());
        assert!((out.thrust_n - 0.68 * 9.81).abs() < 1e-12);
        assert_eq!(out.rates, Vec3::zeros());
    }

    #[test]
    fn sines_and_cosines_from_the_matrix_equal_the_angles() {
        for (roll, pitch, yaw) in [(0.3, -0.2, 2.5), (-1.2, 1.4, -3.0), (0.0, 0.0, 0.0), (3.0, -1.5, 1.0)] {
            let att: Rot<Body, MocapNav> = Rot::from_euler(Euler::new(roll, pitch, yaw));
            let e = att.euler();
            let ((sf, cf), (st, ct)) = roll_pitch_sin_cos(&att, &e);
            let ((sf2, cf2), (st2, ct2)) = (e.roll.sin_cos(), e.pitch.sin_cos());
            for (a, b) in [(sf, sf2), (cf, cf2), (st, st2), (ct, ct2)] {
                assert!((a - b).abs() < 1e-14, "({roll}, {pitch}): {a} vs {b}");
            }
        }
        // θ = π/2 exactly: q = (½, ½, ½, −½) has R₃₁ = 2(q_x·q_z − q_w·q_y) = −1,
        // R₃₂ = 2(q_y·q_z + q_w·q_x) = 0 and R₃₃ = 1 − 2(q_x² + q_y²) = 0 to the bit, so
        // cos θ = 0, φ is not defined by R and the angles' own sines are used (dividing by
        // cos θ would give 0/0)
        let q = nalgebra::UnitQuaternion::new_unchecked(nalgebra::Quaternion::new(0.5, 0.5, 0.5, -0.5));
        let att: Rot<Body, MocapNav> = Rot::from_quaternion(q);
        assert_eq!((att.matrix()[(2, 1)], att.matrix()[(2, 2)]), (0.0, 0.0));
        let e = att.euler();
        assert_eq!(roll_pitch_sin_cos(&att, &e), (e.roll.sin_cos(), e.pitch.sin_cos()));
        assert!((e.pitch - std::f64::consts::FRAC_PI_2).abs() < 1e-7, "pitch {}", e.pitch);
    }

    /// Body rates from ZYX Euler-angle rates, derived independently of `t_w_inv`:
    /// ω = ṙoll·x̂ + Rx(φ)ᵀ·(ṗitch·ŷ + Ry(θ)ᵀ·ẏaw·ẑ).
    fn body_rates_by_hand(phi: f64, theta: f64, rates: Vector3<f64>) -> Vector3<f64> {
        let rx = nalgebra::Rotation3::from_axis_angle(&Vector3::x_axis(), phi);
        let ry = nalgebra::Rotation3::from_axis_angle(&Vector3::y_axis(), theta);
        Vector3::x() * rates.x + rx.inverse() * (Vector3::y() * rates.y + ry.inverse() * (Vector3::z() * rates.z))
    }

    #[test]
    fn t_w_inv_inverts_the_euler_rate_map() {
        let (phi, theta) = (0.4_f64, -0.3_f64);
        let rates = Vector3::new(0.3, -0.7, 1.1);
        assert!((t_w_inv(phi, theta) * rates - body_rates_by_hand(phi, theta, rates)).norm() < 1e-14);
    }

    #[test]
    fn a_vehicle_east_of_its_reference_rolls_left() {
        let r = hold(Vec3::zeros());
        let out = control(&gains(), &r, Vec3::new(0.0, 0.1, 0.0), Vec3::zeros(), Rot::identity());
        // v̇_com = K_V·K_X·(−0.1) = −0.2 m/s²  →  φ_com = asin(−0.2/g)
        assert!((out.angles_com.roll - (-0.2f64 / 9.81).asin()).abs() < 1e-12);
        assert!(out.rates.x() < 0.0);
    }

    /// (1)–(5) by hand at a tilted, yawed attitude, with position, velocity, acceleration and
    /// yaw-rate feed-forward and different gains on every axis (so K_X and K_V, the axes, and
    /// φ and θ in T_w⁻¹ cannot be exchanged unnoticed). C_b^n is built here from its elementary
    /// rotations Rz(ψ)·Ry(θ)·Rx(φ), not from the code's attitude type.
    #[test]
    fn the_cascade_in_closed_form_off_identity() {
        let g = Gains {
            k_x: [1.0, 1.5, 0.8],
            k_v: [2.0, 2.5, 3.0],
            k_att: [6.0, 5.0, 3.0],
            max_tilt: [0.6, 0.6],
            thrust_max_n: 24.0,
            mass_kg: 0.68,
        };
        let (phi, theta, psi) = (0.1, -0.2, 0.5);
        let rot =
            |axis: nalgebra::Unit<Vector3<f64>>, a: f64| nalgebra::Rotation3::from_axis_angle(&axis, a).into_inner();
        let c_b_n = rot(Vector3::z_axis(), psi) * rot(Vector3::y_axis(), theta) * rot(Vector3::x_axis(), phi);
        let c_n_b = c_b_n.transpose();
        let att: Rot<Body, MocapNav> = Rot::from_euler(Euler::new(phi, theta, psi));
        let (r_pos, r_vel, r_acc) =
            (Vector3::new(1.0, -0.5, -1.2), Vector3::new(0.3, 0.2, -0.1), Vector3::new(0.2, -0.3, 0.1));
        let (pos, vel) = (Vector3::new(0.8, -0.3, -1.0), Vector3::new(0.1, 0.4, 0.05));
        let r = Reference {
            pos: Vec3::from_raw(r_pos),
            vel: Vec3::from_raw(r_vel),
            acc: Vec3::from_raw(r_acc),
            yaw: 0.7,
            yaw_rate: 0.2,
            lateral: LateralMode::Closed,
            motors_off: false,
        };
        let out = control(&g, &r, Vec3::from_raw(pos), Vec3::from_raw(vel), att);
        let dx = c_n_b * (r_pos - pos);
        let dv = c_n_b * (r_vel - vel);
        let a = c_n_b * r_acc
            + Vector3::new(
                g.k_v[0] * (g.k_x[0] * dx.x + dv.x),
                g.k_v[1] * (g.k_x[1] * dx.y + dv.y),
                g.k_v[2] * (g.k_x[2] * dx.z + dv.z),
            );
        assert!((out.accel_com.raw() - a).norm() < 1e-12, "(2): {:?} vs {a:?}", out.accel_com);
        let roll_com = (a.y / (GRAVITY * theta.cos())).asin();
        let pitch_com = (-a.x / GRAVITY).asin();
        assert!((out.angles_com.roll - roll_com).abs() < 1e-12 && (out.angles_com.pitch - pitch_com).abs() < 1e-12);
        let rates = Vector3::new(6.0 * (roll_com - phi), 5.0 * (pitch_com - theta), 3.0 * (0.7 - psi) + 0.2);
        let t = nalgebra::Matrix3::new(
            1.0,
            0.0,
            -theta.sin(),
            0.0,
            phi.cos(),
            theta.cos() * phi.sin(),
            0.0,
            -phi.sin(),
            theta.cos() * phi.cos(),
        );
        assert!((out.rates.raw() - t * rates).norm() < 1e-12, "(3)-(4): {:?} vs {:?}", out.rates, t * rates);
        let thrust = -0.68 * (a.z - GRAVITY * phi.cos() * theta.cos());
        assert!((out.thrust_n - thrust).abs() < 1e-12, "(5): {} vs {thrust}", out.thrust_n);
        // (6): the yaw flight holds φ_com = 0 whatever the lateral error, and nothing else changes
        let six = control(
            &g,
            &Reference { lateral: LateralMode::RollZero, ..r },
            Vec3::from_raw(pos),
            Vec3::from_raw(vel),
            att,
        );
        assert!(
            six.angles_com.roll == 0.0
                && roll_com.abs() > 0.01
                && six.angles_com.pitch == out.angles_com.pitch
                && six.thrust_n == out.thrust_n
        );
        let rates6 = Vector3::new(6.0 * -phi, rates.y, rates.z);
        assert!((six.rates.raw() - t * rates6).norm() < 1e-12);
    }

    #[test]
    fn angle_commands_saturate() {
        let out = control(&gains(), &hold(Vec3::zeros()), Vec3::new(-50.0, 50.0, 0.0), Vec3::zeros(), Rot::identity());
        // far South-East of the reference: full nose-down (forward) and full left roll
        assert!((out.angles_com.roll + 0.35).abs() < 1e-12 && (out.angles_com.pitch + 0.35).abs() < 1e-12);
    }
}

//! Rigid-body dynamics of the X3D, integrated with classical RK4 at the physics rate (1 kHz).
//!
//! State (SI units): position p and velocity v in [`Nav`] (NED, m and m/s), attitude q as the unit
//! quaternion of C_b^n (`Rot<Body, Nav>`), body rates ω in [`Body`] (rad/s), rotor speeds Ω_i (rad/s).
//!
//! ```text
//! ṗ = v
//! v̇ = g·e_D + (C_b^n·F_b + F_ext)/m,       F_b = (−m·k_x·u, −m·k_y·v_b, −Σ k_f·Ω_i²)
//! q̇ = ½·q ⊗ (0, ω)
//! ω̇ = J⁻¹·(τ_rotors + τ_ext − ω × J·ω)
//! Ω̇_i = (Ω_cmd,i − Ω_i)/τ_m,               Ω_cmd,i clipped to [0, Ω_max]
//! ```
//!
//! The command is held over a step, so the rotor speeds are integrated exactly,
//! Ω_i(t₀ + s) = Ω_cmd,i + (Ω_i(t₀) − Ω_cmd,i)·e^{−s/τ_m}, and RK4 integrates the rigid body with
//! the rotor speeds of its stage times (s = 0, h/2, h).
//!
//! with the rotor torques of the "+" layout (see [`super::rate_loop`]), the rotor-drag
//! coefficients k_x, k_y (1/s, zero by default) acting on the body velocity (u, v_b), and a
//! constant disturbance (F_ext in Nav, τ_ext in Body). The quaternion is renormalised after each
//! step.
//!
//! Ground effect (zero in the presets): near the floor the rotors' thrust grows to
//! T·(1 + c_g·(r/4h)²), h = −p_D the height above the floor, clamped to h ≥ r (r the rotor
//! radius); c_g = 1 is the first-order term of Cheeseman and Bennett's T/T_∞ = 1/(1 − (r/4h)²).
//!
//! Ground contact: the floor is the plane D = 0. While the vehicle is on it (it has not lifted
//! off, or it came down), it is held there level at its heading, at rest: a rigid floor with full
//! friction. It lifts off as soon as the thrust exceeds its weight.

use super::params::{GRAVITY, VehicleParams};
use crate::frames::{Body, Nav, Rot, Vec3};
use nalgebra::{Quaternion, UnitQuaternion};

/// The rigid body's state.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct State {
    /// Position of the centre of mass, nav NED (m).
    pub pos: Vec3<Nav>,
    /// Velocity, nav NED (m/s).
    pub vel: Vec3<Nav>,
    /// Attitude, body → nav.
    pub att: Rot<Body, Nav>,
    /// Angular rate, body FRD (rad/s).
    pub omega: Vec3<Body>,
    /// Rotor speeds (rad/s), in the layout's order.
    pub rotor_speed: [f64; 4],
}

/// Constant external disturbance: a force in the nav frame (wind, a tether, N) and a torque in the
/// body frame (a bent rotor, N·m).
#[derive(Clone, Copy, Debug, Default, serde::Serialize)]
pub struct Disturbance {
    /// Force in the nav frame (N).
    pub force_nav_n: [f64; 3],
    /// Torque in the body frame (N·m).
    pub torque_body_nm: [f64; 3],
}

/// The quadrotor's rigid-body dynamics with first-order rotors and the floor (see the module doc).
#[derive(Clone, Debug)]
pub struct X3d {
    p: VehicleParams,
    disturbance: Disturbance,
    state: State,
    on_ground: bool,
    /// (h, e^{−h/(2τ_m)}) for the last step size h: the rotor decay over half a step.
    half_step_decay: (f64, f64),
}

/// The ground effect's thrust factor 1 + c_g·(r/4h)² at NED height `pos_d` (h = −pos_d ≥ r);
/// exactly 1 without ground effect.
#[inline(always)]
fn ground_gain(p: &VehicleParams, pos_d: f64) -> f64 {
    if p.ground_effect == 0.0 {
        return 1.0;
    }
    let ratio = p.rotor_radius_m / (4.0 * (-pos_d).max(p.rotor_radius_m));
    1.0 + p.ground_effect * ratio * ratio
}

/// The rigid body's state vector, flat (so that RK4's stage sums are plain loops the compiler
/// vectorises): p (Nav, 0..3), v (Nav, 3..6), q as nalgebra's coordinates [x, y, z, w] (6..10),
/// ω (Body, 10..13). The same layout holds a derivative. The rotor speeds are integrated exactly,
/// outside it.
const N: usize = 13;
const P: usize = 0;
const V: usize = 3;
const Q: usize = 6;
const W: usize = 10;
type Flat = [f64; N];

/// y + d·h, element by element.
#[inline(always)]
fn plus(y: &Flat, d: &Flat, h: f64) -> Flat {
    let mut out = [0.0; N];
    for i in 0..N {
        out[i] = y[i] + d[i] * h;
    }
    out
}

/// a × b, in nalgebra's operation order (so that results match its `cross` bit for bit).
#[inline(always)]
fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

/// [`rotate`] of (0, 0, f_z): the same operations without the products by zero (the result
/// differs from `rotate`'s at most in the sign of an exact zero).
#[inline(always)]
fn rotate_body_z(qv: [f64; 3], qw: f64, fz: f64) -> [f64; 3] {
    let t = [(qv[1] * fz) * 2.0, -(qv[0] * fz) * 2.0];
    let u = [-(qv[2] * t[1]), qv[2] * t[0], qv[0] * t[1] - qv[1] * t[0]];
    [t[0] * qw + u[0], t[1] * qw + u[1], u[2] + fz]
}

/// Rotates `v` by the unit quaternion with vector part `qv` and scalar part `qw` (nalgebra's
/// `UnitQuaternion * Vector3`: t = 2·(qv × v), v' = t·qw + qv × t + v).
#[inline(always)]
fn rotate(qv: [f64; 3], qw: f64, v: [f64; 3]) -> [f64; 3] {
    let c = cross(qv, v);
    let t = [c[0] * 2.0, c[1] * 2.0, c[2] * 2.0];
    let u = cross(qv, t);
    [t[0] * qw + u[0] + v[0], t[1] * qw + u[1] + v[1], t[2] * qw + u[2] + v[2]]
}

impl X3d {
    /// A vehicle at rest on the floor at `home` (D = 0), heading `yaw` (rad).
    pub fn on_floor(p: VehicleParams, disturbance: Disturbance, home: Vec3<Nav>, yaw: f64) -> Self {
        let att = Rot::from_euler(crate::frames::Euler::new(0.0, 0.0, yaw));
        let state = State {
            pos: Vec3::new(home.x(), home.y(), 0.0),
            vel: Vec3::zeros(),
            att,
            omega: Vec3::zeros(),
            rotor_speed: [0.0; 4],
        };
        X3d { p, disturbance, state, on_ground: true, half_step_decay: (f64::NAN, f64::NAN) }
    }

    /// A vehicle in free flight at a given state (for tests and benchmarks).
    pub fn in_flight(p: VehicleParams, disturbance: Disturbance, state: State) -> Self {
        X3d { p, disturbance, state, on_ground: false, half_step_decay: (f64::NAN, f64::NAN) }
    }

    /// The vehicle's parameters.
    pub fn params(&self) -> &VehicleParams {
        &self.p
    }
    /// The current state.
    pub fn state(&self) -> &State {
        &self.state
    }
    /// The vehicle rests on the floor.
    pub fn on_ground(&self) -> bool {
        self.on_ground
    }

    /// Rotor speed that makes each rotor carry a quarter of the weight (rad/s).
    pub fn hover_rotor_speed(&self) -> f64 {
        (self.p.hover_thrust() / (4.0 * self.p.k_thrust)).sqrt()
    }

    /// Collective thrust of the rotors now (N).
    pub fn thrust(&self) -> f64 {
        self.state.rotor_speed.iter().map(|w| self.p.k_thrust * w * w).sum()
    }

    /// Specific force in the body frame (what an ideal accelerometer reads), m/s².
    ///
    /// f = (F_rotors + F_drag)/m + C_n^b·F_ext/m, all evaluated at the current state (so the
    /// attitude that rotates it and the forces belong to the same instant). On the floor the
    /// reaction cancels gravity: f = C_n^b·(0, 0, −g).
    pub fn specific_force(&self) -> Vec3<Body> {
        let s = &self.state;
        if self.on_ground {
            return s.att.inverse().apply(Vec3::<Nav>::new(0.0, 0.0, -GRAVITY));
        }
        let p = &self.p;
        let thrust: f64 = s.rotor_speed.iter().map(|w| p.k_thrust * w * w).sum::<f64>() * ground_gain(p, s.pos.z());
        // without drag or disturbance (the presets) the rotations below contribute exact zeros
        if p.rotor_drag_per_s == [0.0; 2] && self.disturbance.force_nav_n == [0.0; 3] {
            return Vec3::new(0.0, 0.0, -thrust / p.mass_kg);
        }
        let v_body = s.att.inverse().apply(s.vel);
        let dist = s.att.inverse().apply(Vec3::<Nav>::from_array(self.disturbance.force_nav_n));
        Vec3::new(
            -p.rotor_drag_per_s[0] * v_body.x() + dist.x() / p.mass_kg,
            -p.rotor_drag_per_s[1] * v_body.y() + dist.y() / p.mass_kg,
            -thrust / p.mass_kg + dist.z() / p.mass_kg,
        )
    }

    /// Angular acceleration ω̇ = J⁻¹·(τ_rotors + τ_ext − ω × J·ω) now, body FRD (rad/s²): the
    /// derivative at the current state and rotor speeds (zero on the floor, which holds the body).
    pub fn angular_acceleration(&self) -> Vec3<Body> {
        if self.on_ground {
            return Vec3::zeros();
        }
        let (pos, vel, omega) = (self.state.pos.raw(), self.state.vel.raw(), self.state.omega.raw());
        let q = self.state.att.quaternion().coords;
        #[rustfmt::skip]
        let s: Flat = [pos.x, pos.y, pos.z, vel.x, vel.y, vel.z, q[0], q[1], q[2], q[3], omega.x, omega.y, omega.z];
        let d = self.deriv(&s, &self.state.rotor_speed);
        Vec3::new(d[W], d[W + 1], d[W + 2])
    }

    /// The rigid body's time derivative (the equations at the top of this module) with the rotors
    /// at `rotor` (rad/s).
    #[inline(always)]
    fn deriv(&self, s: &Flat, rotor: &[f64; 4]) -> Flat {
        let p = &self.p;
        let (qv, qw) = ([s[Q], s[Q + 1], s[Q + 2]], s[Q + 3]);
        let w = [s[W], s[W + 1], s[W + 2]];
        // the ground effect scales every rotor's thrust (× 1.0 exactly without it)
        let gain = ground_gain(p, s[P + 2]);
        let [ff, fr, fb, fl] = rotor.map(|o| p.k_thrust * o * o * gain);
        let thrust_z = -(ff + fr + fb + fl);
        let force_nav = match p.rotor_drag_per_s {
            // without rotor drag (the presets) the body force is (0, 0, −T): skip the rotation
            // of the body velocity, and rotate the force with the zero products left out
            [0.0, 0.0] => rotate_body_z(qv, qw, thrust_z),
            [kx, ky] => {
                let v_body = rotate([-qv[0], -qv[1], -qv[2]], qw, [s[V], s[V + 1], s[V + 2]]);
                rotate(qv, qw, [-p.mass_kg * kx * v_body[0], -p.mass_kg * ky * v_body[1], thrust_z])
            }
        };
        let dist = &self.disturbance;
        let l = p.arm_m;
        let tau = [
            l * (fl - fr) + dist.torque_body_nm[0],
            l * (ff - fb) + dist.torque_body_nm[1],
            p.k_torque_m * (ff + fb - fr - fl) + dist.torque_body_nm[2],
        ];
        let j = &p.inertia_kg_m2;
        let gyro = cross(w, [j[0] * w[0], j[1] * w[1], j[2] * w[2]]);
        let mut d = [0.0; N];
        d[P] = s[V];
        d[P + 1] = s[V + 1];
        d[P + 2] = s[V + 2];
        d[V] = 0.0 + (force_nav[0] + dist.force_nav_n[0]) / p.mass_kg;
        d[V + 1] = 0.0 + (force_nav[1] + dist.force_nav_n[1]) / p.mass_kg;
        d[V + 2] = GRAVITY + (force_nav[2] + dist.force_nav_n[2]) / p.mass_kg;
        // q̇ = ½·q ⊗ (0, ω), nalgebra's product order
        let [x, y, z] = qv;
        d[Q] = (qw * w[0] + y * w[2] - z * w[1]) * 0.5;
        d[Q + 1] = (qw * w[1] - x * w[2] + z * w[0]) * 0.5;
        d[Q + 2] = (qw * w[2] + x * w[1] - y * w[0]) * 0.5;
        d[Q + 3] = (-x * w[0] - y * w[1] - z * w[2]) * 0.5;
        for k in 0..3 {
            d[W + k] = (tau[k] - gyro[k]) / j[k];
        }
        d
    }

    crate::cpu::avx2_dispatch! {
        /// Advances the state by `dt` seconds with rotor speed commands held constant.
        pub fn step => step_avx2, step_any_cpu(&mut self, rotor_cmd: &[f64; 4], dt: f64)
    }

    #[inline(always)]
    fn step_any_cpu(&mut self, rotor_cmd: &[f64; 4], dt: f64) {
        let (pos, vel, omega) = (self.state.pos.raw(), self.state.vel.raw(), self.state.omega.raw());
        let q = self.state.att.quaternion().coords;
        #[rustfmt::skip]
        let s0: Flat = [pos.x, pos.y, pos.z, vel.x, vel.y, vel.z, q[0], q[1], q[2], q[3], omega.x, omega.y, omega.z];
        // rotors: exact first-order lag towards the held (clipped) command
        if self.half_step_decay.0 != dt {
            self.half_step_decay = (dt, (-dt / (2.0 * self.p.motor_tau_s)).exp());
        }
        let decay = self.half_step_decay.1;
        let max = self.p.rotor_speed_max;
        let cmd = rotor_cmd.map(|c| c.clamp(0.0, max));
        let o0 = self.state.rotor_speed;
        let o_half: [f64; 4] = std::array::from_fn(|i| cmd[i] + (o0[i] - cmd[i]) * decay);
        let o_end: [f64; 4] = std::array::from_fn(|i| cmd[i] + (o_half[i] - cmd[i]) * decay);
        let k1 = self.deriv(&s0, &o0);
        let k2 = self.deriv(&plus(&s0, &k1, dt / 2.0), &o_half);
        let k3 = self.deriv(&plus(&s0, &k2, dt / 2.0), &o_half);
        let k4 = self.deriv(&plus(&s0, &k3, dt), &o_end);
        let h = dt / 6.0;
        let mut y = [0.0; N];
        for i in 0..N {
            y[i] = s0[i] + (k1[i] + (k2[i] + k3[i]) * 2.0 + k4[i]) * h;
        }
        let q = UnitQuaternion::new_normalize(Quaternion::new(y[Q + 3], y[Q], y[Q + 1], y[Q + 2]));
        self.state = State {
            pos: Vec3::new(y[P], y[P + 1], y[P + 2]),
            vel: Vec3::new(y[V], y[V + 1], y[V + 2]),
            att: Rot::from_quaternion(q),
            omega: Vec3::new(y[W], y[W + 1], y[W + 2]),
            rotor_speed: o_end,
        };
        self.on_ground = self.state.pos.z() >= 0.0;
        if self.on_ground {
            let yaw = self.state.att.euler().yaw;
            self.state.pos = Vec3::new(y[P], y[P + 1], 0.0);
            self.state.vel = Vec3::zeros();
            self.state.omega = Vec3::zeros();
            self.state.att = Rot::from_euler(crate::frames::Euler::new(0.0, 0.0, yaw));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frames::Euler;
    use nalgebra::Vector3;

    fn hovering() -> X3d {
        let p = VehicleParams::x3d();
        let s = State {
            pos: Vec3::new(0.0, 0.0, -1.0),
            vel: Vec3::zeros(),
            att: Rot::identity(),
            omega: Vec3::zeros(),
            rotor_speed: [0.0; 4],
        };
        let mut x = X3d::in_flight(p, Disturbance::default(), s);
        let w = x.hover_rotor_speed();
        x.state.rotor_speed = [w; 4];
        x
    }

    /// ω̇ = J⁻¹(τ − ω×Jω) by hand: left rotor at 1.1·Ω and right at 0.9·Ω roll the body at
    /// l·k·Ω²·(1.21 − 0.81)/J_x; equal rotors and ω = (1, 0, 3) rad/s give the gyroscopic
    /// ω̇_y = 3·(J_z − J_x)/J_y alone; on the floor ω̇ = 0.
    #[test]
    fn angular_acceleration_is_the_torque_over_the_inertia_by_hand() {
        let mut x = hovering();
        let (w, p) = (x.hover_rotor_speed(), x.params().clone());
        x.state.rotor_speed = [w, 0.9 * w, w, 1.1 * w];
        let want = p.arm_m * p.k_thrust * w * w * (1.21 - 0.81) / p.inertia_kg_m2[0];
        let a = x.angular_acceleration();
        assert!((a.x() - want).abs() < 1e-9 * want && a.y().abs() < 1e-12, "{a:?} for {want}");
        x.state.rotor_speed = [w; 4];
        x.state.omega = Vec3::new(1.0, 0.0, 3.0);
        let j = p.inertia_kg_m2;
        let a = x.angular_acceleration();
        assert!(
            a.x().abs() < 1e-12 && (a.y() - 3.0 * (j[2] - j[0]) / j[1]).abs() < 1e-9 && a.z().abs() < 1e-12,
            "{a:?}"
        );
        let floor = X3d::on_floor(p, Disturbance::default(), Vec3::zeros(), 0.0);
        assert_eq!(floor.angular_acceleration(), Vec3::zeros());
    }

    /// The disturbance torque τ_ext (body frame) adds to the rotors' on every axis with its
    /// sign: equal rotors, ω = 0, τ_ext = (0.01, −0.02, 0.003) N·m give ω̇ = τ_ext,i / J_i.
    #[test]
    fn a_disturbance_torque_accelerates_each_body_axis_by_itself() {
        let mut x = hovering();
        let tau = [0.01, -0.02, 0.003];
        x.disturbance.torque_body_nm = tau;
        let j = x.params().inertia_kg_m2;
        let a = x.angular_acceleration().to_array();
        for i in 0..3 {
            let want = tau[i] / j[i];
            assert!((a[i] - want).abs() < 1e-9 * want.abs(), "axis {i}: {a:?}, want {want}");
        }
    }

    #[test]
    fn hover_rotor_speed_holds_altitude_and_thrust_equals_weight() {
        let mut x = hovering();
        let w = x.hover_rotor_speed();
        assert!((x.thrust() - 0.68 * 9.81).abs() < 1e-9);
        for _ in 0..2000 {
            x.step(&[w; 4], 1e-3);
        }
        assert!(x.state().pos.z() + 1.0 < 1e-9 && x.state().pos.z() + 1.0 > -1e-9);
        let f = x.specific_force();
        assert!((f.z() + 9.81).abs() < 1e-9, "hover specific force {f:?}");
    }

    /// Ground effect in closed form: hover rotor speeds at h = 0.2 m with c_g = 1 and r = 0.1 m
    /// give T·(1 + (0.1/0.8)²) = 1.015625·m·g, so the body accelerates up at 0.015625·g; below
    /// h = r the factor stays at its h = r value, 1 + (1/4)² = 1.0625; without ground effect
    /// nothing changes at any height.
    #[test]
    fn ground_effect_adds_thrust_as_in_closed_form() {
        let mut x = hovering();
        x.p.ground_effect = 1.0;
        for (h, gain) in [(0.2, 1.015_625), (0.05, 1.0625), (1.0, 1.0 + (0.1f64 / 4.0).powi(2))] {
            x.state.pos = Vec3::new(0.0, 0.0, -h);
            let f = x.specific_force();
            assert!((f.z() + 9.81 * gain).abs() < 1e-12, "h {h}: {f:?}");
            // the integrated vertical acceleration over 1 ms agrees (the height hardly moves)
            let mut y = x.clone();
            let w = y.hover_rotor_speed();
            y.step(&[w; 4], 1e-3);
            let a = y.state().vel.z() / 1e-3;
            assert!((a - 9.81 * (1.0 - gain)).abs() < 1e-6 * 9.81, "h {h}: {a}");
        }
        let mut plain = hovering();
        plain.state.pos = Vec3::new(0.0, 0.0, -0.05);
        assert_eq!(plain.specific_force().z(), -plain.thrust() / 0.68);
    }

    /// Regression: the accelerometer took the acceleration from the start of the 1 ms step and
    /// the attitude from its end, a 1 ms skew that `identify` found as a spurious rotor drag
    /// (k ≈ −0.005 1/s). Now the specific force must equal the velocity's rate of change,
    /// rotated by the attitude of the same instant: C_b^n·f + g·e_D = dv/dt (central difference).
    #[test]
    fn specific_force_matches_the_acceleration_at_the_same_instant() {
        let mut x = hovering();
        let w = x.hover_rotor_speed();
        // roll and pitch hard: left/right and front/back rotors unequal
        let cmd = [w * 1.02, w * 0.97, w * 0.99, w * 1.03];
        let dt = 1e-3;
        let mut prev = x.state().vel;
        let mut worst: f64 = 0.0;
        for k in 0..400 {
            x.step(&cmd, dt);
            let f = x.specific_force();
            let (v_now, att) = (x.state().vel, x.state().att);
            let mut next = x.clone();
            next.step(&cmd, dt);
            if k > 10 {
                let dv = (next.state().vel - prev) * (0.5 / dt);
                let model = att.apply(f) + Vec3::<Nav>::new(0.0, 0.0, GRAVITY);
                worst = worst.max((dv - model).norm());
            }
            prev = v_now;
        }
        assert!(x.state().omega.norm() > 1.0, "the test must rotate the body: {:?}", x.state().omega);
        // central-difference truncation is O(dt²); the old 1 ms skew gave ≈ |ω|·dt·g > 1e-2
        assert!(worst < 1e-4, "specific force and acceleration disagree by {worst} m/s²");
        // no drag, no disturbance: the rotors push along body z only
        let f = x.specific_force();
        assert!(f.x() == 0.0 && f.y() == 0.0 && (f.z() + x.thrust() / 0.68).abs() < 1e-12, "{f:?}");
    }

    /// Rotor drag by hand: at a constant tilted and yawed attitude (ω = 0 and equal rotors: no
    /// torque) the body velocity obeys v̇_b = C_n^b·g·e_D − K·v_b + (0, 0, −T/m), K = diag(k_x,
    /// k_y, 0), so along the body's x and y v_i(t) = c_i/k_i + (v_i(0) − c_i/k_i)·e^{−k_i·t} and
    /// along z v_z(0) + c_z·t. After 0.1 s of 1 ms steps the nav velocity must be C_b^n·v_b(t)
    /// within RK4's error (k·h ≤ 5·10⁻⁴). A bug it catches: the drag's body velocity read with a
    /// sign of the inverse rotation lost, or from the wrong state index.
    #[test]
    fn rotor_drag_decays_the_body_velocity_in_closed_form() {
        let mut p = VehicleParams::x3d();
        p.rotor_drag_per_s = [0.3, 0.5];
        let att = Rot::<Body, Nav>::from_euler(Euler::new(0.2, -0.3, 1.0));
        let v0 = Vec3::<Nav>::new(2.0, 1.0, -0.5);
        let s = State { pos: Vec3::new(0.0, 0.0, -5.0), vel: v0, att, omega: Vec3::zeros(), rotor_speed: [0.0; 4] };
        let mut x = X3d::in_flight(p.clone(), Disturbance::default(), s);
        let w = x.hover_rotor_speed();
        x.state.rotor_speed = [w; 4];
        let c_b_n = att.matrix();
        let vb0 = c_b_n.transpose() * v0.raw();
        let c = c_b_n.transpose() * Vector3::new(0.0, 0.0, GRAVITY) - Vector3::new(0.0, 0.0, x.thrust() / p.mass_kg);
        for _ in 0..100 {
            x.step(&[w; 4], 1e-3);
        }
        let (t, k) = (0.1, p.rotor_drag_per_s);
        let decay = |i: usize| c[i] / k[i] + (vb0[i] - c[i] / k[i]) * (-k[i] * t).exp();
        let want = c_b_n * Vector3::new(decay(0), decay(1), vb0.z + c.z * t);
        assert!((x.state().vel.raw() - want).amax() < 1e-9, "{:?} vs {want:?}", x.state().vel);
        assert_eq!(x.state().omega, Vec3::zeros(), "the attitude must stay constant");
        // the drag is felt: without it the velocity would differ by more than 1 cm/s
        assert!((c_b_n * (vb0 + c * t) - want).amax() > 0.01);
    }

    /// The accelerometer by hand at a tilted, yawed attitude in motion: with rotor drag alone f =
    /// (−k_x·v_b,x, −k_y·v_b,y, −T/m), with an external force F alone f = C_n^b·F/m + (0, 0, −T/m),
    /// with both the sum, where v_b = C_n^b·v and −T/m is the plain vehicle's reading (no drag, no
    /// force: the fast path). A bug it catches: the fast path taken when *either* was zero (`&&` as
    /// `||`) dropped the drag from the reading, and only identify's whole flights noticed.
    #[test]
    fn the_accelerometer_feels_rotor_drag_and_an_external_force_each_alone() {
        let att = Rot::<Body, Nav>::from_euler(Euler::new(0.2, -0.3, 1.0));
        let v = Vec3::<Nav>::new(2.0, 1.0, -0.5);
        let force = [0.3, -0.2, 0.1];
        let vehicle = |drag: [f64; 2], force_nav_n: [f64; 3]| {
            let mut p = VehicleParams::x3d();
            p.rotor_drag_per_s = drag;
            let s = State { pos: Vec3::new(0.0, 0.0, -5.0), vel: v, att, omega: Vec3::zeros(), rotor_speed: [0.0; 4] };
            let mut x = X3d::in_flight(p, Disturbance { force_nav_n, torque_body_nm: [0.0; 3] }, s);
            x.state.rotor_speed = [x.hover_rotor_speed(); 4];
            x.specific_force()
        };
        let c_n_b = att.matrix().transpose();
        let v_b = c_n_b * v.raw();
        let f_ext = c_n_b * Vector3::from(force) / VehicleParams::x3d().mass_kg;
        let plain = vehicle([0.0; 2], [0.0; 3]);
        assert!(plain.x() == 0.0 && plain.y() == 0.0 && plain.z() < -9.0, "{plain:?}");
        let thrust = Vector3::new(0.0, 0.0, plain.z());
        let drag = Vector3::new(-0.3 * v_b.x, -0.5 * v_b.y, 0.0);
        for (k, f_ext_n, want) in [
            ([0.3, 0.5], [0.0; 3], thrust + drag),
            ([0.0; 2], force, thrust + f_ext),
            ([0.3, 0.5], force, thrust + drag + f_ext),
        ] {
            let got = vehicle(k, f_ext_n);
            assert!((got.raw() - want).amax() < 1e-12, "drag {k:?}, force {f_ext_n:?}: {got:?} vs {want:?}");
        }
    }

    #[test]
    fn free_fall_matches_closed_form() {
        let mut x = hovering();
        for _ in 0..300 {
            x.step(&[0.0; 4], 1e-3);
        }
        // Rotors spin down with τ_m: Ω(t) = Ω₀e^{−t/τ}, thrust ∝ e^{−2t/τ}; after they stop the fall
        // is pure gravity. ∫∫ of the thrust deficit has a closed form:
        // z(t) = −1 + g t²/2 − (g τ²/4)·(2t/τ − 1 + e^{−2t/τ})
        let (g, tau, t) = (9.81_f64, 0.0125_f64, 0.3_f64);
        let expected = -1.0 + g * t * t / 2.0 - g * tau * tau / 4.0 * (2.0 * t / tau - 1.0 + (-2.0 * t / tau).exp());
        // the rotor speeds are exact; RK4 integrates the thrust e^{−2t/τ} sampled at its stage
        // times, with a local error ~(2h/τ)⁵/2880 ≈ 4e-8 of a step's velocity change: 4.4e-9 m
        // after 0.3 s (the bound was 1e-7 while RK4 integrated the rotors too)
        assert!((x.state().pos.z() - expected).abs() < 1e-8, "{} vs {}", x.state().pos.z(), expected);
        // Ω(t) = Ω₀·e^{−t/τ} exactly
        let w0 = hovering().hover_rotor_speed();
        for w in x.state().rotor_speed {
            assert!((w - w0 * (-t / tau).exp()).abs() < 1e-12 * w0, "{w}");
        }
    }

    /// The rotor lag is integrated exactly whatever the step: 300 steps of 1 ms and 3 steps of
    /// 100 ms both land on Ω_cmd + (Ω₀ − Ω_cmd)·e^{−t/τ_m}.
    #[test]
    fn rotor_lag_is_exact_for_any_step() {
        let tau = VehicleParams::x3d().motor_tau_s;
        for (steps, dt) in [(300, 1e-3), (3, 0.1)] {
            let mut x = hovering();
            let w0 = x.hover_rotor_speed();
            let cmd = [w0 * 1.1, w0 * 0.9, w0 * 1.05, w0];
            for _ in 0..steps {
                x.step(&cmd, dt);
            }
            let t = steps as f64 * dt;
            for i in 0..4 {
                let exact = cmd[i] + (w0 - cmd[i]) * (-t / tau).exp();
                assert!((x.state().rotor_speed[i] - exact).abs() < 1e-12 * w0, "dt {dt}: rotor {i}");
            }
        }
    }

    /// A torque-free body keeps its angular momentum constant *in the inertial frame*:
    /// L_nav = R·J·ω (Euler's equations, J·ω̇ = −ω × J·ω, are exactly this in body axes). With
    /// equal rotor speeds the rotors give no torque, so L_nav after 1 s of tumbling at |ω| = 3.7
    /// rad/s must equal its start to RK4's accuracy (local error ~(|ω|·h)⁵ ≈ 7·10⁻¹³ per step).
    /// |J·ω| in the body frame would stay constant with the gyroscopic term's sign flipped or
    /// without it; the vector in Nav does not (it then turns by ~|ω|·t).
    #[test]
    fn torque_free_spin_conserves_angular_momentum_in_the_inertial_frame() {
        let mut x = hovering();
        x.state.omega = Vec3::new(1.0, -2.0, 3.0);
        let w = x.hover_rotor_speed();
        let l_nav = |x: &X3d| {
            let o = x.state().omega;
            x.state().att.apply(Vec3::<Body>::new(0.007 * o.x(), 0.007 * o.y(), 0.012 * o.z()))
        };
        let l0 = l_nav(&x);
        for _ in 0..1000 {
            x.step(&[w; 4], 1e-3);
        }
        let l1 = l_nav(&x);
        assert!((l1 - l0).norm() / l0.norm() < 1e-8, "{l0:?} -> {l1:?}");
        // the body-frame vector does move (the test is not trivially satisfied): ω is not along
        // a principal axis, so J·ω precesses in the body
        let o = x.state().omega;
        let lb1 = Vector3::new(0.007 * o.x(), 0.007 * o.y(), 0.012 * o.z());
        let lb0 = Vector3::new(0.007, -0.014, 0.036);
        assert!((lb1 - lb0).norm() > 1e-3 * lb0.norm(), "{lb0:?} {lb1:?}");
        let _ = Euler::ZERO;
    }

    /// Touchdown by hand: a body falling through D = 0 with its rotors stopped keeps its horizontal
    /// position (it moved at constant horizontal velocity during the step: no thrust, no drag on
    /// the preset) and its heading, and rests level on the floor with no velocity and no rate.
    /// First tilted (roll 0.1, pitch −0.05, yaw 0.8 rad) with no rate; then level, spinning about
    /// the vertical at 0.2 rad/s, a principal axis (no gyroscopic term), so its heading after the
    /// step is 0.8 + 0.2·dt. A bug it catches: the floor's position at (x, x) instead of (x, y).
    #[test]
    fn touchdown_keeps_the_horizontal_position_and_heading_and_levels_the_body() {
        let dt = 1e-3;
        for (att, omega, yaw) in
            [(Euler::new(0.1, -0.05, 0.8), 0.0, 0.8), (Euler::new(0.0, 0.0, 0.8), 0.2, 0.8 + 0.2 * dt)]
        {
            let s = State {
                pos: Vec3::new(1.5, -0.7, -0.0005),
                vel: Vec3::new(0.2, -0.1, 1.0),
                att: Rot::from_euler(att),
                omega: Vec3::new(0.0, 0.0, omega),
                rotor_speed: [0.0; 4],
            };
            let mut x = X3d::in_flight(VehicleParams::x3d(), Disturbance::default(), s);
            x.step(&[0.0; 4], dt);
            assert!(x.on_ground());
            let (pos, e) = (x.state().pos, x.state().att.euler());
            assert!(
                (pos.x() - (1.5 + 0.2 * dt)).abs() < 1e-12
                    && (pos.y() - (-0.7 - 0.1 * dt)).abs() < 1e-12
                    && pos.z() == 0.0,
                "{pos:?}"
            );
            assert!(e.roll.abs() < 1e-12 && e.pitch.abs() < 1e-12 && (e.yaw - yaw).abs() < 1e-12, "{e:?}");
            assert_eq!((x.state().vel, x.state().omega), (Vec3::zeros(), Vec3::zeros()));
        }
    }

    #[test]
    fn stays_on_floor_until_thrust_exceeds_weight() {
        let p = VehicleParams::x3d();
        let mut x = X3d::on_floor(p, Disturbance::default(), Vec3::zeros(), 0.3);
        let w = x.hover_rotor_speed();
        for _ in 0..200 {
            x.step(&[0.99 * w; 4], 1e-3);
        }
        assert!(x.on_ground() && x.state().pos.z() == 0.0);
        assert!((x.specific_force().z() + 9.81).abs() < 1e-12);
        for _ in 0..200 {
            x.step(&[1.05 * w; 4], 1e-3);
        }
        assert!(!x.on_ground() && x.state().pos.z() < 0.0);
    }
}

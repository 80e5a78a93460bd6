//! The onboard 1 kHz body-rate controller of the X3D.
//!
//! Input: the decoded radio command (body rates p, q, r in rad/s and collective thrust T in N,
//! held between 50 Hz PPM frames) and the gyro sample ω_gyro (body frame, rad/s).
//! Law: τ_com = J·K_ω·(ω_com − ω_gyro) + J·K_I·∫(ω_com − ω_gyro)dt + ω_gyro × J·ω_gyro
//! (rate tracking with gyroscopic feed-forward; K_I = 0, proportional only, in the presets). The
//! integral runs only while thrust is commanded (reset to 0 with the motors off: no wind-up on
//! the floor) and is summed by the rectangle rule at the loop's period. With K_I > 0 a constant
//! disturbance torque τ_d is held with no rate error in steady state (∫ settles at
//! τ_d/(J·K_I)); without it the loop needs ω_com − ω = τ_d/(J·K_ω). The mixer of the "+" layout then solves
//!
//! ```text
//!  T  = f_F + f_R + f_B + f_L          (collective thrust, along −z_body)
//!  τx = l·(f_L − f_R)                  (roll: left rotor lifts the left side)
//!  τy = l·(f_F − f_B)                  (pitch: front rotor lifts the nose)
//!  τz = k_m·(f_F + f_B − f_R − f_L)    (yaw: reaction of the rotor drag torques)
//! ```
//!
//! for the rotor thrusts f_i, clips each to [0, f_max] and commands Ω_i = √(f_i/k_f).

use super::params::VehicleParams;
use crate::frames::{Body, Vec3};

/// What the vehicle's radio receiver holds: body-rate and thrust commands in SI units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RateCommand {
    /// Commanded body rates (rad/s).
    pub rates: Vec3<Body>,
    /// Commanded collective thrust (N).
    pub thrust_n: f64,
}

impl RateCommand {
    /// Zero rates and zero thrust.
    pub fn idle() -> Self {
        RateCommand { rates: Vec3::zeros(), thrust_n: 0.0 }
    }
}

/// The onboard rate loop: the mixer and the per-axis gains (see the module doc).
#[derive(Clone, Debug)]
pub struct RateLoop {
    inertia: [f64; 3],
    gain: [f64; 3],
    integral_gain: [f64; 3],
    /// ∫(ω_com − ω_gyro)dt (rad), and the loop's period (s).
    integral: [f64; 3],
    period_s: f64,
    arm: f64,
    k_m: f64,
    k_f: f64,
    f_max: f64,
}

impl RateLoop {
    /// The loop of vehicle `p`, run every `period_s` seconds.
    pub fn new(p: &VehicleParams, period_s: f64) -> Self {
        RateLoop {
            inertia: p.inertia_kg_m2,
            gain: p.rate_loop_gain_per_s,
            integral_gain: p.rate_loop_integral_per_s2,
            integral: [0.0; 3],
            period_s,
            arm: p.arm_m,
            k_m: p.k_torque_m,
            k_f: p.k_thrust,
            f_max: p.rotor_thrust_max(),
        }
    }

    /// Rotor thrusts [front, right, back, left] (N) for a collective thrust and body torque.
    pub fn mix(&self, thrust: f64, torque: [f64; 3]) -> [f64; 4] {
        let [tx, ty, tz] = torque;
        let a = thrust / 4.0;
        let yaw = tz / (4.0 * self.k_m);
        let f_front = a + ty / (2.0 * self.arm) + yaw;
        let f_back = a - ty / (2.0 * self.arm) + yaw;
        let f_left = a + tx / (2.0 * self.arm) - yaw;
        let f_right = a - tx / (2.0 * self.arm) - yaw;
        [f_front, f_right, f_back, f_left].map(|f| f.clamp(0.0, self.f_max))
    }

    /// Rotor speed commands [front, right, back, left] (rad/s); one call per loop period.
    pub fn rotor_speed_commands(&mut self, cmd: &RateCommand, gyro: Vec3<Body>) -> [f64; 4] {
        let w = gyro.to_array();
        let j = self.inertia;
        let err = (cmd.rates - gyro).to_array();
        let jw = [j[0] * w[0], j[1] * w[1], j[2] * w[2]];
        let gyroscopic = [w[1] * jw[2] - w[2] * jw[1], w[2] * jw[0] - w[0] * jw[2], w[0] * jw[1] - w[1] * jw[0]];
        let mut torque = [0, 1, 2].map(|i| j[i] * self.gain[i] * err[i] + gyroscopic[i]);
        if self.integral_gain.iter().any(|k| *k != 0.0) {
            for i in 0..3 {
                self.integral[i] = if cmd.thrust_n > 0.0 { self.integral[i] + err[i] * self.period_s } else { 0.0 };
                torque[i] += j[i] * self.integral_gain[i] * self.integral[i];
            }
        }
        self.mix(cmd.thrust_n, torque).map(|f| (f / self.k_f).sqrt())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The body torque (N·m) of rotor forces [front, right, back, left] (N) by the X3D's
    /// geometry, written from the parameters (not the loop's copies): roll ℓ·(f_l − f_r),
    /// pitch ℓ·(f_f − f_b), yaw k_m·(f_f + f_b − f_r − f_l).
    fn body_torque(p: &VehicleParams, [front, right, back, left]: [f64; 4]) -> [f64; 3] {
        [p.arm_m * (left - right), p.arm_m * (front - back), p.k_torque_m * (front + back - right - left)]
    }

    /// The rotor forces k_f·ω² (N) of rotor speed commands (rad/s).
    fn forces(p: &VehicleParams, speeds: [f64; 4]) -> [f64; 4] {
        speeds.map(|x| p.k_thrust * x * x)
    }

    #[test]
    fn mixer_reproduces_requested_thrust_and_torque() {
        let p = VehicleParams::x3d();
        let rl = RateLoop::new(&p, 1e-3);
        let (t, tau) = (7.0, [0.05, -0.03, 0.01]);
        let f = rl.mix(t, tau);
        assert!((f.iter().sum::<f64>() - t).abs() < 1e-12);
        for (got, want) in body_torque(&p, f).iter().zip(tau) {
            assert!((got - want).abs() < 1e-12, "{f:?}");
        }
    }

    /// With the rates on command (no error, no integral) the loop commands the gyroscopic torque
    /// alone, ω × Jω = ((J_z − J_y)·q·r, (J_x − J_z)·p·r, (J_y − J_x)·p·q) (Euler's equations),
    /// read back from the rotor speeds through the mixer. J = (0.01, 0.02, 0.04) kg·m² and ω = (1,
    /// 2, 3) rad/s give (0.12, −0.09, 0.02) N·m. A bug it catches: J·ω's `*` as `+`.
    #[test]
    fn on_command_the_loop_cancels_the_gyroscopic_torque() {
        let mut p = VehicleParams::x3d();
        p.inertia_kg_m2 = [0.01, 0.02, 0.04];
        let mut rl = RateLoop::new(&p, 1e-3);
        let w = Vec3::new(1.0, 2.0, 3.0);
        let f = forces(&p, rl.rotor_speed_commands(&RateCommand { rates: w, thrust_n: 8.0 }, w));
        let tau = body_torque(&p, f);
        for (got, want) in tau.iter().zip([0.12, -0.09, 0.02]) {
            assert!((got - want).abs() < 1e-12, "{tau:?}");
        }
        assert!((f.iter().sum::<f64>() - 8.0).abs() < 1e-12, "{f:?}");
    }

    /// The rate loop alone on a rigid yaw axis J·ṙ = τ_com + τ_d (rotor lag ignored: the torque
    /// acts at once, the loop at 1 kHz). With K_I = 0 the step torque τ_d leaves the rate error
    /// τ_d/(J·K_ω); with K_I > 0 the error decays to 0 and ∫e settles at τ_d/(J·K_I), with an
    /// integral on yaw alone or on every axis. A bug it catches: the guard "some K_I ≠ 0" as "some
    /// K_I = 0" skipped the integral exactly when every axis has one, and passed while the tests
    /// gave it to yaw alone.
    #[test]
    fn the_integral_removes_the_rate_error_of_a_constant_torque() {
        let (tau_d, dt) = (0.02, 1e-3);
        let steady = |ki: [f64; 3]| {
            let mut p = VehicleParams::x3d();
            p.rate_loop_integral_per_s2 = ki;
            let mut rl = RateLoop::new(&p, dt);
            let j = p.inertia_kg_m2[2];
            let cmd = RateCommand { rates: Vec3::zeros(), thrust_n: 7.0 };
            let mut r = 0.0;
            for _ in 0..10_000 {
                let tau = body_torque(&p, forces(&p, rl.rotor_speed_commands(&cmd, Vec3::new(0.0, 0.0, r))));
                r += (tau[2] + tau_d) / j * dt;
            }
            (r, rl.integral[2], j)
        };
        let (r_p, _, j) = steady([0.0; 3]);
        assert!((r_p - tau_d / (j * 10.0)).abs() < 1e-6, "P only: rate {r_p}");
        for ki in [[0.0, 0.0, 25.0], [25.0; 3]] {
            let (r_pi, integral, _) = steady(ki);
            assert!(r_pi.abs() < 1e-6, "PI {ki:?}: rate {r_pi}");
            assert!((integral - (-tau_d / (j * 25.0))).abs() < 1e-5, "PI {ki:?}: ∫e = {integral}");
        }
    }

    /// No wind-up on the floor: with the motors off (T = 0) a rate error of (0.1, −0.2, 0.3) rad/s
    /// held for 1 s leaves the integral at 0 on every axis; the first tick with thrust adds e·Δt =
    /// (1, −2, 3)·10⁻⁴ rad, and a return to T = 0 resets it. A bug it catches: `T > 0` as `T ≥ 0`
    /// wound the integral up on the floor.
    #[test]
    fn the_integral_is_held_at_zero_with_the_motors_off() {
        let mut p = VehicleParams::x3d();
        p.rate_loop_integral_per_s2 = [25.0; 3];
        let dt = 1e-3;
        let mut rl = RateLoop::new(&p, dt);
        let rates = Vec3::new(0.1, -0.2, 0.3);
        let off = RateCommand { rates, thrust_n: 0.0 };
        for _ in 0..1000 {
            rl.rotor_speed_commands(&off, Vec3::zeros());
        }
        assert_eq!(rl.integral, [0.0; 3], "wound up on the floor");
        rl.rotor_speed_commands(&RateCommand { rates, thrust_n: 7.0 }, Vec3::zeros());
        for (got, want) in rl.integral.iter().zip([1e-4, -2e-4, 3e-4]) {
            assert!((got - want).abs() < 1e-18, "{:?}", rl.integral);
        }
        rl.rotor_speed_commands(&off, Vec3::zeros());
        assert_eq!(rl.integral, [0.0; 3], "reset with the motors off");
    }
}

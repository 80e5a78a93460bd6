//! The onboard 1 kHz body-rate controller of the X3D.
//!
//! Input: the decoded radio command (body rates p, q, r in rad/s and collective thrust T in N,
//! held between 50 Hz PPM frames) and the gyro sample ω_gyro (body frame, rad/s).
//! Law: τ_com = J·K_ω·(ω_com − ω_gyro) + ω_gyro × J·ω_gyro (proportional rate tracking with
//! gyroscopic feed-forward). The mixer of the "+" layout then solves
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
    pub rates: Vec3<Body>,
    pub thrust_n: f64,
}

impl RateCommand {
    pub fn idle() -> Self {
        RateCommand { rates: Vec3::zeros(), thrust_n: 0.0 }
    }
}

#[derive(Clone, Debug)]
pub struct RateLoop {
    inertia: [f64; 3],
    gain: [f64; 3],
    arm: f64,
    k_m: f64,
    k_f: f64,
    f_max: f64,
}

impl RateLoop {
    pub fn new(p: &VehicleParams) -> Self {
        RateLoop { inertia: p.inertia_kg_m2, gain: p.rate_loop_gain_per_s, arm: p.arm_m, k_m: p.k_torque_m, k_f: p.k_thrust, f_max: p.rotor_thrust_max() }
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

    /// Rotor speed commands [front, right, back, left] (rad/s).
    pub fn rotor_speed_commands(&self, cmd: &RateCommand, gyro: Vec3<Body>) -> [f64; 4] {
        let w = gyro.to_array();
        let j = self.inertia;
        let err = (cmd.rates - gyro).to_array();
        let jw = [j[0] * w[0], j[1] * w[1], j[2] * w[2]];
        let gyroscopic = [w[1] * jw[2] - w[2] * jw[1], w[2] * jw[0] - w[0] * jw[2], w[0] * jw[1] - w[1] * jw[0]];
        let torque = [0, 1, 2].map(|i| j[i] * self.gain[i] * err[i] + gyroscopic[i]);
        self.mix(cmd.thrust_n, torque).map(|f| (f / self.k_f).sqrt())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mixer_reproduces_requested_thrust_and_torque() {
        let p = VehicleParams::x3d();
        let rl = RateLoop::new(&p);
        let (t, tau) = (7.0, [0.05, -0.03, 0.01]);
        let [f, r, b, l] = rl.mix(t, tau);
        assert!((f + r + b + l - t).abs() < 1e-12);
        assert!((p.arm_m * (l - r) - tau[0]).abs() < 1e-12);
        assert!((p.arm_m * (f - b) - tau[1]).abs() < 1e-12);
        assert!((p.k_torque_m * (f + b - r - l) - tau[2]).abs() < 1e-12);
    }
}

//! The onboard attitude mode: the vehicle holds roll and pitch angles and a heading by itself,
//! and the radio carries angle commands instead of body rates (AscTec's "attitude" commands).
//!
//! Frames: the body frame is the physical vehicle's (the IMU's), the onboard attitude estimate
//! refers to gravity and to the heading at power-on, never to the mocap. That is the point of
//! the mode: a commanded tilt is a tilt of the *physical* body, so the straight flight (6)
//! goes where the body points, and a marker yaw becomes visible to (8)–(9) (docs/findings.md).
//!
//! Gyro calibration at power-on, as flight firmware does: until the motors first run (the vehicle
//! at rest on the floor), b̂ is the mean gyro reading; after that it is frozen, and both onboard
//! loops use ω̃ = ω_gyro − b̂. Without it a gyro bias b leaves the P attitude loop a stand-off
//! φ − φ_com = −b_x/K_φ (the rate loop holds the *gyro's* rate at the command, so the true rate is
//! 0 at K_φ·(φ_com − φ) = b_x), and that tilt, small as it is (0.0125° for 0.1 °/s at K_φ = 8),
//! drifts the straight flight sideways by g·ε·t²/2. A scenario gives the calibration time with
//! an `idle` phase before the take-off; without one it sees only the few milliseconds before the
//! first radio frame and b̂ is mostly noise.
//!
//! Estimate (1 kHz, rectangle rule; angles in rad):
//! ```text
//! φ̂, θ̂ = the body's true roll and pitch      (a gravity-referenced filter; its error is not the topic)
//! ψ̂̇    = (q̃·sin φ̂ + r̃·cos φ̂)/cos θ̂         (the Euler yaw rate from the calibrated gyro)
//! ```
//! Heading hold: the set point integrates the radio's yaw-rate channel, ψ_set̂̇ = ψ̇_com, and
//! follows ψ̂ while the thrust is 0 (no wind-up on the floor).
//!
//! Law, then the body-rate loop ([`super::RateLoop`]) as in rate mode:
//! ```text
//! [φ̇ θ̇ ψ̇]_com = [K_φ·(φ_com − φ̂), K_θ·(θ_com − θ̂), K_ψ·wrap(ψ_set − ψ̂) + ψ̇_com]
//! [p q r]_com  = T_w⁻¹(φ̂, θ̂)·[φ̇ θ̇ ψ̇]_com                      (4)
//! ```

use super::rate_loop::RateCommand;
use crate::frames::{Body, Nav, Rot, Vec3, t_w_inv, wrap_pi};

/// What the onboard controller of a vehicle tracks, and so what the radio carries.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum OnboardMode {
    /// Body rates p, q, r (the paper's X3D): the ground closes the attitude loop on the mocap.
    #[default]
    Rate,
    /// Roll and pitch angles and a yaw rate, held onboard on the vehicle's own attitude estimate.
    Attitude,
}

/// An attitude command as the receiver decodes it (rad, rad/s; collective thrust in N).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AttitudeCommand {
    /// Roll command φ_com (rad).
    pub roll: f64,
    /// Pitch command θ_com (rad).
    pub pitch: f64,
    /// Heading rate ψ̇_com (an Euler rate, rad/s).
    pub yaw_rate: f64,
    /// Collective thrust (N).
    pub thrust_n: f64,
}

/// The onboard attitude loop of one vehicle (see the module doc).
#[derive(Clone, Debug)]
pub struct AttitudeLoop {
    gain: [f64; 3],
    period_s: f64,
    /// ψ̂ and ψ_set (rad).
    yaw_est: f64,
    yaw_set: f64,
    /// Σω_gyro and the count while at rest, until the motors first run.
    rest_sum: Vec3<Body>,
    rest_n: u32,
    armed: bool,
}

impl AttitudeLoop {
    /// Gains [K_φ, K_θ, K_ψ] (1/s), run every `period_s`; the heading estimate starts at `yaw0`.
    pub fn new(gain: [f64; 3], period_s: f64, yaw0: f64) -> Self {
        AttitudeLoop { gain, period_s, yaw_est: yaw0, yaw_set: yaw0, rest_sum: Vec3::zeros(), rest_n: 0, armed: false }
    }

    /// The power-on gyro bias estimate b̂ (rad/s; 0 before the first sample).
    pub fn gyro_bias(&self) -> Vec3<Body> {
        if self.rest_n == 0 { Vec3::zeros() } else { self.rest_sum * (1.0 / self.rest_n as f64) }
    }

    /// The calibrated gyro ω̃ = ω_gyro − b̂ that both onboard loops use.
    pub fn calibrated(&self, gyro: Vec3<Body>) -> Vec3<Body> {
        gyro - self.gyro_bias()
    }

    /// The onboard heading estimate ψ̂ (rad, wrapped to (−π, π]).
    pub fn yaw_estimate(&self) -> f64 {
        wrap_pi(self.yaw_est)
    }

    /// One loop period: the body-rate command for the rate loop, from the command the receiver
    /// holds, the body's true attitude (for φ̂, θ̂) and the raw gyro sample (calibrated here).
    pub fn rate_command(&mut self, cmd: &AttitudeCommand, att_true: &Rot<Body, Nav>, gyro: Vec3<Body>) -> RateCommand {
        self.armed |= cmd.thrust_n > 0.0;
        if !self.armed {
            self.rest_sum += gyro;
            self.rest_n += 1;
        }
        let gyro = self.calibrated(gyro);
        let e = att_true.euler();
        let (sf, cf) = e.roll.sin_cos();
        let ct = e.pitch.cos();
        self.yaw_est += (gyro.y() * sf + gyro.z() * cf) / ct * self.period_s;
        if cmd.thrust_n > 0.0 {
            self.yaw_set += cmd.yaw_rate * self.period_s;
        } else {
            self.yaw_set = self.yaw_est;
        }
        let k = self.gain;
        let euler_rates = nalgebra::Vector3::new(k[0] * (cmd.roll - e.roll), k[1] * (cmd.pitch - e.pitch), k[2] * wrap_pi(self.yaw_set - self.yaw_est) + cmd.yaw_rate);
        RateCommand { rates: Vec3::from_raw(t_w_inv(e.roll, e.pitch) * euler_rates), thrust_n: cmd.thrust_n }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frames::Euler;

    fn cmd(roll_deg: f64, pitch_deg: f64, yaw_rate: f64) -> AttitudeCommand {
        AttitudeCommand { roll: roll_deg.to_radians(), pitch: pitch_deg.to_radians(), yaw_rate, thrust_n: 5.0 }
    }

    /// Level, heading held: a roll error of 2° asks p = K_φ·2° and nothing else; a pitch error
    /// asks q alone.
    #[test]
    fn angle_errors_become_body_rates_at_level() {
        let mut l = AttitudeLoop::new([8.0, 7.0, 3.0], 1e-3, 0.0);
        let r = l.rate_command(&cmd(2.0, 0.0, 0.0), &Rot::identity(), Vec3::zeros());
        assert!((r.rates.x() - 8.0 * 2f64.to_radians()).abs() < 1e-12 && r.rates.y() == 0.0 && r.rates.z() == 0.0, "{:?}", r.rates);
        let r = l.rate_command(&cmd(0.0, -1.0, 0.0), &Rot::identity(), Vec3::zeros());
        assert!((r.rates.y() + 7.0 * 1f64.to_radians()).abs() < 1e-12 && r.rates.x() == 0.0, "{:?}", r.rates);
    }

    /// The angles are held against the *body's* attitude: at the commanded roll and pitch of
    /// 10° and −5° the loop asks for nothing, whatever the heading (a marker rotation cannot
    /// enter, the loop never sees the mocap).
    #[test]
    fn at_the_commanded_angles_the_loop_is_quiet() {
        for yaw in [0.0f64, 40.0, -170.0] {
            let mut l = AttitudeLoop::new([8.0, 8.0, 3.0], 1e-3, yaw.to_radians());
            let att = Rot::from_euler(Euler::from_degrees(10.0, -5.0, yaw));
            let r = l.rate_command(&cmd(10.0, -5.0, 0.0), &att, Vec3::zeros());
            assert!(r.rates.norm() < 1e-12, "yaw {yaw}: {:?}", r.rates);
        }
    }

    /// Heading: a gyro reading r = 0.1 rad/s at level for 1 s moves ψ̂ by 0.1 rad (a gyro bias
    /// is a heading drift); the set point stays, so the loop turns back at K_ψ·0.1 rad/s. A
    /// commanded ψ̇ moves the set point instead and is fed forward.
    #[test]
    fn the_heading_integrates_the_gyro_and_holds_its_set_point() {
        let mut l = AttitudeLoop::new([8.0, 8.0, 3.0], 1e-3, 0.0);
        let mut r = RateCommand::idle();
        for _ in 0..1000 {
            r = l.rate_command(&cmd(0.0, 0.0, 0.0), &Rot::identity(), Vec3::new(0.0, 0.0, 0.1));
        }
        assert!((l.yaw_estimate() - 0.1).abs() < 1e-12, "{}", l.yaw_estimate());
        // the last call saw ψ̂ = 0.1 rad: r_com = 3·(0 − 0.1)
        assert!((r.rates.z() + 0.3).abs() < 1e-9, "{:?}", r.rates);
        let mut l = AttitudeLoop::new([8.0, 8.0, 3.0], 1e-3, 0.0);
        let r = l.rate_command(&cmd(0.0, 0.0, 0.2), &Rot::identity(), Vec3::zeros());
        // ψ_set moved by 0.2·1 ms: r = 3·0.0002 + 0.2
        assert!((r.rates.z() - (0.2 + 3.0 * 0.0002)).abs() < 1e-12, "{:?}", r.rates);
    }

    /// With the motors off the set point follows the estimate: a vehicle turned by hand on the
    /// floor after a landing (the gyro calibration frozen at the first flight) is not fought at
    /// the next take-off.
    #[test]
    fn no_heading_wind_up_on_the_floor() {
        let mut l = AttitudeLoop::new([8.0, 8.0, 3.0], 1e-3, 0.0);
        l.rate_command(&cmd(0.0, 0.0, 0.0), &Rot::identity(), Vec3::zeros());
        let off = AttitudeCommand { thrust_n: 0.0, ..cmd(0.0, 0.0, 0.0) };
        for _ in 0..500 {
            l.rate_command(&off, &Rot::identity(), Vec3::new(0.0, 0.0, 0.2));
        }
        let r = l.rate_command(&cmd(0.0, 0.0, 0.0), &Rot::identity(), Vec3::zeros());
        assert!(r.rates.z().abs() < 1e-12, "{:?}", r.rates);
    }

    /// Off level the Euler rates go through T_w⁻¹: at φ = 30° a pure ψ̇ command is
    /// q = cos θ·sin φ·ψ̇, r = cos θ·cos φ·ψ̇ (θ = 0), and the heading integrates
    /// (q·sin φ + r·cos φ)/cos θ = ψ̇ back.
    #[test]
    fn off_level_the_yaw_rate_goes_through_t_w_inv() {
        let mut l = AttitudeLoop::new([8.0, 8.0, 0.0], 1e-3, 0.0);
        let att = Rot::from_euler(Euler::from_degrees(30.0, 0.0, 0.0));
        let r = l.rate_command(&cmd(30.0, 0.0, 0.5), &att, Vec3::zeros());
        let (s, c) = 30f64.to_radians().sin_cos();
        assert!((r.rates.y() - s * 0.5).abs() < 1e-12 && (r.rates.z() - c * 0.5).abs() < 1e-12 && r.rates.x().abs() < 1e-12, "{:?}", r.rates);
        let before = l.yaw_estimate();
        l.rate_command(&cmd(30.0, 0.0, 0.5), &att, r.rates);
        assert!((l.yaw_estimate() - before - 0.5e-3).abs() < 1e-12);
        // pitched by θ = 30° (φ = 0) a heading turn ψ̇ is p = −sin θ·ψ̇, r = cos θ·ψ̇: the
        // heading integrates r/cos θ = ψ̇, not r or r·cos θ
        let mut l = AttitudeLoop::new([8.0, 8.0, 0.0], 1e-3, 0.0);
        let att = Rot::from_euler(Euler::from_degrees(0.0, 30.0, 0.0));
        let (s, c) = 30f64.to_radians().sin_cos();
        for _ in 0..1000 {
            l.rate_command(&cmd(0.0, 30.0, 0.5), &att, Vec3::new(-s * 0.5, 0.0, c * 0.5));
        }
        assert!((l.yaw_estimate() - 0.5).abs() < 1e-9, "{}", l.yaw_estimate());
    }

    /// Power-on calibration: at rest with a bias of (0.1, −0.1, 0.2) rad/s the heading stays put
    /// (the mean is subtracted from the first sample on), and the estimate is frozen at the first
    /// thrust: readings after it (a real turn of 0.3 rad/s) are not taken for bias.
    #[test]
    fn the_gyro_is_calibrated_at_rest_until_the_motors_run() {
        let b = Vec3::<Body>::new(0.1, -0.1, 0.2);
        let mut l = AttitudeLoop::new([8.0, 8.0, 3.0], 1e-3, 0.0);
        let off = AttitudeCommand { thrust_n: 0.0, ..cmd(0.0, 0.0, 0.0) };
        for _ in 0..100 {
            l.rate_command(&off, &Rot::identity(), b);
        }
        assert!((l.gyro_bias() - b).norm() < 1e-15 && l.yaw_estimate().abs() < 1e-15, "{:?}", l.gyro_bias());
        for _ in 0..100 {
            l.rate_command(&cmd(0.0, 0.0, 0.0), &Rot::identity(), b + Vec3::new(0.0, 0.0, 0.3));
        }
        assert!((l.gyro_bias() - b).norm() < 1e-15, "{:?}", l.gyro_bias());
        assert!((l.yaw_estimate() - 0.03).abs() < 1e-12, "{}", l.yaw_estimate());
        // and the rate loop gets the calibrated rate
        assert!((l.calibrated(b) - Vec3::zeros()).norm() < 1e-15);
    }
}

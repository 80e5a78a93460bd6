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
//! The onboard attitude estimate Ĉ_b^n (1 kHz; the estimate's "down" is gravity as the
//! accelerometer sees it, its heading the power-on heading integrated with the gyro):
//! ```text
//! at rest (before the first thrust):  φ̂ = atan2(−f̄_y, −f̄_z),  θ̂ = asin(f̄_x/|f̄|)   (f̄ the mean accelerometer)
//!                                     ψ̂ integrates the calibrated gyro
//! in flight (Mahony's complementary filter, proportional part):
//!   d_meas = −f/|f|          the accelerometer's "down", body      (used when 0.5·g < |f| < 1.5·g)
//!   d̂      = Ĉ_n^b·e_D        the estimate's "down", body
//!   Ĉ_b^n ← Ĉ_b^n·exp((ω̃ + k_a·d_meas × d̂)·Δt)
//! ```
//! k_a = 0.2 1/s ([`LEVEL_GAIN_PER_S`], PX4's `ATT_W_ACC`). The correction has no component about the
//! estimated vertical d̂: it moves the level, not the heading. What this estimate gets wrong, as a real one
//! does:
//! - an accelerometer bias b tilts the level by b/g: at rest f̄ = (b_x, b_y, −g + b_z), so
//!   φ̂ = φ − b_y/g and θ̂ = θ + b_x/g (small angles); holding φ̂ = 0 the body flies rolled by
//!   ε_φ = b_y/g (1 mg: 0.057°). The filter keeps that error in flight (in a hover the
//!   accelerometer reads the same −g·e_z + b). An accelerometer turned by α against the thrust
//!   axis is the same error as a bias of g·α;
//! - in an acceleration a along body x the accelerometer reads the thrust axis, not gravity,
//!   and the filter pulls θ̂ toward the thrust axis at k_a·a/g rad/s (0.5 m/s² for 1.5 s: 0.9°);
//!   the roll estimate, the one the straight flight (6) needs, does not see it.
//!
//! Heading hold: the set point integrates the radio's yaw-rate channel, ψ_set̂̇ = ψ̇_com, and
//! follows ψ̂ while the thrust is 0 (no wind-up on the floor).
//!
//! Law, on the estimate's Euler angles (φ̂, θ̂, ψ̂), then the body-rate loop ([`super::RateLoop`])
//! as in rate mode:
//! ```text
//! [φ̇ θ̇ ψ̇]_com = [K_φ·(φ_com − φ̂), K_θ·(θ_com − θ̂), K_ψ·wrap(ψ_set − ψ̂) + ψ̇_com]
//! [p q r]_com  = T_w⁻¹(φ̂, θ̂)·[φ̇ θ̇ ψ̇]_com                      (4)
//! ```

use super::imu::ImuSample;
use super::params::GRAVITY;
use super::rate_loop::RateCommand;
use crate::frames::{Body, Euler, Nav, Rot, Vec3, t_w_inv, wrap_pi};

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

/// k_a of the level filter (1/s): how fast the onboard level follows the accelerometer's
/// gravity (PX4's `ATT_W_ACC` default).
pub const LEVEL_GAIN_PER_S: f64 = 0.2;

/// The onboard attitude loop of one vehicle, with its own attitude estimate (see the module doc).
#[derive(Clone, Debug)]
pub struct AttitudeLoop {
    gain: [f64; 3],
    period_s: f64,
    /// Ĉ_b^n: the onboard estimate of the body's attitude (level from the accelerometer, heading
    /// from the gyro since power-on).
    est: Rot<Body, Nav>,
    /// ψ_set (rad).
    yaw_set: f64,
    /// Σω_gyro, Σf and the count while at rest, until the motors first run.
    rest_gyro: Vec3<Body>,
    rest_accel: Vec3<Body>,
    rest_n: u32,
    armed: bool,
}

impl AttitudeLoop {
    /// Gains [K_φ, K_θ, K_ψ] (1/s), run every `period_s`; the estimate starts level at heading
    /// `yaw0`.
    pub fn new(gain: [f64; 3], period_s: f64, yaw0: f64) -> Self {
        let est = Rot::from_euler(Euler::new(0.0, 0.0, yaw0));
        AttitudeLoop {
            gain,
            period_s,
            est,
            yaw_set: yaw0,
            rest_gyro: Vec3::zeros(),
            rest_accel: Vec3::zeros(),
            rest_n: 0,
            armed: false,
        }
    }

    /// The power-on gyro bias estimate b̂ (rad/s; 0 before the first sample).
    pub fn gyro_bias(&self) -> Vec3<Body> {
        if self.rest_n == 0 { Vec3::zeros() } else { self.rest_gyro * (1.0 / self.rest_n as f64) }
    }

    /// The calibrated gyro ω̃ = ω_gyro − b̂ that both onboard loops use.
    pub fn calibrated(&self, gyro: Vec3<Body>) -> Vec3<Body> {
        gyro - self.gyro_bias()
    }

    /// The onboard attitude estimate Ĉ_b^n.
    pub fn estimate(&self) -> Rot<Body, Nav> {
        self.est
    }

    /// The onboard heading estimate ψ̂ (rad, wrapped to (−π, π]).
    pub fn yaw_estimate(&self) -> f64 {
        wrap_pi(self.est.euler().yaw)
    }

    /// One loop period: the body-rate command for the rate loop, from the command the receiver
    /// holds and the raw IMU sample (the estimate is updated with it first).
    pub fn rate_command(&mut self, cmd: &AttitudeCommand, imu: &ImuSample) -> RateCommand {
        self.update_estimate(cmd.thrust_n > 0.0, imu);
        let e = self.est.euler();
        if cmd.thrust_n > 0.0 {
            self.yaw_set += cmd.yaw_rate * self.period_s;
        } else {
            self.yaw_set = e.yaw;
        }
        let k = self.gain;
        let euler_rates = nalgebra::Vector3::new(
            k[0] * (cmd.roll - e.roll),
            k[1] * (cmd.pitch - e.pitch),
            k[2] * wrap_pi(self.yaw_set - e.yaw) + cmd.yaw_rate,
        );
        RateCommand { rates: Vec3::from_raw(t_w_inv(e.roll, e.pitch) * euler_rates), thrust_n: cmd.thrust_n }
    }

    /// The estimate's step (module doc): at rest the level of the mean accelerometer and the
    /// heading integrated; from the first thrust on the complementary filter.
    fn update_estimate(&mut self, thrust: bool, imu: &ImuSample) {
        self.armed |= thrust;
        if !self.armed {
            self.rest_gyro += imu.gyro;
            self.rest_accel += imu.specific_force;
            self.rest_n += 1;
        }
        let mut omega = self.calibrated(imu.gyro);
        let f = imu.specific_force;
        let g = f.norm();
        if self.armed && g > 0.5 * GRAVITY && g < 1.5 * GRAVITY {
            let d_meas = f * (-1.0 / g);
            let d_est = self.est.inverse().apply(Vec3::<Nav>::new(0.0, 0.0, 1.0));
            omega += d_meas.cross(&d_est) * LEVEL_GAIN_PER_S;
        }
        self.est = self.est * Rot::from_rotation_vector(omega * self.period_s);
        if !self.armed {
            let m = self.rest_accel;
            let n = m.norm();
            if n > 0.0 {
                let yaw = self.est.euler().yaw;
                self.est = Rot::from_euler(Euler::new((-m.y()).atan2(-m.z()), (m.x() / n).asin(), yaw));
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cmd(roll_deg: f64, pitch_deg: f64, yaw_rate: f64) -> AttitudeCommand {
        AttitudeCommand { roll: roll_deg.to_radians(), pitch: pitch_deg.to_radians(), yaw_rate, thrust_n: 5.0 }
    }

    fn off() -> AttitudeCommand {
        AttitudeCommand { thrust_n: 0.0, ..cmd(0.0, 0.0, 0.0) }
    }

    /// What an ideal IMU reads at rest at attitude `att` turning at `gyro`: the specific force
    /// C_n^b·(0, 0, −g).
    fn at_rest(att: Euler, gyro: Vec3<Body>) -> ImuSample {
        let c: Rot<Body, Nav> = Rot::from_euler(att);
        ImuSample { gyro, specific_force: c.inverse().apply(Vec3::new(0.0, 0.0, -GRAVITY)) }
    }

    fn level(gyro: Vec3<Body>) -> ImuSample {
        at_rest(Euler::ZERO, gyro)
    }

    /// A loop whose estimate has settled at rest at `att` (100 samples, motors off).
    fn rested_at(att: Euler, gain: [f64; 3]) -> AttitudeLoop {
        let mut l = AttitudeLoop::new(gain, 1e-3, att.yaw);
        for _ in 0..100 {
            l.rate_command(&off(), &at_rest(att, Vec3::zeros()));
        }
        l
    }

    /// Level, heading held: a roll error of 2° asks p = K_φ·2° and nothing else; a pitch error
    /// asks q alone.
    #[test]
    fn angle_errors_become_body_rates_at_level() {
        let mut l = AttitudeLoop::new([8.0, 7.0, 3.0], 1e-3, 0.0);
        let r = l.rate_command(&cmd(2.0, 0.0, 0.0), &level(Vec3::zeros()));
        assert!(
            (r.rates.x() - 8.0 * 2f64.to_radians()).abs() < 1e-12 && r.rates.y() == 0.0 && r.rates.z() == 0.0,
            "{:?}",
            r.rates
        );
        let r = l.rate_command(&cmd(0.0, -1.0, 0.0), &level(Vec3::zeros()));
        assert!((r.rates.y() + 7.0 * 1f64.to_radians()).abs() < 1e-12 && r.rates.x() == 0.0, "{:?}", r.rates);
    }

    /// The angles are held against the onboard estimate, which at rest is the accelerometer's
    /// level: resting at roll 10°, pitch −5° (gravity read as C_n^b·(0, 0, −g)) and asked for
    /// exactly that, the loop asks for nothing, whatever the heading (a marker rotation cannot
    /// enter, the loop never sees the mocap).
    #[test]
    fn at_the_commanded_angles_the_loop_is_quiet() {
        for yaw in [0.0f64, 40.0, -170.0] {
            let att = Euler::from_degrees(10.0, -5.0, yaw);
            let mut l = rested_at(att, [8.0, 8.0, 3.0]);
            let e = l.estimate().euler();
            assert!(
                (e.roll - att.roll).abs() < 1e-12
                    && (e.pitch - att.pitch).abs() < 1e-12
                    && wrap_pi(e.yaw - att.yaw).abs() < 1e-12,
                "{e:?}"
            );
            let r = l.rate_command(&cmd(10.0, -5.0, 0.0), &at_rest(att, Vec3::zeros()));
            assert!(r.rates.norm() < 1e-9, "yaw {yaw}: {:?}", r.rates);
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
            r = l.rate_command(&cmd(0.0, 0.0, 0.0), &level(Vec3::new(0.0, 0.0, 0.1)));
        }
        assert!((l.yaw_estimate() - 0.1).abs() < 1e-12, "{}", l.yaw_estimate());
        // the last call saw ψ̂ = 0.1 rad: r_com = 3·(0 − 0.1)
        assert!((r.rates.z() + 0.3).abs() < 1e-9, "{:?}", r.rates);
        let mut l = AttitudeLoop::new([8.0, 8.0, 3.0], 1e-3, 0.0);
        let r = l.rate_command(&cmd(0.0, 0.0, 0.2), &level(Vec3::zeros()));
        // ψ_set moved by 0.2·1 ms: r = 3·0.0002 + 0.2
        assert!((r.rates.z() - (0.2 + 3.0 * 0.0002)).abs() < 1e-12, "{:?}", r.rates);
    }

    /// With the motors off the set point follows the estimate: a vehicle turned by hand on the
    /// floor after a landing (the gyro calibration frozen at the first flight) is not fought at
    /// the next take-off.
    #[test]
    fn no_heading_wind_up_on_the_floor() {
        let mut l = AttitudeLoop::new([8.0, 8.0, 3.0], 1e-3, 0.0);
        l.rate_command(&cmd(0.0, 0.0, 0.0), &level(Vec3::zeros()));
        for _ in 0..500 {
            l.rate_command(&off(), &level(Vec3::new(0.0, 0.0, 0.2)));
        }
        let r = l.rate_command(&cmd(0.0, 0.0, 0.0), &level(Vec3::zeros()));
        assert!(r.rates.z().abs() < 1e-12, "{:?}", r.rates);
    }

    /// Off level the Euler rates go through T_w⁻¹: at φ = 30° a pure ψ̇ command is
    /// q = cos θ·sin φ·ψ̇, r = cos θ·cos φ·ψ̇ (θ = 0), and the heading integrates
    /// (q·sin φ + r·cos φ)/cos θ = ψ̇ back.
    #[test]
    fn off_level_the_yaw_rate_goes_through_t_w_inv() {
        let att = Euler::from_degrees(30.0, 0.0, 0.0);
        let mut l = rested_at(att, [8.0, 8.0, 0.0]);
        let r = l.rate_command(&cmd(30.0, 0.0, 0.5), &at_rest(att, Vec3::zeros()));
        let (s, c) = 30f64.to_radians().sin_cos();
        assert!(
            (r.rates.y() - s * 0.5).abs() < 1e-9 && (r.rates.z() - c * 0.5).abs() < 1e-9 && r.rates.x().abs() < 1e-9,
            "{:?}",
            r.rates
        );
        let before = l.yaw_estimate();
        l.rate_command(&cmd(30.0, 0.0, 0.5), &at_rest(att, r.rates));
        assert!((l.yaw_estimate() - before - 0.5e-3).abs() < 1e-9);
        // pitched by θ = 30° (φ = 0) a heading turn ψ̇ is p = −sin θ·ψ̇, r = cos θ·ψ̇: the
        // heading integrates r/cos θ = ψ̇, not r or r·cos θ
        let att = Euler::from_degrees(0.0, 30.0, 0.0);
        let mut l = rested_at(att, [8.0, 8.0, 0.0]);
        for _ in 0..1000 {
            // a turn about the vertical leaves gravity fixed in the body
            l.rate_command(&cmd(0.0, 30.0, 0.5), &at_rest(att, Vec3::new(-s * 0.5, 0.0, c * 0.5)));
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
        for _ in 0..100 {
            l.rate_command(&off(), &level(b));
        }
        assert!((l.gyro_bias() - b).norm() < 1e-15 && l.yaw_estimate().abs() < 1e-15, "{:?}", l.gyro_bias());
        for _ in 0..100 {
            l.rate_command(&cmd(0.0, 0.0, 0.0), &level(b + Vec3::new(0.0, 0.0, 0.3)));
        }
        assert!((l.gyro_bias() - b).norm() < 1e-15, "{:?}", l.gyro_bias());
        assert!((l.yaw_estimate() - 0.03).abs() < 1e-12, "{}", l.yaw_estimate());
        // and the rate loop gets the calibrated rate
        assert!((l.calibrated(b) - Vec3::zeros()).norm() < 1e-15);
    }

    /// An accelerometer bias is a level error of b/g: resting level with b = (2, −1, 0) mg the
    /// estimate reads roll atan2(−b_y, g) and pitch asin(b_x/|f|) (by hand: +0.0573°, +0.1146°),
    /// so a loop asked for level asks to roll the body by +b_y/g and pitch it by −b_x/g.
    #[test]
    fn an_accelerometer_bias_is_a_level_error_of_b_over_g() {
        let mg = GRAVITY * 1e-3;
        let bias = Vec3::<Body>::new(2.0 * mg, -mg, 0.0);
        let mut l = AttitudeLoop::new([8.0, 8.0, 3.0], 1e-3, 0.0);
        let biased = ImuSample { gyro: Vec3::zeros(), specific_force: Vec3::new(0.0, 0.0, -GRAVITY) + bias };
        for _ in 0..10 {
            l.rate_command(&off(), &biased);
        }
        let e = l.estimate().euler();
        let (roll, pitch) = ((1e-3f64).atan(), (2e-3 / (1.0f64 + 5e-6).sqrt()).asin());
        assert!((e.roll - roll).abs() < 1e-15 && (e.pitch - pitch).abs() < 1e-15, "{:?}", e.to_degrees());
        assert!((roll.to_degrees() - 0.0573).abs() < 1e-4 && (pitch.to_degrees() - 0.1146).abs() < 1e-4);
        let r = l.rate_command(&cmd(0.0, 0.0, 0.0), &biased);
        // (T_w⁻¹ at the estimate: q = cos φ̂·θ̇, a part in 10⁶ off 8·θ̂)
        assert!((r.rates.x() + 8.0 * roll).abs() < 1e-9 && (r.rates.y() + 8.0 * pitch).abs() < 1e-7, "{:?}", r.rates);
    }

    /// In flight the level follows the accelerometer's gravity at k_a: an estimate 1° off in
    /// roll on a level, still body decays as e^(−k_a·t), to 1°·e⁻¹ = 0.368° after 1/k_a = 5 s; a
    /// reading far from g (free fall, 0.2·g) corrects nothing.
    #[test]
    fn the_level_follows_gravity_at_its_gain() {
        let mut l = rested_at(Euler::from_degrees(1.0, 0.0, 0.0), [8.0, 8.0, 3.0]);
        let steps = (1.0 / LEVEL_GAIN_PER_S / 1e-3).round() as usize;
        for _ in 0..steps {
            l.rate_command(&cmd(0.0, 0.0, 0.0), &level(Vec3::zeros()));
        }
        let roll = l.estimate().euler().roll.to_degrees();
        assert!((roll - (-1f64).exp()).abs() < 2e-4, "{roll}");
        let mut l = rested_at(Euler::from_degrees(1.0, 0.0, 0.0), [8.0, 8.0, 3.0]);
        let falling = ImuSample { gyro: Vec3::zeros(), specific_force: Vec3::new(0.0, 0.0, -0.2 * GRAVITY) };
        for _ in 0..steps {
            l.rate_command(&cmd(0.0, 0.0, 0.0), &falling);
        }
        assert!((l.estimate().euler().roll.to_degrees() - 1.0).abs() < 1e-9);
    }
}

//! The onboard IMU: gyro and accelerometer, both in the body frame.
//!
//! gyro  = ω_body + b_g + n_g,  n_g ~ N(0, σ_g²) per axis (rad/s)
//! accel = f_body + b_a + n_a,  f_body = C_n^b·(a_nav − g·e_D) (specific force, m/s²):
//! at rest on the floor f_body = (0, 0, −g).
//!
//! An IMU at r from the centre of mass (body FRD, m) reads the specific force of its own point,
//! f_imu = f_cm + ω̇×r + ω×(ω×r) (a rigid body's acceleration at r; [`lever_arm_specific_force`]);
//! the gyro reads the same ω anywhere on the body.

use crate::frames::{Body, Vec3};
use crate::rng::Stream;

/// Noise and bias of the IMU (see the module doc).
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct ImuParams {
    /// Gyro white-noise standard deviation σ_g per axis (rad/s).
    pub gyro_noise_rad_s: f64,
    /// Accelerometer white-noise standard deviation σ_a per axis (m/s²).
    pub accel_noise_m_s2: f64,
    /// Constant gyro bias b_g, body (rad/s).
    pub gyro_bias_rad_s: [f64; 3],
    /// Constant accelerometer bias b_a, body (m/s²).
    pub accel_bias_m_s2: [f64; 3],
    /// Position r of the IMU from the centre of mass, body FRD (m).
    pub position_m: [f64; 3],
}

/// One IMU reading.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImuSample {
    /// Angular rate, body (rad/s).
    pub gyro: Vec3<Body>,
    /// Specific force, body (m/s²).
    pub specific_force: Vec3<Body>,
}

/// The IMU of one vehicle, with its own noise stream.
#[derive(Clone, Debug)]
pub struct Imu {
    params: ImuParams,
    rng: Stream,
}

impl Imu {
    /// An IMU with these parameters, drawing its noise from `rng`.
    pub fn new(params: ImuParams, rng: Stream) -> Self {
        Imu { params, rng }
    }

    /// The IMU's position from the centre of mass (body FRD, m), if it is not at it.
    pub fn position(&self) -> Option<Vec3<Body>> {
        (self.params.position_m != [0.0; 3]).then(|| Vec3::from_array(self.params.position_m))
    }

    /// One reading of the true angular rate and specific force (body), with bias and noise added.
    pub fn sample(&mut self, omega: Vec3<Body>, specific_force: Vec3<Body>) -> ImuSample {
        let p = &self.params;
        let mut noise = |s: f64| if s > 0.0 { s * self.rng.normal() } else { 0.0 };
        let ng = Vec3::new(noise(p.gyro_noise_rad_s), noise(p.gyro_noise_rad_s), noise(p.gyro_noise_rad_s));
        let na = Vec3::new(noise(p.accel_noise_m_s2), noise(p.accel_noise_m_s2), noise(p.accel_noise_m_s2));
        ImuSample {
            gyro: omega + Vec3::from_array(p.gyro_bias_rad_s) + ng,
            specific_force: specific_force + Vec3::from_array(p.accel_bias_m_s2) + na,
        }
    }
}

/// The specific force a point at r from the centre of mass feels beyond the centre of mass's,
/// ω̇×r + ω×(ω×r) (body FRD; ω rad/s, ω̇ rad/s², r m → m/s²): the tangential and centripetal
/// acceleration of a rigid body's point.
pub fn lever_arm_specific_force(omega: Vec3<Body>, omega_dot: Vec3<Body>, r: Vec3<Body>) -> Vec3<Body> {
    omega_dot.cross(&r) + omega.cross(&omega.cross(&r))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The IMU noise stream of run `seed`.
    fn noise_stream(seed: u64) -> Stream {
        Stream::new(seed, crate::rng::Component::ImuNoise, 0)
    }

    /// The engine adds the lever-arm acceleration only where `position` is `Some`: an IMU at the
    /// centre of mass has none, one off it has exactly its configured r (body FRD). A bug it
    /// catches: `Some(0)` always, and `None` off the centre, lost the lever arm and.
    #[test]
    fn an_imu_off_the_centre_reports_its_position_and_one_at_it_none() {
        let stream = || noise_stream(1);
        assert_eq!(Imu::new(ImuParams::default(), stream()).position(), None);
        let off = ImuParams { position_m: [0.05, -0.02, 0.01], ..ImuParams::default() };
        assert_eq!(Imu::new(off, stream()).position().map(Vec3::to_array), Some([0.05, -0.02, 0.01]));
        let below = ImuParams { position_m: [0.0, 0.0, 0.03], ..ImuParams::default() };
        assert_eq!(Imu::new(below, stream()).position().map(Vec3::to_array), Some([0.0, 0.0, 0.03]));
    }

    /// Closed forms: a point 0.1 m ahead of the centre on a body spinning about z at 3 rad/s is
    /// pulled towards the axis by ω²r = 0.9 m/s² (−x); the same point under ω̇ = 2 rad/s² about z
    /// is pushed sideways (+y, FRD: right) by ω̇·r = 0.2 m/s²; a point on the axis feels neither.
    #[test]
    fn a_point_off_the_centre_feels_the_centripetal_and_tangential_acceleration() {
        let r = Vec3::<Body>::new(0.1, 0.0, 0.0);
        let z = Vec3::<Body>::zeros();
        let f = lever_arm_specific_force(Vec3::new(0.0, 0.0, 3.0), z, r);
        assert!((f.x() + 0.9).abs() < 1e-12 && f.y().abs() < 1e-12 && f.z().abs() < 1e-12, "{f:?}");
        let f = lever_arm_specific_force(z, Vec3::new(0.0, 0.0, 2.0), r);
        assert!(f.x().abs() < 1e-12 && (f.y() - 0.2).abs() < 1e-12 && f.z().abs() < 1e-12, "{f:?}");
        let f = lever_arm_specific_force(Vec3::new(0.0, 0.0, 3.0), Vec3::new(0.0, 0.0, 2.0), Vec3::new(0.0, 0.0, 0.05));
        assert!(f.norm() < 1e-12, "{f:?}");
        // a point below the centre (r_z > 0) under a pitch acceleration ω̇_y: ω̇ × r = (ω̇_y·r_z, 0, 0)
        let f = lever_arm_specific_force(z, Vec3::new(0.0, 5.0, 0.0), Vec3::new(0.0, 0.0, 0.02));
        assert!((f.x() - 0.1).abs() < 1e-12 && f.y().abs() < 1e-12, "{f:?}");
    }

    /// Closed forms: each axis reads truth + bias + N(0, σ²). Over n = 4,000 readings the axis mean
    /// is off its truth + bias by at most 5σ/√n, and the sample variance s² is within 5·√(2/(n −
    /// 1)) (≈ 11 %) of σ² (the variance of s² is 2σ⁴/(n − 1) for Gaussian noise): a false alarm
    /// once in ~10⁶ per check, while an IMU that adds no noise, or the gyro's σ to the
    /// accelerometer (σ² 400 times too small), is off by about 100 %. A noise-free IMU reads truth +
    /// bias exactly. A bug it catches: noise only where σ == 0 (i.e. never).
    #[test]
    fn an_imu_adds_its_bias_and_white_noise_of_the_configured_spread_on_every_axis() {
        let params = ImuParams {
            gyro_noise_rad_s: 0.01,
            accel_noise_m_s2: 0.2,
            gyro_bias_rad_s: [0.02, -0.03, 0.005],
            accel_bias_m_s2: [-0.1, 0.05, 0.3],
            ..ImuParams::default()
        };
        let (omega, force) = (Vec3::<Body>::new(0.5, -1.0, 2.0), Vec3::<Body>::new(0.0, 1.0, -9.81));
        let mut imu = Imu::new(params.clone(), noise_stream(7));
        let n = 4000;
        let readings: Vec<ImuSample> = (0..n).map(|_| imu.sample(omega, force)).collect();
        let check = |name: &str, read: &dyn Fn(&ImuSample) -> [f64; 3], truth: [f64; 3], bias: [f64; 3], sigma: f64| {
            for k in 0..3 {
                let x: Vec<f64> = readings.iter().map(|s| read(s)[k]).collect();
                let mean = x.iter().sum::<f64>() / n as f64;
                let var = x.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1) as f64;
                assert!(
                    (mean - truth[k] - bias[k]).abs() < 5.0 * sigma / (n as f64).sqrt(),
                    "{name}[{k}]: mean {mean}"
                );
                assert!(
                    (var / (sigma * sigma) - 1.0).abs() < 5.0 * (2.0 / (n - 1) as f64).sqrt(),
                    "{name}[{k}]: s² {var} against σ² {}",
                    sigma * sigma
                );
            }
        };
        check("gyro", &|s| s.gyro.to_array(), omega.to_array(), params.gyro_bias_rad_s, params.gyro_noise_rad_s);
        check(
            "accel",
            &|s| s.specific_force.to_array(),
            force.to_array(),
            params.accel_bias_m_s2,
            params.accel_noise_m_s2,
        );
        let quiet = ImuParams { gyro_noise_rad_s: 0.0, accel_noise_m_s2: 0.0, ..params.clone() };
        let s = Imu::new(quiet, noise_stream(7)).sample(omega, force);
        assert_eq!(s.gyro.to_array(), (omega + Vec3::from_array(params.gyro_bias_rad_s)).to_array());
        assert_eq!(s.specific_force.to_array(), (force + Vec3::from_array(params.accel_bias_m_s2)).to_array());
    }
}

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
        ImuSample { gyro: omega + Vec3::from_array(p.gyro_bias_rad_s) + ng, specific_force: specific_force + Vec3::from_array(p.accel_bias_m_s2) + na }
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

    /// The engine adds the lever-arm acceleration only where `position` is `Some`: an IMU at
    /// the centre of mass has none, one off it has exactly its configured r (body FRD). Census
    /// of 33c1bbe, shards 51-52: `Some(0)` always, and `None` off the centre, lost the lever arm
    /// and were caught only by `identify`'s off-centre IMU flight.
    #[test]
    fn an_imu_off_the_centre_reports_its_position_and_one_at_it_none() {
        let stream = || crate::rng::Stream::new(1, crate::rng::Component::ImuNoise, 0);
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
}

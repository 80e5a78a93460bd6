//! The onboard IMU: gyro and accelerometer, both in the body frame.
//!
//! gyro  = ω_body + b_g + n_g,  n_g ~ N(0, σ_g²) per axis (rad/s)
//! accel = f_body + b_a + n_a,  f_body = C_n^b·(a_nav − g·e_D) (specific force, m/s²):
//! at rest on the floor f_body = (0, 0, −g).

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

    /// One reading of the true angular rate and specific force (body), with bias and noise added.
    pub fn sample(&mut self, omega: Vec3<Body>, specific_force: Vec3<Body>) -> ImuSample {
        let p = &self.params;
        let mut noise = |s: f64| if s > 0.0 { s * self.rng.normal() } else { 0.0 };
        let ng = Vec3::new(noise(p.gyro_noise_rad_s), noise(p.gyro_noise_rad_s), noise(p.gyro_noise_rad_s));
        let na = Vec3::new(noise(p.accel_noise_m_s2), noise(p.accel_noise_m_s2), noise(p.accel_noise_m_s2));
        ImuSample { gyro: omega + Vec3::from_array(p.gyro_bias_rad_s) + ng, specific_force: specific_force + Vec3::from_array(p.accel_bias_m_s2) + na }
    }
}

//! Velocity estimation from mocap positions (paper Sec. III.C).
//!
//! v_k = α·v_{k−1} + (1 − α)·(x_k − x_{k−1})/Δt_k,   α = exp(−2π·f_c·Δt_k)
//!
//! a first-order low-pass filter (cut-off f_c) of the finite-difference velocity, in the mocap's
//! NED frame. Δt_k is the difference of the frames' capture timestamps, so a dropped packet makes a
//! longer, correctly scaled step instead of a velocity spike.

use crate::clock::Nanos;
use crate::frames::{MocapNav, Vec3};

/// The station's velocity estimate (module doc).
#[derive(Clone, Debug)]
pub struct VelocityEstimator {
    cutoff_hz: f64,
    last: Option<(Nanos, Vec3<MocapNav>)>,
    vel: Vec3<MocapNav>,
}

impl VelocityEstimator {
    /// A filter with this cut-off (Hz), at rest.
    pub fn new(cutoff_hz: f64) -> Self {
        VelocityEstimator { cutoff_hz, last: None, vel: Vec3::zeros() }
    }

    /// The current estimate (m/s, mocap NED).
    pub fn velocity(&self) -> Vec3<MocapNav> {
        self.vel
    }

    /// Feeds one position with its capture time; returns the updated velocity (m/s).
    pub fn update(&mut self, t: Nanos, pos: Vec3<MocapNav>) -> Vec3<MocapNav> {
        if let Some((t0, p0)) = self.last
            && t > t0
        {
            let dt = (t - t0).as_secs_f64();
            let raw = (pos - p0) * (1.0 / dt);
            let alpha = (-std::f64::consts::TAU * self.cutoff_hz * dt).exp();
            self.vel = self.vel * alpha + raw * (1.0 - alpha);
        }
        self.last = Some((t, pos));
        self.vel
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn constant_velocity_is_recovered_across_dropped_frames() {
        let mut e = VelocityEstimator::new(10.0);
        let v = Vec3::<MocapNav>::new(0.5, -0.25, 0.1);
        for k in 0..400i64 {
            if k % 7 == 3 {
                continue; // dropped packet: the estimator must use the real Δt
            }
            let t = Nanos::from_millis(5 * k);
            e.update(t, v * t.as_secs_f64());
        }
        assert!((e.velocity() - v).norm() < 1e-12);
    }

    #[test]
    fn step_response_has_the_filter_time_constant() {
        // A velocity step from 0 to 1 m/s: after one time constant 1/(2π f_c) the estimate reaches
        // 1 − e⁻¹ of the step (discretised at 5 ms, exact for the discrete filter).
        let fc = 5.0;
        let mut e = VelocityEstimator::new(fc);
        let mut x = 0.0;
        e.update(Nanos(0), Vec3::zeros());
        let n = 200; // 1 s
        for k in 1..=n {
            x += 0.005;
            e.update(Nanos::from_millis(5 * k), Vec3::new(x, 0.0, 0.0));
        }
        let tau_steps = 1.0 / (std::f64::consts::TAU * fc) / 0.005;
        let expected = 1.0 - (-(n as f64) / tau_steps).exp();
        assert!((e.velocity().x() - expected).abs() < 1e-12);
    }
}

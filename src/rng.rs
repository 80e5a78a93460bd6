//! Seeded random streams: one independent stream per component and vehicle.
//!
//! A stream is a xoshiro256++ generator whose state is derived (SplitMix64) from the scenario seed,
//! a component tag and the vehicle index. Adding a vehicle or a noise source therefore never changes
//! the draws of the others, and a run is reproducible from `(scenario, seed)` alone.
//! The generator is implemented here (20 lines) so that its output can never change with a
//! dependency upgrade.
//!
//! ```
//! use flyarena::rng::{Stream, Component};
//! let mut a = Stream::new(7, Component::MocapNoise, 0);
//! let mut b = Stream::new(7, Component::MocapNoise, 0);
//! assert_eq!(a.next_u64(), b.next_u64());
//! let mut other = Stream::new(7, Component::LinkLoss, 0);
//! assert_ne!(Stream::new(7, Component::MocapNoise, 0).next_u64(), other.next_u64());
//! ```

/// The random consumers in the arena. The discriminant is part of the seed derivation: never
/// renumber, only append.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u64)]
pub enum Component {
    MocapNoise = 1,
    LinkLoss = 2,
    LinkJitter = 3,
    ImuNoise = 4,
    TelemetryLoss = 5,
    TelemetryJitter = 6,
    /// Per-run draws of a sweep (varied parameters and the run's seed); "vehicle" = run index.
    Sweep = 7,
}

fn splitmix64(x: &mut u64) -> u64 {
    *x = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
    let mut z = *x;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// A xoshiro256++ stream with a cached second normal deviate.
#[derive(Clone, Debug)]
pub struct Stream {
    s: [u64; 4],
    spare_normal: Option<f64>,
}

impl Stream {
    pub fn new(seed: u64, component: Component, vehicle: usize) -> Self {
        let mut x = seed ^ (component as u64).wrapping_mul(0xD6E8_FEB8_6659_FD93);
        x ^= (vehicle as u64 + 1).wrapping_mul(0xA076_1D64_78BD_642F);
        let mut s = [0u64; 4];
        for v in &mut s {
            *v = splitmix64(&mut x);
        }
        Stream { s, spare_normal: None }
    }

    pub fn next_u64(&mut self) -> u64 {
        let s = &mut self.s;
        let result = s[0].wrapping_add(s[3]).rotate_left(23).wrapping_add(s[0]);
        let t = s[1] << 17;
        s[2] ^= s[0];
        s[3] ^= s[1];
        s[1] ^= s[2];
        s[0] ^= s[3];
        s[2] ^= t;
        s[3] = s[3].rotate_left(45);
        result
    }

    /// Uniform on [0, 1) with 53 bits of resolution.
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// True with probability `p`.
    pub fn bernoulli(&mut self, p: f64) -> bool {
        self.uniform() < p
    }

    /// Standard normal deviate (Marsaglia polar method).
    pub fn normal(&mut self) -> f64 {
        if let Some(z) = self.spare_normal.take() {
            return z;
        }
        loop {
            let u = 2.0 * self.uniform() - 1.0;
            let v = 2.0 * self.uniform() - 1.0;
            let s = u * u + v * v;
            if s > 0.0 && s < 1.0 {
                let k = (-2.0 * s.ln() / s).sqrt();
                self.spare_normal = Some(v * k);
                return u * k;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normal_has_unit_variance_and_zero_mean() {
        let mut r = Stream::new(42, Component::ImuNoise, 3);
        let n = 200_000;
        let (mut s, mut s2) = (0.0, 0.0);
        for _ in 0..n {
            let z = r.normal();
            s += z;
            s2 += z * z;
        }
        let mean = s / n as f64;
        let var = s2 / n as f64 - mean * mean;
        // Standard error of the mean is 1/sqrt(n) = 0.0022; of the variance sqrt(2/n) = 0.0032.
        assert!(mean.abs() < 0.01, "mean {mean}");
        assert!((var - 1.0).abs() < 0.015, "var {var}");
    }

    #[test]
    fn streams_differ_by_vehicle_and_component() {
        let a = Stream::new(1, Component::MocapNoise, 0).next_u64();
        let b = Stream::new(1, Component::MocapNoise, 1).next_u64();
        let c = Stream::new(1, Component::LinkLoss, 0).next_u64();
        assert!(a != b && a != c && b != c);
    }
}

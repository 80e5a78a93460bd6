//! Body-rate telemetry: what the X3D sends back to the control computers over its second radio
//! (an XBee link in the arena, Sec. II of the paper: "the body-rates measured onboard … are sent
//! back to the control computer").
//!
//! The onboard loop reads its gyro at 1 kHz; a serial radio cannot carry that, so every telemetry
//! period the vehicle sends the **mean** body rate over the period with the period's bounds,
//! integrated by the trapezoid rule over the 1 kHz samples ω_k = ω_gyro(t_k):
//! ω̄ = (1/(t₁ − t₀))·Σ ½(ω_k + ω_{k+1})·(t_{k+1} − t_k) over t₀ ≤ t_k < t₁ (rad/s, body frame
//! FRD), exact to O(dt²·ω̈). (A plain mean of the samples would be a left Riemann sum, which
//! reads as a ½ dt = 0.5 ms time shift between gyro and mocap: while the rate vector turns, as it
//! does when the vehicle circles, that shift looks like a rotation about the turning axis —
//! 0.09° of yaw for a 2 s circle.) Frames carry a sequence number and travel over a
//! [`crate::link::Link`] with their own latency and loss.

use crate::clock::Nanos;
use crate::frames::{Body, Vec3};

/// One telemetry packet.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TelemetryFrame {
    /// Sequence number, one per packet.
    pub seq: u32,
    /// The averaging interval [t0, t1) on the vehicle's clock: the arena's, unless the scenario
    /// gives the telemetry clock an offset or a drift ([`Downlink::with_clock`]).
    pub t0: Nanos,
    /// End of the averaging interval.
    pub t1: Nanos,
    /// Mean gyro reading over the interval (rad/s, body frame).
    pub gyro_mean: Vec3<Body>,
}

/// The onboard side: integrates gyro samples and emits a frame every `every` physics ticks.
#[derive(Clone, Debug)]
pub struct Downlink {
    every: u32,
    integral: Vec3<Body>,
    n: u32,
    t0: Nanos,
    last: Option<(Nanos, Vec3<Body>)>,
    seq: u32,
    clock_offset: Nanos,
    clock_drift_ppm: f64,
}

impl Downlink {
    /// `every`: physics ticks per telemetry frame (≥ 1).
    pub fn new(every: u32) -> Self {
        Downlink {
            every: every.max(1),
            integral: Vec3::zeros(),
            n: 0,
            t0: Nanos::ZERO,
            last: None,
            seq: 0,
            clock_offset: Nanos::ZERO,
            clock_drift_ppm: 0.0,
        }
    }

    /// Stamps the frames with the vehicle's clock t_v = t + offset + drift·t (drift in parts per
    /// million, rounded to the nanosecond); the mean rate is the same on either clock.
    pub fn with_clock(mut self, offset: Nanos, drift_ppm: f64) -> Self {
        self.clock_offset = offset;
        self.clock_drift_ppm = drift_ppm;
        self
    }

    fn stamp(&self, t: Nanos) -> Nanos {
        Nanos(t.0 + self.clock_offset.0 + (t.0 as f64 * self.clock_drift_ppm * 1e-6).round() as i64)
    }

    /// Adds the gyro sample taken at `t`; returns a frame when a period has been completed.
    pub fn sample(&mut self, t: Nanos, gyro: Vec3<Body>) -> Option<TelemetryFrame> {
        let Some((t_prev, w_prev)) = self.last.replace((t, gyro)) else {
            self.t0 = t;
            return None;
        };
        self.integral += (w_prev + gyro) * (0.5 * (t - t_prev).as_secs_f64());
        self.n += 1;
        if self.n < self.every {
            return None;
        }
        let span = (t - self.t0).as_secs_f64();
        let f = TelemetryFrame {
            seq: self.seq,
            t0: self.stamp(self.t0),
            t1: self.stamp(t),
            gyro_mean: self.integral * (1.0 / span),
        };
        self.seq = self.seq.wrapping_add(1);
        self.integral = Vec3::zeros();
        self.n = 0;
        self.t0 = t;
        Some(f)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_carry_the_trapezoid_mean_over_their_interval() {
        let mut d = Downlink::new(10);
        let mut out = Vec::new();
        // ω_x(t) = t (ms): the exact mean over [0, 10] ms is 5, over [10, 20] is 15
        for k in 0..25 {
            if let Some(f) = d.sample(Nanos::from_millis(k), Vec3::new(k as f64, 0.0, -1.0)) {
                out.push(f);
            }
        }
        assert_eq!(out.len(), 2);
        assert!((out[0].gyro_mean - Vec3::new(5.0, 0.0, -1.0)).norm() < 1e-12, "{:?}", out[0].gyro_mean);
        assert_eq!((out[0].t0, out[0].t1), (Nanos::ZERO, Nanos::from_millis(10)));
        assert!((out[1].gyro_mean.x() - 15.0).abs() < 1e-12);
        assert_eq!((out[1].seq, out[1].t0, out[1].t1), (1, Nanos::from_millis(10), Nanos::from_millis(20)));
    }
}

//! The 72 MHz PPM command radio: 50 Hz frames of 8 channels, each an integer 0..255.
//!
//! Channel map (the rest are held at their neutral values):
//! 0: roll rate p · 1: pitch rate q · 2: yaw rate r · 3: collective thrust T · 4–7: auxiliary (0).
//!
//! Rates: count = clamp(round(128 + ω/s), 0, 255), ω = (count − 128)·s, with s the rate scale in
//! rad/s per count (default 1.5 °/s, so −192…+190.5 °/s). 128 is exactly zero rate.
//! Thrust: count = clamp(round(255·T/T_max), 0, 255), T = count·T_max/255 (default T_max = the
//! vehicle's maximum collective thrust, 24.0 N for the X3D: 0.094 N a count).
//! The transmitter samples the controller's latest command every frame (zero-order hold until the
//! next frame); the receiver decodes the frame `latency` after it was sampled.

use crate::clock::Nanos;
use crate::frames::{Body, Vec3};
use crate::vehicle::RateCommand;
use std::collections::VecDeque;

pub const MAX_CHANNELS: usize = 12;
pub const RATE_CENTER: u8 = 128;

#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct RadioParams {
    pub channels: usize,
    pub latency: Nanos,
    pub rate_scale_rad_s: f64,
    pub thrust_max_n: f64,
}

/// One PPM frame as transmitted.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub struct PpmFrame {
    pub channels: [u8; MAX_CHANNELS],
    pub len: usize,
}

impl PpmFrame {
    pub fn p(&self) -> u8 {
        self.channels[0]
    }
    pub fn q(&self) -> u8 {
        self.channels[1]
    }
    pub fn r(&self) -> u8 {
        self.channels[2]
    }
    pub fn thrust(&self) -> u8 {
        self.channels[3]
    }
}

#[derive(Clone, Debug)]
pub struct Radio {
    params: RadioParams,
    in_flight: VecDeque<(Nanos, PpmFrame)>,
    held: RateCommand,
    last_sent: Option<PpmFrame>,
}

impl Radio {
    pub fn new(params: RadioParams) -> Self {
        Radio { params, in_flight: VecDeque::with_capacity(8), held: RateCommand::idle(), last_sent: None }
    }

    pub fn encode(&self, rates: Vec3<Body>, thrust_n: f64) -> PpmFrame {
        let s = self.params.rate_scale_rad_s;
        let rate = |w: f64| (RATE_CENTER as f64 + w / s).round().clamp(0.0, 255.0) as u8;
        let thrust = (255.0 * thrust_n / self.params.thrust_max_n).round().clamp(0.0, 255.0) as u8;
        let mut channels = [0u8; MAX_CHANNELS];
        channels[0] = rate(rates.x());
        channels[1] = rate(rates.y());
        channels[2] = rate(rates.z());
        channels[3] = thrust;
        PpmFrame { channels, len: self.params.channels }
    }

    pub fn decode(&self, f: &PpmFrame) -> RateCommand {
        let s = self.params.rate_scale_rad_s;
        let rate = |c: u8| (c as f64 - RATE_CENTER as f64) * s;
        RateCommand { rates: Vec3::new(rate(f.p()), rate(f.q()), rate(f.r())), thrust_n: f.thrust() as f64 * self.params.thrust_max_n / 255.0 }
    }

    /// Transmits one frame at `now`; returns it (for logging).
    pub fn transmit(&mut self, now: Nanos, rates: Vec3<Body>, thrust_n: f64) -> PpmFrame {
        let f = self.encode(rates, thrust_n);
        self.in_flight.push_back((now + self.params.latency, f));
        self.last_sent = Some(f);
        f
    }

    pub fn last_sent(&self) -> Option<&PpmFrame> {
        self.last_sent.as_ref()
    }

    /// The command the vehicle's receiver holds at `now` (zero-order hold of the last decoded frame).
    pub fn receiver(&mut self, now: Nanos) -> RateCommand {
        while let Some(&(t, f)) = self.in_flight.front() {
            if t > now {
                break;
            }
            self.in_flight.pop_front();
            self.held = self.decode(&f);
        }
        self.held
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn radio() -> Radio {
        Radio::new(RadioParams { channels: 8, latency: Nanos::from_millis(10), rate_scale_rad_s: 1.5f64.to_radians(), thrust_max_n: 24.0 })
    }

    #[test]
    fn zero_rate_is_exactly_representable_and_saturates() {
        let r = radio();
        let f = r.encode(Vec3::new(0.0, 10.0, -10.0), 1000.0);
        assert_eq!((f.p(), f.q(), f.r(), f.thrust()), (128, 255, 0, 255));
        let c = r.decode(&r.encode(Vec3::zeros(), 0.0));
        assert_eq!(c.rates, Vec3::zeros());
        assert_eq!(c.thrust_n, 0.0);
    }

    /// Thrust counts by hand with T_max = 24 N: 23 N is 255·23/24 = 244.375 → 244 (over 256
    /// counts it would be 245), count 100 is 100·24/255 = 9.41176 N (9.375 N over 256), and the
    /// full count gives exactly T_max.
    #[test]
    fn thrust_counts_are_255ths_of_the_maximum() {
        let r = radio();
        assert_eq!(r.encode(Vec3::zeros(), 23.0).thrust(), 244);
        assert_eq!(r.encode(Vec3::zeros(), 24.0).thrust(), 255);
        let hundred = r.decode(&r.encode(Vec3::zeros(), 100.0 * 24.0 / 255.0));
        assert!((hundred.thrust_n - 9.411_764_705_882_353).abs() < 1e-12, "{}", hundred.thrust_n);
        assert_eq!(r.decode(&r.encode(Vec3::zeros(), 24.0)).thrust_n, 24.0);
    }

    #[test]
    fn quantization_error_is_at_most_half_a_count() {
        let r = radio();
        let s = 1.5f64.to_radians();
        for k in -1000..1000 {
            let w = k as f64 * 0.0037;
            let back = r.decode(&r.encode(Vec3::new(w, 0.0, 0.0), 6.67)).rates.x();
            if w.abs() < 1.9 {
                assert!((back - w).abs() <= s / 2.0 + 1e-12);
            }
        }
        let t = r.decode(&r.encode(Vec3::zeros(), 6.67)).thrust_n;
        assert!((t - 6.67).abs() <= 24.0 / 255.0 / 2.0);
    }

    #[test]
    fn receiver_holds_the_last_frame_after_latency() {
        let mut r = radio();
        r.transmit(Nanos(0), Vec3::new(0.1, 0.0, 0.0), 5.0);
        assert_eq!(r.receiver(Nanos::from_millis(9)), RateCommand::idle());
        let c = r.receiver(Nanos::from_millis(10));
        assert!(c.thrust_n > 4.9);
        assert_eq!(r.receiver(Nanos::from_millis(25)), c);
    }
}

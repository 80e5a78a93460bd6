//! The 72 MHz PPM command radio: 50 Hz frames of 8 channels, each an integer 0..255.
//!
//! Channel map (the rest are held at their neutral values), by the vehicle's [`OnboardMode`]:
//! - rate mode: 0: roll rate p · 1: pitch rate q · 2: yaw rate r · 3: collective thrust T;
//! - attitude mode: 0: roll angle φ_com · 1: pitch angle θ_com · 2: heading rate ψ̇_com · 3: T.
//!
//! 4–7: auxiliary (0).
//!
//! Rates: count = clamp(round(128 + ω/s), 0, 255), ω = (count − 128)·s, with s the rate scale in
//! rad/s per count (default 1.5 °/s, so −192…+190.5 °/s). 128 is exactly zero rate.
//! Angles: count = clamp(round(128 + α/s_α), 0, 255), α = (count − 128)·s_α, with s_α the angle
//! scale in rad per count (default 0.25°, so −32…+31.75°). 128 is exactly level. The flown
//! transmitter ([`Radio::transmit`]) carries each angle frame's rounding into the next (first-order
//! error feedback: x_k = 128 + α_k/s_α + e_{k−1}, count_k = round(x_k), e_k = x_k − count_k, |e| ≤ ½), so
//! a steady command between two counts is sent as the mix of both whose mean it is: the mean
//! tilt an attitude-mode vehicle holds is the commanded one, not the nearest count (a
//! 0.125° rounding of a held roll drifts a straight flight sideways).
//! Thrust: count = clamp(round(255·T/T_max), 0, 255), T = count·T_max/255 (default T_max = the
//! vehicle's maximum collective thrust, 24.0 N for the X3D: 0.094 N a count).
//! The transmitter samples the controller's latest command every frame (zero-order hold until the
//! next frame); the receiver decodes the frame `latency` after it was sampled.

use crate::clock::Nanos;
use crate::control::ControlOutput;
use crate::frames::Vec3;
use crate::vehicle::{AttitudeCommand, OnboardMode, RateCommand};
use std::collections::VecDeque;

/// The most channels a frame holds.
pub const MAX_CHANNELS: usize = 12;
/// The count of zero rate (and of a level angle).
pub const RATE_CENTER: u8 = 128;

/// The radio's frame and scales (see the module doc).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct RadioParams {
    /// Channels per frame.
    pub channels: usize,
    /// From sampling a frame to its decoding on the vehicle.
    pub latency: Nanos,
    /// Rate channels: rad/s per count.
    pub rate_scale_rad_s: f64,
    /// Attitude mode's roll and pitch channels: rad per count.
    pub angle_scale_rad: f64,
    /// The thrust of count 255 (N).
    pub thrust_max_n: f64,
    /// What the vehicle's onboard controller tracks, and so what the channels carry.
    pub mode: OnboardMode,
}

/// One PPM frame as transmitted.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub struct PpmFrame {
    /// The counts, 0..255 (the first `len` are sent).
    pub channels: [u8; MAX_CHANNELS],
    /// Channels in the frame.
    pub len: usize,
}

impl PpmFrame {
    /// Channel 0 (roll rate, or roll angle in attitude mode).
    pub fn p(&self) -> u8 {
        self.channels[0]
    }
    /// Channel 1 (pitch rate, or pitch angle in attitude mode).
    pub fn q(&self) -> u8 {
        self.channels[1]
    }
    /// Channel 2 (yaw rate, or heading rate in attitude mode).
    pub fn r(&self) -> u8 {
        self.channels[2]
    }
    /// Channel 3, the collective thrust.
    pub fn thrust(&self) -> u8 {
        self.channels[3]
    }
}

/// What the receiver holds, decoded by the vehicle's mode.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Received {
    /// Body rates and thrust (rate mode).
    Rates(RateCommand),
    /// Roll, pitch, heading rate and thrust (attitude mode).
    Attitude(AttitudeCommand),
}

impl Received {
    /// The commanded collective thrust (N).
    pub fn thrust_n(&self) -> f64 {
        match self {
            Received::Rates(c) => c.thrust_n,
            Received::Attitude(c) => c.thrust_n,
        }
    }
}

/// The transmitter, the frames in the air, and the receiver's held command.
#[derive(Clone, Debug)]
pub struct Radio {
    params: RadioParams,
    in_flight: VecDeque<(Nanos, PpmFrame)>,
    held: Received,
    last_sent: Option<PpmFrame>,
    /// The error feedback of the roll and pitch angle channels (counts).
    residual: [f64; 2],
}

impl Radio {
    /// A radio whose receiver holds the idle command (zero rates or level, zero thrust).
    pub fn new(params: RadioParams) -> Self {
        let held = match params.mode {
            OnboardMode::Rate => Received::Rates(RateCommand::idle()),
            OnboardMode::Attitude => {
                Received::Attitude(AttitudeCommand { roll: 0.0, pitch: 0.0, yaw_rate: 0.0, thrust_n: 0.0 })
            }
        };
        Radio { params, in_flight: VecDeque::with_capacity(8), held, last_sent: None, residual: [0.0; 2] }
    }

    /// The frame for a controller output: its body rates (rate mode) or its roll and pitch
    /// commands and heading rate (attitude mode), and its thrust.
    pub fn encode(&self, out: &ControlOutput) -> PpmFrame {
        let count = |x: f64, scale: f64| (RATE_CENTER as f64 + x / scale).round().clamp(0.0, 255.0) as u8;
        let (s, sa) = (self.params.rate_scale_rad_s, self.params.angle_scale_rad);
        let mut channels = [0u8; MAX_CHANNELS];
        let first = match self.params.mode {
            OnboardMode::Rate => [count(out.rates.x(), s), count(out.rates.y(), s), count(out.rates.z(), s)],
            OnboardMode::Attitude => {
                [count(out.angles_com.roll, sa), count(out.angles_com.pitch, sa), count(out.yaw_rate_com, s)]
            }
        };
        channels[..3].copy_from_slice(&first);
        channels[3] = (255.0 * out.thrust_n / self.params.thrust_max_n).round().clamp(0.0, 255.0) as u8;
        PpmFrame { channels, len: self.params.channels }
    }

    /// What the receiver makes of a frame, by the vehicle's mode.
    pub fn decode(&self, f: &PpmFrame) -> Received {
        let value = |c: u8, scale: f64| (c as f64 - RATE_CENTER as f64) * scale;
        let (s, sa) = (self.params.rate_scale_rad_s, self.params.angle_scale_rad);
        let thrust_n = f.thrust() as f64 * self.params.thrust_max_n / 255.0;
        match self.params.mode {
            OnboardMode::Rate => Received::Rates(RateCommand {
                rates: Vec3::new(value(f.p(), s), value(f.q(), s), value(f.r(), s)),
                thrust_n,
            }),
            OnboardMode::Attitude => Received::Attitude(AttitudeCommand {
                roll: value(f.channels[0], sa),
                pitch: value(f.channels[1], sa),
                yaw_rate: value(f.channels[2], s),
                thrust_n,
            }),
        }
    }

    /// Transmits one frame at `now`; returns it (for logging). In attitude mode the angle
    /// channels carry their rounding into the next frame (module doc).
    pub fn transmit(&mut self, now: Nanos, out: &ControlOutput) -> PpmFrame {
        let mut f = self.encode(out);
        if self.params.mode == OnboardMode::Attitude {
            let sa = self.params.angle_scale_rad;
            for (k, angle) in [out.angles_com.roll, out.angles_com.pitch].into_iter().enumerate() {
                let x = RATE_CENTER as f64 + angle / sa + self.residual[k];
                let c = x.round().clamp(0.0, 255.0);
                f.channels[k] = c as u8;
                self.residual[k] = (x - c).clamp(-0.5, 0.5);
            }
        }
        self.transmit_frame(now, f);
        f
    }

    /// Transmits a frame given as counts (an external controller's, [`crate::serve`]); only the
    /// radio's first `channels` are sent, the rest go out as 0.
    pub fn transmit_frame(&mut self, now: Nanos, mut f: PpmFrame) {
        f.len = self.params.channels;
        f.channels[f.len..].fill(0);
        self.in_flight.push_back((now + self.params.latency, f));
        self.last_sent = Some(f);
    }

    /// The idle frame: zero rates or level, zero heading rate, zero thrust (128, 128, 128, 0).
    pub fn idle_frame(&self) -> PpmFrame {
        let mut channels = [0u8; MAX_CHANNELS];
        channels[..3].fill(RATE_CENTER);
        PpmFrame { channels, len: self.params.channels }
    }

    /// The frame transmitted last.
    pub fn last_sent(&self) -> Option<&PpmFrame> {
        self.last_sent.as_ref()
    }

    /// The command the vehicle's receiver holds at `now` (zero-order hold of the last decoded frame).
    pub fn receiver(&mut self, now: Nanos) -> Received {
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

    use crate::frames::{Body, Euler};

    fn params(mode: OnboardMode) -> RadioParams {
        RadioParams {
            channels: 8,
            latency: Nanos::from_millis(10),
            rate_scale_rad_s: 1.5f64.to_radians(),
            angle_scale_rad: 0.25f64.to_radians(),
            thrust_max_n: 24.0,
            mode,
        }
    }

    fn radio() -> Radio {
        Radio::new(params(OnboardMode::Rate))
    }

    /// A controller output with these body rates and thrust (and angle commands that rate mode
    /// must ignore).
    fn out(rates: Vec3<Body>, thrust_n: f64) -> ControlOutput {
        ControlOutput {
            rates,
            thrust_n,
            angles_com: Euler::from_degrees(7.0, -3.0, 20.0),
            yaw_rate_com: 0.3,
            accel_com: Vec3::zeros(),
        }
    }

    impl Radio {
        fn encode_rates(&self, rates: Vec3<Body>, thrust_n: f64) -> PpmFrame {
            self.encode(&out(rates, thrust_n))
        }
    }

    fn rates(r: Received) -> RateCommand {
        match r {
            Received::Rates(c) => c,
            Received::Attitude(c) => panic!("rate mode decoded {c:?}"),
        }
    }

    #[test]
    fn zero_rate_is_exactly_representable_and_saturates() {
        let r = radio();
        let f = r.encode_rates(Vec3::new(0.0, 10.0, -10.0), 1000.0);
        assert_eq!((f.p(), f.q(), f.r(), f.thrust()), (128, 255, 0, 255));
        let c = rates(r.decode(&r.encode_rates(Vec3::zeros(), 0.0)));
        assert_eq!(c.rates, Vec3::zeros());
        assert_eq!(c.thrust_n, 0.0);
    }

    /// Thrust counts by hand with T_max = 24 N: 23 N is 255·23/24 = 244.375 → 244 (over 256
    /// counts it would be 245), count 100 is 100·24/255 = 9.41176 N (9.375 N over 256), and the
    /// full count gives exactly T_max.
    #[test]
    fn thrust_counts_are_255ths_of_the_maximum() {
        let r = radio();
        assert_eq!(r.encode_rates(Vec3::zeros(), 23.0).thrust(), 244);
        assert_eq!(r.encode_rates(Vec3::zeros(), 24.0).thrust(), 255);
        let hundred = rates(r.decode(&r.encode_rates(Vec3::zeros(), 100.0 * 24.0 / 255.0)));
        assert!((hundred.thrust_n - 9.411_764_705_882_353).abs() < 1e-12, "{}", hundred.thrust_n);
        assert_eq!(rates(r.decode(&r.encode_rates(Vec3::zeros(), 24.0))).thrust_n, 24.0);
    }

    #[test]
    fn quantization_error_is_at_most_half_a_count() {
        let r = radio();
        let s = 1.5f64.to_radians();
        for k in -1000..1000 {
            let w = k as f64 * 0.0037;
            let back = rates(r.decode(&r.encode_rates(Vec3::new(w, 0.0, 0.0), 6.67))).rates.x();
            if w.abs() < 1.9 {
                assert!((back - w).abs() <= s / 2.0 + 1e-12);
            }
        }
        let t = rates(r.decode(&r.encode_rates(Vec3::zeros(), 6.67))).thrust_n;
        assert!((t - 6.67).abs() <= 24.0 / 255.0 / 2.0);
    }

    /// The receiver holds idle until the latency has passed, then the frame until the next; the
    /// radio remembers the frame it sent last (the log's `ppm` column) from the moment it is sent
    /// (a bug it catches: `last_sent` as None).
    #[test]
    fn receiver_holds_the_last_frame_after_latency() {
        let mut r = radio();
        assert_eq!(r.last_sent(), None, "nothing sent yet");
        let sent = r.transmit(Nanos(0), &out(Vec3::new(0.1, 0.0, 0.0), 5.0));
        assert_eq!(r.last_sent(), Some(&sent));
        assert_eq!(r.receiver(Nanos::from_millis(9)), Received::Rates(RateCommand::idle()));
        let c = r.receiver(Nanos::from_millis(10));
        assert!(c.thrust_n() > 4.9);
        assert_eq!(r.receiver(Nanos::from_millis(25)), c);
    }

    /// Attitude mode carries the angle commands and the heading rate, not the body rates: 7° of
    /// roll at 0.25° a count is 128 + 28 = 156, −3° of pitch 116, 0.3 rad/s of heading rate
    /// 128 + 0.3/(1.5°/s) = 139.46 → 139; level is exactly 128 and decodes to exactly 0; beyond
    /// ±32° the channel saturates.
    #[test]
    fn attitude_mode_carries_angles_in_counts() {
        let r = Radio::new(params(OnboardMode::Attitude));
        let f = r.encode(&out(Vec3::new(1.0, -1.0, 0.5), 12.0));
        assert_eq!((f.channels[0], f.channels[1], f.channels[2], f.thrust()), (156, 116, 139, 128));
        let Received::Attitude(c) = r.decode(&f) else { panic!("attitude mode decoded rates") };
        assert!((c.roll - 7f64.to_radians()).abs() < 1e-12 && (c.pitch + 3f64.to_radians()).abs() < 1e-12, "{c:?}");
        assert!(
            (c.yaw_rate - 11.0 * 1.5f64.to_radians()).abs() < 1e-12
                && (c.thrust_n - 128.0 * 24.0 / 255.0).abs() < 1e-12,
            "{c:?}"
        );
        let level = ControlOutput { angles_com: Euler::ZERO, yaw_rate_com: 0.0, ..out(Vec3::zeros(), 5.0) };
        let Received::Attitude(c) = r.decode(&r.encode(&level)) else { panic!() };
        assert_eq!((c.roll, c.pitch, c.yaw_rate), (0.0, 0.0, 0.0));
        let steep = ControlOutput { angles_com: Euler::from_degrees(40.0, -40.0, 0.0), ..level };
        assert_eq!(&r.encode(&steep).channels[..2], &[255, 0]);
        // before the first frame the receiver holds level, no thrust
        let mut r = r;
        assert_eq!(
            r.receiver(Nanos::ZERO),
            Received::Attitude(AttitudeCommand { roll: 0.0, pitch: 0.0, yaw_rate: 0.0, thrust_n: 0.0 })
        );
    }

    /// A held roll of 0.1° (0.4 count) and pitch of −0.3125° (−1.25 counts) go out frame by
    /// frame as the rounding of the running sum, by hand: roll 128.4 → 128 (e 0.4), 128.8 → 129,
    /// 128.2 → 128, 128.6 → 129, 128.0 → 128; pitch 126.75 → 127, 126.5 → 127 (ties away from
    /// zero), 126.25 → 126, 127.0 → 127. Over 20 frames the mean is the command to ½ count / 20.
    /// Rate mode sends the plain rounding.
    #[test]
    fn a_held_angle_between_counts_is_sent_as_its_mean() {
        let mut r = Radio::new(params(OnboardMode::Attitude));
        let held = ControlOutput {
            angles_com: Euler::from_degrees(0.1, -0.3125, 0.0),
            yaw_rate_com: 0.0,
            ..out(Vec3::zeros(), 5.0)
        };
        let sent: Vec<PpmFrame> = (0..20).map(|k| r.transmit(Nanos::from_millis(20 * k), &held)).collect();
        let roll: Vec<u8> = sent.iter().map(|f| f.channels[0]).collect();
        assert_eq!(&roll[..5], &[128, 129, 128, 129, 128], "{roll:?}");
        let pitch: Vec<u8> = sent.iter().map(|f| f.channels[1]).collect();
        assert_eq!(&pitch[..4], &[127, 127, 126, 127], "{pitch:?}");
        let mean = |c: &[u8]| c.iter().map(|&x| x as f64 - 128.0).sum::<f64>() / c.len() as f64;
        assert!(
            (mean(&roll) - 0.4).abs() <= 0.5 / 20.0 && (mean(&pitch) + 1.25).abs() <= 0.5 / 20.0,
            "{} {}",
            mean(&roll),
            mean(&pitch)
        );
        let mut r = Radio::new(params(OnboardMode::Rate));
        let f = r.transmit(Nanos::ZERO, &held);
        assert_eq!(f, r.encode(&held));
    }
}

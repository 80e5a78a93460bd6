//! The command path back: flyarena's own small UDP packets between an external controller and
//! `flyarena serve`, on the same port as NatNet's commands (the magic tells them apart). All
//! integers little-endian.
//!
//! | packet | direction | bytes | layout |
//! |---|---|---|---|
//! | command | controller → flyarena | 12 + n | `"FACM"`, version u8 = 1, vehicle id u8 (the rigid body's id: 1 + fleet index), n u8 (channels, 4..=12), 0 u8, sequence u32, counts u8 × n (0..255: the radio's channels, [`crate::radio`]) |
//! | request | flyarena → controller | 20 | `"FARQ"`, version u8 = 1, vehicle id u8, 0 u16, radio period u32, simulated time of that radio tick i64 (ns) |
//! | offset | controller → flyarena | 32 | `"FAOF"`, version u8 = 1, vehicle id u8, 0 u16, roll, pitch, yaw f64 (rad): the controller's estimate of the marker offset, in flyarena's convention (the rotation `markers.rotation_deg` declares: body FRD to the markers' frame, Z-Y-X); NaN where it has none |
//! | telemetry | flyarena → controller | 40 | `"FATM"`, version u8 = 1, vehicle id u8, 0 u16, sequence u32, interval start i64, end i64 (ns, vehicle clock), mean gyro x y z f32 (rad/s, body FRD) |
//!
//! A controller registers for a vehicle with a command sent before the flight starts (any
//! frame and any sequence number: it registers the address and is not applied, nor does it
//! answer a request); requests and telemetry go to the address its latest applied command came
//! from (a duplicate or stale command, from anywhere, points them nowhere else). At
//! each radio tick of its vehicle flyarena sends a request naming the radio period k, from 0. In
//! lockstep the tick waits for a command whose sequence number is k or later; in real time every
//! command is applied when it arrives. A controller silent for `radio.failsafe_ms` of simulated
//! time is failed safe as a PPM receiver would be: the radio sends the idle frame (zero rates or
//! level, zero thrust) until a new command comes, which is applied as usual. In lockstep, a tick
//! that waited its timeout in vain goes on without the controller's command (counted), and the
//! next tick waits again. Either way the transmitter sends the held frame at each
//! radio tick (zero-order hold), as a PPM transmitter does, and the receiver side counts what
//! happened ([`CommandStats`]): a sequence number equal to the last applied one is a duplicate,
//! a smaller one arrived out of order, both are dropped; a jump counts the numbers skipped as
//! missing; a radio tick without a new command re-sends the held frame.

use crate::radio::{MAX_CHANNELS, PpmFrame};
use crate::vehicle::TelemetryFrame;

/// Version of the packets.
pub(crate) const VERSION: u8 = 1;
/// A command's magic.
pub const COMMAND: [u8; 4] = *b"FACM";
/// A request's magic.
const REQUEST: [u8; 4] = *b"FARQ";
/// A telemetry packet's magic.
const TELEMETRY: [u8; 4] = *b"FATM";
/// An offset report's magic.
pub const OFFSET: [u8; 4] = *b"FAOF";

/// Writes an offset report: the marker offset (roll, pitch, yaw, rad) a controller estimated.
pub fn offset(vehicle_id: u8, roll_pitch_yaw: [f64; 3]) -> Vec<u8> {
    let mut b = Vec::with_capacity(32);
    b.extend_from_slice(&OFFSET);
    b.extend_from_slice(&[VERSION, vehicle_id, 0, 0]);
    for x in roll_pitch_yaw {
        b.extend_from_slice(&x.to_le_bytes());
    }
    b
}

/// Reads an offset report: the vehicle id and (roll, pitch, yaw) in rad. `None` unless it is
/// 32 bytes of version 1, its reserved bytes zero, with a finite roll and pitch (yaw may be
/// NaN: not estimated).
pub(crate) fn parse_offset(b: &[u8]) -> Option<(u8, [f64; 3])> {
    if b.len() != 32 || b[0..4] != OFFSET || b[4] != VERSION || b[6..8] != [0, 0] {
        return None;
    }
    let f = |i: usize| f64::from_le_bytes(b[8 + 8 * i..16 + 8 * i].try_into().expect("8 bytes"));
    let o = [f(0), f(1), f(2)];
    (o[0].is_finite() && o[1].is_finite() && !o[2].is_infinite()).then_some((b[5], o))
}

/// One command from an external controller.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Command {
    /// The rigid body's id (1 + fleet index).
    pub vehicle_id: u8,
    /// The sequence number (lockstep: the radio period it answers).
    pub seq: u32,
    /// The counts (`len` of them sent).
    pub frame: PpmFrame,
}

/// Why a packet is not a command.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum BadCommand {
    /// Not `FACM` (not a command at all).
    #[error("not a flyarena command (magic is not FACM)")]
    Magic,
    /// Another version.
    #[error("command version {0}; flyarena reads version 1")]
    Version(u8),
    /// The reserved byte (the eighth) is not zero.
    #[error("a command's reserved byte 7 must be 0, not {0}")]
    Reserved(u8),
    /// The channel count is outside 4..=12 or the length does not match it.
    #[error("a command with {channels} channels must be {} bytes, not {len}", 12 + *channels as usize)]
    Length {
        /// Channels announced.
        channels: u8,
        /// Bytes received.
        len: usize,
    },
}

/// Reads a command packet.
pub fn parse_command(b: &[u8]) -> Result<Command, BadCommand> {
    if b.get(0..4) != Some(&COMMAND[..]) {
        return Err(BadCommand::Magic);
    }
    let len = b.len();
    let (version, id, n) = match b.get(4..7) {
        Some(&[v, id, n]) => (v, id, n),
        _ => return Err(BadCommand::Length { channels: 0, len }),
    };
    if version != VERSION {
        return Err(BadCommand::Version(version));
    }
    if !(4..=MAX_CHANNELS as u8).contains(&n) || len != 12 + n as usize {
        return Err(BadCommand::Length { channels: n, len });
    }
    if b[7] != 0 {
        return Err(BadCommand::Reserved(b[7]));
    }
    let seq = u32::from_le_bytes(b[8..12].try_into().expect("4 bytes"));
    let mut channels = [0u8; MAX_CHANNELS];
    channels[..n as usize].copy_from_slice(&b[12..]);
    Ok(Command { vehicle_id: id, seq, frame: PpmFrame { channels, len: n as usize } })
}

/// Writes a command packet (for controllers written in Rust, and the tests).
pub fn command(vehicle_id: u8, seq: u32, counts: &[u8]) -> Vec<u8> {
    let mut b = Vec::with_capacity(12 + counts.len());
    b.extend_from_slice(&COMMAND);
    b.extend_from_slice(&[VERSION, vehicle_id, counts.len() as u8, 0]);
    b.extend_from_slice(&seq.to_le_bytes());
    b.extend_from_slice(counts);
    b
}

/// A request for radio period `period` at simulated time `t_ns`.
pub fn request(vehicle_id: u8, period: u32, t_ns: i64) -> Vec<u8> {
    let mut b = Vec::with_capacity(20);
    b.extend_from_slice(&REQUEST);
    b.extend_from_slice(&[VERSION, vehicle_id, 0, 0]);
    b.extend_from_slice(&period.to_le_bytes());
    b.extend_from_slice(&t_ns.to_le_bytes());
    b
}

/// A telemetry packet.
pub fn telemetry(vehicle_id: u8, f: &TelemetryFrame) -> Vec<u8> {
    let mut b = Vec::with_capacity(40);
    b.extend_from_slice(&TELEMETRY);
    b.extend_from_slice(&[VERSION, vehicle_id, 0, 0]);
    b.extend_from_slice(&f.seq.to_le_bytes());
    b.extend_from_slice(&f.t0.as_nanos().to_le_bytes());
    b.extend_from_slice(&f.t1.as_nanos().to_le_bytes());
    for x in f.gyro_mean.to_array() {
        b.extend_from_slice(&(x as f32).to_le_bytes());
    }
    b
}

/// What the receiver side saw of one vehicle's commands.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct CommandStats {
    /// Commands received for the vehicle.
    pub received: u64,
    /// Commands applied (the newest so far when they arrived).
    pub applied: u64,
    /// Dropped: the same sequence number as the last applied one.
    pub duplicates: u64,
    /// Dropped: an older sequence number than the last applied one.
    pub out_of_order: u64,
    /// Sequence numbers skipped between applied commands (lost or never sent).
    pub missing: u64,
    /// Radio ticks that re-sent the held frame because no new command had come.
    pub held: u64,
    /// Lockstep: radio ticks that gave up waiting (the timeout) and went on without the
    /// controller's command.
    pub timeouts: u64,
    /// Radio ticks that sent the idle frame because the controller had sent no new command for
    /// `radio.failsafe_ms` (the receiver's failsafe).
    pub failsafe: u64,
}

/// The receiver side of one vehicle's commands: which to apply, and the counts.
#[derive(Clone, Debug, Default)]
pub(crate) struct Receiver {
    last: Option<u32>,
    fresh: bool,
    /// The counts so far.
    pub stats: CommandStats,
}

impl Receiver {
    /// Takes a command; `true` when it is to be applied (newer than every one before).
    pub fn accept(&mut self, seq: u32) -> bool {
        self.stats.received += 1;
        match self.last {
            Some(l) if seq == l => {
                self.stats.duplicates += 1;
                false
            }
            Some(l) if seq < l => {
                self.stats.out_of_order += 1;
                false
            }
            _ => {
                if let Some(l) = self.last {
                    self.stats.missing += (seq - l - 1) as u64;
                }
                self.last = Some(seq);
                self.stats.applied += 1;
                self.fresh = true;
                true
            }
        }
    }

    /// The newest sequence number applied.
    pub fn last(&self) -> Option<u32> {
        self.last
    }

    /// A radio tick: counts a held frame when no command came since the previous tick.
    pub(crate) fn radio_tick(&mut self) {
        if !std::mem::take(&mut self.fresh) {
            self.stats.held += 1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn commands_are_read_and_malformed_ones_named() {
        let b = command(2, 7, &[128, 130, 126, 200]);
        assert_eq!(b, [b'F', b'A', b'C', b'M', 1, 2, 4, 0, 7, 0, 0, 0, 128, 130, 126, 200]);
        let c = parse_command(&b).unwrap();
        assert_eq!(
            (c.vehicle_id, c.seq, c.frame.len, &c.frame.channels[..5]),
            (2, 7, 4, &[128u8, 130, 126, 200, 0][..])
        );
        assert_eq!(parse_command(&b[..15]), Err(BadCommand::Length { channels: 4, len: 15 }));
        assert_eq!(parse_command(b"FACM"), Err(BadCommand::Length { channels: 0, len: 4 }));
        let mut v2 = b.clone();
        v2[4] = 2;
        assert_eq!(parse_command(&v2), Err(BadCommand::Version(2)));
        assert_eq!(parse_command(&command(1, 0, &[1, 2, 3])), Err(BadCommand::Length { channels: 3, len: 15 }));
        assert_eq!(parse_command(&command(1, 0, &[0; 13])), Err(BadCommand::Length { channels: 13, len: 25 }));
        assert_eq!(parse_command(b"\x00\x00\x05\x00Ping\x00"), Err(BadCommand::Magic));
        let mut reserved = b.clone();
        reserved[7] = 7;
        assert_eq!(parse_command(&reserved), Err(BadCommand::Reserved(7)));
        assert_eq!(
            BadCommand::Length { channels: 4, len: 15 }.to_string(),
            "a command with 4 channels must be 16 bytes, not 15"
        );
    }

    /// The counts of a sequence written out by hand: 0 1 1 3 2 6 applies 0, 1, 3, 6 (missing:
    /// 2 between 1 and 3, which then arrives out of order, and 4, 5), one duplicate.
    #[test]
    fn the_receiver_applies_only_newer_commands_and_counts_the_rest() {
        let mut r = Receiver::default();
        let applied: Vec<bool> = [0, 1, 1, 3, 2, 6].into_iter().map(|s| r.accept(s)).collect();
        assert_eq!(applied, [true, true, false, true, false, true]);
        assert_eq!(
            r.stats,
            CommandStats {
                received: 6,
                applied: 4,
                duplicates: 1,
                out_of_order: 1,
                missing: 3,
                held: 0,
                timeouts: 0,
                failsafe: 0
            }
        );
        assert_eq!(r.last(), Some(6));
        r.radio_tick(); // a new command came: not held
        r.radio_tick(); // none since: held
        r.radio_tick();
        assert_eq!(r.stats.held, 2);
        r.accept(7);
        r.radio_tick();
        assert_eq!(r.stats.held, 2);
    }

    #[test]
    fn offset_reports_are_read_and_bad_ones_refused() {
        let b = offset(2, [0.05, -0.03, f64::NAN]);
        assert_eq!(b.len(), 32);
        assert_eq!(&b[..8], &[b'F', b'A', b'O', b'F', 1, 2, 0, 0]);
        let (id, o) = parse_offset(&b).unwrap();
        assert_eq!((id, o[0], o[1]), (2, 0.05, -0.03));
        assert!(o[2].is_nan());
        assert_eq!(parse_offset(&b[..31]), None);
        assert_eq!(parse_offset(&offset(2, [f64::NAN, 0.0, 0.0])), None, "no roll: no report");
        assert_eq!(parse_offset(&offset(2, [0.0, 0.0, f64::INFINITY])), None);
        let mut v2 = b.clone();
        v2[4] = 2;
        assert_eq!(parse_offset(&v2), None);
        let mut reserved = b.clone();
        reserved[7] = 7;
        assert_eq!(parse_offset(&reserved), None, "the reserved bytes are zero");
    }

    #[test]
    fn requests_and_telemetry_have_their_documented_layout() {
        let q = request(3, 9, 180_000_000);
        assert_eq!(q.len(), 20);
        assert_eq!(&q[..8], &[b'F', b'A', b'R', b'Q', 1, 3, 0, 0]);
        assert_eq!(u32::from_le_bytes(q[8..12].try_into().unwrap()), 9);
        assert_eq!(i64::from_le_bytes(q[12..20].try_into().unwrap()), 180_000_000);
        let f = TelemetryFrame {
            seq: 4,
            t0: crate::clock::Nanos(10),
            t1: crate::clock::Nanos(20),
            gyro_mean: crate::frames::Vec3::new(0.5, -0.25, 2.0),
        };
        let t = telemetry(1, &f);
        assert_eq!(t.len(), 40);
        assert_eq!(&t[..8], &[b'F', b'A', b'T', b'M', 1, 1, 0, 0]);
        assert_eq!(u32::from_le_bytes(t[8..12].try_into().unwrap()), 4);
        assert_eq!(
            (i64::from_le_bytes(t[12..20].try_into().unwrap()), i64::from_le_bytes(t[20..28].try_into().unwrap())),
            (10, 20)
        );
        assert_eq!(f32::from_le_bytes(t[36..40].try_into().unwrap()), 2.0);
    }
}

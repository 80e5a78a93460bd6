//! Any datagram through `serve`'s classification of its command port (flyarena's command and
//! offset packets, NatNet requests): never a panic, and what it accepts as one of flyarena's
//! packets is exactly what that packet's writer writes.
#![no_main]
use flyarena::serve::{Incoming, classify, command};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    match classify(data) {
        Incoming::Command(c) => {
            assert_eq!(command::command(c.vehicle_id, c.seq, &c.frame.channels[..c.frame.len]), data);
        }
        Incoming::Offset { vehicle_id, roll_pitch_yaw: [r, p, y] } => {
            assert!(r.is_finite() && p.is_finite() && !y.is_infinite());
            assert_eq!(command::offset(vehicle_id, [r, p, y])[..8], data[..8]);
            assert_eq!(command::offset(vehicle_id, [r, p, y])[8..], data[8..]);
        }
        Incoming::Request(_) => assert!(data.len() >= 4),
        Incoming::Rejected => {}
    }
});

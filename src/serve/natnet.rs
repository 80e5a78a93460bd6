//! OptiTrack's NatNet protocol, version 3.1, as the server side writes it: the packets that
//! libmotioncapture's `optitrack` backend (the mocap layer of Crazyswarm2) and the `natnet`
//! Python client read. Pure functions from values to bytes and back; the sockets are in
//! [`crate::serve`].
//!
//! Every packet is `u16 message id, u16 payload bytes, payload`, little-endian, strings
//! NUL-terminated. The messages used:
//!
//! | id | message | direction | payload |
//! |---|---|---|---|
//! | 0 | connect | client → server | "Ping" |
//! | 1 | server info | server → client | name (256 bytes), app version (4 bytes), NatNet version (4 bytes), clock frequency u64, data port u16, multicast u8, multicast group (4 bytes) |
//! | 2 / 3 | request / response | both | a text command / i32 result |
//! | 4 / 5 | model definition request / reply | both | the rigid bodies' names, ids and markers |
//! | 7 | frame of data | server → client | frame number, rigid bodies, timestamps |
//! | 10 | keep-alive | client → server | (none) |
//! | 100 | unrecognised request | server → client | (none) |
//!
//! The frame's fields at version 3.1, in order: frame number u32; marker sets (count 0);
//! unlabelled markers (count 0); rigid bodies (count, then per body: id i32, x y z f32 (m),
//! qx qy qz qw f32, mean marker error f32 (m), params u16 with bit 0 = tracked); skeletons
//! (count 0); labelled markers (count 0); force plates (count 0); devices (count 0); timecode
//! u32, timecode sub-frame u32; timestamp f64 (s); camera mid-exposure, camera data received
//! and transmit timestamps u64 (ticks of the clock frequency in the server info); frame params
//! u16 (bit 1: the tracked model list changed); end-of-data tag u32 = 0.

use std::net::Ipv4Addr;

/// Client → server: ask for the server info.
pub const NAT_CONNECT: u16 = 0;
/// Server → client: the server info.
const NAT_SERVERINFO: u16 = 1;
/// Client → server: a text command.
pub const NAT_REQUEST: u16 = 2;
/// Server → client: the result of a text command.
pub const NAT_RESPONSE: u16 = 3;
/// Client → server: ask for the model definitions.
pub const NAT_REQUEST_MODELDEF: u16 = 4;
/// Server → client: the model definitions.
const NAT_MODELDEF: u16 = 5;
/// Client → server: ask for the latest frame.
pub const NAT_REQUEST_FRAMEOFDATA: u16 = 6;
/// Server → client: one frame of mocap data.
const NAT_FRAMEOFDATA: u16 = 7;
/// Client → server: the client goes away.
pub const NAT_DISCONNECT: u16 = 9;
/// Client → server: the client is still there (unicast).
pub const NAT_KEEPALIVE: u16 = 10;
/// Server → client: a request the server does not know.
pub const NAT_UNRECOGNIZED_REQUEST: u16 = 100;

/// The NatNet version flyarena speaks (major, minor, build, revision).
pub(crate) const VERSION: [u8; 4] = [3, 1, 0, 0];
/// Ticks per second of every timestamp flyarena sends: nanoseconds of simulated time.
pub const CLOCK_HZ: u64 = 1_000_000_000;

/// One rigid body in a frame, in the stream's convention ([`crate::serve::Up`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RigidBody {
    /// The rigid body's id (the model definition pairs it with a name).
    pub id: i32,
    /// Position of the rigid body's origin (m).
    pub pos_m: [f32; 3],
    /// Orientation as the unit quaternion (x, y, z, w) that turns body coordinates into world
    /// coordinates.
    pub quat_xyzw: [f32; 4],
    /// Mean marker residual of the rigid fit (m).
    pub mean_error_m: f32,
    /// Whether the body was tracked in this frame.
    pub tracked: bool,
}

/// One frame of data.
#[derive(Clone, Debug, PartialEq)]
pub struct Frame {
    /// The mocap's frame number (+1 per camera frame).
    pub number: u32,
    /// The rigid bodies in this frame.
    pub bodies: Vec<RigidBody>,
    /// Time of the frame (s), on the server's clock.
    pub timestamp_s: f64,
    /// When the cameras exposed the frame ([`CLOCK_HZ`] ticks).
    pub mid_exposure: u64,
    /// When the frame had been processed ([`CLOCK_HZ`] ticks).
    pub data_received: u64,
    /// When the server sent it ([`CLOCK_HZ`] ticks).
    pub transmit: u64,
    /// Whether the tracked model list changed (the first frame, a body lost or found).
    pub models_changed: bool,
}

/// A rigid body's definition.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct RigidBodyDef {
    /// Name (the scenario's vehicle name).
    pub name: String,
    /// Id, as in the frames.
    pub id: i32,
    /// Marker positions relative to the rigid body's origin (m), in the stream's convention.
    pub markers_m: Vec<[f32; 3]>,
}

/// A request from a client.
#[derive(Clone, Debug, PartialEq)]
pub enum Request {
    /// [`NAT_CONNECT`].
    Connect,
    /// [`NAT_REQUEST_MODELDEF`].
    ModelDef,
    /// [`NAT_REQUEST_FRAMEOFDATA`].
    FrameOfData,
    /// [`NAT_KEEPALIVE`].
    KeepAlive,
    /// [`NAT_DISCONNECT`].
    Disconnect,
    /// [`NAT_REQUEST`] with its text.
    Command(String),
    /// Any other message id.
    Unknown(u16),
}

/// Reads a client's packet. `None` when it is shorter than its header or its payload.
pub(crate) fn parse_request(packet: &[u8]) -> Option<Request> {
    let id = u16::from_le_bytes(packet.get(0..2)?.try_into().ok()?);
    let n = u16::from_le_bytes(packet.get(2..4)?.try_into().ok()?) as usize;
    let payload = packet.get(4..4 + n)?;
    Some(match id {
        NAT_CONNECT => Request::Connect,
        NAT_REQUEST_MODELDEF => Request::ModelDef,
        NAT_REQUEST_FRAMEOFDATA => Request::FrameOfData,
        NAT_KEEPALIVE => Request::KeepAlive,
        NAT_DISCONNECT => Request::Disconnect,
        NAT_REQUEST => {
            let text = payload.split(|b| *b == 0).next().unwrap_or(&[]);
            Request::Command(String::from_utf8_lossy(text).into_owned())
        }
        other => Request::Unknown(other),
    })
}

/// A growing packet: the header is patched with the payload size when it is finished.
struct Packet(Vec<u8>);

impl Packet {
    fn new(id: u16) -> Self {
        let mut b = Vec::with_capacity(512);
        b.extend_from_slice(&id.to_le_bytes());
        b.extend_from_slice(&[0, 0]);
        Packet(b)
    }
    fn u8(&mut self, x: u8) -> &mut Self {
        self.0.push(x);
        self
    }
    fn u16(&mut self, x: u16) -> &mut Self {
        self.0.extend_from_slice(&x.to_le_bytes());
        self
    }
    fn i32(&mut self, x: i32) -> &mut Self {
        self.0.extend_from_slice(&x.to_le_bytes());
        self
    }
    fn u32(&mut self, x: u32) -> &mut Self {
        self.0.extend_from_slice(&x.to_le_bytes());
        self
    }
    fn u64(&mut self, x: u64) -> &mut Self {
        self.0.extend_from_slice(&x.to_le_bytes());
        self
    }
    fn f32(&mut self, x: f32) -> &mut Self {
        self.0.extend_from_slice(&x.to_le_bytes());
        self
    }
    fn f64(&mut self, x: f64) -> &mut Self {
        self.0.extend_from_slice(&x.to_le_bytes());
        self
    }
    fn bytes(&mut self, x: &[u8]) -> &mut Self {
        self.0.extend_from_slice(x);
        self
    }
    /// A NUL-terminated string (NUL bytes inside are dropped).
    fn cstr(&mut self, s: &str) -> &mut Self {
        self.0.extend(s.bytes().filter(|b| *b != 0));
        self.0.push(0);
        self
    }
    /// The finished packet. Panics when the payload exceeds the u16 size field (64 kB), which
    /// flyarena's at most 16 rigid bodies of at most 8 markers never reach.
    fn finish(mut self) -> Vec<u8> {
        let n = u16::try_from(self.0.len() - 4).expect("a NatNet payload fits in 64 kB");
        self.0[2..4].copy_from_slice(&n.to_le_bytes());
        self.0
    }
}

/// The server info (reply to [`Request::Connect`]): application name, versions, the timestamps'
/// clock, and where the data goes (the data port; the multicast group, if any).
pub(crate) fn server_info(
    app_name: &str,
    app_version: [u8; 4],
    data_port: u16,
    multicast: Option<Ipv4Addr>,
) -> Vec<u8> {
    let mut name = [0u8; 256];
    let b = app_name.as_bytes();
    let n = b.len().min(255);
    name[..n].copy_from_slice(&b[..n]);
    let mut p = Packet::new(NAT_SERVERINFO);
    p.bytes(&name)
        .bytes(&app_version)
        .bytes(&VERSION)
        .u64(CLOCK_HZ)
        .u16(data_port)
        .u8(multicast.is_some() as u8)
        .bytes(&multicast.unwrap_or(Ipv4Addr::UNSPECIFIED).octets());
    p.finish()
}

/// The model definitions (reply to [`Request::ModelDef`]): one rigid body per definition, no
/// parent, zero offset.
pub(crate) fn model_def(bodies: &[RigidBodyDef]) -> Vec<u8> {
    let mut p = Packet::new(NAT_MODELDEF);
    p.u32(bodies.len() as u32);
    for b in bodies {
        p.u32(1).cstr(&b.name).i32(b.id).i32(-1).f32(0.0).f32(0.0).f32(0.0);
        p.u32(b.markers_m.len() as u32);
        for m in &b.markers_m {
            p.f32(m[0]).f32(m[1]).f32(m[2]);
        }
        for _ in &b.markers_m {
            p.i32(0); // active labels: passive markers
        }
    }
    p.finish()
}

/// One frame of data.
pub fn frame(f: &Frame) -> Vec<u8> {
    let mut p = Packet::new(NAT_FRAMEOFDATA);
    p.u32(f.number).u32(0).u32(0).u32(f.bodies.len() as u32);
    for b in &f.bodies {
        p.i32(b.id);
        for x in b.pos_m.iter().chain(&b.quat_xyzw) {
            p.f32(*x);
        }
        p.f32(b.mean_error_m).u16(b.tracked as u16);
    }
    // skeletons, labelled markers, force plates, devices
    p.u32(0).u32(0).u32(0).u32(0);
    p.u32(0).u32(0).f64(f.timestamp_s).u64(f.mid_exposure).u64(f.data_received).u64(f.transmit);
    p.u16(if f.models_changed { 0x02 } else { 0 }).u32(0);
    p.finish()
}

/// A short reply without payload: [`NAT_UNRECOGNIZED_REQUEST`], or [`NAT_RESPONSE`] with an
/// i32 result for a text command.
pub fn response(result: Option<i32>) -> Vec<u8> {
    match result {
        Some(r) => {
            let mut p = Packet::new(NAT_RESPONSE);
            p.i32(r);
            p.finish()
        }
        None => Packet::new(NAT_UNRECOGNIZED_REQUEST).finish(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn u16_at(b: &[u8], i: usize) -> u16 {
        u16::from_le_bytes(b[i..i + 2].try_into().unwrap())
    }
    fn u32_at(b: &[u8], i: usize) -> u32 {
        u32::from_le_bytes(b[i..i + 4].try_into().unwrap())
    }
    fn f32_at(b: &[u8], i: usize) -> f32 {
        f32::from_le_bytes(b[i..i + 4].try_into().unwrap())
    }

    /// The byte layout written out by hand from the table in the module doc (and from
    /// libmotioncapture's `sResponse` struct: 4 + 256 + 4 + 4 + 8 + 2 + 1 + 4 bytes).
    #[test]
    fn server_info_has_the_layout_libmotioncapture_reads() {
        let b = server_info("flyarena", [0, 1, 0, 0], 1511, Some(Ipv4Addr::new(239, 255, 42, 99)));
        assert_eq!(b.len(), 283);
        assert_eq!(u16_at(&b, 0), NAT_SERVERINFO);
        assert_eq!(u16_at(&b, 2), 279);
        assert_eq!(&b[4..12], b"flyarena");
        assert_eq!(b[12], 0);
        assert_eq!(&b[264..268], &[3, 1, 0, 0]);
        assert_eq!(u64::from_le_bytes(b[268..276].try_into().unwrap()), 1_000_000_000);
        assert_eq!(u16_at(&b, 276), 1511);
        assert_eq!(b[278], 1);
        assert_eq!(&b[279..283], &[239, 255, 42, 99]);
        let u = server_info("x", [0; 4], 7, None);
        assert_eq!((u[278], &u[279..283]), (0, &[0u8, 0, 0, 0][..]));
    }

    #[test]
    fn a_frame_with_one_body_has_the_version_3_1_layout() {
        let f = Frame {
            number: 42,
            bodies: vec![RigidBody {
                id: 3,
                pos_m: [1.0, -2.0, 0.5],
                quat_xyzw: [0.0, 0.0, 0.6, 0.8],
                mean_error_m: 0.001,
                tracked: true,
            }],
            timestamp_s: 1.25,
            mid_exposure: 1_250_000_000,
            data_received: 1_260_000_000,
            transmit: 1_260_000_000,
            models_changed: true,
        };
        let b = frame(&f);
        // header 4; number, marker sets, unlabelled, bodies 16; body 4 + 28 + 4 + 2 = 38;
        // skeletons, labelled, plates, devices 16; timecode 8; timestamp 8; stamps 24; params 2; eod 4
        assert_eq!(b.len(), 4 + 16 + 38 + 16 + 8 + 8 + 24 + 2 + 4);
        assert_eq!(u16_at(&b, 0), NAT_FRAMEOFDATA);
        assert_eq!(u16_at(&b, 2) as usize, b.len() - 4);
        assert_eq!((u32_at(&b, 4), u32_at(&b, 8), u32_at(&b, 12), u32_at(&b, 16)), (42, 0, 0, 1));
        assert_eq!(u32_at(&b, 20), 3);
        assert_eq!((f32_at(&b, 24), f32_at(&b, 28), f32_at(&b, 32)), (1.0, -2.0, 0.5));
        assert_eq!((f32_at(&b, 44), f32_at(&b, 48)), (0.6, 0.8));
        assert_eq!(f32_at(&b, 52), 0.001);
        assert_eq!(u16_at(&b, 56), 1);
        let t = 58 + 16 + 8;
        assert_eq!(f64::from_le_bytes(b[t..t + 8].try_into().unwrap()), 1.25);
        assert_eq!(u64::from_le_bytes(b[t + 8..t + 16].try_into().unwrap()), 1_250_000_000);
        assert_eq!(u64::from_le_bytes(b[t + 16..t + 24].try_into().unwrap()), 1_260_000_000);
        assert_eq!(u16_at(&b, t + 32), 0x02);
        assert_eq!(u32_at(&b, t + 34), 0);
    }

    #[test]
    fn model_def_lists_names_ids_and_markers() {
        let b = model_def(&[RigidBodyDef {
            name: "cf1".into(),
            id: 7,
            markers_m: vec![[0.1, 0.0, 0.0], [0.0, 0.1, 0.0], [0.0, 0.0, 0.1]],
        }]);
        assert_eq!(u16_at(&b, 0), NAT_MODELDEF);
        assert_eq!(u16_at(&b, 2) as usize, b.len() - 4);
        assert_eq!((u32_at(&b, 4), u32_at(&b, 8)), (1, 1));
        assert_eq!(&b[12..16], b"cf1\0");
        assert_eq!((u32_at(&b, 16) as i32, u32_at(&b, 20) as i32), (7, -1));
        assert_eq!(u32_at(&b, 36), 3);
        assert_eq!(f32_at(&b, 40), 0.1);
        assert_eq!(b.len(), 40 + 3 * 12 + 3 * 4);
    }

    #[test]
    fn requests_are_read_and_short_packets_refused() {
        assert_eq!(parse_request(&[0, 0, 5, 0, b'P', b'i', b'n', b'g', 0]), Some(Request::Connect));
        assert_eq!(parse_request(&[4, 0, 1, 0, 0]), Some(Request::ModelDef));
        assert_eq!(parse_request(&[10, 0, 1, 0, 0]), Some(Request::KeepAlive));
        assert_eq!(parse_request(&[2, 0, 4, 0, b'a', b'b', 0, 0]), Some(Request::Command("ab".into())));
        assert_eq!(parse_request(&[55, 0, 0, 0]), Some(Request::Unknown(55)));
        assert_eq!(parse_request(&[0, 0, 5, 0, b'P']), None, "payload shorter than its size");
        assert_eq!(parse_request(&[0]), None);
        assert_eq!(response(Some(0)), vec![3, 0, 4, 0, 0, 0, 0, 0]);
        assert_eq!(response(None), vec![100, 0, 0, 0]);
    }
}

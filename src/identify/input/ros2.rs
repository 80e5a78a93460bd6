//! ROS 2 bags in MCAP as identification data.
//!
//! A mapping with a `ros2:` block names the topics; the units and frames are ROS's own (REP 103:
//! SI units, radians; `world` and `body` say which way the axes point, z-up world and FLU body by
//! default):
//!
//! ```yaml
//! vehicle: crazyflie21
//! ros2:
//!   pose: /vicon/cf/pose      # geometry_msgs/msg/PoseStamped or TransformStamped (body → world)
//!   imu: /cf/imu              # sensor_msgs/msg/Imu: angular_velocity, linear_acceleration
//!   motors: /cf/motors        # optional: std_msgs/msg/Float64MultiArray, PWM 0..65535 per motor
//!   battery: /cf/battery      # optional: sensor_msgs/msg/BatteryState, voltage
//! smoothing_ms: 50
//! ```
//!
//! The messages are read with the `mcap` crate (chunks compressed with zstd or lz4 or not) and
//! decoded from CDR (XCDR1, either byte order; this module, for the message types above). They
//! are put on the IMU's clock by each message's header stamp (the array, which has no header, by
//! its log time) as `identify/input/joined.rs` says: one row per IMU message, the pose interpolated, no
//! pose across a dropped frame, motors and battery held. The rows then go through the same
//! reader as a CSV log ([`super::mapping`]), so that the routes cannot drift apart.
//!
//! Nothing read from the file can panic: a message cut short, a wrong schema or encoding, a
//! missing topic or a non-finite value is an error naming the topic and the message's index.

use super::error::InputError;
use super::joined::{Stream, Streams};
use super::read_note::ReadNote;
use mcap::records::Record;
use mcap::sans_io::linear_reader::{LinearReadEvent, LinearReader, LinearReaderOptions};
use std::collections::HashMap;

/// The longest record, or decompressed chunk, the reader takes (256 MiB): a corrupt length
/// beyond it is an error, not an allocation that could abort the process.
const RECORD_LIMIT: usize = 256 << 20;

/// The records read (schema, channel, message, chunk); the others are skipped unparsed, which
/// spares `mcap`'s parser of records flyarena does not use (an attachment shorter than its
/// header made it panic).
const NEEDED: [u8; 4] = [0x03, 0x04, 0x05, 0x06];

/// The topics of a ROS 2 mapping.
#[derive(Debug, Clone, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Topics {
    /// The pose topic (`geometry_msgs/PoseStamped`).
    pub pose: String,
    /// The IMU topic (`sensor_msgs/Imu`).
    pub imu: String,
    /// The motor commands topic, if logged.
    #[serde(default)]
    pub motors: Option<String>,
    /// The battery topic (`sensor_msgs/BatteryState`), if logged.
    #[serde(default)]
    pub battery: Option<String>,
}

/// An MCAP file starts with these magic bytes.
pub(crate) const MAGIC: &[u8] = b"\x89MCAP0\r\n";

/// A little CDR (XCDR1) reader: primitives aligned to their size from the start of the payload
/// (after the 4-byte encapsulation header), in the byte order the header names.
/// Why a message's CDR payload does not decode, or does not hold what its topic needs.
#[derive(Debug, thiserror::Error)]
enum CdrError {
    #[error("shorter than its CDR header")]
    NoHeader,
    #[error("CDR representation {0:#04x} is not plain CDR (0x00 big or 0x01 little endian)")]
    NotPlain(u8),
    #[error("cut short")]
    CutShort,
    #[error("{0}")]
    Content(String),
}

impl From<&str> for CdrError {
    fn from(s: &str) -> Self {
        CdrError::Content(s.to_string())
    }
}

impl From<String> for CdrError {
    fn from(s: String) -> Self {
        CdrError::Content(s)
    }
}

struct Cdr<'a> {
    buf: &'a [u8],
    pos: usize,
    little: bool,
}

impl<'a> Cdr<'a> {
    fn new(data: &'a [u8]) -> Result<Cdr<'a>, CdrError> {
        if data.len() < 4 {
            return Err(CdrError::NoHeader);
        }
        let little = match data[1] {
            0x00 => false,
            0x01 => true,
            k => return Err(CdrError::NotPlain(k)),
        };
        Ok(Cdr { buf: &data[4..], pos: 0, little })
    }
    fn take(&mut self, size: usize, align: usize) -> Result<&'a [u8], CdrError> {
        let start = self.pos.div_ceil(align) * align;
        let end = start.checked_add(size).filter(|e| *e <= self.buf.len()).ok_or(CdrError::CutShort)?;
        self.pos = end;
        Ok(&self.buf[start..end])
    }
    fn u32(&mut self) -> Result<u32, CdrError> {
        let b: [u8; 4] = self.take(4, 4)?.try_into().expect("4 bytes");
        Ok(if self.little { u32::from_le_bytes(b) } else { u32::from_be_bytes(b) })
    }
    fn i32(&mut self) -> Result<i32, CdrError> {
        Ok(self.u32()? as i32)
    }
    fn f32(&mut self) -> Result<f64, CdrError> {
        Ok(f32::from_bits(self.u32()?) as f64)
    }
    fn f64(&mut self) -> Result<f64, CdrError> {
        let b: [u8; 8] = self.take(8, 8)?.try_into().expect("8 bytes");
        Ok(if self.little { f64::from_le_bytes(b) } else { f64::from_be_bytes(b) })
    }
    fn f64s<const N: usize>(&mut self) -> Result<[f64; N], CdrError> {
        let mut out = [0.0; N];
        for x in &mut out {
            *x = self.f64()?;
        }
        Ok(out)
    }
    fn string(&mut self) -> Result<(), CdrError> {
        let n = self.u32()? as usize;
        self.take(n, 1)?;
        Ok(())
    }
    /// std_msgs/Header: the stamp in nanoseconds (the frame id is skipped).
    fn header(&mut self) -> Result<i128, CdrError> {
        let sec = self.i32()? as i128;
        let nanosec = self.u32()? as i128;
        self.string()?;
        Ok(sec * 1_000_000_000 + nanosec)
    }
}

fn schema_is(name: &str, want: &str) -> bool {
    // "geometry_msgs/msg/PoseStamped" (ROS 2) or "geometry_msgs/PoseStamped"
    name == want || name.replace("/msg/", "/") == want.replace("/msg/", "/")
}

/// Reads the bag `bytes` through `topics` into the rows of a CSV log with the columns
/// `t,px,py,pz,qx,qy,qz,qw,gx,gy,gz,ax,ay,az[,m1..mN][,vbat]`, and the repairs made.
pub fn to_csv(bytes: &[u8], topics: &Topics, file: &str) -> Result<(String, Vec<ReadNote>), InputError> {
    if !bytes.starts_with(MAGIC) {
        return Err(InputError::log(file, "not an MCAP file (no MCAP magic bytes)"));
    }
    Ok(guarded(bytes, topics, file)?.join())
}

/// [`read`], with a panic inside the `mcap` reader (a corrupt file can make it index past its
/// buffers) turned into an error that names the file and the byte at which the reader failed:
/// the end of the shortest head of the file that makes it fail, found by bisection (the reader
/// reads linearly, so every longer head fails too).
fn guarded(bytes: &[u8], topics: &Topics, file: &str) -> Result<Streams, InputError> {
    match std::panic::catch_unwind(|| read(bytes, topics, file)) {
        Ok(r) => r,
        Err(_) => {
            let at = shortest_failing_head(bytes.len(), |n| {
                std::panic::catch_unwind(|| read(&bytes[..n], topics, file)).is_err()
            });
            Err(InputError::log(
                file,
                format!("the MCAP reader failed on the record that ends at byte {at} (a corrupt file)"),
            ))
        }
    }
}

/// The length of the shortest head of a `len`-byte file for which `fails` holds, given that it
/// holds of the whole file and of every head longer than one for which it holds.
fn shortest_failing_head(len: usize, fails: impl Fn(usize) -> bool) -> usize {
    let (mut ok, mut bad) = (0, len);
    while bad - ok > 1 {
        let mid = ok + (bad - ok) / 2;
        if fails(mid) { bad = mid } else { ok = mid }
    }
    bad
}

/// Decodes every message on the four topics; a topic named but empty is an error. The file is
/// read by `mcap`'s linear reader, which hands over each chunk whole: flyarena decompresses it
/// ([`chunk_records`]) and walks its records itself, because `mcap` 0.25's own chunk reading
/// loops forever on a zstd frame that ends before the chunk's declared size.
fn read(bytes: &[u8], topics: &Topics, file: &str) -> Result<Streams, InputError> {
    let mut d = Decoder {
        s: Streams {
            pose: Stream::new(),
            imu: Stream::new(),
            motors: Stream::new(),
            n_motors: None,
            battery: Stream::new(),
        },
        schemas: HashMap::new(),
        channels: HashMap::new(),
        topics,
        file,
    };
    let mut reader = LinearReader::new_with_options(
        LinearReaderOptions::default().with_emit_chunks(true).with_record_length_limit(RECORD_LIMIT),
    );
    let mut fed = 0usize;
    while let Some(event) = reader.next_event() {
        let at = |e: mcap::McapError| InputError::log(file, format!("reading up to byte {fed}: {e}"));
        let (opcode, data) = match event.map_err(at)? {
            LinearReadEvent::ReadRequest(need) => {
                let n = need.min(bytes.len() - fed);
                reader.insert(n).copy_from_slice(&bytes[fed..fed + n]);
                reader.notify_read(n);
                fed += n;
                continue;
            }
            LinearReadEvent::Record { opcode, data } => (opcode, data),
        };
        if !NEEDED.contains(&opcode) {
            continue;
        }
        match mcap::parse_record(opcode, data).map_err(at)? {
            Record::Chunk { header, data } => {
                let in_chunk = |why: String| InputError::log(file, format!("the chunk read up to byte {fed}: {why}"));
                let records = chunk_records(&header, &data).map_err(in_chunk)?;
                let mut rest = &records[..];
                while !rest.is_empty() {
                    let (op, body, tail) =
                        split_record(rest).ok_or_else(|| in_chunk("a record is cut short".into()))?;
                    rest = tail;
                    if NEEDED.contains(&op) {
                        d.take(mcap::parse_record(op, body).map_err(at)?, fed)?;
                    }
                }
            }
            record => d.take(record, fed)?,
        }
    }
    let Decoder { s, .. } = d;
    for (topic, n) in [
        (Some(&topics.pose), s.pose.t.len()),
        (Some(&topics.imu), s.imu.t.len()),
        (topics.motors.as_ref(), s.motors.t.len()),
        (topics.battery.as_ref(), s.battery.t.len()),
    ] {
        if let Some(topic) = topic
            && n == 0
        {
            return Err(InputError::log(file, format!("no message on topic `{topic}`")));
        }
    }
    Ok(Streams {
        pose: s.pose.sorted(),
        imu: s.imu.sorted(),
        motors: s.motors.sorted(),
        n_motors: s.n_motors,
        battery: s.battery.sorted(),
    })
}

/// What the records decoded so far hold: the schemas' names and the channels (as the file
/// declares them before their messages), and the streams of the four topics.
struct Decoder<'a> {
    s: Streams,
    schemas: HashMap<u16, String>,
    channels: HashMap<u16, mcap::records::Channel>,
    topics: &'a Topics,
    file: &'a str,
}

impl Decoder<'_> {
    /// Takes one record (read up to byte `fed` of the file): a schema or channel is kept, a
    /// message on one of the four topics decoded.
    fn take(&mut self, record: Record, fed: usize) -> Result<(), InputError> {
        let (header, data) = match record {
            Record::Schema { header, .. } => {
                self.schemas.insert(header.id, header.name);
                return Ok(());
            }
            Record::Channel(c) => {
                self.channels.insert(c.id, c);
                return Ok(());
            }
            Record::Message { header, data } => (header, data),
            _ => return Ok(()),
        };
        let (file, topics, s) = (self.file, self.topics, &mut self.s);
        let Some(channel) = self.channels.get(&header.channel_id) else {
            return Err(InputError::log(
                file,
                format!(
                    "the message read up to byte {fed} is on channel {}, which the file never declared",
                    header.channel_id
                ),
            ));
        };
        let topic = channel.topic.as_str();
        let which = [Some(&topics.pose), Some(&topics.imu), topics.motors.as_ref(), topics.battery.as_ref()]
            .iter()
            .position(|t| t.is_some_and(|t| t == topic));
        let Some(which) = which else { return Ok(()) };
        let schema = self.schemas.get(&channel.schema_id).map_or("", String::as_str);
        if channel.message_encoding != "cdr" {
            return Err(InputError::log(
                file,
                format!("topic `{topic}` is encoded as `{}`, not `cdr` (ROS 2)", channel.message_encoding),
            ));
        }
        let at = |e: CdrError| InputError::Message {
            file: file.to_string(),
            topic: topic.to_string(),
            sequence: header.sequence,
            schema: schema.to_string(),
            reason: e.to_string(),
        };
        let mut c = Cdr::new(&data).map_err(at)?;
        match which {
            0 => {
                let (t, v) = pose_message(&mut c, schema).map_err(at)?;
                s.pose.push(t, v).map_err(|e| at(e.into()))
            }
            1 => {
                let (t, v) = imu_message(&mut c, schema).map_err(at)?;
                s.imu.push(t, v).map_err(|e| at(e.into()))
            }
            2 => {
                let (n, v) = motors_message(&mut c, schema, s.n_motors).map_err(at)?;
                s.n_motors = Some(n);
                s.motors.push(header.log_time as i128, v).map_err(|e| at(e.into()))
            }
            _ => {
                let (t, v) = battery_message(&mut c, schema).map_err(at)?;
                s.battery.push(t, v).map_err(|e| at(e.into()))
            }
        }
    }
}

/// A chunk's records: stored as they are, or a zstd or lz4 frame decompressed to exactly the
/// chunk's declared size, which is at most [`RECORD_LIMIT`]; the CRC-32 of the records checked
/// unless it is 0 (not computed), as the MCAP specification says.
fn chunk_records<'a>(h: &mcap::records::ChunkHeader, data: &'a [u8]) -> Result<std::borrow::Cow<'a, [u8]>, String> {
    let size = usize::try_from(h.uncompressed_size)
        .ok()
        .filter(|n| *n <= RECORD_LIMIT)
        .ok_or_else(|| format!("its records' size {} is over the 256 MiB limit", h.uncompressed_size))?;
    let records: std::borrow::Cow<[u8]> = match h.compression.as_str() {
        "" => data.into(),
        "zstd" => zstd::bulk::decompress(data, size).map_err(|e| format!("zstd: {e}"))?.into(),
        "lz4" => {
            use std::io::Read as _;
            let mut out = Vec::new();
            lz4::Decoder::new(data)
                .map_err(|e| format!("lz4: {e}"))?
                .take(size as u64 + 1)
                .read_to_end(&mut out)
                .map_err(|e| format!("lz4: {e}"))?;
            out.into()
        }
        other => return Err(format!("compression `{other}` is neither zstd nor lz4")),
    };
    if records.len() != size {
        return Err(format!("its records take {} bytes, not the {size} it declares", records.len()));
    }
    if h.uncompressed_crc != 0 && crc32fast::hash(&records) != h.uncompressed_crc {
        return Err("its records' CRC does not match".into());
    }
    Ok(records)
}

/// The first record of `b`, as MCAP lays records out (opcode u8, length u64 little-endian,
/// then the body): (opcode, body, the rest); `None` when `b` is shorter than the record.
fn split_record(b: &[u8]) -> Option<(u8, &[u8], &[u8])> {
    let len = usize::try_from(u64::from_le_bytes(b.get(1..9)?.try_into().ok()?)).ok()?;
    let end = 9usize.checked_add(len)?;
    Some((b[0], b.get(9..end)?, &b[end..]))
}

/// A geometry_msgs PoseStamped or TransformStamped: its stamp and (position, quaternion x, y, z, w).
fn pose_message(c: &mut Cdr, schema: &str) -> Result<(i128, [f64; 7]), CdrError> {
    // the two differ only by the transform's child_frame_id after the header
    let transform = schema_is(schema, "geometry_msgs/msg/TransformStamped");
    if !transform && !schema_is(schema, "geometry_msgs/msg/PoseStamped") {
        return Err("the pose topic must be geometry_msgs/msg/PoseStamped or TransformStamped".into());
    }
    let t = c.header()?;
    if transform {
        c.string()?;
    }
    Ok((t, c.f64s::<7>()?))
}

/// A sensor_msgs Imu: its stamp and (angular velocity, linear acceleration).
fn imu_message(c: &mut Cdr, schema: &str) -> Result<(i128, [f64; 6]), CdrError> {
    if !schema_is(schema, "sensor_msgs/msg/Imu") {
        return Err("the imu topic must be sensor_msgs/msg/Imu".into());
    }
    let t = c.header()?;
    c.f64s::<4>()?; // orientation
    c.f64s::<9>()?;
    let w = c.f64s::<3>()?;
    c.f64s::<9>()?;
    let a = c.f64s::<3>()?;
    Ok((t, [w[0], w[1], w[2], a[0], a[1], a[2]]))
}

/// A std_msgs Float64MultiArray of 1 to 8 motor values, as many as earlier messages had
/// (`n_before`): their number and the values (zero beyond it). It has no stamp: the caller takes
/// the log time.
fn motors_message(c: &mut Cdr, schema: &str, n_before: Option<usize>) -> Result<(usize, [f64; 8]), CdrError> {
    if !schema_is(schema, "std_msgs/msg/Float64MultiArray") {
        return Err("the motors topic must be std_msgs/msg/Float64MultiArray".into());
    }
    let dims = c.u32()?;
    for _ in 0..dims {
        c.string()?;
        c.u32()?;
        c.u32()?;
    }
    c.u32()?; // data_offset
    let n = c.u32()? as usize;
    if n == 0 || n > 8 {
        return Err(format!("{n} motor values; 1 to 8 expected").into());
    }
    if n_before.is_some_and(|m| m != n) {
        return Err(format!("{n} motor values where earlier messages had {}", n_before.unwrap_or(0)).into());
    }
    let mut v = [0.0; 8];
    for x in v.iter_mut().take(n) {
        *x = c.f64()?;
    }
    Ok((n, v))
}

/// A sensor_msgs BatteryState: its stamp and voltage (V).
fn battery_message(c: &mut Cdr, schema: &str) -> Result<(i128, [f64; 1]), CdrError> {
    if !schema_is(schema, "sensor_msgs/msg/BatteryState") {
        return Err("the battery topic must be sensor_msgs/msg/BatteryState".into());
    }
    let t = c.header()?;
    Ok((t, [c.f32()?]))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// CDR by hand: little endian header, a Header (sec 7, nanosec 5, frame "ab"), then a
    /// float64 aligned to 8 from the payload start: 4 + 4 + 4 (length) + 3 ("ab\0") = 15 → pad
    /// to 16.
    #[test]
    fn cdr_aligns_from_the_payload_and_reads_a_header() {
        let mut b = vec![0u8, 1, 0, 0];
        b.extend(7i32.to_le_bytes());
        b.extend(5u32.to_le_bytes());
        b.extend(3u32.to_le_bytes());
        b.extend(b"ab\0");
        b.push(0); // padding to 16
        b.extend(2.5f64.to_le_bytes());
        let mut c = Cdr::new(&b).unwrap();
        assert_eq!(c.header().unwrap(), 7_000_000_005);
        assert_eq!(c.f64().unwrap(), 2.5);
        assert!(c.f64().is_err(), "reading past the end is an error, not a panic");
        // big endian
        let mut b = vec![0u8, 0, 0, 0];
        b.extend(1.25f64.to_be_bytes());
        assert_eq!(Cdr::new(&b).unwrap().f64().unwrap(), 1.25);
        assert!(Cdr::new(&[0, 7, 0, 0]).is_err());
        assert!(Cdr::new(&[0, 1]).is_err());
    }

    /// A Float64MultiArray of motor commands by hand (no dimensions, offset 0, n values from
    /// byte 12, already aligned to 8): 4 values are read; 0 and 9 are refused with their count,
    /// and so is a count that changes between messages.
    #[test]
    fn motor_arrays_hold_one_to_eight_values() {
        let array = |n: u32| {
            let mut b = vec![0u8, 1, 0, 0];
            b.extend(0u32.to_le_bytes());
            b.extend(0u32.to_le_bytes());
            b.extend(n.to_le_bytes());
            b.extend([0u8; 4]);
            for k in 0..n {
                b.extend((k as f64 + 0.5).to_le_bytes());
            }
            b
        };
        let schema = "std_msgs/msg/Float64MultiArray";
        let four = array(4);
        let (n, v) = motors_message(&mut Cdr::new(&four).unwrap(), schema, None).unwrap();
        assert_eq!((n, v), (4, [0.5, 1.5, 2.5, 3.5, 0.0, 0.0, 0.0, 0.0]));
        for (bad, want) in [(0, "0 motor values; 1 to 8 expected"), (9, "9 motor values; 1 to 8 expected")] {
            let b = array(bad);
            let e = motors_message(&mut Cdr::new(&b).unwrap(), schema, None).unwrap_err();
            assert_eq!(e.to_string(), want);
        }
        let e = motors_message(&mut Cdr::new(&four).unwrap(), schema, Some(3)).unwrap_err();
        assert_eq!(e.to_string(), "4 motor values where earlier messages had 3");
    }

    #[test]
    fn a_file_that_is_not_mcap_is_named() {
        let t = Topics { pose: "/p".into(), imu: "/i".into(), motors: None, battery: None };
        let e = to_csv(b"t,px\n1,2\n", &t, "f.mcap").unwrap_err().to_string();
        assert_eq!(e, "f.mcap: not an MCAP file (no MCAP magic bytes)");
    }

    /// The bisection finds the first failing head whatever the length: 4,242 of 100,000 bytes,
    /// the last byte, the first.
    #[test]
    fn the_byte_a_reader_fails_at_is_found_by_bisection() {
        assert_eq!(shortest_failing_head(100_000, |n| n >= 4242), 4242);
        assert_eq!(shortest_failing_head(100_000, |n| n >= 100_000), 100_000);
        assert_eq!(shortest_failing_head(100_000, |n| n >= 1), 1);
    }

    /// An MCAP file of a header and one chunk holding `records` (the chunk's CRC 0: not
    /// checked), stored as they are or as a zstd frame of one raw block (RFC 8878: magic, a
    /// single-segment header with a 1-byte content size, a last raw block), then `tail`.
    fn one_chunk(records: &[u8], zstd: bool, tail: &[u8]) -> Vec<u8> {
        chunk_declaring(records, records.len() as u64, zstd, tail)
    }

    /// [`one_chunk`] whose header declares `size` bytes of records.
    fn chunk_declaring(records: &[u8], size: u64, zstd: bool, tail: &[u8]) -> Vec<u8> {
        let mut b = MAGIC.to_vec();
        let string = |b: &mut Vec<u8>, s: &str| {
            b.extend_from_slice(&(s.len() as u32).to_le_bytes());
            b.extend_from_slice(s.as_bytes());
        };
        // header: profile "ros2", library ""
        let mut h = Vec::new();
        string(&mut h, "ros2");
        string(&mut h, "");
        b.push(0x01);
        b.extend_from_slice(&(h.len() as u64).to_le_bytes());
        b.extend_from_slice(&h);
        // chunk: start, end, uncompressed size, crc 0, compression, the records
        let stored = if zstd {
            assert!(records.len() < 256);
            let n = records.len() as u32;
            let mut z = vec![0x28, 0xB5, 0x2F, 0xFD, 0x20, n as u8];
            z.extend_from_slice(&(1 | n << 3).to_le_bytes()[..3]);
            z.extend_from_slice(records);
            z
        } else {
            records.to_vec()
        };
        let mut c = Vec::new();
        c.extend_from_slice(&[0u8; 16]);
        c.extend_from_slice(&size.to_le_bytes());
        c.extend_from_slice(&0u32.to_le_bytes());
        string(&mut c, if zstd { "zstd" } else { "" });
        c.extend_from_slice(&(stored.len() as u64).to_le_bytes());
        c.extend_from_slice(&stored);
        b.push(0x06);
        b.extend_from_slice(&(c.len() as u64).to_le_bytes());
        b.extend_from_slice(&c);
        b.extend_from_slice(tail);
        b
    }

    /// What follows the data: a data end (CRC 0), a footer (no summary), the closing magic.
    fn end_of_file() -> Vec<u8> {
        let mut end = vec![0x0F];
        end.extend_from_slice(&4u64.to_le_bytes());
        end.extend_from_slice(&[0; 4]);
        end.push(0x02);
        end.extend_from_slice(&20u64.to_le_bytes());
        end.extend_from_slice(&[0; 20]);
        end.extend_from_slice(MAGIC);
        end
    }

    fn topics() -> Topics {
        Topics { pose: "/p".into(), imu: "/i".into(), motors: None, battery: None }
    }

    /// A chunk that declares 5 bytes of records, fewer than a record's 9-byte opcode and length:
    /// the `mcap` reader's count of the chunk's remaining bytes went below zero (a panic where
    /// overflow is checked, a wrapped count where it is not). An error naming the file.
    #[test]
    fn a_chunk_shorter_than_its_record_is_an_error_not_a_panic() {
        let b = one_chunk(&[0x05, 0, 0, 0, 0], false, &[0u8; 16]);
        let e = to_csv(&b, &topics(), "bad.mcap").unwrap_err().to_string();
        assert!(e.starts_with("bad.mcap"), "{e}");
    }

    /// A record inside a compressed chunk whose length is 2⁶⁴ − 1 (or 2⁴⁰): the `mcap`
    /// reader sized its decompression buffer by it, a capacity overflow (a panic, in every
    /// build) or an allocation that aborts the process. The reader's record limit makes it an
    /// error naming the file. The same records uncompressed, and a record that fits, read.
    #[test]
    fn a_record_longer_than_the_limit_is_an_error_not_an_abort() {
        let fits = one_chunk(&[0x80, 0, 0, 0, 0, 0, 0, 0, 0], true, &end_of_file());
        let e = to_csv(&fits, &topics(), "ok.mcap").unwrap_err().to_string();
        assert!(e.contains("no message on topic `/p`"), "the frame decompresses: {e}");
        for (len, zstd) in [(u64::MAX, true), (1 << 40, true), (1 << 40, false)] {
            let mut r = vec![0x80];
            r.extend_from_slice(&len.to_le_bytes());
            let b = one_chunk(&r, zstd, &[0u8; 64]);
            let e = to_csv(&b, &topics(), "bad.mcap").unwrap_err().to_string();
            assert!(e.starts_with("bad.mcap") && e.contains("byte"), "{e}");
        }
    }

    /// A zstd chunk whose frame ends (9 bytes) before the 100 bytes of records it declares:
    /// `mcap` 0.25's chunk reading waits forever for the decompressor to give the rest (it
    /// consumes and writes nothing, and the loop goes round); a bag of 200 bytes hung
    /// `identify`. flyarena's own decompression says the sizes differ.
    #[test]
    fn a_chunk_shorter_than_it_declares_is_an_error_not_a_hang() {
        let b = chunk_declaring(&[0x80, 0, 0, 0, 0, 0, 0, 0, 0], 100, true, &[0u8; 64]);
        let e = to_csv(&b, &topics(), "short.mcap").unwrap_err().to_string();
        assert!(e.starts_with("short.mcap") && e.contains("not the 100 it declares"), "{e}");
    }

    /// An attachment record (opcode 0x09) whose 32 bytes hold its header and data length but
    /// not its CRC: `mcap`'s record parser slices past it and panics.
    /// flyarena skips the records it does not use, so the bag reads up to its missing topics.
    #[test]
    fn a_record_flyarena_does_not_use_is_skipped_unparsed() {
        let mut r = vec![0x09];
        r.extend_from_slice(&32u64.to_le_bytes());
        r.extend_from_slice(&[0; 32]);
        assert!(std::panic::catch_unwind(|| mcap::parse_record(0x09, &[0; 32])).is_err(), "mcap panics on it");
        let b = one_chunk(&r, false, &end_of_file());
        let e = to_csv(&b, &topics(), "att.mcap").unwrap_err().to_string();
        assert!(e.contains("no message on topic `/p`"), "{e}");
    }
}

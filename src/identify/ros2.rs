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
//! are put on the IMU's clock, one row per IMU message, by each message's header stamp (the
//! array, which has no header, by its log time): the pose is interpolated between the two poses
//! around the row (linearly, and the attitude by normalised linear interpolation), or taken as
//! is when a pose has the row's own stamp; a row between two poses further apart than 1.5
//! median pose intervals (a dropped frame) is a frame in which the vehicle was not seen. Motors and battery hold their last
//! value; rows before the first of them are left out (said in the repairs). The rows then go
//! through the same reader as a CSV log ([`super::mapping`]), so that the two routes cannot
//! drift apart: time is seconds from the first IMU stamp, exact in integer nanoseconds.
//!
//! Nothing read from the file can panic: a message cut short, a wrong schema or encoding, a
//! missing topic or a non-finite value is an error naming the topic and the message's index.

use super::error::InputError;
use std::fmt::Write as _;

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

/// One decoded stream: stamps (ns) and values.
struct Stream<const N: usize> {
    t: Vec<i128>,
    v: Vec<[f64; N]>,
}

impl<const N: usize> Stream<N> {
    fn new() -> Self {
        Stream { t: Vec::new(), v: Vec::new() }
    }
    /// Appends a decoded message; a value that is not finite is an error.
    fn push(&mut self, m: Result<(i128, [f64; N]), CdrError>) -> Result<(), CdrError> {
        let (t, v) = m?;
        if !v.iter().all(|x| x.is_finite()) {
            return Err("a value is not finite".into());
        }
        self.t.push(t);
        self.v.push(v);
        Ok(())
    }
    /// Sorted by stamp (stable: messages with one stamp keep their order).
    fn sorted(mut self) -> Self {
        let mut idx: Vec<usize> = (0..self.t.len()).collect();
        idx.sort_by_key(|&i| self.t[i]);
        self.t = idx.iter().map(|&i| self.t[i]).collect();
        self.v = idx.iter().map(|&i| self.v[i]).collect();
        self
    }
}

fn schema_is(name: &str, want: &str) -> bool {
    // "geometry_msgs/msg/PoseStamped" (ROS 2) or "geometry_msgs/PoseStamped"
    name == want || name.replace("/msg/", "/") == want.replace("/msg/", "/")
}

/// Reads the bag `bytes` through `topics` into the rows of a CSV log with the columns
/// `t,px,py,pz,qx,qy,qz,qw,gx,gy,gz,ax,ay,az[,m1..mN][,vbat]`, and the repairs made.
pub fn to_csv(bytes: &[u8], topics: &Topics, file: &str) -> Result<(String, Vec<String>), InputError> {
    if !bytes.starts_with(MAGIC) {
        return Err(InputError::log(file, "not an MCAP file (no MCAP magic bytes)"));
    }
    let streams = Streams::read(bytes, topics, file)?;
    Ok(streams.join(topics))
}

/// The four topics' messages, decoded (stamps in ns).
struct Streams {
    pose: Stream<7>,
    imu: Stream<6>,
    motors: Stream<8>,
    /// The number of motor values per message, the same in every message.
    n_motors: Option<usize>,
    battery: Stream<1>,
}

impl Streams {
    /// Decodes every message on the four topics; a topic named but empty is an error.
    fn read(bytes: &[u8], topics: &Topics, file: &str) -> Result<Streams, InputError> {
        let mut s = Streams { pose: Stream::new(), imu: Stream::new(), motors: Stream::new(), n_motors: None, battery: Stream::new() };
        let stream = mcap::MessageStream::new(bytes).map_err(|e| InputError::log(file, e.to_string()))?;
        for (k, m) in stream.enumerate() {
            let m = m.map_err(|e| InputError::log(file, format!("record {k}: {e}")))?;
            let topic = m.channel.topic.as_str();
            let which = [Some(&topics.pose), Some(&topics.imu), topics.motors.as_ref(), topics.battery.as_ref()].iter().position(|t| t.is_some_and(|t| t == topic));
            let Some(which) = which else { continue };
            let schema = m.channel.schema.as_ref().map_or("", |s| s.name.as_str());
            if m.channel.message_encoding != "cdr" {
                return Err(InputError::log(file, format!("topic `{topic}` is encoded as `{}`, not `cdr` (ROS 2)", m.channel.message_encoding)));
            }
            let at =
                |e: CdrError| InputError::Message { file: file.to_string(), topic: topic.to_string(), sequence: m.sequence, schema: schema.to_string(), reason: e.to_string() };
            let mut c = Cdr::new(&m.data).map_err(at)?;
            match which {
                0 => s.pose.push(pose_message(&mut c, schema)).map_err(at)?,
                1 => s.imu.push(imu_message(&mut c, schema)).map_err(at)?,
                2 => {
                    let (n, v) = motors_message(&mut c, schema, s.n_motors).map_err(at)?;
                    s.n_motors = Some(n);
                    s.motors.push(Ok((m.log_time as i128, v))).map_err(at)?;
                }
                _ => s.battery.push(battery_message(&mut c, schema)).map_err(at)?,
            }
        }
        for (topic, n) in
            [(Some(&topics.pose), s.pose.t.len()), (Some(&topics.imu), s.imu.t.len()), (topics.motors.as_ref(), s.motors.t.len()), (topics.battery.as_ref(), s.battery.t.len())]
        {
            if let Some(topic) = topic
                && n == 0
            {
                return Err(InputError::log(file, format!("no message on topic `{topic}`")));
            }
        }
        Ok(Streams { pose: s.pose.sorted(), imu: s.imu.sorted(), motors: s.motors.sorted(), n_motors: s.n_motors, battery: s.battery.sorted() })
    }

    /// One CSV row per IMU message: the pose at its stamp (interpolated, or empty across a
    /// dropped frame), the last motor and battery values at or before it. Returns the CSV and the
    /// repairs made.
    fn join(&self, topics: &Topics) -> (String, Vec<String>) {
        let (pose, imu, motors, battery) = (&self.pose, &self.imu, &self.motors, &self.battery);
        // two poses further apart than 1.5 median intervals have a dropped frame between them:
        // nothing is interpolated across it
        let reach = {
            let mut d: Vec<i128> = pose.t.windows(2).map(|w| w[1] - w[0]).filter(|d| *d > 0).collect();
            d.sort_unstable();
            d.get(d.len() / 2).map_or(0, |m| 3 * m / 2)
        };
        let mut csv = String::from("t,px,py,pz,qx,qy,qz,qw,gx,gy,gz,ax,ay,az");
        for i in 0..self.n_motors.unwrap_or(0) {
            let _ = write!(csv, ",m{}", i + 1);
        }
        if topics.battery.is_some() {
            csv.push_str(",vbat");
        }
        csv.push('\n');
        let mut repairs = Vec::new();
        let (mut skipped, mut p, mut mo, mut ba) = (0usize, 0usize, 0usize, 0usize);
        let t0 = imu.t[0];
        for (t, v) in imu.t.iter().zip(&imu.v) {
            // the last motor and battery values at or before t
            while mo < motors.t.len() && motors.t[mo] <= *t {
                mo += 1;
            }
            while ba < battery.t.len() && battery.t[ba] <= *t {
                ba += 1;
            }
            if (topics.motors.is_some() && mo == 0) || (topics.battery.is_some() && ba == 0) {
                skipped += 1;
                continue;
            }
            // the first pose after t (p), and the one before
            while p < pose.t.len() && pose.t[p] <= *t {
                p += 1;
            }
            let _ = write!(csv, "{}", (*t - t0) as f64 * 1e-9);
            if p > 0 && pose.t[p - 1] == *t {
                for x in &pose.v[p - 1] {
                    let _ = write!(csv, ",{x}");
                }
            } else if p > 0 && p < pose.t.len() && pose.t[p] - pose.t[p - 1] <= reach {
                let f = (*t - pose.t[p - 1]) as f64 / (pose.t[p] - pose.t[p - 1]) as f64;
                for x in interpolate_pose(&pose.v[p - 1], &pose.v[p], f) {
                    let _ = write!(csv, ",{x}");
                }
            } else {
                csv.push_str(",,,,,,,");
            }
            for x in v {
                let _ = write!(csv, ",{x}");
            }
            if let Some(n) = self.n_motors {
                for x in &motors.v[mo - 1][..n] {
                    let _ = write!(csv, ",{x}");
                }
            }
            if topics.battery.is_some() {
                let _ = write!(csv, ",{}", battery.v[ba - 1][0]);
            }
            csv.push('\n');
        }
        if skipped > 0 {
            repairs.push(format!("{skipped} IMU messages before the first motor or battery message were left out"));
        }
        (csv, repairs)
    }
}

/// The pose a fraction `f` of the way from `a` to `b` (position, quaternion x, y, z, w):
/// position linear, attitude by nlerp on the shorter arc.
fn interpolate_pose(a: &[f64; 7], b: &[f64; 7], f: f64) -> [f64; 7] {
    let mut out = [0.0; 7];
    for k in 0..3 {
        out[k] = a[k] * (1.0 - f) + b[k] * f;
    }
    let sign = if (3..7).map(|k| a[k] * b[k]).sum::<f64>() < 0.0 { -1.0 } else { 1.0 };
    for k in 3..7 {
        out[k] = a[k] * (1.0 - f) + sign * b[k] * f;
    }
    let norm = out[3..].iter().map(|x| x * x).sum::<f64>().sqrt();
    for x in &mut out[3..] {
        *x /= norm;
    }
    out
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

    /// The pose between two samples whose quaternions lie on opposite hemispheres (q and −q are
    /// one attitude): position halfway, attitude halfway along the shorter arc. From the identity
    /// to −(90° about z), the shorter arc's middle is 45° about z, (0, 0, sin 22.5°, cos 22.5°);
    /// the longer arc would give 135° about −z.
    #[test]
    fn a_pose_is_interpolated_on_the_shorter_arc() {
        let h = std::f64::consts::FRAC_PI_4; // half of 90°
        let a = [0.0, 2.0, -1.0, 0.0, 0.0, 0.0, 1.0];
        let b = [1.0, 4.0, -1.0, 0.0, 0.0, -h.sin(), -h.cos()];
        let m = interpolate_pose(&a, &b, 0.5);
        let want = [0.5, 3.0, -1.0, 0.0, 0.0, (h / 2.0).sin(), (h / 2.0).cos()];
        for k in 0..7 {
            assert!((m[k] - want[k]).abs() < 1e-12, "{m:?}");
        }
        // a quarter of the way, nlerp (not slerp): 2·atan2(f·sin 45°, (1 − f) + f·cos 45°) = 21.6°
        let q = interpolate_pose(&a, &b, 0.25);
        let want = 2.0 * (0.25 * h.sin()).atan2(0.75 + 0.25 * h.cos());
        assert!((2.0 * q[5].atan2(q[6]) - want).abs() < 1e-12 && q[3] == 0.0 && q[4] == 0.0, "{q:?}");
    }

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

    /// Motors and battery hold their last value; an IMU row before the first of either is left
    /// out and counted in the repairs. IMU every 5 ms from 0, poses every 10 ms, battery from
    /// 0 ms, the motors from 10 ms: the rows at 0 and 5 ms go, the row at 15 ms has the motors
    /// of 10 ms and the pose halfway between 10 and 20 ms, and time still counts from the first
    /// IMU stamp. With the motors from 0 ms nothing goes and no repair is said.
    #[test]
    fn imu_rows_before_the_first_motor_or_battery_message_are_left_out_and_said() {
        let ms = 1_000_000i128;
        let stream = |stamps: &[i128], f: &dyn Fn(usize) -> f64| {
            let mut s = Stream::<7>::new();
            for (i, t) in stamps.iter().enumerate() {
                s.push(Ok((t * ms, [f(i), 0.0, 0.0, 0.0, 0.0, 0.0, 1.0]))).unwrap();
            }
            s
        };
        let streams = |motors_from: i128| {
            let pose = stream(&[0, 10, 20, 30], &|i| i as f64);
            let imu = stream(&[0, 5, 10, 15, 20, 25], &|_| 0.0);
            let motors = stream(&[motors_from, 20], &|i| 100.0 + i as f64);
            let battery = stream(&[0], &|_| 11.1);
            let six = |s: Stream<7>| Stream { t: s.t, v: s.v.iter().map(|v| [v[0], v[1], v[2], v[3], v[4], v[5]]).collect() };
            let eight = |s: Stream<7>| Stream { t: s.t, v: s.v.iter().map(|v| [v[0]; 8]).collect() };
            let one = |s: Stream<7>| Stream { t: s.t, v: s.v.iter().map(|v| [v[0]]).collect() };
            Streams { pose, imu: six(imu), motors: eight(motors), n_motors: Some(1), battery: one(battery) }
        };
        let topics = Topics { pose: "/p".into(), imu: "/i".into(), motors: Some("/m".into()), battery: Some("/b".into()) };
        let (csv, repairs) = streams(10).join(&topics);
        assert_eq!(repairs, ["2 IMU messages before the first motor or battery message were left out"]);
        let rows: Vec<&str> = csv.lines().collect();
        assert_eq!(rows[0], "t,px,py,pz,qx,qy,qz,qw,gx,gy,gz,ax,ay,az,m1,vbat");
        assert_eq!(rows.len(), 1 + 4, "{csv}");
        assert!(rows[1].starts_with("0.01,1,0,0,0,0,0,1,"), "{}", rows[1]);
        let f: Vec<&str> = rows[2].split(',').collect();
        assert!((f[0].parse::<f64>().unwrap() - 0.015).abs() < 1e-12 && f[1] == "1.5", "{}", rows[2]);
        assert!(rows[2].ends_with(",100,11.1"), "{}", rows[2]);
        assert!(rows[3].ends_with(",101,11.1"), "{}", rows[3]);
        let (csv, repairs) = streams(0).join(&topics);
        assert!(repairs.is_empty(), "{repairs:?}");
        assert_eq!(csv.lines().count(), 1 + 6);
    }

    #[test]
    fn a_file_that_is_not_mcap_is_named() {
        let t = Topics { pose: "/p".into(), imu: "/i".into(), motors: None, battery: None };
        let e = to_csv(b"t,px\n1,2\n", &t, "f.mcap").unwrap_err().to_string();
        assert_eq!(e, "f.mcap: not an MCAP file (no MCAP magic bytes)");
    }
}

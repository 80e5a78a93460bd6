//! PX4 flight logs (ULog, `.ulg`) as identification data.
//!
//! A mapping with a `px4:` block reads a ULog file instead of a CSV (`mappings/px4.yaml`):
//!
//! ```yaml
//! vehicle: crazyflie21
//! px4:
//!   pose: vehicle_visual_odometry  # or vehicle_mocap_odometry (default: the first the log has)
//!   imu: sensor_combined           # default; or vehicle_imu
//!   motors: actuator_motors        # optional; or actuator_outputs with output_range
//!   battery: battery_status        # optional
//!   instance: 0                    # which instance of a multi-instance topic (default 0)
//! smoothing_ms: 50
//! ```
//!
//! The file is parsed by the `px4-ulog` crate (maintained in the PX4 organisation), appended
//! data sections included; a log cut short or with a malformed record is read up to the fault,
//! which the repairs name. What each topic gives, in PX4's frames and units (uORB message
//! definitions):
//! - the pose, `VehicleOdometry`: `position` (m) and `q` (w, x, y, z: the rotation from the FRD
//!   body to the reference frame, NED or a world-fixed FRD), both z down, so the mapping's world
//!   is `z_down` and its body `frd`; logs before PX4 1.14 name the position `x, y, z`. A pose
//!   with a NaN (PX4's "invalid") is a frame in which the vehicle was not seen. It is stamped by
//!   `timestamp_sample`, the time the mocap captured it as the bridge set it, where the log has
//!   it and it is not 0, else by `timestamp`, the time PX4 published it (later by the bridge's
//!   and the link's latency, which a mocap delay then absorbs); the report says which.
//! - the IMU, `SensorCombined`: `gyro_rad` (rad/s) at `timestamp` and `accelerometer_m_s2`
//!   (m/s², specific force) at `timestamp + accelerometer_timestamp_relative` (µs); rows are at
//!   the gyro's stamp and the report says by how much the accelerometer's differ. Or
//!   `VehicleImu`: `delta_angle`/`delta_angle_dt` and `delta_velocity`/`delta_velocity_dt`, the
//!   mean rate and specific force over the integration interval, at its middle
//!   (`timestamp_sample − dt/2`).
//! - the motors, `ActuatorMotors`: `control` in [0, 1] per motor (NaN: stopped, read as 0),
//!   read as the fraction u of full command that the preset's thrust map takes (u = PWM/65535
//!   on a Crazyflie); or `ActuatorOutputs`: `output` mapped to u by the mapping's
//!   `output_range: [zero, full]` (e.g. [1000, 2000] µs). The motors are the first
//!   `motor_count` (default: as many as ever hold a number, at most 8).
//! - the battery, `BatteryStatus`: `voltage_v` (V); a sample at 0 V (no battery) is left out.
//!
//! The streams are then joined onto the IMU's clock (`identify/input/joined.rs`) and go through the same
//! reader as a CSV log, as a ROS 2 bag does, so all three routes give one report. Nothing read
//! from the file can panic: a parser failure, a missing topic or field is an error that names
//! the file and, for a missing topic, the `SDLOG_PROFILE` bit that logs it.

use super::error::InputError;
use super::joined::{Stream, Streams};
use super::read_note::{ReadNote, StampField};
use px4_ulog::full_parser::{Completeness, FlattenedFieldType};
use px4_ulog::stream_parser::{DataMessage, LogParser};
use std::collections::BTreeMap;
use std::path::Path;

/// A ULog file starts with these bytes (the header's magic and its version byte comes after).
pub(crate) const MAGIC: &[u8] = b"ULog\x01\x12\x35";

/// The topics of a PX4 mapping (the `px4:` block).
#[derive(Debug, Clone, Default, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Topics {
    /// The mocap pose: `vehicle_visual_odometry` or `vehicle_mocap_odometry` (default: the first
    /// of the two the log has).
    #[serde(default)]
    pub pose: Option<String>,
    /// The IMU: `sensor_combined` (default) or `vehicle_imu`.
    #[serde(default)]
    pub imu: Option<String>,
    /// The motor commands: `actuator_motors` or `actuator_outputs`, if wanted.
    #[serde(default)]
    pub motors: Option<String>,
    /// `actuator_outputs` only: the output values that mean no command and full command.
    #[serde(default)]
    pub output_range: Option<[f64; 2]>,
    /// How many motors (default: as many controls as ever hold a number, at most 8).
    #[serde(default)]
    pub motor_count: Option<usize>,
    /// The battery: `battery_status`, if wanted.
    #[serde(default)]
    pub battery: Option<String>,
    /// The instance of each multi-instance topic (default 0).
    #[serde(default)]
    pub instance: u8,
}

/// One topic instance of a log: its `timestamp`s (µs since boot) and its fields as numbers
/// (integers and booleans converted exactly, `f32` widened; a `char` field is left out).
#[derive(Debug, Clone)]
pub struct TopicData {
    /// The uORB topic.
    pub name: String,
    /// Its instance (`multi_id`).
    pub instance: u8,
    /// Each field by its flattened name (`gyro_rad[0]`), one value per message.
    pub fields: BTreeMap<String, Vec<f64>>,
}

impl TopicData {
    /// The `timestamp` field (µs), as logged.
    pub fn timestamps(&self) -> &[f64] {
        self.fields.get("timestamp").map_or(&[], Vec::as_slice)
    }
    fn field(&self, name: &str) -> Option<&[f64]> {
        self.fields.get(name).map(Vec::as_slice)
    }
    fn need(&self, name: &str, file: &str) -> Result<&[f64], InputError> {
        self.field(name).ok_or_else(|| InputError::log(file, format!("topic `{}` has no field `{name}`", self.name)))
    }
    fn len(&self) -> usize {
        self.timestamps().len()
    }
}

/// A parsed log: every topic instance, and how the data ended (`None`: cleanly).
#[derive(Debug, Clone)]
pub struct Log {
    /// The topic instances, by name then instance.
    pub topics: Vec<TopicData>,
    /// Why the reading stopped early, if it did: [`ReadNote::Truncated`] or [`ReadNote::MalformedRecord`].
    pub incomplete: Option<ReadNote>,
}

impl Log {
    /// Reads a `.ulg` file; see [`Log::parse`].
    pub fn read(path: &Path) -> Result<Log, InputError> {
        let file = path.display().to_string();
        let bytes = std::fs::read(path).map_err(|e| InputError::io(&file, e))?;
        Log::parse(&bytes, &file)
    }

    /// Parses the bytes of a `.ulg` file (named `file` in errors) with `px4-ulog`'s stream
    /// parser, appended data sections included. A file the parser rejects before its data, or
    /// that makes it panic, is an error naming the file and the byte at which the parser
    /// failed (the last byte of the record it was reading), never a panic of ours.
    pub fn parse(bytes: &[u8], file: &str) -> Result<Log, InputError> {
        if !bytes.starts_with(MAGIC) {
            return Err(InputError::log(file, "not a ULog file (no ULog magic bytes)"));
        }
        // the parser indexes its buffers by offsets the file gives: a corrupt file can make it
        // panic. The first pass feeds large chunks; after a fault, a second feeds the faulty
        // chunk byte by byte, so the error can name the byte.
        let parsed = match drive(bytes, bytes.len()) {
            Err(Fault { chunk_start, .. }) => match drive(bytes, chunk_start) {
                Err(f) => Err(f),
                Ok(_) => Err(Fault { chunk_start, at: None, why: "the parser failed on a chunk of the file".into() }),
            },
            ok => ok,
        };
        let (collected, completeness) = parsed.map_err(|f| {
            let at = f.at.map_or_else(
                || format!("between byte {} and byte {}", f.chunk_start, f.chunk_start + CHUNK),
                |b| format!("at byte {b}"),
            );
            InputError::log(file, format!("not a readable ULog file: {} {at}", f.why))
        })?;
        let incomplete = match completeness {
            Completeness::Complete => None,
            Completeness::Truncated => Some(ReadNote::Truncated),
            Completeness::MalformedRecord(why) => Some(ReadNote::MalformedRecord { why }),
        };
        let mut topics: Vec<TopicData> = collected
            .into_iter()
            .map(|((name, instance), c)| TopicData {
                name,
                instance,
                fields: c.names.into_iter().zip(c.values).filter_map(|(k, v)| v.map(|v| (k, v))).collect(),
            })
            .collect();
        topics.sort_by(|a, b| (&a.name, a.instance).cmp(&(&b.name, b.instance)));
        Ok(Log { topics, incomplete })
    }

    /// The instance `instance` of `topic`; `named` says where the mapping names it ("which
    /// m.yaml names in `px4.imu`", or the key's default). Absent, an error naming the instances
    /// there are or, for a topic the log lacks, the mapping's key, the closest topic and every
    /// topic the log has.
    fn topic(&self, topic: &str, instance: u8, file: &str, named: &str) -> Result<&TopicData, InputError> {
        let all: Vec<&TopicData> = self.topics.iter().filter(|t| t.name == topic).collect();
        match all.iter().find(|t| t.instance == instance) {
            Some(t) if t.len() > 0 => Ok(t),
            Some(_) => Err(InputError::log(file, format!("topic `{topic}` has no message"))),
            None if all.is_empty() => {
                let mut names: Vec<&str> = self.topics.iter().map(|t| t.name.as_str()).collect();
                names.dedup();
                let close = crate::scenario::error::closest(topic, names.iter().copied(), 3.max(topic.len() / 4))
                    .map_or(String::new(), |n| format!(" (is it `{n}`?)"));
                Err(InputError::log(
                    file,
                    format!(
                        "the log has no topic `{topic}`, {named}{close}{}; the log's topics: {}",
                        profile_hint(topic),
                        names.join(", ")
                    ),
                ))
            }
            None => Err(InputError::log(
                file,
                format!(
                    "topic `{topic}` has no instance {instance} (instances: {}); set `px4.instance`",
                    all.iter().map(|t| t.instance.to_string()).collect::<Vec<_>>().join(", ")
                ),
            )),
        }
    }

    fn has(&self, topic: &str) -> bool {
        self.topics.iter().any(|t| t.name == topic && t.len() > 0)
    }
}

/// The size of a field in bytes, and whether it is a number (a `char` is not).
fn field_size(t: &FlattenedFieldType) -> (usize, bool) {
    use FlattenedFieldType as T;
    match t {
        T::Int8 | T::UInt8 | T::Bool => (1, true),
        T::Char => (1, false),
        T::Int16 | T::UInt16 => (2, true),
        T::Int32 | T::UInt32 | T::Float => (4, true),
        T::Int64 | T::UInt64 | T::Double => (8, true),
    }
}

/// A field's value as `f64` (little-endian, as ULog stores it): integers and booleans exactly
/// (µs since boot stay below 2⁵³, 285 years), `f32` widened.
fn decode(t: &FlattenedFieldType, b: &[u8]) -> f64 {
    use FlattenedFieldType as T;
    let a = |n: usize| -> [u8; 8] {
        let mut x = [0u8; 8];
        x[..n].copy_from_slice(&b[..n]);
        x
    };
    match t {
        T::Int8 => f64::from(b[0] as i8),
        T::UInt8 | T::Char => f64::from(b[0]),
        T::Bool => f64::from(u8::from(b[0] != 0)),
        T::Int16 => f64::from(i16::from_le_bytes([b[0], b[1]])),
        T::UInt16 => f64::from(u16::from_le_bytes([b[0], b[1]])),
        T::Int32 => f64::from(i32::from_le_bytes([b[0], b[1], b[2], b[3]])),
        T::UInt32 => f64::from(u32::from_le_bytes([b[0], b[1], b[2], b[3]])),
        T::Float => f64::from(f32::from_le_bytes([b[0], b[1], b[2], b[3]])),
        T::Int64 => i64::from_le_bytes(a(8)) as f64,
        T::UInt64 => u64::from_le_bytes(a(8)) as f64,
        T::Double => f64::from_le_bytes(a(8)),
    }
}

/// The fields of one topic instance as collected: names in the format's order, each column
/// `None` for a `char` field.
#[derive(Default)]
struct Collected {
    names: Vec<String>,
    values: Vec<Option<Vec<f64>>>,
}

/// How the parser failed: in the chunk fed from `chunk_start`, at byte `at` when it was fed
/// byte by byte.
struct Fault {
    chunk_start: usize,
    at: Option<usize>,
    why: String,
}

/// Adds a data message's numbers to its topic instance's columns; a message whose format
/// changed, or that is shorter than its format, is an error.
fn collect(collected: &mut BTreeMap<(String, u8), Collected>, m: &DataMessage) -> Result<(), String> {
    let f = m.flattened_format;
    let c = collected.entry((f.message_name.clone(), m.multi_id.value())).or_default();
    if c.names.is_empty() {
        c.names = f.fields.iter().map(|x| x.flattened_field_name.clone()).collect();
        c.values = f.fields.iter().map(|x| field_size(&x.field_type).1.then(Vec::new)).collect();
    }
    if c.names.len() != f.fields.len() {
        return Err(format!("topic `{}` changed its format", f.message_name));
    }
    for (x, col) in f.fields.iter().zip(&mut c.values) {
        let Some(col) = col else { continue };
        let (n, _) = field_size(&x.field_type);
        let b = m.data.get(x.offset as usize..x.offset as usize + n);
        col.push(decode(
            &x.field_type,
            b.ok_or_else(|| format!("a record of `{}` is shorter than its format", f.message_name))?,
        ));
    }
    Ok(())
}

/// Bytes fed to the parser at once, before the chunk that holds a fault.
const CHUNK: usize = 1 << 16;

/// Feeds `bytes` to `px4-ulog`'s stream parser as its own file driver does (the header byte
/// by byte until the flag bits give the appended sections, the primary section up to the first
/// of them, then each section from its offset), in chunks of [`CHUNK`] bytes before `fine_from`
/// and of one byte from there on. Collects every data message by topic and instance.
#[allow(clippy::type_complexity)]
fn drive(bytes: &[u8], fine_from: usize) -> Result<(BTreeMap<(String, u8), Collected>, Completeness), Fault> {
    let fed = std::cell::Cell::new(0usize);
    let short = std::cell::RefCell::new(None::<String>);
    let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        let mut collected: BTreeMap<(String, u8), Collected> = BTreeMap::new();
        let mut callback = |m: &DataMessage| {
            if let Err(why) = collect(&mut collected, m) {
                short.borrow_mut().get_or_insert(why);
            }
        };
        let mut parser = LogParser::default();
        parser.set_data_message_callback(&mut callback);
        let feed = |parser: &mut LogParser, from: usize, to: usize| -> Result<(), String> {
            let mut at = from;
            while at < to && short.borrow().is_none() {
                let n = if at >= fine_from { 1 } else { CHUNK.min(fine_from - at) };
                let end = (at + n).min(to);
                fed.set(at);
                parser.consume_bytes(&bytes[at..end]).map_err(|e| format!("{e:?}"))?;
                at = end;
            }
            Ok(())
        };
        let mut at = 0;
        // the header and flag bits, byte by byte
        while at < bytes.len() && !parser.header_complete() {
            fed.set(at);
            if let Err(e) = parser.consume_bytes(&bytes[at..at + 1]) {
                return Err(format!("{e:?}"));
            }
            at += 1;
        }
        let sections: Vec<usize> =
            parser.appended_offsets().iter().filter(|&&o| o != 0).map(|&o| (o as usize).min(bytes.len())).collect();
        let mut outcome = feed(&mut parser, at, sections.first().copied().unwrap_or(bytes.len()).max(at));
        for (i, &start) in sections.iter().enumerate() {
            if outcome.is_err() {
                break;
            }
            parser.clear_leftover();
            let end = sections.get(i + 1).copied().unwrap_or(bytes.len()).max(start);
            outcome = feed(&mut parser, start, end);
        }
        let completeness = match outcome {
            Ok(()) if parser.has_leftover() => Completeness::Truncated,
            Ok(()) => Completeness::Complete,
            Err(why) if parser.in_data() => Completeness::MalformedRecord(why),
            Err(why) => return Err(why),
        };
        drop(parser);
        Ok((collected, completeness))
    }));
    let fault = |why: String| {
        let chunk_start = fed.get();
        let at = (chunk_start >= fine_from).then_some(chunk_start);
        Fault { chunk_start, at, why }
    };
    match result {
        Err(_) => Err(fault("the parser panicked".into())),
        Ok(_) if short.borrow().is_some() => Err(fault(short.take().unwrap_or_default())),
        Ok(Err(why)) => Err(fault(why)),
        Ok(Ok(x)) => Ok(x),
    }
}

/// Which `SDLOG_PROFILE` bit records a topic at a rate `identify` can use (PX4's logger,
/// `logged_topics.cpp`): the estimator-replay set (bit 1) logs `vehicle_visual_odometry` and
/// `sensor_combined` at full rate, the computer-vision set (bit 7) both odometry topics at 30 ms,
/// the system-identification set (bit 3) `actuator_motors` at full rate (the default set: 100 ms).
pub(crate) fn profile_hint(topic: &str) -> &'static str {
    match topic {
        "vehicle_visual_odometry" => {
            " (PX4 logs it with SDLOG_PROFILE bit 1, estimator replay, at full rate: add 2; or bit 7, computer vision, at 30 ms: add 128)"
        }
        "vehicle_mocap_odometry" => " (PX4 logs it with SDLOG_PROFILE bit 7, computer vision, at 30 ms: add 128)",
        "sensor_combined" => " (PX4's default logging profile records it at full rate: SDLOG_PROFILE bit 0)",
        "actuator_motors" => {
            " (PX4 logs it at 10 Hz by default; SDLOG_PROFILE bit 3, system identification, at full rate: add 8)"
        }
        "battery_status" => " (PX4's default logging profile records it: SDLOG_PROFILE bit 0)",
        _ => "",
    }
}

/// Microseconds (as logged) to the nanoseconds the join counts in.
fn ns(us: f64) -> i128 {
    us as i128 * 1000
}

/// Reads the log at `path` through `topics` into the rows of a CSV log
/// (`t,px,py,pz,qx,qy,qz,qw,gx,gy,gz,ax,ay,az[,m1..mN][,vbat]`, see `identify/input/joined.rs`), and
/// the repairs and notes made.
pub fn to_csv(bytes: &[u8], topics: &Topics, file: &str, mapping: &str) -> Result<(String, Vec<ReadNote>), InputError> {
    let file = file.to_string();
    // where the mapping names each topic, or that it left the key to its default
    let at = |k: &str, given: bool| {
        if given {
            format!("which {mapping} names in `{k}`")
        } else {
            format!("the default of `{k}`, which {mapping} leaves out")
        }
    };
    let log = Log::parse(bytes, &file)?;
    let mut notes = Vec::new();
    notes.extend(log.incomplete.clone());
    let pose_topic = match &topics.pose {
        Some(p) => p.clone(),
        None => ["vehicle_visual_odometry", "vehicle_mocap_odometry"]
            .into_iter()
            .find(|t| log.has(t))
            .map(str::to_string)
            .ok_or_else(|| {
                InputError::log(
                    &file,
                    format!(
                        "the log has neither `vehicle_visual_odometry` nor `vehicle_mocap_odometry`{}",
                        profile_hint("vehicle_visual_odometry")
                    ),
                )
            })?,
    };
    let instance = topics.instance;
    let pose = log.topic(&pose_topic, instance, &file, &at("px4.pose", topics.pose.is_some()))?;
    let pose = pose_stream(pose, &file, &mut notes)?;
    let imu_topic = topics.imu.as_deref().unwrap_or("sensor_combined");
    let imu =
        imu_stream(log.topic(imu_topic, instance, &file, &at("px4.imu", topics.imu.is_some()))?, &file, &mut notes)?;
    let (motors, n_motors) = match &topics.motors {
        Some(m) => {
            let (s, n) =
                motor_stream(log.topic(m, instance, &file, &at("px4.motors", true))?, topics, &file, &mut notes)?;
            (s, Some(n))
        }
        None => (Stream::new(), None),
    };
    let battery = match &topics.battery {
        Some(b) => battery_stream(log.topic(b, instance, &file, &at("px4.battery", true))?, &file, &mut notes)?,
        None => Stream::new(),
    };
    let streams = Streams {
        pose: pose.sorted(),
        imu: imu.sorted(),
        motors: motors.sorted(),
        n_motors,
        battery: battery.sorted(),
    };
    let (csv, repairs) = streams.join();
    notes.extend(repairs);
    Ok((csv, notes))
}

/// The stamps of a topic that has `timestamp_sample`: those, where every one is set, else
/// `timestamp`; and which one was used.
fn sample_stamps<'a>(t: &'a TopicData, file: &str) -> Result<(&'a [f64], StampField), InputError> {
    match t.field("timestamp_sample") {
        Some(s) if s.iter().all(|x| *x > 0.0) => Ok((s, StampField::Sample)),
        _ => Ok((t.need("timestamp", file)?, StampField::Publication)),
    }
}

fn pose_stream(t: &TopicData, file: &str, notes: &mut Vec<ReadNote>) -> Result<Stream<7>, InputError> {
    let (stamps, stamp) = sample_stamps(t, file)?;
    let pos: [&[f64]; 3] = match t.field("position[0]") {
        Some(_) => [t.need("position[0]", file)?, t.need("position[1]", file)?, t.need("position[2]", file)?],
        None => [t.need("x", file)?, t.need("y", file)?, t.need("z", file)?],
    };
    let q: [&[f64]; 4] = [t.need("q[0]", file)?, t.need("q[1]", file)?, t.need("q[2]", file)?, t.need("q[3]", file)?];
    if let Some(frame) = t.field("pose_frame")
        && frame.iter().any(|f| *f != 1.0 && *f != 2.0)
    {
        notes.push(ReadNote::UnknownPoseFrame { topic: t.name.clone() });
    }
    let mut s = Stream::new();
    let mut invalid = 0;
    for i in 0..stamps.len() {
        // PX4: w, x, y, z; the join: x, y, z, w
        let v = [pos[0][i], pos[1][i], pos[2][i], q[1][i], q[2][i], q[3][i], q[0][i]];
        if v.iter().any(|x| !x.is_finite()) {
            invalid += 1;
            continue;
        }
        s.push(ns(stamps[i]), v).map_err(|e| InputError::log(file, format!("`{}` message {i}: {e}", t.name)))?;
    }
    notes.push(ReadNote::PoseStampedBy { topic: t.name.clone(), stamp });
    if invalid > 0 {
        notes.push(ReadNote::InvalidPoses { count: invalid, topic: t.name.clone() });
    }
    Ok(s)
}

fn imu_stream(t: &TopicData, file: &str, notes: &mut Vec<ReadNote>) -> Result<Stream<6>, InputError> {
    let mut s = Stream::new();
    let at = |i: usize| move |e: &str| InputError::log(file, format!("`{}` message {i}: {e}", t.name));
    if t.name == "vehicle_imu" {
        let stamps = t.need("timestamp_sample", file)?;
        let da: [&[f64]; 3] =
            [t.need("delta_angle[0]", file)?, t.need("delta_angle[1]", file)?, t.need("delta_angle[2]", file)?];
        let dv: [&[f64]; 3] = [
            t.need("delta_velocity[0]", file)?,
            t.need("delta_velocity[1]", file)?,
            t.need("delta_velocity[2]", file)?,
        ];
        let (da_dt, dv_dt) = (t.need("delta_angle_dt", file)?, t.need("delta_velocity_dt", file)?);
        let mut skipped = 0;
        for i in 0..stamps.len() {
            if da_dt[i] <= 0.0 || dv_dt[i] <= 0.0 {
                skipped += 1;
                continue;
            }
            let (wa, wv) = (1e6 / da_dt[i], 1e6 / dv_dt[i]);
            let v = [da[0][i] * wa, da[1][i] * wa, da[2][i] * wa, dv[0][i] * wv, dv[1][i] * wv, dv[2][i] * wv];
            s.push(ns(stamps[i] - da_dt[i] / 2.0), v).map_err(at(i))?;
        }
        if skipped > 0 {
            notes.push(ReadNote::NoIntegrationInterval { count: skipped });
        }
        return Ok(s);
    }
    let stamps = t.need("timestamp", file)?;
    let g: [&[f64]; 3] = [t.need("gyro_rad[0]", file)?, t.need("gyro_rad[1]", file)?, t.need("gyro_rad[2]", file)?];
    let a: [&[f64]; 3] = [
        t.need("accelerometer_m_s2[0]", file)?,
        t.need("accelerometer_m_s2[1]", file)?,
        t.need("accelerometer_m_s2[2]", file)?,
    ];
    let rel = t.field("accelerometer_timestamp_relative");
    // PX4's RELATIVE_TIMESTAMP_INVALID: no accelerometer sample in this message
    const INVALID: f64 = i32::MAX as f64;
    let (mut skipped, mut offsets) = (0, Vec::new());
    for i in 0..stamps.len() {
        if let Some(r) = rel {
            if r[i] == INVALID {
                skipped += 1;
                continue;
            }
            offsets.push(r[i]);
        }
        s.push(ns(stamps[i]), [g[0][i], g[1][i], g[2][i], a[0][i], a[1][i], a[2][i]]).map_err(at(i))?;
    }
    if skipped > 0 {
        notes.push(ReadNote::NoAccelerometerSample { count: skipped });
    }
    offsets.sort_by(f64::total_cmp);
    if let Some(m) = offsets.get(offsets.len() / 2)
        && *m != 0.0
    {
        notes.push(ReadNote::AccelStampOffset { median_us: *m });
    }
    Ok(s)
}

fn motor_stream(
    t: &TopicData,
    topics: &Topics,
    file: &str,
    notes: &mut Vec<ReadNote>,
) -> Result<(Stream<8>, usize), InputError> {
    let outputs = t.name == "actuator_outputs";
    let (prefix, range) = if outputs {
        let r = topics.output_range.ok_or_else(|| {
            InputError::log(
                file,
                "`actuator_outputs` needs `px4.output_range: [zero, full]`, the outputs that mean no and full command",
            )
        })?;
        if !(r[0].is_finite() && r[1].is_finite() && r[1] != r[0]) {
            return Err(InputError::log(file, format!("px4.output_range {r:?} must be two different numbers")));
        }
        ("output", r)
    } else {
        ("control", [0.0, 1.0])
    };
    let (stamps, stamp) = sample_stamps(t, file)?;
    let columns: Vec<&[f64]> = (0..16).map_while(|k| t.field(&format!("{prefix}[{k}]"))).collect();
    let n = match topics.motor_count {
        Some(n) => n,
        None => columns.iter().take_while(|c| c.iter().any(|x| x.is_finite())).count(),
    };
    if n == 0 || n > 8 || n > columns.len() {
        return Err(InputError::log(
            file,
            format!(
                "`{}`: {n} motors; 1 to 8 of its {} `{prefix}` fields expected (set `px4.motor_count`)",
                t.name,
                columns.len()
            ),
        ));
    }
    let mut s = Stream::new();
    for i in 0..stamps.len() {
        let mut v = [0.0; 8];
        for (k, x) in v.iter_mut().enumerate().take(n) {
            // NaN: the motor is stopped (disarmed); the thrust map takes u in [0, 1]
            let u = (columns[k][i] - range[0]) / (range[1] - range[0]);
            *x = if u.is_finite() { u.clamp(0.0, 1.0) * 65535.0 } else { 0.0 };
        }
        s.push(ns(stamps[i]), v).map_err(|e| InputError::log(file, format!("`{}` message {i}: {e}", t.name)))?;
    }
    let span = (stamps[stamps.len() - 1] - stamps[0]) * 1e-6;
    if stamps.len() > 1 && span > 0.0 && (stamps.len() - 1) as f64 / span < 50.0 {
        notes.push(ReadNote::CoarseMotorRate { topic: t.name.clone(), rate_hz: (stamps.len() - 1) as f64 / span });
    }
    notes.push(ReadNote::MotorsStampedBy { topic: t.name.clone(), motors: n, stamp });
    Ok((s, n))
}

fn battery_stream(t: &TopicData, file: &str, notes: &mut Vec<ReadNote>) -> Result<Stream<1>, InputError> {
    let stamps = t.need("timestamp", file)?;
    let v = t.need("voltage_v", file)?;
    let mut s = Stream::new();
    let mut skipped = 0;
    for i in 0..stamps.len() {
        if v[i].is_nan() || v[i] <= 0.0 {
            skipped += 1;
            continue;
        }
        s.push(ns(stamps[i]), [v[i]]).map_err(|e| InputError::log(file, format!("`{}` message {i}: {e}", t.name)))?;
    }
    if skipped > 0 {
        notes.push(ReadNote::NoBatteryVoltage { count: skipped, topic: t.name.clone() });
    }
    if s.t.is_empty() {
        return Err(InputError::log(file, format!("`{}` has no sample with a voltage", t.name)));
    }
    Ok(s)
}

/// The topics `identify` can read from a log, with their fields: for a user who wants to know
/// what a log holds, and for tests against another parser.
pub fn readable_topics(log: &Log) -> Vec<&TopicData> {
    const READ: [&str; 7] = [
        "vehicle_visual_odometry",
        "vehicle_mocap_odometry",
        "sensor_combined",
        "vehicle_imu",
        "actuator_motors",
        "actuator_outputs",
        "battery_status",
    ];
    log.topics.iter().filter(|t| READ.contains(&t.name.as_str())).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn topic(name: &str, fields: &[(&str, Vec<f64>)]) -> TopicData {
        TopicData {
            name: name.to_string(),
            instance: 0,
            fields: fields.iter().map(|(k, v)| (k.to_string(), v.clone())).collect(),
        }
    }

    /// A topic the log lacks is named with the mapping's file and key (or the key's default),
    /// the closest topic the log has, and every topic it has; a topic with another
    /// instance names the instances.
    #[test]
    fn a_missing_topic_names_the_mapping_key_and_the_logs_topics() {
        let t = |name: &str, instance: u8| TopicData { instance, ..topic(name, &[("timestamp", vec![1.0])]) };
        let log = Log {
            topics: vec![t("battery_status", 0), t("sensor_combined", 0), t("sensor_combined", 1)],
            incomplete: None,
        };
        let e = log.topic("sensor_combind", 0, "f.ulg", "which m.yaml names in `px4.imu`").unwrap_err().to_string();
        assert_eq!(
            e,
            "f.ulg: the log has no topic `sensor_combind`, which m.yaml names in `px4.imu` (is it `sensor_combined`?); the log's topics: battery_status, sensor_combined"
        );
        let e = log.topic("vehicle_visual_odometry", 0, "f.ulg", "the default of `px4.pose`, which m.yaml leaves out");
        let e = e.unwrap_err().to_string();
        assert!(e.contains("`vehicle_visual_odometry`, the default of `px4.pose`, which m.yaml leaves out (PX4 logs it with SDLOG_PROFILE bit 1"), "{e}");
        assert!(!e.contains("is it"), "{e}");
        let e = log.topic("sensor_combined", 2, "f.ulg", "which m.yaml names in `px4.imu`").unwrap_err().to_string();
        assert!(e.contains("has no instance 2 (instances: 0, 1)"), "{e}");
    }

    /// `vehicle_imu` by hand: 0.01 rad about x and (0, 0, −0.0981) m/s over 10 ms are a mean
    /// rate of 1 rad/s and a specific force of −9.81 m/s² along z, at the interval's middle, 5 ms
    /// before `timestamp_sample`; an interval of 0 µs is left out and said.
    #[test]
    fn vehicle_imu_is_the_mean_rate_and_force_at_the_middle_of_its_interval() {
        let t = topic(
            "vehicle_imu",
            &[
                ("timestamp", vec![20_000.0, 30_000.0]),
                ("timestamp_sample", vec![19_000.0, 29_000.0]),
                ("delta_angle[0]", vec![0.01, 0.01]),
                ("delta_angle[1]", vec![0.0, 0.0]),
                ("delta_angle[2]", vec![0.0, 0.0]),
                ("delta_velocity[0]", vec![0.0, 0.0]),
                ("delta_velocity[1]", vec![0.0, 0.0]),
                ("delta_velocity[2]", vec![-0.0981, -0.0981]),
                ("delta_angle_dt", vec![10_000.0, 0.0]),
                ("delta_velocity_dt", vec![10_000.0, 10_000.0]),
            ],
        );
        let mut notes = Vec::new();
        let s = imu_stream(&t, "f.ulg", &mut notes).unwrap();
        assert_eq!(s.t, vec![14_000_000]);
        assert!((s.v[0][0] - 1.0).abs() < 1e-12 && (s.v[0][5] + 9.81).abs() < 1e-12, "{:?}", s.v);
        assert_eq!(notes, [ReadNote::NoIntegrationInterval { count: 1 }]);
    }

    /// Motor commands by hand: `actuator_motors` control 0.5 is half of full PWM and NaN (a
    /// stopped motor) is 0; `actuator_outputs` 1500 µs on [1000, 2000] is half too, 2100 is
    /// clamped to full, and without `output_range` it is an error that says what to set. The
    /// motor count is the controls that ever hold a number.
    #[test]
    fn motor_commands_are_fractions_of_full_command() {
        let nan = f64::NAN;
        let m = topic(
            "actuator_motors",
            &[
                ("timestamp", vec![1.0, 2.0]),
                ("control[0]", vec![0.5, nan]),
                ("control[1]", vec![nan, 1.0]),
                ("control[2]", vec![nan, nan]),
            ],
        );
        let (s, n) = motor_stream(&m, &Topics::default(), "f.ulg", &mut Vec::new()).unwrap();
        assert_eq!(n, 2);
        assert_eq!((s.v[0][0], s.v[0][1], s.v[1][0], s.v[1][1]), (32767.5, 0.0, 0.0, 65535.0));
        let o = topic(
            "actuator_outputs",
            &[("timestamp", vec![1.0]), ("output[0]", vec![1500.0]), ("output[1]", vec![2100.0])],
        );
        let e = motor_stream(&o, &Topics::default(), "f.ulg", &mut Vec::new()).unwrap_err().to_string();
        assert!(e.contains("output_range"), "{e}");
        let with = Topics { output_range: Some([1000.0, 2000.0]), ..Topics::default() };
        let (s, n) = motor_stream(&o, &with, "f.ulg", &mut Vec::new()).unwrap();
        assert_eq!((n, s.v[0][0], s.v[0][1]), (2, 32767.5, 65535.0));
    }

    /// The pose: PX4's (w, x, y, z) becomes the join's (x, y, z, w); `timestamp_sample` stamps it
    /// when every sample has one, `timestamp` otherwise (said either way); a NaN pose is no pose.
    #[test]
    fn a_pose_is_reordered_stamped_by_its_sample_time_and_nan_is_not_seen() {
        let nan = f64::NAN;
        let fields = |sample: Vec<f64>| {
            vec![
                ("timestamp", vec![15.0, 25.0]),
                ("timestamp_sample", sample),
                ("position[0]", vec![1.0, nan]),
                ("position[1]", vec![2.0, 0.0]),
                ("position[2]", vec![-3.0, 0.0]),
                ("q[0]", vec![0.5, 1.0]),
                ("q[1]", vec![0.5, 0.0]),
                ("q[2]", vec![-0.5, 0.0]),
                ("q[3]", vec![0.5, 0.0]),
            ]
        };
        let mut notes = Vec::new();
        let s = pose_stream(&topic("vehicle_visual_odometry", &fields(vec![10.0, 20.0])), "f.ulg", &mut notes).unwrap();
        assert_eq!((s.t.clone(), s.v[0]), (vec![10_000], [1.0, 2.0, -3.0, 0.5, -0.5, 0.5, 0.5]));
        let topic_name = || "vehicle_visual_odometry".to_string();
        assert_eq!(
            notes,
            [
                ReadNote::PoseStampedBy { topic: topic_name(), stamp: StampField::Sample },
                ReadNote::InvalidPoses { count: 1, topic: topic_name() }
            ]
        );
        let mut notes = Vec::new();
        let s = pose_stream(&topic("vehicle_visual_odometry", &fields(vec![0.0, 20.0])), "f.ulg", &mut notes).unwrap();
        assert_eq!(s.t, vec![15_000]);
        assert_eq!(notes[0], ReadNote::PoseStampedBy { topic: topic_name(), stamp: StampField::Publication });
    }

    /// A ULog header and flag bits (bytes 0–58), then a parameter record whose key length (200)
    /// runs past its 2 bytes (59–63): `px4-ulog` indexes past the record and panics. The error
    /// names the file and byte 63, the last of that record, counted from 0. A record with no
    /// byte at all panics on its first index: byte 61.
    #[test]
    fn a_record_that_makes_the_parser_panic_is_an_error_naming_its_byte() {
        let head = || {
            let mut b = MAGIC.to_vec();
            b.push(1); // version
            b.extend_from_slice(&0u64.to_le_bytes()); // timestamp
            b.extend_from_slice(&40u16.to_le_bytes());
            b.push(b'B'); // flag bits: compatible, incompatible, three appended offsets
            b.extend_from_slice(&[0u8; 40]);
            assert_eq!(b.len(), 59);
            b
        };
        let mut b = head();
        b.extend_from_slice(&2u16.to_le_bytes());
        b.push(b'P');
        b.extend_from_slice(&[200, b'x']);
        let e = Log::parse(&b, "bad.ulg").unwrap_err().to_string();
        assert!(e.starts_with("bad.ulg") && e.contains("panicked at byte 63"), "{e}");
        let mut b = head();
        b.extend_from_slice(&0u16.to_le_bytes());
        b.push(b'P');
        let e = Log::parse(&b, "bad.ulg").unwrap_err().to_string();
        assert!(e.contains("panicked at byte 61"), "{e}");
    }
}

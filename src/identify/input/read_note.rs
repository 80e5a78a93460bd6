//! What a reader did to a log so it could be read, and what it read it by: a row dropped, a gap,
//! messages left out, the stamps a PX4 topic was read by. One [`ReadNote`] each, in the order
//! the readers made them; the sentences are in the presentation layer (`output/read_note.rs`).

use crate::log::Repair;

/// One thing a reader did to a log, or read it by: data to match on; `Display` gives the
/// sentence the report prints after `read:` (and the JSON's `repairs` hold).
///
/// Topics and fields are PX4's uORB names (a `.ulg` log); counts are of messages or samples
/// left out of the series.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub enum ReadNote {
    /// The rows of a CSV log (flyarena's, a mapped one, or the rows a bag or a PX4 log was joined
    /// into) were repaired: a repeated time, a cut last line, a gap.
    Rows(Repair),
    /// The ULog file ends in the middle of a message; it is read up to the cut.
    Truncated,
    /// A malformed ULog record stopped the reading; the data before it is read.
    MalformedRecord {
        /// The parser's reason.
        why: String,
    },
    /// The pose topic has poses of a `pose_frame` other than NED (1) or FRD (2); they are read as
    /// z-down.
    UnknownPoseFrame {
        /// The pose topic.
        topic: String,
    },
    /// Poses with a NaN (frames in which the vehicle was not seen) were left out.
    InvalidPoses {
        /// How many.
        count: usize,
        /// The pose topic.
        topic: String,
    },
    /// `vehicle_imu` messages with no integration interval (`delta_*_dt` of 0) were left out.
    NoIntegrationInterval {
        /// How many.
        count: usize,
    },
    /// `sensor_combined` messages with no accelerometer sample were left out.
    NoAccelerometerSample {
        /// How many.
        count: usize,
    },
    /// `sensor_combined`'s accelerometer samples are stamped apart from the gyro's; each row takes
    /// the gyro's stamp.
    AccelStampOffset {
        /// The median of `accelerometer_timestamp_relative` (µs).
        median_us: f64,
    },
    /// The motor topic is logged below 50 Hz, coarse for the force channel.
    CoarseMotorRate {
        /// The motor topic.
        topic: String,
        /// Its mean rate over the log (Hz).
        rate_hz: f64,
    },
    /// Which stamp the pose topic was read by.
    PoseStampedBy {
        /// The pose topic.
        topic: String,
        /// The stamp field.
        stamp: StampField,
    },
    /// Which stamp the motor topic was read by, and how many motors it gave.
    MotorsStampedBy {
        /// The motor topic.
        topic: String,
        /// Motors read.
        motors: usize,
        /// The stamp field.
        stamp: StampField,
    },
    /// Battery samples at 0 V (no battery connected) were left out.
    NoBatteryVoltage {
        /// How many.
        count: usize,
        /// The battery topic.
        topic: String,
    },
    /// IMU messages before the first motor or battery message (a bag or a PX4 log) were left out:
    /// a row needs every stream.
    ImuBeforeOthers {
        /// How many.
        count: usize,
    },
}

/// The stamp a PX4 topic is read by: `timestamp_sample` (when the sensor sampled) where every
/// message has one, else `timestamp` (when the message was published).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum StampField {
    /// `timestamp_sample`.
    Sample,
    /// `timestamp`.
    Publication,
}

impl StampField {
    /// The uORB field.
    pub fn field(self) -> &'static str {
        match self {
            StampField::Sample => "timestamp_sample",
            StampField::Publication => "timestamp",
        }
    }
}

impl From<Repair> for ReadNote {
    fn from(r: Repair) -> Self {
        ReadNote::Rows(r)
    }
}

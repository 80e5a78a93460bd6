//! What the readers did, as the sentences a reader sees: `Display` for the report's `read:`
//! lines, and `Serialize` as the same sentence, so the JSON's `repairs` hold what the text shows.

use crate::identify::input::read_note::ReadNote;
use crate::identify::input::ulog::profile_hint;
use std::fmt::{self, Display, Formatter};

impl Display for ReadNote {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        match self {
            ReadNote::Rows(r) => r.fmt(f),
            ReadNote::Truncated => {
                f.write_str("the log ends in the middle of a message (cut short); it is read up to the cut")
            }
            ReadNote::MalformedRecord { why } => {
                write!(f, "a malformed record stopped the reading ({why}); the data before it is read")
            }
            ReadNote::UnknownPoseFrame { topic } => write!(
                f,
                "`{topic}` has poses of an unknown frame (pose_frame not 1, NED, or 2, FRD); they are read as z-down"
            ),
            ReadNote::InvalidPoses { count, topic } => {
                write!(f, "{count} poses of `{topic}` are invalid (NaN): frames in which the vehicle was not seen")
            }
            ReadNote::NoIntegrationInterval { count } => {
                write!(f, "{count} `vehicle_imu` messages with no integration interval were left out")
            }
            ReadNote::NoAccelerometerSample { count } => {
                write!(f, "{count} `sensor_combined` messages without an accelerometer sample were left out")
            }
            ReadNote::AccelStampOffset { median_us } => write!(
                f,
                "the accelerometer's samples are stamped a median {median_us} µs from the gyro's; each row takes the gyro's stamp"
            ),
            ReadNote::CoarseMotorRate { topic, rate_hz } => {
                write!(f, "`{topic}` is logged at {rate_hz:.0} Hz, coarse for the force channel{}", profile_hint(topic))
            }
            ReadNote::PoseStampedBy { topic, stamp } => {
                write!(f, "the pose (`{topic}`) is stamped by its `{}`", stamp.field())
            }
            ReadNote::MotorsStampedBy { topic, motors, stamp } => {
                write!(f, "the motors (`{topic}`, {motors}) are stamped by their `{}`", stamp.field())
            }
            ReadNote::NoBatteryVoltage { count, topic } => {
                write!(f, "{count} `{topic}` samples at 0 V (no battery) were left out")
            }
            ReadNote::ImuBeforeOthers { count } => {
                write!(f, "{count} IMU messages before the first motor or battery message were left out")
            }
        }
    }
}

impl serde::Serialize for ReadNote {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_str(self)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::identify::input::read_note::StampField;
    use crate::log::Repair;

    /// Each note's sentence, written out by hand, and its JSON the same sentence as a string.
    #[test]
    fn a_read_note_reads_as_its_sentence() {
        let cases = [
            (
                ReadNote::Rows(Repair::RepeatedTime { line: 3, t_s: None }),
                "line 3: repeats the time of the previous row and was dropped",
            ),
            (ReadNote::Truncated, "the log ends in the middle of a message (cut short); it is read up to the cut"),
            (
                ReadNote::MalformedRecord { why: "bad size".into() },
                "a malformed record stopped the reading (bad size); the data before it is read",
            ),
            (
                ReadNote::UnknownPoseFrame { topic: "vehicle_mocap_odometry".into() },
                "`vehicle_mocap_odometry` has poses of an unknown frame (pose_frame not 1, NED, or 2, FRD); they are read as z-down",
            ),
            (
                ReadNote::InvalidPoses { count: 4, topic: "vehicle_visual_odometry".into() },
                "4 poses of `vehicle_visual_odometry` are invalid (NaN): frames in which the vehicle was not seen",
            ),
            (
                ReadNote::NoIntegrationInterval { count: 2 },
                "2 `vehicle_imu` messages with no integration interval were left out",
            ),
            (
                ReadNote::NoAccelerometerSample { count: 5 },
                "5 `sensor_combined` messages without an accelerometer sample were left out",
            ),
            (
                ReadNote::AccelStampOffset { median_us: -250.0 },
                "the accelerometer's samples are stamped a median -250 µs from the gyro's; each row takes the gyro's stamp",
            ),
            (
                ReadNote::CoarseMotorRate { topic: "actuator_motors".into(), rate_hz: 9.6 },
                "`actuator_motors` is logged at 10 Hz, coarse for the force channel (PX4 logs it at 10 Hz by default; SDLOG_PROFILE bit 3, system identification, at full rate: add 8)",
            ),
            (
                ReadNote::CoarseMotorRate { topic: "actuator_outputs".into(), rate_hz: 20.4 },
                "`actuator_outputs` is logged at 20 Hz, coarse for the force channel",
            ),
            (
                ReadNote::PoseStampedBy { topic: "vehicle_visual_odometry".into(), stamp: StampField::Sample },
                "the pose (`vehicle_visual_odometry`) is stamped by its `timestamp_sample`",
            ),
            (
                ReadNote::MotorsStampedBy {
                    topic: "actuator_motors".into(),
                    motors: 4,
                    stamp: StampField::Publication,
                },
                "the motors (`actuator_motors`, 4) are stamped by their `timestamp`",
            ),
            (
                ReadNote::NoBatteryVoltage { count: 7, topic: "battery_status".into() },
                "7 `battery_status` samples at 0 V (no battery) were left out",
            ),
            (
                ReadNote::ImuBeforeOthers { count: 2 },
                "2 IMU messages before the first motor or battery message were left out",
            ),
        ];
        for (note, want) in cases {
            assert_eq!(note.to_string(), want);
            assert_eq!(serde_json::to_value(&note).unwrap(), serde_json::Value::String(want.into()));
        }
    }
}

//! What the data-quality gate cut, as the sentences a reader sees: a stretch (`Cut`) and each
//! defect found in it (`Finding`); the JSON's `reason` is the findings' sentences joined by `; `.

use super::note::joined;
use crate::identify::fit::quality::{Cut, Finding};
use crate::vehicle::params::GRAVITY;
use std::fmt::{self, Display, Formatter};

impl Display for Cut {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} {:.2}–{:.2} s: {}{}",
            self.channel.name(),
            self.from_s,
            self.to_s,
            joined(&self.findings, "; "),
            if self.at_floor { " (at the floor: touchdown or contact)" } else { "" }
        )
    }
}

impl Display for Finding {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        match *self {
            Finding::AccelFullScale { count, worst_m_s2, range_m_s2 } => write!(
                f,
                "{count} samples at the accelerometer's full scale (up to {worst_m_s2:.1} m/s², range ±{range_m_s2:.1} m/s²)"
            ),
            Finding::GyroFullScale { count, worst_rad_s, range_rad_s } => write!(
                f,
                "{count} samples at the gyro's full scale (up to {:.0} °/s, range ±{:.0} °/s)",
                worst_rad_s.to_degrees(),
                range_rad_s.to_degrees()
            ),
            Finding::AccelDisagrees { count, worst_m_s2, bound_m_s2 } => write!(
                f,
                "{count} samples where the accelerometer and the mocap's specific force disagree by up to {worst_m_s2:.1} m/s² ({:.1} g; no modelled effect explains more than {bound_m_s2:.1} m/s²)",
                worst_m_s2 / GRAVITY
            ),
            Finding::GyroDisagrees { count, worst_rad_s, bound_rad_s } => write!(
                f,
                "{count} samples where the gyro and the mocap's body rate disagree by up to {:.0} °/s (no modelled effect explains more than {:.0} °/s)",
                worst_rad_s.to_degrees(),
                bound_rad_s.to_degrees()
            ),
            Finding::MocapJump { count, worst_ratio } => {
                write!(f, "{count} mocap jumps no vehicle makes (up to {worst_ratio:.2} × the largest possible step)")
            }
            Finding::MocapFrozen { count, worst_turn_rad } => write!(
                f,
                "{count} samples of a frozen mocap pose while the gyro turns (up to {:.1}° turned)",
                worst_turn_rad.to_degrees()
            ),
            Finding::ImuStuck { count, channel, worst_s } => write!(
                f,
                "{count} samples of a frozen {} reading in the air (one value for up to {worst_s:.2} s)",
                channel.name()
            ),
        }
    }
}

/// A stretch in the JSON: its fields, with the findings as `reason`, the sentence the text shows
/// after the stretch.
impl serde::Serialize for Cut {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeStruct as _;
        let mut st = s.serialize_struct("Cut", 6)?;
        st.serialize_field("channel", &self.channel)?;
        st.serialize_field("from_s", &self.from_s)?;
        st.serialize_field("to_s", &self.to_s)?;
        st.serialize_field("flagged", &self.flagged)?;
        st.serialize_field("at_floor", &self.at_floor)?;
        st.serialize_field("reason", &joined(&self.findings, "; "))?;
        st.end()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::identify::fit::quality::QualityChannel;

    /// Each finding's sentence, written out by hand: degrees for angles and rates, g beside m/s²
    /// for a disagreement of the accelerometer.
    #[test]
    fn a_finding_reads_as_its_sentence() {
        let deg = f64::to_radians;
        let cases = [
            (
                Finding::AccelFullScale { count: 3, worst_m_s2: 156.04, range_m_s2: 156.96 },
                "3 samples at the accelerometer's full scale (up to 156.0 m/s², range ±157.0 m/s²)",
            ),
            (
                Finding::GyroFullScale { count: 2, worst_rad_s: deg(1990.2), range_rad_s: deg(2000.0) },
                "2 samples at the gyro's full scale (up to 1990 °/s, range ±2000 °/s)",
            ),
            (
                Finding::AccelDisagrees { count: 40, worst_m_s2: 2.0 * GRAVITY * 10.0, bound_m_s2: 4.0 * GRAVITY },
                "40 samples where the accelerometer and the mocap's specific force disagree by up to 196.2 m/s² (20.0 g; no modelled effect explains more than 39.2 m/s²)",
            ),
            (
                Finding::GyroDisagrees { count: 5, worst_rad_s: deg(450.4), bound_rad_s: deg(300.0) },
                "5 samples where the gyro and the mocap's body rate disagree by up to 450 °/s (no modelled effect explains more than 300 °/s)",
            ),
            (
                Finding::MocapJump { count: 1, worst_ratio: 12.345 },
                "1 mocap jumps no vehicle makes (up to 12.35 × the largest possible step)",
            ),
            (
                Finding::MocapFrozen { count: 30, worst_turn_rad: deg(7.24) },
                "30 samples of a frozen mocap pose while the gyro turns (up to 7.2° turned)",
            ),
            (
                Finding::ImuStuck { count: 100, channel: QualityChannel::Gyro, worst_s: 0.5 },
                "100 samples of a frozen gyro reading in the air (one value for up to 0.50 s)",
            ),
        ];
        for (finding, want) in cases {
            assert_eq!(finding.to_string(), want);
        }
    }

    /// A stretch: its channel, its times to the hundredth, its findings joined by `; `, and the
    /// floor's remark; in JSON the findings are `reason`, the same sentences.
    #[test]
    fn a_cut_reads_as_its_findings() {
        let cut = Cut {
            channel: QualityChannel::Accel,
            from_s: 1.234,
            to_s: 2.0,
            flagged: 4,
            at_floor: true,
            findings: vec![
                Finding::AccelFullScale { count: 1, worst_m_s2: 157.0, range_m_s2: 157.0 },
                Finding::ImuStuck { count: 3, channel: QualityChannel::Accel, worst_s: 0.06 },
            ],
        };
        let reason = "1 samples at the accelerometer's full scale (up to 157.0 m/s², range ±157.0 m/s²); 3 samples of a frozen accel reading in the air (one value for up to 0.06 s)";
        assert_eq!(cut.to_string(), format!("accel 1.23–2.00 s: {reason} (at the floor: touchdown or contact)"));
        assert_eq!(
            serde_json::to_string(&cut).unwrap(),
            format!(
                r#"{{"channel":"accel","from_s":1.234,"to_s":2.0,"flagged":4,"at_floor":true,"reason":"{reason}"}}"#
            )
        );
    }
}

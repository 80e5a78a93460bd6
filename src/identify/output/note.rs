//! A report's notes as the sentences a reader sees: `Display` for the text report, and
//! `Serialize` as the same sentence, so the JSON's `notes` hold what the text shows.

use crate::effects::Effect;
use crate::identify::fit::ground::TiltAgreement;
use crate::identify::fit::note::{ForceLead, Moved, Note, OtherReference, Unavailable};
use crate::identify::precision::{signed_with_interval as pm, with_interval};
use std::fmt::{self, Display, Formatter};

impl Display for Note {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        match self {
            Note::DataQualityCut { rows_cut, rows, margin_s, cuts } => write!(
                f,
                "the data-quality gate cut {rows_cut} of {rows} rows before the fit (samples no flight can produce, with a {margin_s} s margin): {}",
                joined(cuts, "; ")
            ),
            Note::NoForceModel { rigid_body } => write!(
                f,
                "{}, so the effects are fitted on the accelerometer against the mocap (accel_kin) and the gyro; those that act only through the thrust are not tried",
                if *rigid_body {
                    "a rigid body (`vehicle: rigid_body`): no force model by declaration"
                } else {
                    "no motor commands in the log: no force model"
                }
            ),
            Note::TooFewSamples { usable, needed, min_height_m } => write!(
                f,
                "only {usable} usable training samples (airborne above {min_height_m} m, away from gaps and edges; decimated): at least {needed} are needed to select effects, so none were tried"
            ),
            Note::Glitches { count, sigmas, window_ms } => write!(
                f,
                "{count} mocap glitches (poses more than {sigmas} robust σ, and 1 mm or 0.5°, off the midpoint of their neighbours; consecutive ones count once) were left out with ±{window_ms} ms around each"
            ),
            Note::LeftOut { effect, why } => write!(f, "--with {}: left out, {why}", effect.key()),
            Note::Forced { effects } => {
                write!(f, "fitted without testing (forced): {}", joined(effects.iter().map(|e| e.key()), ", "))
            }
            Note::MaxSteps { steps } => write!(f, "stopped after {steps} steps (max_steps)"),
            Note::FramesNotApart { correlation: rho, yaw_spread_deg } => write!(
                f,
                "mocap world tilt and body offset roll/pitch are not identifiable apart in this flight (canonical correlation {rho:.4}, yaw spread {yaw_spread_deg:.1}°): they differ only through yaw changes, body rates and accelerations other than gravity"
            ),
            Note::ChosenOver { chosen, rival, correlation: rho, yaw_spread_deg } => write!(
                f,
                "{} was chosen over {} by ΔBIC, but this flight cannot tell them apart (canonical correlation {rho:.4}, yaw spread {yaw_spread_deg:.1}°): not identifiable; fly yaw turns, circles and accelerations to separate them",
                chosen.key(),
                rival.key()
            ),
            Note::ExplainAlike { effect, other, correlation: rho, yaw_spread_deg } => write!(
                f,
                "{e} and {} explain this flight's residual alike once the other effects are fitted (canonical correlation {rho:.4}, yaw spread {yaw_spread_deg:.1}°): not identifiable; {e}'s parameters are one explanation of two, and the other effects' intervals cover both",
                other.key(),
                e = effect.key()
            ),
            Note::MocapLeadsImu { delay_s } => write!(
                f,
                "the mocap delay came out negative ({:.1} ms: the mocap leads the IMU): a clock offset between the streams, or a delay of the gyro alone against the accelerometer, which `--with gyro_delay` tests",
                delay_s * 1e3
            ),
            Note::HalfSupported { effect, delta_bic, p_value, heldout_gain, min_heldout_gain, very_strong, moved } => {
                let gate = very_strong.then_some(*min_heldout_gain);
                half_supported(f, *effect, *delta_bic, *p_value, *heldout_gain, gate, moved)
            }
            Note::ImuOffsetSignature { leads } => write!(
                f,
                "{}: the signature of an IMU off the centre of mass (ω̇ × r, the accelerometer ahead of or below the point the force model describes), which `--with imu_offset` tests",
                joined(leads, ", ")
            ),
            Note::GroundWithinFlight { tilt, difference_deg, ci95_deg } => write!(
                f,
                "ground check and flight differ by {}° in {tilt}, within what this flight determines: the flight cannot pin its tilt down to 1°",
                with_interval(*difference_deg, *ci95_deg)
            ),
            Note::GroundDisagrees { tilt, agreement, other, rest_scatter_deg } => {
                ground_disagrees(f, tilt, agreement, other.as_ref(), *rest_scatter_deg)
            }
            Note::RestOffAxis { off_axis_deg } => write!(
                f,
                "the log rests with the vertical {off_axis_deg:.0}° from the nearest body axis: the ground check reads tilts about two body axes that are level at rest, so it is left out (the fit assumes nothing about the rest attitude)"
            ),
        }
    }
}

/// The sentence of [`Note::HalfSupported`]: with very strong evidence (`gate`, the held-out
/// gain the gate needs, given) it names the option that fits the candidate as a tested
/// hypothesis; it names the estimates that would move.
fn half_supported(
    f: &mut Formatter<'_>,
    effect: Effect,
    delta_bic: f64,
    p_value: f64,
    heldout_gain: f64,
    gate: Option<f64>,
    moved: &[Moved],
) -> fmt::Result {
    let key = effect.key();
    if let Some(min_heldout_gain) = gate {
        write!(
            f,
            "{key} has very strong evidence in the fit (ΔBIC {delta_bic:.0}, F-test p {p_value:.1e}) and fails only the held-out gate (held-out error {:+.1} %, the gate needs −{:.0} %): not added; `--with {key}` fits it as a hypothesis, with its interval",
            -100.0 * heldout_gain,
            100.0 * min_heldout_gain
        )?;
    } else {
        write!(
            f,
            "{key} is significant in the fit (ΔBIC {delta_bic:.0}, F-test p {p_value:.1e}) but does not cut the held-out error enough to join ({:+.1} %)",
            -100.0 * heldout_gain
        )?;
    }
    if !moved.is_empty() {
        write!(f, "; with it in, the estimates would move ({}): their intervals cover both", joined(moved, ", "))?;
    }
    Ok(())
}

/// The sentence of [`Note::GroundDisagrees`]: both sides, the reference that agrees with the
/// flight, and a warning when the rest's pose scatters.
fn ground_disagrees(
    f: &mut Formatter<'_>,
    tilt: &str,
    t: &TiltAgreement,
    other: Option<&OtherReference>,
    rest_scatter_deg: Option<f64>,
) -> fmt::Result {
    write!(f, "ground check and flight disagree in {tilt}: the ground reads {:.2}°", t.ground_deg)?;
    if t.bias_tilt_deg != 0.0 {
        write!(f, " ({:.2}° once the fitted accelerometer bias is removed)", t.ground_corrected_deg)?;
    }
    write!(
        f,
        ", the flight {:.2}° (difference {}°): the markers or the IMU board moved between rest and flight, or the flight holds an effect the candidate library lacks",
        t.flight_deg,
        with_interval(t.difference_deg, t.ci95_deg)
    )?;
    match other {
        Some(OtherReference::SpinUp(sp)) => write!(
            f,
            "; the spin-up (motors on, still on the floor) moved {}° from the rest toward the flight and agrees with it ({}°): consistent with a tilt the spinning rotors add, which the flight carries too (rectified vibration, a mount that bends under thrust) and a rest with the motors off cannot see",
            pm(sp.change_deg, sp.change_ci95_deg),
            pm(sp.difference_deg, sp.ci95_deg)
        )?,
        Some(OtherReference::RestsBracket(l)) => write!(
            f,
            "; the mean of the rests before and after the flight agrees with it ({}°): the tilt at rest moved during the flight",
            pm(l.bracket_difference_deg, l.bracket_ci95_deg)
        )?,
        None => {}
    }
    if let Some(sd) = rest_scatter_deg {
        write!(
            f,
            "; the still pose scatters by {sd:.3}° per sample in roll at rest (a clear view: under {}°): the cameras see the markers badly on the floor, so the rest's tilt is not a reliable reference here",
            crate::identify::fit::ground::STILL_POSE_SD_DEG
        )?;
    }
    Ok(())
}

impl Display for Unavailable {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        match self {
            Unavailable::NoVoltage => f.write_str("the log has no battery voltage"),
            Unavailable::TooShort { span_s, min_s } => {
                write!(f, "the log's usable samples span {span_s:.0} s and a drift is fitted on {min_s:.0} s or more")
            }
            Unavailable::NoMotorCommands => {
                f.write_str("it acts only through the thrust model and the log has no motor commands")
            }
        }
    }
}

impl Display for Moved {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        write!(f, "{} {} {:+.3} {}", self.effect.key(), self.param, self.shift, self.unit)
    }
}

impl Display for ForceLead {
    fn fmt(&self, f: &mut Formatter<'_>) -> fmt::Result {
        write!(f, "force.{} follows {} (r = {:+.2})", self.axis, self.signal, self.r)
    }
}

impl serde::Serialize for Note {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_str(self)
    }
}

/// The items' sentences, joined by `sep`.
pub(super) fn joined<T: Display>(items: impl IntoIterator<Item = T>, sep: &str) -> String {
    items.into_iter().map(|x| x.to_string()).collect::<Vec<_>>().join(sep)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::effects::Effect;
    use crate::identify::fit::ground::TiltAgreement;
    use crate::identify::fit::ground::{CheckAxis, LandedAxis, STILL_POSE_SD_DEG};
    use crate::identify::fit::quality::{Cut, Finding, QualityChannel};

    /// The sentences of the notes on the data, written out by hand: the gate's cut (its
    /// stretches joined by "; ", a floor contact named), the data's limits and a rest off its
    /// axes. A bug it catches: a field in the wrong slot, a clause dropped or a precision
    /// changed, which would change the JSON's `notes` too.
    #[test]
    fn the_notes_on_the_data_read_as_their_sentences() {
        let cut = |from_s, at_floor| Cut {
            channel: QualityChannel::Accel,
            from_s,
            to_s: from_s + 0.5,
            flagged: 3,
            at_floor,
            findings: vec![Finding::AccelDisagrees { count: 3, worst_m_s2: 320.0, bound_m_s2: 160.0 }],
        };
        sentences([
            (
                Note::DataQualityCut {
                    rows_cut: 40,
                    rows: 9000,
                    margin_s: 0.25,
                    cuts: vec![cut(12.0, false), cut(30.2, true)],
                },
                "the data-quality gate cut 40 of 9000 rows before the fit (samples no flight can produce, with a 0.25 s margin): accel 12.00–12.50 s: 3 samples where the accelerometer and the mocap's specific force disagree by up to 320.0 m/s² (32.6 g; no modelled effect explains more than 160.0 m/s²); accel 30.20–30.70 s: 3 samples where the accelerometer and the mocap's specific force disagree by up to 320.0 m/s² (32.6 g; no modelled effect explains more than 160.0 m/s²) (at the floor: touchdown or contact)",
            ),
            (
                Note::NoForceModel { rigid_body: true },
                "a rigid body (`vehicle: rigid_body`): no force model by declaration, so the effects are fitted on the accelerometer against the mocap (accel_kin) and the gyro; those that act only through the thrust are not tried",
            ),
            (
                Note::NoForceModel { rigid_body: false },
                "no motor commands in the log: no force model, so the effects are fitted on the accelerometer against the mocap (accel_kin) and the gyro; those that act only through the thrust are not tried",
            ),
            (
                Note::TooFewSamples { usable: 94, needed: 200, min_height_m: 0.15 },
                "only 94 usable training samples (airborne above 0.15 m, away from gaps and edges; decimated): at least 200 are needed to select effects, so none were tried",
            ),
            (
                Note::Glitches { count: 5, sigmas: 20.0, window_ms: 30.0 },
                "5 mocap glitches (poses more than 20 robust σ, and 1 mm or 0.5°, off the midpoint of their neighbours; consecutive ones count once) were left out with ±30 ms around each",
            ),
            (
                Note::RestOffAxis { off_axis_deg: 39.6 },
                "the log rests with the vertical 40° from the nearest body axis: the ground check reads tilts about two body axes that are level at rest, so it is left out (the fit assumes nothing about the rest attitude)",
            ),
        ]);
    }

    /// The sentences of the selection's notes that its own tests do not render, written out by
    /// hand: the options left out and why, the forced effects, the step limit, the IMU-offset
    /// hint and a pair that explains the residual alike.
    #[test]
    fn the_selection_notes_read_as_their_sentences() {
        sentences([
            (
                Note::LeftOut { effect: Effect::ThrustVoltage, why: Unavailable::NoVoltage },
                "--with thrust_voltage: left out, the log has no battery voltage",
            ),
            (
                Note::LeftOut {
                    effect: Effect::GyroBiasDrift,
                    why: Unavailable::TooShort { span_s: 61.4, min_s: 120.0 },
                },
                "--with gyro_bias_drift: left out, the log's usable samples span 61 s and a drift is fitted on 120 s or more",
            ),
            (
                Note::LeftOut { effect: Effect::ThrustScale, why: Unavailable::NoMotorCommands },
                "--with thrust_scale: left out, it acts only through the thrust model and the log has no motor commands",
            ),
            (
                Note::Forced { effects: vec![Effect::BodyOffset, Effect::MocapDelay] },
                "fitted without testing (forced): body_offset, mocap_delay",
            ),
            (Note::MaxSteps { steps: 8 }, "stopped after 8 steps (max_steps)"),
            (
                Note::ImuOffsetSignature {
                    leads: vec![
                        ForceLead { axis: 'x', signal: "angular acceleration y (rad/s²)".into(), r: 0.254 },
                        ForceLead { axis: 'y', signal: "angular acceleration x (rad/s²)".into(), r: -0.31 },
                    ],
                },
                "force.x follows angular acceleration y (rad/s²) (r = +0.25), force.y follows angular acceleration x (rad/s²) (r = -0.31): the signature of an IMU off the centre of mass (ω̇ × r, the accelerometer ahead of or below the point the force model describes), which `--with imu_offset` tests",
            ),
            (
                Note::ExplainAlike {
                    effect: Effect::ThrustScale,
                    other: Effect::ThrustVoltage,
                    correlation: 0.99612,
                    yaw_spread_deg: 3.04,
                },
                "thrust_scale and thrust_voltage explain this flight's residual alike once the other effects are fitted (canonical correlation 0.9961, yaw spread 3.0°): not identifiable; thrust_scale's parameters are one explanation of two, and the other effects' intervals cover both",
            ),
        ]);
    }

    /// Each note reads as its sentence, and its JSON is that sentence.
    fn sentences<const N: usize>(cases: [(Note, &str); N]) {
        for (note, sentence) in cases {
            assert_eq!(note.to_string(), sentence);
            assert_eq!(serde_json::to_value(&note).unwrap(), serde_json::Value::String(sentence.into()));
        }
    }

    /// A ground disagreement with all its clauses, and without the optional ones: the bias
    /// clause only when a bias tilts the ground check, the rests' bracket at its interval's
    /// precision, the scatter against the still-pose threshold.
    #[test]
    fn a_ground_disagreement_reads_with_the_clauses_it_holds() {
        let t = TiltAgreement {
            ground_deg: 0.8,
            bias_tilt_deg: 0.25,
            ground_corrected_deg: 0.55,
            flight_deg: 1.3,
            difference_deg: -0.75,
            ci95_deg: 0.21,
            covers: false,
        };
        let bracket = LandedAxis {
            check: CheckAxis {
                ground_corrected_deg: 1.1,
                change_deg: 0.5,
                change_ci95_deg: 0.05,
                difference_deg: -0.2,
                ci95_deg: 0.3,
                covers: true,
            },
            bracket_difference_deg: -0.1,
            bracket_ci95_deg: 0.35,
            bracket_covers: true,
        };
        let full = Note::GroundDisagrees {
            tilt: "pitch",
            agreement: t,
            other: Some(OtherReference::RestsBracket(bracket)),
            rest_scatter_deg: Some(0.1234),
        };
        assert_eq!(
            full.to_string(),
            format!(
                "ground check and flight disagree in pitch: the ground reads 0.80° (0.55° once the fitted accelerometer bias is removed), the flight 1.30° (difference -0.75 ± 0.21°): the markers or the IMU board moved between rest and flight, or the flight holds an effect the candidate library lacks; the mean of the rests before and after the flight agrees with it (-0.10 ± 0.35°): the tilt at rest moved during the flight; the still pose scatters by 0.123° per sample in roll at rest (a clear view: under {STILL_POSE_SD_DEG}°): the cameras see the markers badly on the floor, so the rest's tilt is not a reliable reference here"
            )
        );
        let bare = Note::GroundDisagrees {
            tilt: "about y",
            agreement: TiltAgreement { bias_tilt_deg: 0.0, ..t },
            other: None,
            rest_scatter_deg: None,
        };
        assert_eq!(
            bare.to_string(),
            "ground check and flight disagree in about y: the ground reads 0.80°, the flight 1.30° (difference -0.75 ± 0.21°): the markers or the IMU board moved between rest and flight, or the flight holds an effect the candidate library lacks"
        );
    }
}

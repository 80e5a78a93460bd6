//! What a report says beside its numbers, as data: one variant per kind of note, holding the
//! values its sentence is made of, so a program can act on a note (a negative delay, a pair the
//! flight cannot tell apart, a ground check that disagrees) without parsing text. The sentences
//! are the presentation layer's (`output/note.rs`: `Display`, and `Serialize` as that sentence,
//! so the JSON holds what the text shows).
//!
//! Units are those of the sentence: degrees and seconds at this edge, as in the report.

use super::ground::{CheckAxis, GroundAgreement, LandedAxis, TiltAgreement};
use super::quality::Cut;
use crate::effects::Effect;

/// One note of a [`Report`](super::select::Report).
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub enum Note {
    /// The data-quality gate cut rows no flight can produce before the fit.
    DataQualityCut {
        /// Rows taken out (the union of the stretches).
        rows_cut: usize,
        /// Rows in the log.
        rows: usize,
        /// The margin cut around each flagged stretch (s).
        margin_s: f64,
        /// The stretches, in time order.
        cuts: Vec<Cut>,
    },
    /// No force model: the effects are fitted on the accelerometer against the mocap and the gyro.
    NoForceModel {
        /// Declared a rigid body (`vehicle: rigid_body`); otherwise the log has no motor commands.
        rigid_body: bool,
    },
    /// Too few usable training samples to select anything.
    TooFewSamples {
        /// Usable training samples.
        usable: usize,
        /// The least a selection needs.
        needed: usize,
        /// Samples below this height (m) are not airborne.
        min_height_m: f64,
    },
    /// Mocap glitches left out of the fit.
    Glitches {
        /// Glitches (consecutive ones count once).
        count: usize,
        /// A glitch lies this many robust standard deviations off its neighbours' midpoint.
        sigmas: f64,
        /// Left out on either side of each glitch (ms).
        window_ms: f64,
    },
    /// An effect asked for with `--with` that the log cannot fit.
    LeftOut {
        /// The effect.
        effect: Effect,
        /// What the log lacks.
        why: Unavailable,
    },
    /// Effects fitted without testing (`--with`).
    Forced {
        /// The effects, in the order they joined.
        effects: Vec<Effect>,
    },
    /// The search stopped at its step limit.
    MaxSteps {
        /// The limit (`max_steps`).
        steps: usize,
    },
    /// The mocap world tilt and the body offset's roll/pitch cannot be told apart in this flight.
    FramesNotApart {
        /// Their canonical correlation.
        correlation: f64,
        /// The flight's yaw spread (deg).
        yaw_spread_deg: f64,
    },
    /// A step chose `chosen` over `rival` by ΔBIC, but the flight cannot tell them apart.
    ChosenOver {
        /// The effect the step added.
        chosen: Effect,
        /// The effect that would have explained the same residual.
        rival: Effect,
        /// Their canonical correlation.
        correlation: f64,
        /// The flight's yaw spread (deg).
        yaw_spread_deg: f64,
    },
    /// Once the other effects are fitted, `effect` and `other` explain the residual alike: the
    /// intervals were widened to cover both.
    ExplainAlike {
        /// The selected effect.
        effect: Effect,
        /// The effect outside the model.
        other: Effect,
        /// Their canonical correlation given the other effects.
        correlation: f64,
        /// The flight's yaw spread (deg).
        yaw_spread_deg: f64,
    },
    /// The fitted mocap delay is negative: the mocap leads the IMU.
    MocapLeadsImu {
        /// The fitted delay (s, negative).
        delay_s: f64,
    },
    /// A candidate significant in the fit that did not cut the held-out error enough to join.
    HalfSupported {
        /// The candidate.
        effect: Effect,
        /// Its ΔBIC.
        delta_bic: f64,
        /// Its F-test p-value.
        p_value: f64,
        /// Its held-out gain (a fraction; positive cuts the error).
        heldout_gain: f64,
        /// The held-out gain an effect needs to join.
        min_heldout_gain: f64,
        /// ΔBIC at or below the very-strong level: the candidate is a hypothesis to test.
        very_strong: bool,
        /// The estimates that would move beyond their own intervals with it in.
        moved: Vec<Moved>,
    },
    /// What is left on the force channel follows an angular acceleration: the signature of an IMU
    /// off the centre of mass, not fitted.
    ImuOffsetSignature {
        /// The force axes and the signals they follow.
        leads: Vec<ForceLead>,
    },
    /// The ground check and the flight differ by more than 1° in one tilt, within what the
    /// flight determines.
    GroundWithinFlight {
        /// The tilt's name ([`UpAxis::tilt_names`](super::ground::UpAxis::tilt_names)).
        tilt: &'static str,
        /// Ground − flight (deg).
        difference_deg: f64,
        /// Its 95 % half-width (deg).
        ci95_deg: f64,
    },
    /// The ground check and the flight disagree in one tilt.
    GroundDisagrees {
        /// The tilt's name ([`UpAxis::tilt_names`](super::ground::UpAxis::tilt_names)).
        tilt: &'static str,
        /// The comparison on that tilt.
        agreement: TiltAgreement,
        /// Another reference that agrees with the flight, the next lead.
        other: Option<OtherReference>,
        /// The still pose's roll scatter (deg per sample), when it is too large for the rest to
        /// be a reliable reference.
        rest_scatter_deg: Option<f64>,
    },
    /// The log rests with the vertical far from every body axis: no ground check.
    RestOffAxis {
        /// The angle from the nearest body axis (deg).
        off_axis_deg: f64,
    },
}

/// Why a log cannot fit an effect asked for.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Unavailable {
    /// The log has no battery voltage.
    NoVoltage,
    /// The usable samples span too short a time for a drift.
    TooShort {
        /// Span of the usable samples (s).
        span_s: f64,
        /// The least span a drift is fitted on (s).
        min_s: f64,
    },
    /// The effect acts only through the thrust model and the log has no motor commands.
    NoMotorCommands,
}

/// An estimate that a half-supported candidate would move.
#[derive(Clone, Debug, PartialEq)]
pub struct Moved {
    /// The effect the parameter belongs to.
    pub effect: Effect,
    /// The parameter's name.
    pub param: String,
    /// With the candidate − without.
    pub shift: f64,
    /// The parameter's unit.
    pub unit: String,
}

/// A force axis whose residual follows a signal.
#[derive(Clone, Debug, PartialEq)]
pub struct ForceLead {
    /// The force residual's axis.
    pub axis: char,
    /// The signal's name and unit.
    pub signal: String,
    /// Their correlation.
    pub r: f64,
}

/// A second reference for a tilt on which the ground check disagrees with the flight.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum OtherReference {
    /// The spin-up (motors on, still on the floor) moved from the rest toward the flight and
    /// agrees with it.
    SpinUp(CheckAxis),
    /// The mean of the rests before and after the flight agrees with it.
    RestsBracket(LandedAxis),
}

/// The notes on a ground agreement: a difference beyond 1° that the flight's interval covers
/// (the flight cannot pin its tilt down), or a disagreement, with the reference that agrees
/// with the flight where there is one.
pub(crate) fn of_ground_agreement(a: &GroundAgreement) -> Vec<Note> {
    let mut notes = Vec::new();
    let [first, _] = a.up_axis.tilt_names();
    for (tilt, t) in a.up_axis.tilt_names().into_iter().zip([&a.roll, &a.pitch]) {
        if t.difference_deg.abs() > 1.0 && t.covers {
            notes.push(Note::GroundWithinFlight { tilt, difference_deg: t.difference_deg, ci95_deg: t.ci95_deg });
        } else if !t.covers {
            // the other references, where they agree: the next lead for this flight
            let spin = a.spin_up.as_ref().map(|s| if tilt == first { s.roll } else { s.pitch });
            let landed = a.after_landing.as_ref().map(|l| if tilt == first { l.roll } else { l.pitch });
            // the spin-up counts only where it moved significantly from the rest, toward the
            // flight, and lands within its interval of it (a wide interval alone agrees with anything)
            let toward = |s: &CheckAxis| {
                s.covers && s.change_deg.abs() > s.change_ci95_deg && s.change_deg * t.difference_deg < 0.0
            };
            let other = match (spin.filter(toward), landed.filter(|l| l.bracket_covers)) {
                (Some(s), _) => Some(OtherReference::SpinUp(s)),
                (None, Some(l)) => Some(OtherReference::RestsBracket(l)),
                (None, None) => None,
            };
            notes.push(Note::GroundDisagrees {
                tilt,
                agreement: *t,
                other,
                rest_scatter_deg: a.rest_pose_scatters.then_some(a.rest_pose_sd_deg[0]),
            });
        }
    }
    notes
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::identify::fit::ground::{LandedAgreement, SpinUpAgreement, UpAxis};

    /// A tilt's comparison: ground − flight = `difference_deg` with half-width `ci95_deg`.
    fn tilt(difference_deg: f64, ci95_deg: f64) -> TiltAgreement {
        TiltAgreement {
            ground_deg: difference_deg,
            bias_tilt_deg: 0.0,
            ground_corrected_deg: difference_deg,
            flight_deg: 0.0,
            difference_deg,
            ci95_deg,
            covers: difference_deg.abs() <= ci95_deg,
        }
    }

    /// A spin-up that moved `change_deg` ± 0.05° from the rest and lands `difference_deg` ±
    /// 0.2° from the flight.
    fn spin(change_deg: f64, difference_deg: f64) -> CheckAxis {
        CheckAxis {
            ground_corrected_deg: 0.0,
            change_deg,
            change_ci95_deg: 0.05,
            difference_deg,
            ci95_deg: 0.2,
            covers: difference_deg.abs() <= 0.2,
        }
    }

    /// Rests whose mean lands `bracket_difference_deg` ± 0.3° from the flight.
    fn landed(bracket_difference_deg: f64) -> LandedAxis {
        LandedAxis {
            check: CheckAxis {
                ground_corrected_deg: 0.0,
                change_deg: 0.0,
                change_ci95_deg: 0.1,
                difference_deg: 0.0,
                ci95_deg: 0.3,
                covers: true,
            },
            bracket_difference_deg,
            bracket_ci95_deg: 0.3,
            bracket_covers: bracket_difference_deg.abs() <= 0.3,
        }
    }

    fn agreement(roll: TiltAgreement, pitch: TiltAgreement) -> GroundAgreement {
        GroundAgreement {
            roll,
            pitch,
            frame_fitted: true,
            accel_bias_fitted: false,
            spin_up: None,
            after_landing: None,
            rest_pose_sd_deg: [0.01, 0.01],
            rest_pose_scatters: false,
            up_axis: UpAxis::Z,
        }
    }

    /// Which note each tilt gets, from agreements written by hand: none within 1° that the
    /// interval covers, "within what the flight determines" beyond 1° when it covers, and a
    /// disagreement otherwise, named by the up axis's tilt names; the second reference is the
    /// same tilt's (the spin-up only where it moved beyond its interval toward the flight, else
    /// the rests' bracket where it covers); the scatter is named only when the pose scatters.
    /// Bugs it catches: roll's reference read for pitch, a spin-up that moved away from the
    /// flight (or within its own interval) counted, the 1° bound moved.
    #[test]
    fn each_tilt_gets_the_note_its_agreement_calls_for() {
        // roll within 1° and covered, pitch 1.5° and covered: one note, for pitch
        assert_eq!(
            of_ground_agreement(&agreement(tilt(0.9, 0.95), tilt(-1.5, 2.0))),
            [Note::GroundWithinFlight { tilt: "pitch", difference_deg: -1.5, ci95_deg: 2.0 }]
        );
        assert!(of_ground_agreement(&agreement(tilt(1.0, 1.2), tilt(0.0, 0.1))).is_empty(), "1° itself is within");
        // both disagree; the spin-up agrees with the flight in pitch only (roll's spin-up agrees
        // too, but moved away from the flight: the same sign as ground − flight)
        let mut a = agreement(tilt(0.5, 0.2), tilt(-0.6, 0.2));
        a.spin_up = Some(SpinUpAgreement {
            thrust_fraction: 0.3,
            duration_s: 1.0,
            roll: spin(0.4, 0.1),
            pitch: spin(0.5, -0.1),
        });
        a.after_landing = Some(LandedAgreement { samples: 100, roll: landed(0.1), pitch: landed(0.6) });
        let notes = of_ground_agreement(&a);
        let other = |n: &Note| match n {
            Note::GroundDisagrees { other, .. } => *other,
            _ => panic!("{n:?}"),
        };
        assert_eq!(notes.len(), 2, "{notes:?}");
        assert!(matches!(notes[0], Note::GroundDisagrees { tilt: "roll", .. }), "{notes:?}");
        assert_eq!(other(&notes[0]), Some(OtherReference::RestsBracket(landed(0.1))), "roll's own bracket");
        assert_eq!(other(&notes[1]), Some(OtherReference::SpinUp(spin(0.5, -0.1))), "pitch's own spin-up");
        // a spin-up within its own interval of the rest counts for nothing, nor a bracket that
        // does not cover; a scattering pose is named
        a.spin_up.as_mut().unwrap().pitch = spin(-0.04, 0.1);
        a.rest_pose_scatters = true;
        a.rest_pose_sd_deg = [0.1, 0.2];
        let notes = of_ground_agreement(&a);
        assert_eq!(other(&notes[1]), None, "{notes:?}");
        assert!(
            notes.iter().all(|n| matches!(n, Note::GroundDisagrees { rest_scatter_deg: Some(0.1), .. })),
            "{notes:?}"
        );
        // a rig resting on its side names its tilts about z and x
        a.up_axis = UpAxis::Y;
        assert!(matches!(of_ground_agreement(&a)[1], Note::GroundDisagrees { tilt: "about x", .. }));
    }
}

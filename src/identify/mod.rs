//! Close the loop with measured data: the residual of the nominal model against a flight, the
//! effect the model lacks, that effect added, and the error before and after.
//!
//! ```text
//! flight log (flyarena CSV + scenario, any CSV + a column mapping, a ROS 2 bag, a PX4 log,
//! an ASL/EuRoC folder, an IMU CSV beside a TUM pose file)
//!   ─► input/   Series (mocap world NED, body FRD, SI) and       series, flyarena_log, mapping, ros2, ulog,
//!               what the readers did to the log; two streams    streams, joined, read_note
//!               on clocks of their own, joined at the start's
//!               clock offset
//!   ─► fit/     the global start: the clock offset (‖ω‖         start,
//!               cross-correlated), the rotation (Wahba),
//!               gravity, lever arm and biases in closed form;
//!               then the data-quality gate, residual channels   quality, design,
//!               and candidate regressors, prewhitened forward   select, stats,
//!               selection with held-out errors, the check that
//!               the fit is physically possible, ground check,   ground, note
//!               the report's notes as data
//!   ─► checks/  across flights, R5, batches with a known truth  consistency, check, trials, handheld,
//!               (and real logs with injected mounts)            injected
//!   ─► output/  report text, scenario fragment, PX4 parameters, report, start, note, read_note, quality,
//!               T_BS and the IMU's trajectory, the consistency  summary, consistency, feedback, px4,
//!               across flights, the hand-held batch's table     calibration, handheld
//! ```
//!
//! The stages are private. The front holds the names the common tasks need; six view
//! modules hold the vocabulary of one stage each, and nine modules are tools of their own:
//!
//! | to | use |
//! |---|---|
//! | run a request as the command line does (a scenario, a flyarena log, a mapped log) | [`run`] with a [`Request`], or [`run_many`] for cross-validation |
//! | identify one flight's [`Series`] | [`identify`] with [`Options`] → [`Report`] ([`report::Found`], [`report::Param`], [`report::Left`], …) |
//! | act on what a report notes (a negative delay, a pair the flight cannot tell apart, a ground check that disagrees) | match on [`Note`]; its `Display` is the sentence the text and JSON show |
//! | see what a reader did to a log (a row dropped, a gap, PX4 messages left out, the stamps read) | match on [`ReadNote`] in [`Series::repairs`] and [`Report::repairs`] |
//! | build a series | [`run_and_log`] (a scenario flown and logged), [`Mapping`] (another tool's log); its parts in [`series`] |
//! | print or write what `run` returns (the one presentation layer) | [`identified_text`], [`identified_json`]; for [`run_many`] [`cross_validated_text`], [`cross_validated_json`] |
//! | print or judge one report | [`report::render`], [`report::verdict`]; a hand-held batch [`render_handheld`] |
//! | compare flights (offsets that agree per mounting, that transfer; R5's measures) | [`consistency`]: [`consistency::consistency`], [`consistency::render`], [`consistency::heldout_cut`] |
//! | check the roll and pitch on the ground (at rest, in the spin-up, after landing) | [`ground`]: [`ground::ground_check`], [`ground::GroundAgreement`], the summaries across flights |
//! | see what the data-quality gate cut and why | [`quality`]: [`quality::gate`] → [`quality::DataQuality`] |
//! | look at the residual, the candidates and the excitation | [`residual`]: [`residual::residual_series`], [`residual::excitation`], [`residual::evaluate`] |
//! | load a scenario with the effects a report found | [`load_with_effects`] |
//!
//! The nine tools: [`mapping`] (the column mapping of another tool's log), [`ros2`] and
//! [`ulog`] (the readers of a ROS 2 bag and a PX4 log), [`start`] (the clocks and frames in
//! closed form, before the fine fit), [`px4`] (PX4's parameters from a report), [`calibration`]
//! (T_BS in the ASL/Kalibr convention and the IMU's trajectory in the TUM format), [`trials`]
//! and [`handheld`] (batches of flights whose truth is known) and [`injected`] (a real log with
//! mounts and clock offsets put on it).
//!
//! The same code runs on flyarena's own runs (where the truth is known and the tests check that
//! the hidden effect is found) and on real flights (NanoBench, docs/nanobench.md).
//!
//! ```
//! use flyarena::identify::{Effect, Options, identify, run_and_log};
//! use flyarena::scenario::Scenario;
//! // the truth has rotor drag; the declared model (the x3d preset) has none
//! let yaml = "
//! name: doc
//! vehicles:
//!   - { name: x3d, imu: { accel_noise_m_s2: 0.05 }, undeclared: { rotor_drag_per_s: [0.3, 0.3] } }
//! plan:
//!   - takeoff: { altitude_m: 1, duration_s: 3 }
//!   - waypoint: { pos_m: [4, 0, -1], speed_m_s: 1.5, accel_m_s2: 1.5, hold_s: 1 }
//!   - waypoint: { pos_m: [0, 3, -1], speed_m_s: 1.5, accel_m_s2: 1.5, hold_s: 1 }
//!   - waypoint: { pos_m: [0, 0, -1], speed_m_s: 1.5, accel_m_s2: 1.5, hold_s: 1 }
//!   - land: { duration_s: 3 }
//! ";
//! let s = Scenario::parse(yaml, std::path::Path::new("doc.yaml")).unwrap();
//! let (_, flight) = run_and_log(&s, 0, "doc").unwrap();   // the flight log, as CSV and back
//! let report = identify(&flight, &Options::default()).unwrap();
//! assert_eq!(report.effects[0].effect, Effect::RotorDrag);
//! let k_x = report.param(Effect::RotorDrag, "k_x").unwrap();
//! assert!((k_x - 0.3).abs() < 0.02, "{k_x}");
//! ```

mod checks;
mod fit;
mod input;
mod output;
pub(crate) mod precision;
mod present;
mod workflow;

// the tools beside the pipeline, each a vocabulary of its own: the column mapping of another
// tool's log, the readers of a ROS 2 bag and a PX4 log, PX4's parameters, and batches of flights
// whose truth is known
pub use checks::{handheld, injected, trials};
pub use fit::start;
pub use input::{mapping, ros2, ulog};
pub use output::{calibration, px4};

// the front: a request as the command line makes it, or one flight's series, and what comes back
pub use crate::effects::{Channel, Effect};
pub use fit::note::Note;
pub use fit::select::{IdentifyError, Options, Report, WholeCovariance, identify};
pub use input::error::InputError;
pub use input::flyarena_log::run_and_log;
pub use input::mapping::Mapping;
pub use input::read_note::ReadNote;
pub use input::series::Series;
pub use output::feedback::{TrajectoryError, load_with_effects};
pub use output::handheld::render as render_handheld;
pub use present::{cross_validated_json, cross_validated_text, identified_json, identified_text};
pub use workflow::{CrossValidated, Error, Exclusion, Identified, Request, Source, run, run_many};

pub mod report {
    //! What a [`Report`](super::Report) holds beside its effects' names, and how it is shown:
    //! the effects found with their parameters, what is left, the steps of the selection, the
    //! start that moved, the fit that is not physically possible, and the payloads of its
    //! [`Note`](super::Note)s and [`ReadNote`](super::ReadNote)s.
    pub use super::fit::note::{ForceLead, Moved, OtherReference, Unavailable};
    pub use super::fit::select::plausible::Implausible;
    pub use super::fit::select::{AxisError, Found, Left, Param, Removal, StartMoved, Step, Whiteness};
    pub use super::fit::stats::LjungBox;
    pub use super::input::read_note::StampField;
    pub use super::output::report::{render, verdict};
}

pub mod series {
    //! The parts of a [`Series`](super::Series): its clocks, the corrections a fit applies, the
    //! nominal model it is compared with, the two streams before they are joined.
    pub use super::input::flyarena_log::THRUST_REL_SD;
    pub use super::input::joined::Streams;
    pub use super::input::series::{Clocks, Corrections, NominalModel, interpolate_attitude};
}

pub mod quality {
    //! The data-quality gate a series passes before any fit: the cuts it makes and why.
    pub use super::fit::quality::{Cut, DataQuality, Finding, QualityChannel, QualityOptions, gate};
}

pub mod residual {
    //! The stage between the series and the report: the residual of the nominal model per
    //! channel, the candidate regressors, the excitation a flight gives each effect, and a
    //! report's fit evaluated on another series.
    pub use super::fit::design::{DesignOptions, glitches};
    pub use super::fit::select::{
        Candidate, Correlate, Excitation, LEAD_MAX, LEAD_MIN_CORR, MIN_TRAIN_SAMPLES, ResidualSeries, evaluate,
        excitation, residual_series,
    };
}

pub mod ground {
    //! The ground checks: the tilt the accelerometer reads against the markers at rest, in the
    //! spin-up and after landing, against the flight's fit, and their summaries across flights.
    pub use super::fit::ground::{
        CheckAxis, GroundAgreement, GroundCheck, LandedAgreement, LandedAxis, LandedAxisSummary, LandedSummary,
        MAX_REST_OFF_AXIS_DEG, Rest, RestPoseAxisSummary, RestPoseSummary, STILL_POSE_SD_DEG, SpinUpAgreement,
        SpinUpAxisSummary, SpinUpSummary, TiltAgreement, UpAxis, ground_check, landed_summary, rest_before_takeoff,
        rest_pose_summary, spin_up_summary, tilt_at_rest,
    };
}

pub mod consistency {
    //! Across flights: whether their offsets agree (per mounting) and transfer, with the measures
    //! R5 holds (the held-out error each effect cuts), and the text it is printed as.
    pub use super::checks::check::{effect_cut, heldout_cut};
    pub use super::checks::consistency::{
        AGREE_P, AxisAgreement, Consistency, Mounting, OffsetMissing, Transfer, consistency,
    };
    pub use super::output::consistency::render;
}

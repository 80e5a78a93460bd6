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
//! The stages are private; what a caller needs is re-exported here, flat:
//!
//! | to | use |
//! |---|---|
//! | run a request as the command line does (a scenario, a flyarena log, a mapped log) | [`run`] with a [`Request`], or [`run_many`] for cross-validation |
//! | identify one flight's [`Series`] | [`identify`] with [`Options`] → [`Report`] ([`Found`], [`Param`], [`Left`], …) |
//! | act on what a report notes (a negative delay, a pair the flight cannot tell apart, a ground check that disagrees) | match on [`Note`]; its `Display` is the sentence the text and JSON show |
//! | see what a reader did to a log (a row dropped, a gap, PX4 messages left out, the stamps read) | match on [`ReadNote`] in [`Series::repairs`] and [`Report::repairs`] |
//! | build a series | [`run_and_log`] (a scenario flown and logged), [`Mapping`] (another tool's log) |
//! | print or write what `run` returns (the one presentation layer) | [`identified_text`], [`identified_json`]; for [`run_many`] [`cross_validated_text`], [`cross_validated_json`] |
//! | print or judge a report | [`render_report`], [`verdict`]; across flights [`consistency`], [`render_consistency`]; a hand-held batch [`render_handheld`] |
//! | look at one stage | [`quality_gate`], [`ground_check`], [`residual_series`], [`excitation`], [`evaluate`] |
//!
//! Nine modules are public because each is a vocabulary of its own: [`mapping`] (the column
//! mapping of another tool's log), [`ros2`] and [`ulog`] (the readers of a ROS 2 bag and a PX4
//! log), [`start`] (the clocks and frames in closed form, before the fine fit), [`px4`] (PX4's
//! parameters from a report), [`calibration`] (T_BS in the ASL/Kalibr convention and the IMU's
//! trajectory in the TUM format), [`trials`] and [`handheld`] (batches of flights whose truth is
//! known) and [`injected`] (a real log with mounts and clock offsets put on it).
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

// the front: a request as the command line makes it, or one flight's series
pub use fit::select::{IdentifyError, Options, Report, identify};
pub use output::feedback::{TrajectoryError, load_with_effects};
pub use output::report::{render as render_report, verdict};
pub use present::{cross_validated_json, cross_validated_text, identified_json, identified_text};
pub use workflow::{CrossValidated, Error, Exclusion, Identified, Request, Source, run, run_many};

// inputs: the series every reader builds, and the readers
pub use input::error::InputError;
pub use input::flyarena_log::{THRUST_REL_SD, run_and_log};
pub use input::joined::Streams;
pub use input::mapping::Mapping;
pub use input::read_note::{ReadNote, StampField};
pub use input::series::{Clocks, Corrections, NominalModel, Series, interpolate_attitude};

// the model of the residual and what the report holds
pub use crate::effects::{Channel, Effect};
pub use fit::design::{DesignOptions, glitches};
pub use fit::ground::{
    CheckAxis, GroundAgreement, GroundCheck, LandedAgreement, LandedAxis, LandedAxisSummary, LandedSummary,
    MAX_REST_OFF_AXIS_DEG, Rest, RestPoseAxisSummary, RestPoseSummary, STILL_POSE_SD_DEG, SpinUpAgreement,
    SpinUpAxisSummary, SpinUpSummary, TiltAgreement, UpAxis, ground_check, landed_summary, rest_before_takeoff,
    rest_pose_summary, spin_up_summary, tilt_at_rest,
};
pub use fit::note::{ForceLead, Moved, Note, OtherReference, Unavailable};
pub use fit::quality::{Cut, DataQuality, Finding, QualityChannel, QualityOptions, gate as quality_gate};
pub use fit::select::plausible::Implausible;
pub use fit::select::{
    AxisError, Candidate, Correlate, Excitation, Found, LEAD_MAX, LEAD_MIN_CORR, Left, MIN_TRAIN_SAMPLES, Param,
    Removal, ResidualSeries, StartMoved, Step, Whiteness, evaluate, excitation, residual_series,
};

// across flights, and the measures R5 holds
pub use checks::check::{effect_cut, heldout_cut};
pub use checks::consistency::{AGREE_P, AxisAgreement, Consistency, Mounting, OffsetMissing, Transfer, consistency};
pub use fit::stats::LjungBox;
pub use output::consistency::render as render_consistency;
pub use output::handheld::render as render_handheld;

//! Scenarios: YAML in, what the arena runs on out.
//!
//! Three steps, one file each, like a command line's arguments read as written and then resolved
//! into what the program runs on:
//!
//! 1. `schema`: the YAML as the author writes it ([`Scenario`] and its sections). Every field is
//!    documented in the guide's scenario reference (docs/scenarios.md); units are in the field
//!    names (`_m`, `_mm`, `_deg`, `_s`, `_ms`, `_hz`), and each single value's range is checked as
//!    it is read (`ranges`). Unknown fields, duplicate keys and wrong types are rejected there.
//! 2. `validate`: the checks that need more than one value (rates that divide the physics clock,
//!    vehicles that can fly and that the mocap can tell apart, requirements that fit their
//!    effects). Every error carries the file, line, column, field path and what is allowed
//!    ([`ScenarioError`]).
//! 3. `spec` (assembled by `assemble`): what passed, as the engine runs it, in SI units and
//!    radians ([`ArenaSpec`]). Degrees exist only in step 1; nothing after step 3 checks again.
//!
//! [`Scenario::load`] and [`Scenario::parse`] run all three; a [`Scenario`] outside this module
//! has always passed them, and [`Scenario::spec`] is what it became. Its public fields are what
//! the file says: to fly something else, change the text ([`patch`]) and parse again, or use
//! [`Scenario::with_seed`] and [`Scenario::with_builtin_stations`], which change both.
//!
//! ```
//! use flyarena::Scenario;
//! let s = Scenario::parse("name: hop\nvehicles: [{name: a}]\nplan: [{hover: {duration_s: 1}}]\n", "hop.yaml".as_ref())?;
//! assert_eq!(s.spec().mocap.rate.hz(), 200); // the default Vicon rate
//! assert_eq!(s.spec().mocap.every, 5); // physics ticks per mocap frame
//! assert_eq!(s.spec().run_time.as_secs_f64(), 2.0); // the plan's end plus 1 s
//! # Ok::<(), flyarena::scenario::ScenarioError>(())
//! ```

mod assemble;
pub mod error;
pub mod patch;
pub mod ranges;
mod schema;
mod spec;
mod validate;

pub use error::{ScenarioError, Span};
pub use schema::{
    BatteryCfg, CalibrationCfg, CameraErrorCfg, ControllerCfg, DisturbanceCfg, ExpectedEffect, HoverDriftReq,
    IdentifyReq, ImuCfg, LinkCfg, LossCfg, LsRlsReq, MarkersCfg, MocapCfg, ModelCfg, OcclusionCfg, OffsetsReq,
    OutageCfg, PhaseCfg, Preset, RadioCfg, RequirementsCfg, Scenario, SweepCfg, TelemetryCfg, TelemetryClockCfg,
    UndeclaredCfg, ValidityReq, Variation, VaryCfg, VaryError, VehicleCfg, Verdict,
};
pub use spec::{
    ArenaSpec, CalibrationSettings, FailsafeSettings, MocapSpec, PHYSICS_HZ, StationKind, TelemetrySpec, VehicleSpec,
};

use std::path::Path;

impl Scenario {
    /// Reads, parses and validates a scenario file.
    pub fn load(path: &Path) -> Result<Scenario, ScenarioError> {
        let src =
            std::fs::read_to_string(path).map_err(|source| ScenarioError::Io { file: path.to_path_buf(), source })?;
        Scenario::parse(&src, path)
    }

    /// Parses and validates YAML text; `file` is only used in messages.
    pub fn parse(src: &str, file: &Path) -> Result<Scenario, ScenarioError> {
        validate::parse(src, file)
    }

    /// What the scenario became once checked: what [`crate::engine::Arena`] runs on.
    pub fn spec(&self) -> &ArenaSpec {
        &self.spec
    }

    /// The seed of every random stream of the run (`seed:`, default 1).
    pub fn seed(&self) -> u64 {
        self.seed
    }

    /// The same scenario with another seed (what `--seed` does).
    pub fn with_seed(mut self, seed: u64) -> Scenario {
        self.seed = seed;
        self.spec.seed = seed;
        self
    }

    /// The same scenario with every vehicle flown by flyarena's own station (e.g. the
    /// uncompensated twin of a run whose vehicles an external controller flew).
    pub fn with_builtin_stations(mut self) -> Scenario {
        for v in &mut self.vehicles.value {
            v.value.station = StationKind::Builtin;
        }
        for v in &mut self.spec.vehicles {
            v.station = StationKind::Builtin;
        }
        self
    }

    /// The vehicles as written, in the scenario's order (without the parser's source locations).
    pub fn vehicle_cfgs(&self) -> impl ExactSizeIterator<Item = &VehicleCfg> {
        self.vehicles.value.iter().map(|v| &v.value)
    }

    /// The plan's phases as written, in order.
    pub fn plan(&self) -> &[PhaseCfg] {
        &self.plan.value
    }

    /// Vehicle `i` as written (panics when out of range, like indexing).
    pub fn vehicle(&self, i: usize) -> &VehicleCfg {
        &self.vehicles.value[i].value
    }

    /// The scenario's name (a safe file name: `out/<name>.json`).
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The free text shown in reports.
    pub fn description(&self) -> &str {
        &self.description
    }

    /// The run time as written (s); `None`: the end of the plan plus 1 s ([`ArenaSpec::run_time`]).
    pub fn duration_s(&self) -> Option<f64> {
        self.duration_s
    }

    /// The motion-capture system as written.
    pub fn mocap(&self) -> &MocapCfg {
        &self.mocap
    }

    /// The mocap → station link as written.
    pub fn link(&self) -> &LinkCfg {
        &self.link
    }

    /// The station → vehicle radio as written.
    pub fn radio(&self) -> &RadioCfg {
        &self.radio
    }

    /// The vehicle → station telemetry as written.
    pub fn telemetry(&self) -> &TelemetryCfg {
        &self.telemetry
    }

    /// The station's controller as written.
    pub fn controller(&self) -> &ControllerCfg {
        &self.controller
    }

    /// The station's calibration settings as written.
    pub fn calibration(&self) -> &CalibrationCfg {
        &self.calibration
    }

    /// R1–R5: what this scenario's run must meet.
    pub fn requirements(&self) -> &RequirementsCfg {
        &self.requirements
    }

    /// The sweep's variations, when the scenario declares one.
    pub fn sweep(&self) -> Option<&SweepCfg> {
        self.sweep.as_ref()
    }
}

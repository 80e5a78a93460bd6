//! One scenario, end to end: the run, its uncompensated counterpart when a requirement compares
//! with it (R2's ratio), and the requirements evaluated; and the summary `flyarena run` writes.
//! `sweep`, `identify`, the tests, the benchmarks and the command line all run scenarios
//! through [`run_scenario`].
//!
//! ```
//! use flyarena::run::run_scenario;
//! use flyarena::scenario::Scenario;
//! let s = Scenario::load(std::path::Path::new("scenarios/fig7-no-offsets.yaml")).unwrap();
//! let outcome = run_scenario(&s, false);
//! assert!(outcome.report.passed());
//! let summary = outcome.summary(&s);
//! assert_eq!(summary.scenario, "fig7-no-offsets");
//! ```

use crate::engine::{RunOptions, RunOutput, run};
use crate::requirements::{self, Report, Row};
use crate::scenario::Scenario;

/// What one scenario run gives.
pub struct Outcome {
    /// The run as declared (calibration applied as the scenario says).
    pub main: RunOutput,
    /// The same flight without applying the calibration, when a requirement needs it.
    pub uncompensated: Option<RunOutput>,
    /// The requirements, evaluated.
    pub report: Report,
}

/// The JSON summary of a run (`out/<scenario>.json`).
#[derive(Debug, serde::Serialize)]
pub struct Summary {
    /// The scenario's name.
    pub scenario: String,
    /// The seed it was flown with.
    pub seed: u64,
    /// Simulated time (s).
    pub duration_s: f64,
    /// Whether every requirement row passed.
    pub passed: bool,
    /// The requirement rows, as in the table.
    pub requirements: Vec<Row>,
    /// Per vehicle: calibration, errors, links and failsafe figures.
    pub vehicles: Vec<requirements::VehicleSummary>,
}

/// Runs a scenario (and its uncompensated counterpart when R2 asks for it) and evaluates it.
/// `trace_uncompensated` keeps the counterpart's trajectory (for the recording).
pub fn run_scenario(s: &Scenario, trace_uncompensated: bool) -> Outcome {
    evaluate(s, run(s.spec(), RunOptions::default()), trace_uncompensated)
}

/// [`run_scenario`] for a main run flown elsewhere (e.g. served over the network by
/// [`crate::serve::serve`]): the uncompensated counterpart when a requirement needs it, and the
/// requirements evaluated.
pub fn evaluate(s: &Scenario, main: RunOutput, trace_uncompensated: bool) -> Outcome {
    let uncompensated = requirements::needs_uncompensated(&s.requirements)
        .then(|| run(s.spec(), RunOptions { trace: trace_uncompensated, apply_calibration: Some(false) }));
    let report = requirements::evaluate(&s.requirements, &main, uncompensated.as_ref());
    Outcome { main, uncompensated, report }
}

impl Outcome {
    /// The summary of this run of `s`.
    pub fn summary(&self, s: &Scenario) -> Summary {
        Summary {
            scenario: s.name.clone(),
            seed: s.seed,
            duration_s: self.main.duration.as_secs_f64(),
            passed: self.report.passed(),
            requirements: self.report.rows.clone(),
            vehicles: self
                .main
                .vehicles
                .iter()
                .enumerate()
                .map(|(i, v)| {
                    requirements::vehicle_summary(v, self.uncompensated.as_ref().and_then(|u| u.vehicles.get(i)))
                })
                .collect(),
        }
    }
}

//! Close the loop with measured data: the residual of the nominal model against a flight, the
//! effect the model lacks, that effect added, and the error before and after.
//!
//! ```text
//! flight log (flyarena CSV + scenario, any CSV + a column mapping, a ROS 2 bag, a PX4 log)
//!   ─► input/   Series (mocap world NED, body FRD, SI)          series, flyarena_log, mapping, ros2, ulog
//!   ─► fit/     data-quality gate, residual channels and        quality, design,
//!               candidate regressors, prewhitened forward       select, stats,
//!               selection with held-out errors, ground check    ground
//!   ─► checks/  across flights, R5, batches with a known truth  consistency, check, trials, handheld
//!   ─► output/  report text, scenario fragment, PX4 parameters  report, feedback, px4
//! ```
//!
//! `workflow` runs the stages for the command line and for Rust callers; the modules above are
//! reached as `identify::series`, `identify::select`, … whatever folder holds them.
//!
//! The same code runs on flyarena's own runs (where the truth is known and the tests check that
//! the hidden effect is found) and on real flights (NanoBench, docs/nanobench.md).
//!
//! ```
//! use flyarena::identify::{Effect, Options, flyarena_log::run_and_log, identify};
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
pub mod workflow;

pub use checks::{check, consistency, handheld, trials};
pub(crate) use fit::stats;
pub use fit::{design, ground, quality, select};
pub use input::{flyarena_log, mapping, ros2, series, ulog};
pub use output::{feedback, px4, report};

pub use design::{Channel, DesignOptions, Effect};
pub use input::error::InputError;
pub use select::{IdentifyError, Options, Report, identify};
pub use series::{Corrections, NominalModel, Series};

//! Close the loop with measured data: the residual of the nominal model against a flight, the
//! effect the model lacks, that effect added, and the error before and after.
//!
//! ```text
//! flight log (flyarena CSV + scenario, or any CSV + a column mapping)
//!   ─► Series (mocap world NED, body FRD, SI)           series, flyarena_log, mapping
//!   ─► residual channels + candidate regressors         design
//!   ─► prewhitened forward selection, held-out errors   select, stats
//!   ─► Report (table, JSON) and a scenario fragment     report, feedback
//! ```
//!
//! The same code runs on flyarena's own runs (where the truth is known and the tests check that
//! the hidden effect is found) and on real flights (NanoBench, in the README).

pub mod check;
pub mod cli;
pub mod design;
pub mod feedback;
pub mod mapping;
pub mod flyarena_log;
pub mod ground;
pub mod report;
pub mod select;
pub mod series;
pub mod stats;

pub use design::{Channel, DesignOptions, Effect};
pub use select::{Options, Report, identify};
pub use series::{Corrections, NominalModel, Series};

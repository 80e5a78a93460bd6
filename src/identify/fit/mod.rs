//! Fitting: the global start (the clocks and frames in closed form, where the fine fit starts),
//! the data-quality gate, the residual channels and the candidates' regressors, the
//! prewhitened selection with its statistics, the rest before take-off, whose tilt the fitted
//! frames must predict (the ground check, read with the fit's covariance), and the check that
//! what was fitted is physically possible.

pub mod design;
pub mod ground;
pub mod note;
pub mod quality;
pub mod select;
pub mod start;
pub mod stats;

//! Fitting: the data-quality gate, the residual channels and the candidates' regressors, the
//! prewhitened selection with its statistics, and the rest before take-off, whose tilt the
//! fitted frames must predict (the ground check, read with the fit's covariance).

pub mod design;
pub mod ground;
pub mod note;
pub mod quality;
pub mod select;
pub mod stats;

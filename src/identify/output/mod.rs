//! What an identification gives its user: the report as text (its notes, the summaries across
//! flights), the scenario fragment that feeds the effects back into the simulation, the PX4
//! parameters, and a calibration as the field's tools take it (T_BS, the IMU's trajectory).

pub mod calibration;
pub(crate) mod consistency;
pub mod feedback;
pub(crate) mod handheld;
mod note;
pub mod px4;
pub(crate) mod quality;
mod read_note;
pub mod report;
mod start;
pub(crate) mod summary;

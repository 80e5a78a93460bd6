//! What an identification gives its user: the report as text (its notes, the summaries across
//! flights), the scenario fragment that feeds the effects back into the simulation, and the PX4
//! parameters.

pub(crate) mod consistency;
pub mod feedback;
mod note;
pub mod px4;
pub(crate) mod quality;
mod read_note;
pub mod report;
pub(crate) mod summary;

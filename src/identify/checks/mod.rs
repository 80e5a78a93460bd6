//! Checking the fit against what it cannot see in one log: the same mounting across flights,
//! the requirement R5 of a scenario that hid its effects, and batches with a known truth
//! (hidden-effect flights, hand-held rigs) scored for recall, invention and coverage, and real
//! logs with a mount and a clock offset injected (scored against their own plain result).

pub mod check;
pub mod consistency;
pub mod handheld;
pub mod injected;
pub mod trials;

pub mod clock;
pub mod frames;
pub mod mocap;
pub mod rng;
pub mod vehicle;

//! The X3D quadrotor: 6-DOF rigid body, four rotors, the onboard 1 kHz body-rate loop, the IMU
//! and the battery.
//!
//! The engine drives it once per physics tick (1 ms):
//! 1. [`imu::Imu::sample`] samples the gyro and accelerometer from the current state;
//! 2. in [`OnboardMode::Attitude`] the [`AttitudeLoop`] turns the last radio command (angles, a
//!    yaw rate) into body rates; the onboard [`RateLoop`] turns those (or, in rate mode, the
//!    radio's own body rates) and the gyro sample into rotor-speed commands, with the thrust;
//! 3. the [`Battery`] delivers the rotors' power; its terminal voltage sets the speed the
//!    motors reach against those commands ([`battery::speed_factor`]);
//! 4. [`X3d::step`] integrates the dynamics over one tick (RK4, see [`dynamics`]);
//! 5. the [`Downlink`] averages the gyro and sends body-rate telemetry back (XBee).

pub mod attitude_loop;
pub mod battery;
pub mod dynamics;
pub mod imu;
pub mod params;
pub mod rate_loop;
pub mod telemetry;

pub use attitude_loop::{AttitudeCommand, AttitudeLoop, LEVEL_GAIN_PER_S, OnboardMode};
pub use battery::{Battery, BatteryParams};
pub use dynamics::{Disturbance, State, X3d};
pub use imu::{Imu, ImuParams, ImuSample};
pub use params::{RotorLayout, VehicleParams};
pub use rate_loop::{RateCommand, RateLoop};
pub use telemetry::{Downlink, TelemetryFrame};

//! What the engine runs on: a scenario validated once, in SI units and radians, every rate a
//! whole number of physics ticks, every vehicle's model, markers and true mounting offset
//! already derived. [`Scenario`](super::Scenario) is what the author wrote; [`ArenaSpec`] is
//! what [`crate::engine::Arena`] is built from, and nothing in it needs checking again.
//!
//! Frames: positions of the plan and the home are in the mocap's navigation frame
//! ([`MocapNav`]); marker templates in the markers' frame ([`MocapBody`]); the true offset maps
//! the markers' frame into the body frame (`R_off`, `t_off` of the paper's (1)).

use crate::calibrate::Compensation;
use crate::clock::{Nanos, Rate};
use crate::control::Gains;
use crate::frames::{MocapBody, MocapNav, Rot, Vec3};
use crate::guidance::Phase;
use crate::link::{LinkParams, LossModel};
use crate::mocap::{CameraError, MarkerSet, Occlusion, TrueOffset};
use crate::radio::RadioParams;
use crate::vehicle::{Disturbance, ImuParams, VehicleParams};

/// The physics and onboard-loop rate (Hz). Every other rate must divide it.
pub const PHYSICS_HZ: u32 = 1000;

/// The physics clock every other rate must divide.
pub(super) const PHYSICS: Rate = match Rate::from_hz(PHYSICS_HZ) {
    Some(r) => r,
    None => panic!("the physics rate has a whole-nanosecond period"),
};

/// A validated scenario as the arena runs it (SI units, radians, whole ticks).
#[derive(Clone, Debug)]
pub struct ArenaSpec {
    /// The scenario's name (a safe file name).
    pub name: String,
    /// Seed of every random stream of the run.
    pub seed: u64,
    /// The physics clock ([`PHYSICS_HZ`]).
    pub physics: Rate,
    /// How long the run lasts: `duration_s`, or the plan's end plus 1 s.
    pub run_time: Nanos,
    /// The motion-capture system every vehicle shares.
    pub mocap: MocapSpec,
    /// The station → vehicle radio's frame rate, and how many physics ticks one frame spans.
    pub radio_rate: Rate,
    /// Physics ticks per radio frame.
    pub radio_every: u64,
    /// The mocap → station network link.
    pub link: LinkParams,
    /// The link's outages: (from, until; `None`: to the end).
    pub outages: Vec<(Nanos, Option<Nanos>)>,
    /// The vehicle → station body-rate telemetry.
    pub telemetry: TelemetrySpec,
    /// The plan every vehicle flies, from its own home and initial yaw.
    pub phases: Vec<Phase>,
    /// The vehicles, in the scenario's order.
    pub vehicles: Vec<VehicleSpec>,
}

/// The motion-capture system.
#[derive(Clone, Copy, Debug)]
pub struct MocapSpec {
    /// The frame rate.
    pub rate: Rate,
    /// Physics ticks per mocap frame.
    pub every: u64,
    /// The latency the mocap declares (capture → packet sent).
    pub latency: Nanos,
    /// White noise on each marker coordinate (m, 1σ).
    pub noise_m: f64,
    /// Whether the station receives the noisy poses (true) or noise-free ones, the noise then
    /// reaching only the recorded poses.
    pub noise_in_loop: bool,
    /// The camera system's error: the mocap's world frame against the true one.
    pub camera: CameraError,
}

/// The body-rate downlink.
#[derive(Clone, Copy, Debug)]
pub struct TelemetrySpec {
    /// The frame rate.
    pub rate: Rate,
    /// Physics ticks per telemetry frame.
    pub every: u32,
    /// Its link (latency, jitter, loss).
    pub link: LinkParams,
    /// The vehicle's clock against the Vicon's at the start.
    pub clock_offset: Nanos,
    /// The vehicle's clock drift (parts per million).
    pub clock_drift_ppm: f64,
}

/// One vehicle, its station and what nobody declared about it.
#[derive(Clone, Debug)]
pub struct VehicleSpec {
    /// A unique, safe name.
    pub name: String,
    /// Who flies it: flyarena's station or an external controller.
    pub station: StationKind,
    /// The model the station and the onboard loops assume (preset with overrides).
    pub params: VehicleParams,
    /// The model the physics flies: `params` with the undeclared effects added.
    pub true_params: VehicleParams,
    /// The marker template (m, the markers' frame).
    pub template: Vec<Vec3<MocapBody>>,
    /// The markers as mounted (template rotated and displaced).
    pub markers: MarkerSet,
    /// The true offset the mounting makes (`R_off`, `t_off`): what the calibration should find.
    pub truth: TrueOffset,
    /// Markers hidden from the cameras, and when.
    pub occlusions: Vec<Occlusion>,
    /// Where it takes off (m, the mocap's navigation frame, on the floor).
    pub home: Vec3<MocapNav>,
    /// Its initial yaw (rad).
    pub yaw0_rad: f64,
    /// Its IMU (SI units, radians).
    pub imu: ImuParams,
    /// A constant disturbance force (N, navigation frame) and torque (N·m, body frame).
    pub disturbance: Disturbance,
    /// The mocap's latency for this vehicle: the declared one plus an undeclared delay.
    pub mocap_latency: Nanos,
    /// The undeclared mocap delay, in whole mocap frames (what a log's time stamps hide).
    pub log_delay_frames: usize,
    /// The undeclared gyro delay, in whole mocap frames.
    pub gyro_log_delay_frames: usize,
    /// Its radio (channel scaling and the thrust the radio can command).
    pub radio: RadioParams,
    /// The station's controller gains for it.
    pub gains: Gains,
    /// The station's calibration settings for it.
    pub calibration: CalibrationSettings,
    /// The station's failsafe.
    pub failsafe: FailsafeSettings,
    /// The station's velocity filter's cutoff (Hz).
    pub velocity_cutoff_hz: f64,
}

/// Calibration settings of the station.
#[derive(Clone, Debug)]
pub struct CalibrationSettings {
    /// Whether the estimated offset is removed from the measured attitude (`calibration.apply`).
    pub apply: bool,
    /// How it is removed.
    pub compensation: Compensation,
    /// The validity check (7): the largest mean |ψ| of the straight flight (rad).
    pub eps_yaw: f64,
    /// The validity check (7): the largest mean |φ| of the straight flight (rad).
    pub eps_roll: f64,
    /// How far X_N must have moved before the RLS of (9) starts (m).
    pub rls_min_spread_m: f64,
    /// The mocap frame period.
    pub mocap_period: Nanos,
    /// The telemetry (body-rate downlink) period.
    pub telemetry_period: Nanos,
    /// The gyro alignment fits the telemetry clock (offset, drift) instead of assuming the Vicon's.
    pub estimate_telemetry_clock: bool,
    /// The straight flight (6) commands the hover's mean roll command, φ_com = φ̄_com,hover,
    /// instead of 0 (`calibration.hover_trim`, attitude mode only): hovering on the spot the true
    /// body is level on average, so the mean roll it was commanded is the roll at which the
    /// onboard estimate holds the body level (minus the onboard level's error).
    pub hover_trim: bool,
}

/// When the mocap falls silent: after `timeout` without a pose the station commands the
/// failsafe ([`crate::control::failsafe`]) on the attitude dead-reckoned from the telemetry
/// gyro; after `motors_off_after` in failsafe it cuts the motors; the first pose that arrives
/// ends it.
#[derive(Clone, Copy, Debug)]
pub struct FailsafeSettings {
    /// Silence of the mocap after which the failsafe takes over.
    pub timeout: Nanos,
    /// The failsafe's thrust as a fraction of the weight (a sink at (1 − f)·g).
    pub thrust_fraction: f64,
    /// Time in failsafe after which the motors are cut.
    pub motors_off_after: Nanos,
}

/// Who computes a vehicle's radio commands.
#[derive(Debug, serde::Deserialize, serde::Serialize, Clone, Copy, PartialEq, Eq, Default)]
#[serde(rename_all = "snake_case")]
pub enum StationKind {
    /// flyarena's own ground station (estimation, guidance, calibration, control).
    #[default]
    Builtin,
    /// An external controller over UDP ([`crate::serve`]); until its first frame the radio sends
    /// the idle frame (motors off).
    External,
}

impl ArenaSpec {
    /// What a [`Scenario`](super::Scenario) holds between deserialising and its checks: no
    /// vehicle and no plan. [`Scenario::parse`](super::Scenario::parse) replaces it.
    pub(super) fn unchecked() -> ArenaSpec {
        let silent = LinkParams { latency: Nanos::ZERO, jitter: Nanos::ZERO, loss: LossModel::Bernoulli { p: 0.0 } };
        ArenaSpec {
            name: String::new(),
            seed: 0,
            physics: PHYSICS,
            run_time: Nanos::ZERO,
            mocap: MocapSpec {
                rate: PHYSICS,
                every: 1,
                latency: Nanos::ZERO,
                noise_m: 0.0,
                noise_in_loop: true,
                camera: CameraError { rotation: Rot::identity(), translation: Vec3::zeros() },
            },
            radio_rate: PHYSICS,
            radio_every: 1,
            link: silent,
            outages: Vec::new(),
            telemetry: TelemetrySpec {
                rate: PHYSICS,
                every: 1,
                link: silent,
                clock_offset: Nanos::ZERO,
                clock_drift_ppm: 0.0,
            },
            phases: Vec::new(),
            vehicles: Vec::new(),
        }
    }
}

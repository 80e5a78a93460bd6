//! # flyarena
//!
//! A deterministic testbench for a quadrotor flying under motion capture when the mocap's idea of
//! the body frame is wrong (Ducard & D'Andrea, ETH Flying Machine Arena). The modules follow the
//! data through the arena:
//!
//! ```text
//! scenario ─► engine (integer clock, 1 kHz) drives, per vehicle:
//!   vehicle (X3D rigid body, rotors, IMU) ─► mocap (markers, rigid fit, 200 Hz) ─► link (UDP)
//!   ─► engine::Station: estimate ─► guidance ─► calibrate ─► control (1)–(5) ─► radio (PPM 0..255)
//!   ─► vehicle's onboard (attitude and) rate loop;  vehicle::telemetry (gyro, XBee) ─► calibrate::gyro
//! requirements (R1–R5) · record (Rerun .rrd) · sweep (Monte Carlo, shards) · log (flight CSV)
//! identify: flight log ─► residuals of the declared model ─► the effect it lacks ─► fragment ─► run
//! run (a scenario end to end, used by all of the above) · output (whole files, contained names)
//! serve: the engine paced by the wall clock (or in lockstep) ─► NatNet frames over UDP to a lab's
//!   mocap client; an external controller's radio frames ─► radio (a vehicle with station: external)
//! the `flyarena` binary (src/main.rs, src/cli.rs) is a thin command line over this library
//! ```
//!
//! ## Frames first
//!
//! Four frames meet in the arena, and the paper's whole problem is that two of them differ:
//! [`frames::Nav`] (true NED), [`frames::Body`] (true FRD), [`frames::MocapNav`] (the Vicon's
//! world) and [`frames::MocapBody`] (the frame the stored marker template defines). Vectors and
//! rotations carry their frames in their types, so the offset has to be applied explicitly:
//!
//! ```
//! use flyarena::frames::{Body, Euler, MocapBody, MocapNav, Rot, Vec3};
//! // markers knocked 3° in roll: the mocap body frame is the true one turned by R_off
//! let r_off: Rot<MocapBody, Body> = Rot::from_euler(Euler::from_degrees(3.0, 0.0, 0.0));
//! // a level vehicle, as the Vicon reports it: R_m = R·R_off
//! let truth: Rot<Body, MocapNav> = Rot::identity();
//! let measured: Rot<MocapBody, MocapNav> = truth * r_off;
//! assert!((measured.euler().roll.to_degrees() - 3.0).abs() < 1e-12);
//! // the controller needs Rot<Body, MocapNav>: only the offset estimate gets it there
//! let compensated: Rot<Body, MocapNav> = measured * r_off.inverse();
//! assert!(compensated.angle() < 1e-12);
//! // thrust acts along body −z; expressed in the Vicon world it points straight up again
//! let up = compensated.apply(Vec3::<Body>::new(0.0, 0.0, -1.0));
//! assert!((up.z() + 1.0).abs() < 1e-12);
//! ```
//!
//! Writing `measured.apply(Vec3::<Body>::new(0.0, 0.0, -1.0))` does not compile: the mocap
//! attitude takes mocap-body vectors only (see [`frames`] for the compile-fail examples).
//!
//! ## A run, end to end
//!
//! The types a user starts from are re-exported at the top: [`Scenario`] (what the YAML says;
//! [`Scenario::spec`] is what it became once checked, in SI units and radians, and what the
//! engine runs), [`engine::run`]'s [`RunOptions`], [`run_scenario`] (with the requirements), [`Sweep`], [`identify()`] and its
//! [`IdentifyReport`], the frames and (feature `record`) [`encode_recording`].
//!
//! ```
//! use flyarena::{RunOptions, Scenario, engine::run};
//! let yaml = "
//! name: doc
//! vehicles:
//!   - { name: x3d, markers: { rotation_deg: [2, 0, 0] } }
//! plan:
//!   - takeoff: { altitude_m: 1, duration_s: 3 }
//!   - calibrate_roll_pitch: { settle_s: 4, average_s: 4 }
//! ";
//! let s = Scenario::parse(yaml, std::path::Path::new("doc.yaml")).unwrap();
//! let out = run(s.spec(), RunOptions::default());
//! let (roll, _, _) = out.vehicles[0].calibration.roll_pitch.unwrap();
//! // the hover average finds the 2° the markers were turned by
//! assert!((roll.to_degrees() - 2.0).abs() < 0.05);
//! ```
//!
//! [`run::run_scenario`] adds what `flyarena run` does on top: the uncompensated twin a
//! requirement may compare with, the requirements evaluated and the summary; `flyarena run` and
//! every run of a sweep go through it. `serve` paces [`engine`] by the wall clock, and
//! `identify` flies a scenario with [`engine::run`] itself (it needs the trace, not the
//! requirements).
//!
//! Angles are radians everywhere inside; degrees exist only in YAML fields named `_deg` and in
//! printed output. Time is [`clock::Nanos`], an integer; every random draw comes from a
//! [`rng::Stream`] of its own, so a run is a pure function of its scenario and seed.

// sample loops index several parallel series (time, poses, IMU, masks) by one index: clearer
// than zipping five iterators
#![warn(missing_docs)]
#![warn(unnameable_types)]
#![allow(clippy::needless_range_loop)]

pub mod calibrate;
pub mod clock;
pub mod control;
pub mod cpu;
pub mod effects;
pub mod engine;
mod error;
pub mod estimate;
pub mod frames;
pub mod guidance;
pub mod identify;
pub mod link;
pub mod log;
pub mod mocap;
pub mod output;
pub mod radio;
#[cfg(feature = "record")]
pub mod record;
pub mod requirements;
pub mod rng;
pub mod run;
pub mod scenario;
pub mod serve;
pub mod slurm;
pub mod sweep;
pub mod vehicle;

pub use error::{Error, Result};

// The types a user starts from, one `use flyarena::…` away (the modules hold the rest):
// a scenario and its run, a sweep, identify's report, the frames, the recording.
pub use engine::{RunOptions, RunOutput};
pub use frames::{Body, MocapBody, MocapNav, Nav, Rot, Vec3};
pub use identify::{Effect, Options as IdentifyOptions, Report as IdentifyReport, identify};
#[cfg(feature = "record")]
pub use record::{RecordOptions, encode as encode_recording};
pub use run::{Outcome, run_scenario};
pub use scenario::Scenario;
pub use sweep::{Sweep, SweepOutput};

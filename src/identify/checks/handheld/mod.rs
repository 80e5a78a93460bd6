//! Mocap–IMU calibration of a rig that is not a vehicle: hand-held flights drawn at the setting
//! of MoCap2GT's simulation, identified, and scored against the truth.
//!
//! **The setting** ([`Setting::default`], MoCap2GT's published simulation): mocap at 300 Hz with
//! 1 mm and 0.002 rad of white noise per axis and frame; an IMU at 500 Hz whose accelerometer and
//! gyro have continuous-time white noise of density σ_a = 2.07·10⁻² m/s²/√Hz and
//! σ_g = 8.39·10⁻⁴ rad/s/√Hz (σ/√Δt per sample) and biases that walk with
//! σ_ba = 1.04·10⁻³ m/s³/√Hz and σ_bg = 1.18·10⁻⁵ rad/s²/√Hz (b ← b + σ_b·√Δt·N(0, 1) per
//! sample); 64 s of motion.
//!
//! **The motion.** The IMU body's attitude R(t) = R_z(ψ)·R_y(θ)·R_x(φ) (body FRD → world NED),
//! each Euler angle a sum of three sinusoids of 0.2–1.2 Hz (rate amplitudes 0.5–1.5 rad/s, angle
//! amplitudes at most 0.45 rad in roll and pitch and 1 rad in yaw); its body rate
//! ω = (φ̇ − ψ̇·sin θ, θ̇·cos φ + ψ̇·cos θ·sin φ, −θ̇·sin φ + ψ̇·cos θ·cos φ) and ω̇ in closed form.
//! The point the mocap tracks moves around (0, 0, −1.2) m by three sinusoids per axis of
//! 0.1–0.8 Hz (acceleration amplitudes 0.5–2.5 m/s², displacement at most 0.4 m each).
//!
//! **The calibration drawn** (MoCap2GT's sizes, random directions and signs):
//!
//! | effect | definition | drawn |
//! |---|---|---|
//! | body offset R_off | v_IMU body = R_off·v_mocap body | 3–5° about a random axis |
//! | world tilt R_w | p_mocap = R_w·p_world, R_w = R_y(τ_y)·R_x(τ_x) | 5–7° in a random direction |
//! | lever arm r | IMU at p + R·r (IMU body, FRD) | (100, 50, 150) mm × 0.8–1.2 per axis, random signs |
//! | mocap delay τ | a pose stamped t was taken at t − τ | ±(2–4) ms |
//! | biases | b_a(0), b_g(0) | ±0.2 m/s², ±0.5 °/s per axis |
//!
//! So the IMU reads ω + b_g and f = Rᵀ(p̈ − g·e_D) + ω̇ × r + ω × (ω × r) + b_a (the specific
//! force of the point r of a rigid body), and the mocap reports R_w·p and R_w·R·R_off, each
//! with its noise (the attitude's as R_w·R·R_off·Exp(n)).
//!
//! **The route** is a user's: the two streams are joined onto the IMU's clock as a bag or a PX4
//! log is (`identify/input/joined.rs`) and read through `mappings/handheld.yaml` (`vehicle: rigid_body`),
//! then `identify` runs with its defaults and no effect named. **Scoring**: the rotation error
//! is the angle of R̂_off⁻¹·R_off, the tilt error the angle between gravity's directions in the
//! mocap world, R̂_w·e_D and R_w·e_D (a yaw of the world about gravity is seen by no sensor), the lever-arm error
//! ‖r̂ − r‖; a parameter is covered when its 95 % interval holds the truth.
//!
//! **The floors**: per trial, the Cramér–Rao bound of the calibration with a perfect mocap and
//! constant biases ([`bound`]), and on the log as recorded, the trajectory a nuisance that the
//! noisy mocap measures and the biases walking ([`bound_as_recorded`]): what no unbiased
//! estimator can beat on that motion.
//!
//! **Any rig** ([`Setting::parse`]): the rates, noise densities, length and drift are read from
//! YAML (`rigs/mocap2gt.yaml` is the default, field for field).
//!
//! **The parts**: [`Setting`] and [`draw`] make a rig and its log (`rig.rs`), [`bound`] and
//! [`bound_as_recorded`] its floors (`bound.rs`, `recorded.rs` with `banded.rs`), [`run`] and [`run_many`] identify and score it (`monte_carlo.rs`); the
//! batch's table is [`render_handheld`](crate::identify::render_handheld) (`identify/output/handheld.rs`).

mod banded;
mod bound;
mod monte_carlo;
mod recorded;
mod rig;

pub use bound::{BOUND_DRAWS, Bound, bound};
pub use monte_carlo::{Estimate, Outcome, options, run, run_many};
pub use recorded::bound_as_recorded;
pub use rig::{BiasTruth, MAX_IMU_SAMPLES, MountDraw, Setting, Trial, Truth, Wave, attitude, draw, draw_for, mapping};

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
//! **The floor** ([`bound`]): per trial, the Cramér–Rao bound of the calibration with a perfect
//! mocap and constant biases, what no unbiased estimator can beat on that motion.
//!
//! **Any rig** ([`Setting::parse`]): the rates, noise densities, length and drift are read from
//! YAML (`rigs/mocap2gt.yaml` is the default, field for field).

use crate::effects::Effect;
use crate::identify::fit::select::{Options, identify};
use crate::identify::fit::start::ClockWindow;
use crate::identify::input::joined::{Stream, Streams};
use crate::identify::input::mapping::Mapping;
use crate::identify::input::series::Series;
use crate::rng::{Component, Stream as Rng};
use crate::scenario::ranges;
use crate::vehicle::params::GRAVITY;
use nalgebra::{DMatrix, DVector, Matrix3xX, UnitQuaternion, Vector3};
use std::f64::consts::TAU;
use std::fmt::Write as _;

/// The rates, noise and length of a hand-held log (SI units). Read from YAML by
/// [`Setting::parse`] (`trials --handheld --setting FILE`): every field optional, a missing one
/// MoCap2GT's ([`Setting::default`]), each checked against its range as it is read.
#[derive(Clone, Copy, Debug, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Setting {
    /// Mocap frame rate (Hz), (0, 10 000].
    #[serde(with = "ranges::sample_rate_hz")]
    pub mocap_hz: f64,
    /// IMU sample rate (Hz), (0, 10 000].
    #[serde(with = "ranges::sample_rate_hz")]
    pub imu_hz: f64,
    /// Length of the log (s), (0, 3600].
    #[serde(with = "ranges::duration_s")]
    pub duration_s: f64,
    /// Mocap position noise per axis and frame (m), [0, 0.1].
    #[serde(with = "ranges::rig_pos_sd_m")]
    pub mocap_pos_sd_m: f64,
    /// Mocap attitude noise per axis and frame (rad), [0, 0.1].
    #[serde(with = "ranges::rig_att_sd_rad")]
    pub mocap_att_sd_rad: f64,
    /// Accelerometer white-noise density (m/s²/√Hz), [0, 1].
    #[serde(with = "ranges::accel_density")]
    pub accel_noise_density: f64,
    /// Accelerometer bias random walk (m/s³/√Hz), [0, 1].
    #[serde(with = "ranges::accel_walk")]
    pub accel_bias_walk: f64,
    /// Gyro white-noise density (rad/s/√Hz), [0, 0.1].
    #[serde(with = "ranges::gyro_density")]
    pub gyro_noise_density: f64,
    /// Gyro bias random walk (rad/s²/√Hz), [0, 0.1].
    #[serde(with = "ranges::gyro_walk")]
    pub gyro_bias_walk: f64,
    /// Accelerometer bias drift, body (m/s² per s, each in [−0.1, 0.1]): the bias grows by this
    /// each second on top of its walk (a board warming up). None in MoCap2GT's setting.
    #[serde(with = "ranges::accel_drift::arr")]
    pub accel_bias_drift: [f64; 3],
    /// Gyro bias drift, body (rad/s per s, each in [−0.01, 0.01]).
    #[serde(with = "ranges::gyro_drift::arr")]
    pub gyro_bias_drift: [f64; 3],
    /// How the IMU is mounted against the markers: `small` (3–5° about a random axis, MoCap2GT's
    /// drawing) or `any` (a rotation drawn uniformly on SO(3): half-turns, axis swaps, anything).
    pub mount: MountDraw,
    /// The streams' clocks apart by up to this (s, [0, 3600]): the mocap's stamps are a uniform
    /// draw in ±this later than the IMU's, on top of the 2–4 ms delay. 0 in MoCap2GT's setting.
    #[serde(with = "ranges::time_s")]
    pub clock_offset_s: f64,
}

/// How a hand-held trial's mount is drawn ([`Setting::mount`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MountDraw {
    /// 3–5° about a random axis (MoCap2GT's).
    #[default]
    Small,
    /// Uniform on SO(3).
    Any,
}

/// The most IMU samples a generated log may hold (an hour at 500 Hz).
pub const MAX_IMU_SAMPLES: f64 = 2e6;

impl Setting {
    /// Both IMU sensors have white noise: without it, and with a perfect mocap, no floor lies
    /// above zero ([`bound`] gives none).
    pub fn imu_has_white_noise(&self) -> bool {
        self.accel_noise_density > 0.0 && self.gyro_noise_density > 0.0
    }

    /// [`Setting::parse`] of a file.
    ///
    /// # Errors
    /// The file cannot be read, or [`Setting::parse`]'s.
    pub fn read(path: &std::path::Path) -> Result<Setting, crate::identify::InputError> {
        let src = std::fs::read_to_string(path).map_err(|e| crate::identify::InputError::io(path.display(), e))?;
        Setting::parse(&src, &path.display().to_string())
    }

    /// A setting from YAML text (`file` names it in errors): SI fields as [`Setting`] names
    /// them, any left out at MoCap2GT's value.
    ///
    /// # Errors
    /// The file, line and column of a field that is unknown, not a number or out of its range;
    /// a length and IMU rate whose log would exceed [`MAX_IMU_SAMPLES`].
    pub fn parse(src: &str, file: &str) -> Result<Setting, crate::identify::InputError> {
        let err = |e: serde_saphyr::Error| {
            crate::identify::InputError::invalid(file, crate::scenario::error::with_suggestion(&e.to_string()))
        };
        let set: Setting =
            if src.trim().is_empty() { Setting::default() } else { serde_saphyr::from_str(src).map_err(err)? };
        let n = set.duration_s * set.imu_hz;
        if n > MAX_IMU_SAMPLES {
            return Err(crate::identify::InputError::invalid(
                file,
                format!(
                    "duration_s × imu_hz = {n} IMU samples; at most {MAX_IMU_SAMPLES} are generated (an hour at 500 Hz)"
                ),
            ));
        }
        Ok(set)
    }
}

impl Default for Setting {
    /// MoCap2GT's simulated setting.
    fn default() -> Self {
        Setting {
            mocap_hz: 300.0,
            imu_hz: 500.0,
            duration_s: 64.0,
            mocap_pos_sd_m: 1e-3,
            mocap_att_sd_rad: 2e-3,
            accel_noise_density: 2.07e-2,
            accel_bias_walk: 1.04e-3,
            gyro_noise_density: 8.39e-4,
            gyro_bias_walk: 1.18e-5,
            accel_bias_drift: [0.0; 3],
            gyro_bias_drift: [0.0; 3],
            mount: MountDraw::Small,
            clock_offset_s: 0.0,
        }
    }
}

/// The biases a log holds, as the fit can know them: a walking bias has no single value, so the
/// truth of the constant is its mean over the log's IMU samples and the truth of a drift is the
/// least-squares slope of its path against time (the walk's own trend included).
#[derive(Clone, Copy, Debug)]
pub struct BiasTruth {
    /// Accelerometer bias, mean over the log (m/s², body).
    pub accel_m_s2: [f64; 3],
    /// Gyro bias, mean over the log (°/s, body).
    pub gyro_deg_s: [f64; 3],
    /// Accelerometer bias, least-squares slope over the log (m/s² per minute).
    pub accel_drift_m_s2_min: [f64; 3],
    /// Gyro bias, least-squares slope over the log (°/s per minute).
    pub gyro_drift_deg_s_min: [f64; 3],
}

/// A sum of sinusoids Σ A·sin(2πf·t + φ), with its first two derivatives.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct Wave(pub Vec<[f64; 3]>);

impl Wave {
    /// Value, first and second derivative at t.
    fn at(&self, t: f64) -> [f64; 3] {
        let mut out = [0.0; 3];
        for [a, f, phase] in &self.0 {
            let w = TAU * f;
            let (s, c) = (w * t + phase).sin_cos();
            out[0] += a * s;
            out[1] += a * w * c;
            out[2] -= a * w * w * s;
        }
        out
    }
}

/// The calibration a hand-held trial hides, in identify's conventions (see the module doc).
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct Truth {
    /// Body offset R_off as roll, pitch, yaw (Z-Y-X Euler angles, deg), as identify reports it.
    pub body_offset_deg: [f64; 3],
    /// World tilt R_w as roll, pitch (deg).
    pub world_tilt_deg: [f64; 2],
    /// Lever arm from the tracked point to the IMU, IMU body FRD (mm).
    pub lever_arm_mm: [f64; 3],
    /// Mocap delay (ms).
    pub mocap_delay_ms: f64,
    /// Accelerometer bias at the start (m/s²).
    pub accel_bias_m_s2: [f64; 3],
    /// Gyro bias at the start (°/s).
    pub gyro_bias_deg_s: [f64; 3],
    /// The mocap's clock ahead of the IMU's (s): its stamps are this plus the delay later.
    #[serde(default)]
    pub clock_offset_s: f64,
}

/// One drawn hand-held trial: its calibration and its motion.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct Trial {
    /// Trial number within the batch.
    pub index: u64,
    /// The hidden calibration.
    pub truth: Truth,
    /// Roll, pitch and yaw of the IMU body (rad).
    pub euler: [Wave; 3],
    /// The tracked point's offset from (0, 0, −1.2) m, NED (m).
    pub position: [Wave; 3],
    /// Seed of the noise.
    pub noise_seed: u64,
}

fn uniform(r: &mut Rng, lo: f64, hi: f64) -> f64 {
    lo + (hi - lo) * r.uniform()
}

fn sign(r: &mut Rng) -> f64 {
    if r.uniform() < 0.5 { -1.0 } else { 1.0 }
}

/// Three sinusoids of `hz` frequencies whose amplitude makes the `order`-th derivative's
/// amplitude `amp` (uniform), capped at `cap`.
fn wave(r: &mut Rng, hz: (f64, f64), amp: (f64, f64), order: i32, cap: f64) -> Wave {
    Wave(
        (0..3)
            .map(|_| {
                let f = uniform(r, hz.0, hz.1);
                let a = (uniform(r, amp.0, amp.1) / (TAU * f).powi(order)).min(cap);
                [a, f, uniform(r, 0.0, TAU)]
            })
            .collect(),
    )
}

/// Draws trial `index` of master seed `seed` at `set`'s mount and clock offset (a pure function
/// of the three): [`draw`]'s trial, its mount drawn again uniformly on SO(3) for
/// [`MountDraw::Any`] and its clocks set apart for a nonzero [`Setting::clock_offset_s`], from
/// draws made after [`draw`]'s (so MoCap2GT's setting gives [`draw`]'s trial bit for bit).
pub fn draw_for(seed: u64, index: u64, set: &Setting) -> Trial {
    let mut trial = draw(seed, index);
    let r = &mut Rng::new(seed, Component::Handheld, index as usize);
    // the default draws first, then these
    let _ = draw_with(r, index);
    if set.mount == MountDraw::Any {
        let q = loop {
            let v = nalgebra::Quaternion::new(r.normal(), r.normal(), r.normal(), r.normal());
            if v.norm() > 1e-6 {
                break UnitQuaternion::from_quaternion(v);
            }
        };
        let (roll, pitch, yaw) = q.euler_angles();
        trial.truth.body_offset_deg = [roll, pitch, yaw].map(f64::to_degrees);
    }
    if set.clock_offset_s > 0.0 {
        trial.truth.clock_offset_s = uniform(r, -set.clock_offset_s, set.clock_offset_s);
    }
    trial
}

/// Draws trial `index` of master seed `seed` (a pure function of both) at MoCap2GT's setting.
pub fn draw(seed: u64, index: u64) -> Trial {
    draw_with(&mut Rng::new(seed, Component::Handheld, index as usize), index)
}

/// [`draw`] from its stream `r`.
fn draw_with(r: &mut Rng, index: u64) -> Trial {
    let axis = loop {
        let v = Vector3::new(r.normal(), r.normal(), r.normal());
        if v.norm() > 1e-6 {
            break v.normalize();
        }
    };
    let r_off = UnitQuaternion::from_scaled_axis(axis * uniform(r, 3.0, 5.0).to_radians());
    let (roll, pitch, yaw) = r_off.euler_angles();
    let (tilt, dir) = (uniform(r, 5.0, 7.0), uniform(r, 0.0, TAU));
    let lever = [100.0, 50.0, 150.0].map(|x| x * uniform(r, 0.8, 1.2) * sign(r));
    let delay = sign(r) * uniform(r, 2.0, 4.0);
    let accel_bias = [0; 3].map(|_| uniform(r, -0.2, 0.2));
    let gyro_bias = [0; 3].map(|_| uniform(r, -0.5, 0.5));
    let truth = Truth {
        body_offset_deg: [roll, pitch, yaw].map(f64::to_degrees),
        world_tilt_deg: [tilt * dir.cos(), tilt * dir.sin()],
        lever_arm_mm: lever,
        mocap_delay_ms: delay,
        accel_bias_m_s2: accel_bias,
        gyro_bias_deg_s: gyro_bias,
        clock_offset_s: 0.0,
    };
    let euler = [0.45, 0.45, 1.0].map(|cap| wave(r, (0.2, 1.2), (0.5, 1.5), 1, cap));
    let position = [0; 3].map(|_| wave(r, (0.1, 0.8), (0.5, 2.5), 2, 0.4));
    Trial { index, truth, euler, position, noise_seed: r.next_u64() }
}

/// The IMU body's attitude (body FRD → world NED), body rate and its derivative (rad/s, rad/s²)
/// at t, from the Euler waves (see the module doc).
pub fn attitude(euler: &[Wave; 3], t: f64) -> (UnitQuaternion<f64>, Vector3<f64>, Vector3<f64>) {
    let [[phi, dphi, ddphi], [th, dth, ddth], [psi, dpsi, ddpsi]] = [euler[0].at(t), euler[1].at(t), euler[2].at(t)];
    let (sf, cf) = phi.sin_cos();
    let (st, ct) = th.sin_cos();
    let w = Vector3::new(dphi - dpsi * st, dth * cf + dpsi * ct * sf, -dth * sf + dpsi * ct * cf);
    let dw = Vector3::new(
        ddphi - ddpsi * st - dpsi * dth * ct,
        ddth * cf - dth * dphi * sf + ddpsi * ct * sf - dpsi * dth * st * sf + dpsi * dphi * ct * cf,
        -ddth * sf - dth * dphi * cf + ddpsi * ct * cf - dpsi * dth * st * cf - dpsi * dphi * ct * sf,
    );
    (UnitQuaternion::from_euler_angles(phi, th, psi), w, dw)
}

impl Trial {
    fn calibration(&self) -> (UnitQuaternion<f64>, UnitQuaternion<f64>, Vector3<f64>, f64) {
        let [r, p, y] = self.truth.body_offset_deg.map(f64::to_radians);
        let [tx, ty] = self.truth.world_tilt_deg.map(f64::to_radians);
        let lever = Vector3::from(self.truth.lever_arm_mm) * 1e-3;
        (
            UnitQuaternion::from_euler_angles(r, p, y),
            UnitQuaternion::from_euler_angles(tx, ty, 0.0),
            lever,
            self.truth.mocap_delay_ms * 1e-3,
        )
    }

    /// The two streams as a rig records them: mocap poses (NED, quaternion x, y, z, w) at their
    /// stamps and IMU samples (gyro, then accelerometer, FRD) at theirs, stamps in ns.
    /// Also returns the biases as the log holds them ([`BiasTruth`]).
    fn streams(&self, set: &Setting) -> (Streams, BiasTruth) {
        let (r_off, r_w, lever, delay) = self.calibration();
        let mut rng = Rng::new(self.noise_seed, Component::ImuNoise, 0);
        let mut imu = Stream::new();
        let dt = 1.0 / set.imu_hz;
        let (mut ba, mut bg) =
            (Vector3::from(self.truth.accel_bias_m_s2), Vector3::from(self.truth.gyro_bias_deg_s.map(f64::to_radians)));
        let n_imu = (set.duration_s * set.imu_hz).round() as i64;
        let normal3 = |r: &mut Rng| Vector3::new(r.normal(), r.normal(), r.normal());
        let (mut ba_sum, mut bg_sum) = (Vector3::zeros(), Vector3::zeros());
        // Σ (t − t̄)·b and Σ (t − t̄)² for the least-squares slopes, t̄ the log's mid-time
        let (mut ba_moment, mut bg_moment, mut tt) = (Vector3::zeros(), Vector3::zeros(), 0.0);
        let t_mid = 0.5 * n_imu as f64 * dt;
        for j in 0..=n_imu {
            let t = j as f64 * dt;
            ba_sum += ba;
            bg_sum += bg;
            ba_moment += ba * (t - t_mid);
            bg_moment += bg * (t - t_mid);
            tt += (t - t_mid).powi(2);
            let (q, w, dw) = attitude(&self.euler, t);
            let acc = Vector3::from_fn(|k, _| self.position[k].at(t)[2]);
            let f =
                q.inverse() * (acc - Vector3::new(0.0, 0.0, GRAVITY)) + dw.cross(&lever) + w.cross(&w.cross(&lever));
            let gyro = w + bg + normal3(&mut rng) * (set.gyro_noise_density / dt.sqrt());
            let accel = f + ba + normal3(&mut rng) * (set.accel_noise_density / dt.sqrt());
            let _ = imu.push(ns(t), [gyro.x, gyro.y, gyro.z, accel.x, accel.y, accel.z]);
            bg += normal3(&mut rng) * (set.gyro_bias_walk * dt.sqrt()) + Vector3::from(set.gyro_bias_drift) * dt;
            ba += normal3(&mut rng) * (set.accel_bias_walk * dt.sqrt()) + Vector3::from(set.accel_bias_drift) * dt;
        }
        let mut rng = Rng::new(self.noise_seed, Component::MocapNoise, 0);
        let mut pose = Stream::new();
        let n_mocap = (set.duration_s * set.mocap_hz).round() as i64;
        for k in 0..=n_mocap {
            let t = k as f64 / set.mocap_hz;
            let (q, _, _) = attitude(&self.euler, t);
            let p = Vector3::new(0.0, 0.0, -1.2) + Vector3::from_fn(|k, _| self.position[k].at(t)[0]);
            let p_m = r_w * p + normal3(&mut rng) * set.mocap_pos_sd_m;
            let q_m = r_w * q * r_off * UnitQuaternion::from_scaled_axis(normal3(&mut rng) * set.mocap_att_sd_rad);
            let _ =
                pose.push(ns(t + delay + self.truth.clock_offset_s), [p_m.x, p_m.y, p_m.z, q_m.i, q_m.j, q_m.k, q_m.w]);
        }
        let count = (n_imu + 1) as f64;
        let (ba_mean, bg_mean) = (ba_sum / count, (bg_sum / count).map(f64::to_degrees));
        let (ba_slope, bg_slope) = (ba_moment * (60.0 / tt), (bg_moment * (60.0 / tt)).map(f64::to_degrees));
        let truth = BiasTruth {
            accel_m_s2: ba_mean.into(),
            gyro_deg_s: bg_mean.into(),
            accel_drift_m_s2_min: if tt > 0.0 { ba_slope.into() } else { [0.0; 3] },
            gyro_drift_deg_s_min: if tt > 0.0 { bg_slope.into() } else { [0.0; 3] },
        };
        (Streams { pose, imu, motors: Stream::new(), n_motors: None, battery: Stream::new() }, truth)
    }

    /// The log a rig records, joined onto the IMU's clock as `mappings/handheld.yaml` reads it
    /// (CSV text: `t,px,py,pz,qx,qy,qz,qw,gx,gy,gz,ax,ay,az`).
    pub fn log(&self, set: &Setting) -> String {
        self.streams(set).0.join().0
    }

    /// The log read through `mappings/handheld.yaml`, as identify's data.
    ///
    /// # Errors
    /// None for a drawn trial; the reader's, were the rows malformed.
    pub fn series(&self, set: &Setting) -> Result<Series, crate::identify::InputError> {
        self.read(&self.streams(set).0, &ClockWindow::default())
    }

    /// The streams joined and read through `mappings/handheld.yaml`, the clock searched within
    /// `clock` first ([`crate::identify::fit::start`]: the poses joined at the offset found when it
    /// lies beyond the fine fit's reach).
    fn read(&self, streams: &Streams, clock: &ClockWindow) -> Result<Series, crate::identify::InputError> {
        crate::identify::fit::start::joined(&mapping(), streams, clock, &format!("handheld flight {}", self.index))
    }
}

/// The Cramér–Rao bound of a trial's calibration: the covariance below which no unbiased
/// estimator can go on that log, computed as if the mocap were perfect and the biases constant.
/// Both only remove uncertainty, so the bound of the log as recorded is at least this large.
///
/// With the mocap trajectory known, the IMU samples are the only noisy data: a_k = f(t_k; θ) +
/// b_a + n_a and ω_k = ω(t_k; θ) + b_g + n_g, white, of variance σ_a²/Δt and σ_g²/Δt per
/// sample (the setting's densities). The Fisher information of θ is
/// F = Σ_k Δt·(J_aᵀJ_a/σ_a² + J_gᵀJ_g/σ_g²), with the first-order sensitivities at the truth
/// (IMU body FRD, f the specific force of the IMU's point, g·e_D gravity in NED):
///
/// | θ (15) | J_a, column j | J_g, column j |
/// |---|---|---|
/// | rotation δ (rad), an error Exp(δ) of R_off | e_j × f | e_j × ω |
/// | world tilt τ_x, τ_y (rad) | Rᵀ(g·e_D × e_j) | 0 |
/// | time offset (s) | ḟ (central difference, h = 10⁻⁴ s) | ω̇ |
/// | lever arm r (m) | ω̇ × e_j + ω × (ω × e_j) | 0 |
/// | accelerometer bias (m/s²) | e_j | 0 |
/// | gyro bias (rad/s) | 0 | e_j |
///
/// and the bound is F⁻¹, of which the four calibration blocks are kept. A column's sign does not
/// change the norms scored. `None` when F is singular (the motion leaves a parameter unseen) or
/// the IMU has no white noise (then, with a perfect mocap, there is no floor above zero).
pub fn bound(trial: &Trial, set: &Setting) -> Option<Bound> {
    if !set.imu_has_white_noise() {
        return None;
    }
    let cov = fisher(trial, set).cholesky()?.inverse();
    let block = |i: usize, n: usize| cov.view((i, i), (n, n)).clone_owned();
    let (rotation, tilt, lever) = (block(0, 3), block(3, 2), block(6, 3));
    Some(Bound {
        rotation: [0, 1, 2].map(|i| [0, 1, 2].map(|j| rotation[(i, j)])),
        tilt: [0, 1].map(|i| [0, 1].map(|j| tilt[(i, j)])),
        delay: cov[(5, 5)],
        lever: [0, 1, 2].map(|i| [0, 1, 2].map(|j| lever[(i, j)])),
    })
}

/// The Fisher information F of [`bound`], in the order rotation δ (3), tilt (2), time offset,
/// lever arm (3), accelerometer bias (3), gyro bias (3).
fn fisher(trial: &Trial, set: &Setting) -> DMatrix<f64> {
    let (_, _, lever, _) = trial.calibration();
    let g = Vector3::new(0.0, 0.0, GRAVITY);
    let state = |t: f64| {
        let (q, w, dw) = attitude(&trial.euler, t);
        let acc = Vector3::from_fn(|k, _| trial.position[k].at(t)[2]);
        (q, w, dw, q.inverse() * (acc - g) + dw.cross(&lever) + w.cross(&w.cross(&lever)))
    };
    let dt = 1.0 / set.imu_hz;
    let (wa, wg) = (dt / set.accel_noise_density.powi(2), dt / set.gyro_noise_density.powi(2));
    let (h, n) = (1e-4, (set.duration_s * set.imu_hz).round() as i64);
    let mut fisher = DMatrix::<f64>::zeros(15, 15);
    let (mut ja, mut jg) = (Matrix3xX::<f64>::zeros(15), Matrix3xX::<f64>::zeros(15));
    for k in 0..=n {
        let t = k as f64 * dt;
        let (q, w, dw, f) = state(t);
        let df = (state(t + h).3 - state(t - h).3) / (2.0 * h);
        for j in 0..3 {
            let e = Vector3::ith(j, 1.0);
            ja.set_column(j, &e.cross(&f));
            jg.set_column(j, &e.cross(&w));
            if j < 2 {
                ja.set_column(3 + j, &(q.inverse() * g.cross(&e)));
            }
            ja.set_column(6 + j, &(dw.cross(&e) + w.cross(&w.cross(&e))));
            ja.set_column(9 + j, &e);
            jg.set_column(12 + j, &e);
        }
        ja.set_column(5, &df);
        jg.set_column(5, &dw);
        fisher += ja.tr_mul(&ja) * wa + jg.tr_mul(&jg) * wg;
    }
    fisher
}

/// A trial's Cramér–Rao bound ([`bound`]): the covariances of the four calibration parameters'
/// errors (SI units).
#[derive(Clone, Copy, Debug, serde::Serialize, serde::Deserialize)]
pub struct Bound {
    /// Rotation error δ, an error Exp(δ) of the body offset (rad², IMU body FRD).
    pub rotation: [[f64; 3]; 3],
    /// World tilt error about the mocap world's x and y (rad²).
    pub tilt: [[f64; 2]; 2],
    /// Time offset error (s²).
    pub delay: f64,
    /// Lever-arm error (m², IMU body FRD).
    pub lever: [[f64; 3]; 3],
}

impl Bound {
    /// `n` sets of errors an efficient estimator makes on the trial, drawn from the bound's
    /// normal distributions (stream [`Component::Bound`] of trial `index`): the rotation's angle
    /// (deg), the tilt's angle (deg), the lever arm's norm (mm) and the time offset's size (µs),
    /// as [`Outcome`] scores the fit's. `None` where a block is not positive definite.
    pub fn draws(&self, index: u64, n: usize) -> Option<Vec<[f64; 4]>> {
        let factor = |m: DMatrix<f64>| m.cholesky().map(|c| c.l());
        let rot = factor(DMatrix::from_fn(3, 3, |i, j| self.rotation[i][j]))?;
        let tilt = factor(DMatrix::from_fn(2, 2, |i, j| self.tilt[i][j]))?;
        let lever = factor(DMatrix::from_fn(3, 3, |i, j| self.lever[i][j]))?;
        let mut r = Rng::new(0, Component::Bound, index as usize);
        let delay = DMatrix::from_element(1, 1, self.delay.sqrt());
        let mut norm = |l: &DMatrix<f64>| (l * DVector::from_fn(l.nrows(), |_, _| r.normal())).norm();
        let out = (0..n)
            .map(|_| [norm(&rot).to_degrees(), norm(&tilt).to_degrees(), norm(&lever) * 1e3, norm(&delay) * 1e6])
            .collect();
        Some(out)
    }
}

/// The time t (s) as integer nanoseconds.
fn ns(t: f64) -> i128 {
    (t * 1e9).round() as i128
}

/// `mappings/handheld.yaml`, as shipped.
pub fn mapping() -> Mapping {
    Mapping::parse(include_str!("../../../mappings/handheld.yaml"), std::path::Path::new("mappings/handheld.yaml"))
        .expect("the shipped mapping parses")
}

/// What the trials run: `identify --calibrate` with the defaults of `mappings/handheld.yaml`
/// (the calibration fitted without testing, any other effect selected on top).
pub fn options() -> Options {
    let mut o = Options { forced: Effect::CALIBRATION.to_vec(), ..Options::default() };
    if let Some(ms) = mapping().smoothing_ms {
        o.design.smoothing_s = ms * 1e-3;
    }
    o
}

/// One parameter: truth, estimate and its 95 % half-width (the report's units).
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct Estimate {
    /// `effect.param`, e.g. `body_offset.roll`.
    pub name: String,
    /// The truth.
    pub truth: f64,
    /// The estimate.
    pub value: f64,
    /// Its 95 % half-width.
    pub ci95: f64,
}

impl Estimate {
    /// The truth lies inside the interval.
    pub fn covered(&self) -> bool {
        (self.value - self.truth).abs() <= self.ci95
    }
}

/// A hand-held trial identified and scored.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct Outcome {
    /// The trial.
    pub trial: Trial,
    /// The effects selected, in the report's order.
    pub selected: Vec<Effect>,
    /// Rotation error: the angle of R̂_off⁻¹·R_off (deg); `None` when the body offset was missed.
    pub rotation_err_deg: Option<f64>,
    /// World-tilt error: the angle between R̂_w·e_D and R_w·e_D (deg).
    pub tilt_err_deg: Option<f64>,
    /// Lever-arm error ‖r̂ − r‖ (mm).
    pub lever_err_mm: Option<f64>,
    /// Time-offset error |τ̂ − τ| (µs).
    pub delay_err_us: Option<f64>,
    /// Every parameter of the four calibration effects, the two biases and their drifts that was
    /// found (a bias's truth is its mean over the log, a drift's the slope of its path).
    pub estimates: Vec<Estimate>,
    /// The trial's Cramér–Rao bound ([`bound`]); `None` when the motion leaves a parameter unseen
    /// or the IMU has no white noise.
    pub bound: Option<Bound>,
    /// Why the trial could not be identified, if it could not.
    pub error: Option<String>,
}

/// Identifies one trial with `o` and scores it.
pub fn run(trial: &Trial, set: &Setting, o: &Options) -> Outcome {
    let mut out = Outcome {
        trial: trial.clone(),
        selected: Vec::new(),
        rotation_err_deg: None,
        tilt_err_deg: None,
        lever_err_mm: None,
        delay_err_us: None,
        estimates: Vec::new(),
        bound: bound(trial, set),
        error: None,
    };
    let (streams, bias) = trial.streams(set);
    let (accel_bias, gyro_bias) = (bias.accel_m_s2, bias.gyro_deg_s);
    let read = trial.read(&streams, &o.clock);
    let report = match read.map_err(|e| e.to_string()).and_then(|s| identify(&s, o).map_err(|e| e.to_string())) {
        Ok(r) => r,
        Err(e) => {
            out.error = Some(e);
            return out;
        }
    };
    out.selected = report.effects.iter().map(|f| f.effect).collect();
    let t = &trial.truth;
    let truths: [(Effect, Vec<f64>); 8] = [
        (Effect::BodyOffset, t.body_offset_deg.to_vec()),
        (Effect::WorldTilt, t.world_tilt_deg.to_vec()),
        (Effect::MocapDelay, vec![t.mocap_delay_ms + t.clock_offset_s * 1e3]),
        (Effect::AccelBias, accel_bias.to_vec()),
        (Effect::GyroBias, gyro_bias.to_vec()),
        (Effect::LeverArm, t.lever_arm_mm.to_vec()),
        (Effect::AccelBiasDrift, bias.accel_drift_m_s2_min.to_vec()),
        (Effect::GyroBiasDrift, bias.gyro_drift_deg_s_min.to_vec()),
    ];
    for (effect, truth) in truths {
        let Some(found) = report.effect(effect) else { continue };
        let v: Vec<f64> = found.params.iter().map(|p| p.value).collect();
        let angle = |a: UnitQuaternion<f64>, b: UnitQuaternion<f64>| a.angle_to(&b).to_degrees();
        let euler = |d: &[f64]| {
            UnitQuaternion::from_euler_angles(
                d[0].to_radians(),
                d[1].to_radians(),
                d.get(2).copied().unwrap_or(0.0).to_radians(),
            )
        };
        if effect == Effect::BodyOffset {
            // the rotation's intervals are a small rotation about the IMU's axes, Exp(δ)·R̂ = R:
            // its error δ = Log(R·R̂⁻¹), about x, y, z, scored against them (at a pitch of ±90°
            // a roll or a yaw alone has no interval)
            let d = (euler(&truth) * euler(&v).inverse()).scaled_axis().map(f64::to_degrees);
            for (k, p) in found.params.iter().enumerate() {
                out.estimates.push(Estimate {
                    name: format!("body_offset.about_{}", ["x", "y", "z"][k]),
                    truth: 0.0,
                    value: d[k],
                    ci95: p.ci95,
                });
            }
        } else {
            for (p, tr) in found.params.iter().zip(&truth) {
                out.estimates.push(Estimate {
                    name: format!("{}.{}", effect.key(), p.name),
                    truth: *tr,
                    value: p.value,
                    ci95: p.ci95,
                });
            }
        }
        match effect {
            Effect::BodyOffset => out.rotation_err_deg = Some(angle(euler(&v), euler(&truth))),
            Effect::WorldTilt => {
                out.tilt_err_deg = Some((euler(&v) * Vector3::z()).angle(&(euler(&truth) * Vector3::z())).to_degrees())
            }
            Effect::MocapDelay => out.delay_err_us = Some((v[0] - truth[0]).abs() * 1e3),
            Effect::LeverArm => {
                out.lever_err_mm = Some((Vector3::from_column_slice(&v) - Vector3::from_column_slice(&truth)).norm())
            }
            _ => {}
        }
    }
    out
}

/// Identifies trials 0..count of master seed `seed` on all cores; outcomes in index order, the
/// same whatever the thread count.
pub fn run_many(seed: u64, count: u64, set: &Setting, o: &Options) -> Vec<Outcome> {
    use rayon::prelude::*;
    (0..count).into_par_iter().map(|i| run(&draw_for(seed, i, set), set, o)).collect()
}

/// The q-quantile of `x` (linear between order statistics); NaN for an empty slice.
fn quantile(x: &[f64], q: f64) -> f64 {
    let mut v = x.to_vec();
    v.sort_by(f64::total_cmp);
    if v.is_empty() {
        return f64::NAN;
    }
    let h = q * (v.len() - 1) as f64;
    let (lo, hi) = (h.floor() as usize, h.ceil() as usize);
    v[lo] + (v[hi] - v[lo]) * (h - lo as f64)
}

/// Draws per rig of an efficient estimator's errors in the table's Cramér–Rao column.
pub const BOUND_DRAWS: usize = 1000;

/// "95.5 % (191/200)", or a dash when there is nothing to cover.
fn coverage(covered: usize, of: usize) -> String {
    if of == 0 { "—".to_string() } else { format!("{:.1} % ({covered}/{of})", 100.0 * covered as f64 / of as f64) }
}

/// One outcome's error in a parameter, if it was found.
type ErrorOf = fn(&Outcome) -> Option<f64>;

/// The batch's table: per calibration parameter the error's median, 90th percentile and
/// largest value, and the 95 % coverage; then what was selected.
pub fn render(outcomes: &[Outcome], set: &Setting) -> String {
    let mut s = String::new();
    let ok: Vec<&Outcome> = outcomes.iter().filter(|o| o.error.is_none()).collect();
    let _ = writeln!(
        s,
        "{} hand-held flight{} of {} s (mocap {} Hz, IMU {} Hz), {} identified\n",
        outcomes.len(),
        if outcomes.len() == 1 { "" } else { "s" },
        set.duration_s,
        set.mocap_hz,
        set.imu_hz,
        ok.len()
    );
    let _ = writeln!(
        s,
        "| parameter | found | median error | p90 error | largest error | 95 % coverage | Cramér–Rao median |\n|---|---|---|---|---|---|---|"
    );
    let efficient: Vec<[f64; 4]> =
        ok.iter().filter_map(|o| o.bound.as_ref()?.draws(o.trial.index, BOUND_DRAWS)).flatten().collect();
    let rows: [(&str, &str, ErrorOf, &str); 4] = [
        ("rotation (angle)", "°", |o| o.rotation_err_deg, "body_offset."),
        ("world tilt (angle)", "°", |o| o.tilt_err_deg, "world_tilt."),
        ("lever arm (norm)", "mm", |o| o.lever_err_mm, "lever_arm."),
        ("time offset", "µs", |o| o.delay_err_us, "mocap_delay."),
    ];
    for (i, (name, unit, err, prefix)) in rows.into_iter().enumerate() {
        let e: Vec<f64> = ok.iter().filter_map(|o| err(o)).collect();
        let est: Vec<&Estimate> = ok.iter().flat_map(|o| &o.estimates).filter(|x| x.name.starts_with(prefix)).collect();
        let covered = est.iter().filter(|x| x.covered()).count();
        let bound: Vec<f64> = efficient.iter().map(|d| d[i]).collect();
        // a parameter no rig gave has no distribution: a dash, not NaN
        let at =
            |v: &[f64], q: f64| if v.is_empty() { "—".to_string() } else { format!("{:.4} {unit}", quantile(v, q)) };
        let _ = writeln!(
            s,
            "| {name} | {}/{} | {} | {} | {} | {} | {} |",
            e.len(),
            ok.len(),
            at(&e, 0.5),
            at(&e, 0.9),
            at(&e, 1.0),
            coverage(covered, est.len()),
            at(&bound, 0.5),
        );
    }
    for prefix in ["accel_bias.", "gyro_bias.", "accel_bias_drift.", "gyro_bias_drift."] {
        let est: Vec<&Estimate> = ok.iter().flat_map(|o| &o.estimates).filter(|x| x.name.starts_with(prefix)).collect();
        if est.is_empty() && prefix.contains("drift") {
            continue;
        }
        let covered = est.iter().filter(|x| x.covered()).count();
        let _ = writeln!(
            s,
            "| {} ({}) | {}/{} | | | | {} | |",
            &prefix[..prefix.len() - 1],
            if prefix.contains("drift") { "slope" } else { "mean" },
            est.len() / 3,
            ok.len(),
            coverage(covered, est.len())
        );
    }
    let mut extra: Vec<(Effect, usize)> = Vec::new();
    for o in &ok {
        for e in o.selected.iter().filter(|e| !Effect::CALIBRATION.contains(e)) {
            match extra.iter_mut().find(|x| x.0 == *e) {
                Some(x) => x.1 += 1,
                None => extra.push((*e, 1)),
            }
        }
    }
    let extra = if extra.is_empty() {
        "none".to_string()
    } else {
        extra.iter().map(|(e, n)| format!("{} in {n}", e.key())).collect::<Vec<_>>().join(", ")
    };
    let unseen = ok.iter().filter(|o| o.bound.is_none()).count();
    let noiseless = !set.imu_has_white_noise();
    let _ = writeln!(
        s,
        "\nCramér–Rao median: {}",
        if noiseless {
            "none, the IMU of this setting has no white noise (with a perfect mocap the floor is zero)".to_string()
        } else {
            format!(
                "the errors of an efficient estimator, {BOUND_DRAWS} draws per rig from its bound (perfect mocap, constant biases){}",
                if unseen > 0 {
                    format!("; {unseen} rigs whose motion leaves a parameter unseen are left out")
                } else {
                    String::new()
                }
            )
        }
    );
    // the rigs carry nothing but the calibration: anything else selected is invented
    let _ = writeln!(s, "effects selected besides the calibration (the rigs have none): {extra}");
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The closed-form body rate and its derivative are those of the attitude they come with:
    /// ω against Log(R(t − h)ᵀ·R(t + h))/2h and ω̇ against the central difference of ω, h = 10⁻⁴ s
    /// (truncation ~h²·|ω'''|, 10⁻⁷ here). A term of ω̇ dropped or a sign flipped in the Z-Y-X
    /// rate map is off by the size of that term, 0.1–10 rad/s².
    #[test]
    fn the_body_rate_is_the_derivative_of_the_attitude() {
        let trial = draw(7, 3);
        let h = 1e-4;
        for t in [0.3, 7.1, 33.3, 60.2] {
            let (q0, _, _) = attitude(&trial.euler, t - h);
            let (q1, _, _) = attitude(&trial.euler, t + h);
            let (_, w, dw) = attitude(&trial.euler, t);
            let w_fd = (q0.inverse() * q1).scaled_axis() / (2.0 * h);
            let dw_fd = (attitude(&trial.euler, t + h).1 - attitude(&trial.euler, t - h).1) / (2.0 * h);
            assert!((w - w_fd).norm() < 1e-6 && w.norm() > 0.1, "t {t}: ω {w:?} against {w_fd:?}");
            assert!((dw - dw_fd).norm() < 1e-5 && dw.norm() > 0.1, "t {t}: ω̇ {dw:?} against {dw_fd:?}");
        }
    }

    /// On a rig without noise and with biases that do not walk, `identify --calibrate` gives the
    /// drawn calibration back: the generator writes the definitions of [`crate::identify::Corrections`]
    /// (R_w·R·R_off, R_w·p, the IMU at p + R·r, a pose stamped τ late) and identify inverts them.
    /// With a 20 ms kernel what is left is the interpolation of 300 Hz poses onto the 500 Hz IMU:
    /// 10⁻⁴° in rotation and tilt, 0.01 mm, 0.5 µs. The shipped 50 ms kernel smooths products
    /// (Rᵀ·p̈, ω × (ω × r)) factor by factor, which at these rates of 2 rad/s costs up to 0.15 mm
    /// and 0.002° (pinned below 0.3 mm and 0.005°: a sixth of the noise's median error). A sign
    /// or an axis of any definition wrong on one side moves its parameter by its own size
    /// (3–7°, 100 mm, 3 ms). Such a rig has no Cramér–Rao floor, and the table says so.
    #[test]
    fn a_rig_without_noise_gives_its_calibration_back() {
        let clean = Setting {
            mocap_pos_sd_m: 0.0,
            mocap_att_sd_rad: 0.0,
            accel_noise_density: 0.0,
            accel_bias_walk: 0.0,
            gyro_noise_density: 0.0,
            gyro_bias_walk: 0.0,
            ..Setting::default()
        };
        let mut sharp = options();
        sharp.design.smoothing_s = 0.02;
        for i in 0..2 {
            for (o, rot, tilt, lever) in [(&sharp, 1e-3, 1e-3, 0.05), (&options(), 1e-3, 5e-3, 0.3)] {
                let out = run(&draw(3, i), &clean, o);
                assert!(out.error.is_none(), "{:?}", out.error);
                let errs = (
                    out.rotation_err_deg.unwrap(),
                    out.tilt_err_deg.unwrap(),
                    out.lever_err_mm.unwrap(),
                    out.delay_err_us.unwrap(),
                );
                assert!(
                    errs.0 < rot && errs.1 < tilt && errs.2 < lever && errs.3 < 2.0,
                    "trial {i}, σ {} s: {errs:?}",
                    o.design.smoothing_s
                );
                for e in out.estimates.iter().filter(|e| e.name.contains("bias")) {
                    assert!((e.value - e.truth).abs() < 1e-3, "{e:?}");
                }
                // an IMU without white noise has no floor above zero, and the table says so
                assert!(out.bound.is_none());
                let table = render(&[out], &clean);
                let no_floor = table.lines().filter(|l| l.ends_with("| — |")).count();
                assert!(no_floor == 4 && table.contains("Cramér–Rao median: none, the IMU"), "{table}");
            }
        }
    }

    /// A bias that drifts is found on a long log, and a bias that only walks is not read as a
    /// drift. Over 180 s with drifts of (0.1, −0.08, 0.06) m/s²/min and (0.3, −0.2, 0.25) °/s/min
    /// on top of MoCap2GT's walks, both drift effects are selected on two rigs, each rate within
    /// three of its half-widths of the truth; the same rigs without the drift select neither
    /// (the walks move the biases by √180 s times their densities, 0.014 m/s² and 0.009 °/s).
    /// A 64 s log is not offered the drift, and asking for it says why.
    #[test]
    fn a_bias_drift_is_found_on_a_long_log_and_not_invented() {
        let per_min = |v: [f64; 3], f: f64| v.map(|x| x * f / 60.0);
        let (accel, gyro) = ([0.1, -0.08, 0.06], [0.3, -0.2, 0.25]);
        let still = Setting { duration_s: 180.0, ..Setting::default() };
        let drifting = Setting {
            accel_bias_drift: per_min(accel, 1.0),
            gyro_bias_drift: per_min(gyro, 1f64.to_radians()),
            ..still
        };
        for i in 0..2 {
            let trial = draw(5, i);
            let fit = |set: &Setting| {
                identify(&trial.read(&trial.streams(set).0, &ClockWindow::default()).unwrap(), &options()).unwrap()
            };
            let r = fit(&drifting);
            let bias = trial.streams(&drifting).1;
            for (k, a) in bias.accel_drift_m_s2_min.iter().enumerate() {
                assert!(
                    (a - accel[k]).abs() < 0.02,
                    "the slope of the path is the drift, with the walk's trend: {a} against {}",
                    accel[k]
                );
            }
            for (e, truth) in [
                (Effect::AccelBiasDrift, bias.accel_drift_m_s2_min),
                (Effect::GyroBiasDrift, bias.gyro_drift_deg_s_min),
            ] {
                let found = r.effect(e).unwrap_or_else(|| {
                    panic!(
                        "rig {i}: {} not selected: {:?}",
                        e.key(),
                        r.effects.iter().map(|f| f.effect).collect::<Vec<_>>()
                    )
                });
                for (p, t) in found.params.iter().zip(truth) {
                    assert!(
                        (p.value - t).abs() <= 3.0 * p.ci95,
                        "rig {i}: {} {} {} ± {} against {t}",
                        e.key(),
                        p.name,
                        p.value,
                        p.ci95
                    );
                }
            }
            let r = fit(&still);
            assert!(
                r.effect(Effect::AccelBiasDrift).is_none() && r.effect(Effect::GyroBiasDrift).is_none(),
                "rig {i}: {:?}",
                r.effects.iter().map(|f| f.effect).collect::<Vec<_>>()
            );
        }
        let trial = draw(5, 0);
        let mut o = options();
        o.forced.push(Effect::AccelBiasDrift);
        let r =
            identify(&trial.read(&trial.streams(&Setting::default()).0, &ClockWindow::default()).unwrap(), &o).unwrap();
        assert!(r.effect(Effect::AccelBiasDrift).is_none(), "{:?}", r.effects);
        assert!(
            r.notes
                .iter()
                .map(ToString::to_string)
                .any(|n| n.starts_with("--with accel_bias_drift: left out, the log's usable samples span 6")
                    && n.ends_with("a drift is fitted on 120 s or more")),
            "{:?}",
            r.notes
        );
    }

    /// The bound's information in closed form, on a rig that only yaws, ψ = A·sin Ωt over whole
    /// periods T, with no lever arm: ω = ψ̇·e_z and f = −g·e_D are the only signals. The rotation
    /// about z and the lever arm along z are then unseen, and [`bound`] says so. Without them,
    /// the gyro alone sees the rotation about x and y (its accelerometer column, g·e_y, is the
    /// bias's), so var δ_x = var δ_y = σ_g²/∫ψ̇² = σ_g²/(A²Ω²T/2); the time offset only in
    /// ω̇, var = σ_g²/(A²Ω⁴T/2); and the biases along axes no other column reaches,
    /// var b_g,x = σ_g²/T and var b_a,z = σ_a²/T. A per-sample weight without Δt, a gyro weight
    /// of the accelerometer's density or a column on the wrong axis moves these by orders of
    /// magnitude.
    #[test]
    fn the_bound_is_the_closed_form_on_a_rig_that_only_yaws() {
        let (a, hz, duration) = (0.8, 0.5, 8.0);
        let set = Setting { duration_s: duration, ..Setting::default() };
        let mut trial = draw(1, 0);
        trial.truth.lever_arm_mm = [0.0; 3];
        trial.euler = [Wave(vec![]), Wave(vec![]), Wave(vec![[a, hz, 0.0]])];
        trial.position = [Wave(vec![]), Wave(vec![]), Wave(vec![])];
        assert!(bound(&trial, &set).is_none(), "the rotation about z and the lever arm along z are unseen");
        assert!(bound(&draw(1, 0), &set).is_some(), "a drawn rig turns about every axis and sees all fifteen");
        let keep: Vec<usize> = (0..15).filter(|i| *i != 2 && *i != 8).collect();
        let f = fisher(&trial, &set).select_rows(&keep).select_columns(&keep);
        let cov = f.cholesky().expect("the rest is seen").inverse();
        let w = TAU * hz;
        let (sg2, sa2) = (set.gyro_noise_density.powi(2), set.accel_noise_density.powi(2));
        // indices after dropping 2 and 8: δ_x 0, δ_y 1, delay 4, b_a,z 9, b_g,x 10
        for (i, want, what) in [
            (0, sg2 / (a * a * w * w * duration / 2.0), "δ_x"),
            (1, sg2 / (a * a * w * w * duration / 2.0), "δ_y"),
            (4, sg2 / (a * a * w.powi(4) * duration / 2.0), "time offset"),
            (9, sa2 / duration, "b_a,z"),
            (10, sg2 / duration, "b_g,x"),
        ] {
            assert!((cov[(i, i)] / want - 1.0).abs() < 2e-3, "{what}: {} against {want}", cov[(i, i)]);
        }
    }

    /// The shipped rig files read, and `rigs/mocap2gt.yaml`, the template a user copies, is the
    /// default setting field for field (a default changed without its template, or a template
    /// edited, fails here). A field out of its range, an unknown field and a log too long are
    /// refused with the file, line and column or the limit.
    #[test]
    fn the_rig_files_read_and_the_template_is_the_default() {
        let rig = |name: &str| std::fs::read_to_string(format!("{}/rigs/{name}", env!("CARGO_MANIFEST_DIR"))).unwrap();
        let template = Setting::parse(&rig("mocap2gt.yaml"), "mocap2gt.yaml").unwrap();
        assert_eq!(serde_json::to_value(template).unwrap(), serde_json::to_value(Setting::default()).unwrap());
        for name in ["drift-180s.yaml", "long-180s.yaml", "imu-white-noise-only.yaml"] {
            let set = Setting::parse(&rig(name), name).unwrap_or_else(|e| panic!("{name}: {e}"));
            assert!(set.imu_hz == 500.0 && set.mocap_hz == 300.0, "{name}: {set:?}");
        }
        let drift = Setting::parse(&rig("drift-180s.yaml"), "d").unwrap();
        assert!(
            (drift.accel_bias_drift[0] * 60.0 - 0.1).abs() < 1e-5
                && (drift.gyro_bias_drift[2].to_degrees() * 60.0 - 0.25).abs() < 1e-5,
            "{drift:?}"
        );
        for (src, want) in [
            ("mocap_hz: 0\n", "line 1 column 11: 0 Hz is outside the allowed range (0, 10000]"),
            ("accel_bias_drift: [0, 0.2, 0]\n", "0.2 m/s² per s is outside the allowed range [-0.1, 0.1]"),
            ("imu_rate: 200\n", "unknown field `imu_rate`"),
            ("duration_s: 3600\nimu_hz: 1000\n", "3600000 IMU samples; at most 2000000"),
        ] {
            let e = Setting::parse(src, "rig.yaml").unwrap_err().to_string();
            assert!(e.starts_with("rig.yaml") && e.contains(want), "{src:?}: {e}");
        }
        assert_eq!(
            serde_json::to_value(Setting::parse("", "empty.yaml").unwrap()).unwrap(),
            serde_json::to_value(Setting::default()).unwrap()
        );
        // an IMU is noiseless for the floor when either sensor is
        let quiet = |a: f64, g: f64| Setting { accel_noise_density: a, gyro_noise_density: g, ..Setting::default() };
        assert!(quiet(2e-2, 8e-4).imu_has_white_noise());
        assert!(!quiet(0.0, 8e-4).imu_has_white_noise() && !quiet(2e-2, 0.0).imu_has_white_noise());
        // the limit itself is allowed
        assert!(Setting::parse("duration_s: 2000\nimu_hz: 1000\n", "rig.yaml").is_ok());
    }

    /// The accelerometer's side of the bound in closed form, on a rig that does not turn and
    /// moves along x as p = A·sin Ωt over whole periods: f = (−AΩ²·sin Ωt, 0, −g). Without a
    /// turn the lever arm, the world tilt and the rotation about x are unseen (zero columns, or
    /// the bias's); of the rest, the time offset is seen only in ḟ = (−AΩ³·cos Ωt, 0, 0), so
    /// var = σ_a²/(A²Ω⁶T/2), and the rotation about z only in e_z × f = (0, −AΩ²·sin Ωt, 0), so
    /// var = σ_a²/(A²Ω⁴T/2). A ḟ by a wrong difference or step moves the first by orders of
    /// magnitude.
    #[test]
    fn the_bound_is_the_closed_form_on_a_rig_that_only_translates() {
        let (a, hz, duration) = (0.3, 0.5, 8.0);
        let set = Setting { duration_s: duration, ..Setting::default() };
        let mut trial = draw(1, 0);
        trial.euler = [Wave(vec![]), Wave(vec![]), Wave(vec![])];
        let w = TAU * hz;
        // the wave's amplitude is the displacement's: A·sin Ωt
        trial.position = [Wave(vec![[a, hz, 0.0]]), Wave(vec![]), Wave(vec![])];
        assert!(bound(&trial, &set).is_none(), "without a turn the lever arm is unseen");
        // kept: δ_y, δ_z, time offset, both biases
        let keep = [1, 2, 5, 9, 10, 11, 12, 13, 14];
        let cov = fisher(&trial, &set)
            .select_rows(&keep)
            .select_columns(&keep)
            .cholesky()
            .expect("the rest is seen")
            .inverse();
        let sa2 = set.accel_noise_density.powi(2);
        for (i, want, what) in [
            (2, sa2 / (a * a * w.powi(6) * duration / 2.0), "time offset"),
            (1, sa2 / (a * a * w.powi(4) * duration / 2.0), "δ_z"),
        ] {
            assert!((cov[(i, i)] / want - 1.0).abs() < 2e-3, "{what}: {} against {want}", cov[(i, i)]);
        }
    }

    /// A rig whose log is too short to calibrate gives a table of dashes, not NaN: at 1 Hz for
    /// 10 s identify fits nothing, and every error, quantile and coverage has no sample.
    #[test]
    fn a_rig_too_short_to_calibrate_prints_dashes_not_nan() {
        let set = Setting { imu_hz: 1.0, mocap_hz: 1.0, duration_s: 10.0, ..Setting::default() };
        let out = run(&draw(1, 0), &set, &options());
        assert!(out.rotation_err_deg.is_none(), "{out:?}");
        let table = render(&[out], &set);
        assert!(!table.contains("NaN") && table.contains("| rotation (angle) | 0/1 | — | — | — | — |"), "{table}");
    }

    /// The efficient errors drawn from a bound have the distributions of their norms, in the
    /// table's units: for an isotropic 3-axis error of σ per axis the norm's median is
    /// σ·√(χ²₃ median) = 1.5382·σ, for a 2-axis one σ·√(2 ln 2) = 1.1774·σ, and for the time
    /// offset 0.6745·σ (half-normal). 4000 draws hold each within 4 %; a unit (rad against deg,
    /// m against mm, s against µs) or a block taken for another is off by far more.
    #[test]
    fn the_bound_draws_have_the_norms_of_their_normals() {
        let (r, t, l, d) = (1e-4, 2e-3, 5e-4, 1e-5);
        let iso3 = |v: f64| [[v * v, 0.0, 0.0], [0.0, v * v, 0.0], [0.0, 0.0, v * v]];
        let b = Bound { rotation: iso3(r), tilt: [[t * t, 0.0], [0.0, t * t]], delay: d * d, lever: iso3(l) };
        let draws = b.draws(7, 4000).unwrap();
        let median = |k: usize| quantile(&draws.iter().map(|x| x[k]).collect::<Vec<_>>(), 0.5);
        for (k, want) in
            [(0, 1.5382 * r.to_degrees()), (1, 1.1774 * t.to_degrees()), (2, 1.5382 * l * 1e3), (3, 0.6745 * d * 1e6)]
        {
            assert!((median(k) / want - 1.0).abs() < 0.04, "column {k}: {} against {want}", median(k));
        }
        assert_eq!(draws, b.draws(7, 4000).unwrap(), "a function of the trial index");
        let singular = Bound { tilt: [[0.0; 2]; 2], ..b };
        assert!(singular.draws(7, 10).is_none());
    }

    /// The calibrations drawn are those the module doc and the guide state, over 300 draws: a
    /// rotation of 3–5°, a tilt of 5–7°, a lever arm of (100, 50, 150) mm × 0.8–1.2 per axis, a
    /// delay of 2–4 ms either way (both signs drawn), biases within ±0.2 m/s² and ±0.5 °/s.
    #[test]
    fn the_calibrations_drawn_lie_in_the_stated_ranges() {
        let within = |x: f64, lo: f64, hi: f64| (lo..=hi).contains(&x);
        let mut signs = [0usize; 2];
        for i in 0..300 {
            let t = draw(11, i).truth;
            let [r, p, y] = t.body_offset_deg.map(f64::to_radians);
            let angle = UnitQuaternion::from_euler_angles(r, p, y).angle().to_degrees();
            let tilt = t.world_tilt_deg[0].hypot(t.world_tilt_deg[1]);
            assert!(within(angle, 3.0, 5.0) && within(tilt, 5.0, 7.0), "trial {i}: rotation {angle}°, tilt {tilt}°");
            for (v, nominal) in t.lever_arm_mm.iter().zip([100.0, 50.0, 150.0]) {
                assert!(within(v.abs() / nominal, 0.8, 1.2), "trial {i}: lever arm {v} mm for {nominal}");
            }
            assert!(within(t.mocap_delay_ms.abs(), 2.0, 4.0), "trial {i}: delay {} ms", t.mocap_delay_ms);
            signs[usize::from(t.mocap_delay_ms > 0.0)] += 1;
            assert!(
                t.accel_bias_m_s2.iter().all(|b| b.abs() <= 0.2) && t.gyro_bias_deg_s.iter().all(|b| b.abs() <= 0.5),
                "trial {i}: {t:?}"
            );
        }
        assert!(signs.iter().all(|n| *n > 100), "delay signs {signs:?}");
    }

    /// The table's quantiles interpolate between order statistics: of 0, 1, …, 10 the median is
    /// 5 and the 90th percentile 9; of 1, 2, 3, 4 the median is 2.5 and the 90th 3.7.
    #[test]
    fn quantiles_interpolate_between_order_statistics() {
        let ten: Vec<f64> = (0..=10).rev().map(f64::from).collect();
        assert_eq!((quantile(&ten, 0.5), quantile(&ten, 0.9), quantile(&ten, 1.0)), (5.0, 9.0, 10.0));
        let four = [4.0, 1.0, 3.0, 2.0];
        assert!((quantile(&four, 0.5) - 2.5).abs() < 1e-12 && (quantile(&four, 0.9) - 3.7).abs() < 1e-12);
        assert!(quantile(&[], 0.5).is_nan());
    }

    /// A trial is a pure function of (seed, index): the same log twice, another for another index.
    #[test]
    fn a_trial_is_a_function_of_seed_and_index() {
        let set = Setting { duration_s: 2.0, ..Setting::default() };
        assert_eq!(draw(5, 1).log(&set), draw(5, 1).log(&set));
        assert_ne!(draw(5, 1).log(&set), draw(5, 2).log(&set));
    }
}

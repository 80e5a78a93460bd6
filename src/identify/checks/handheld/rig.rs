//! A hand-held rig and the log it records: the setting (rates, noise, length), the trial drawn
//! (its hidden calibration and its motion) and the two streams written from them (the module
//! doc of `handheld` states the model).

use crate::frames::{Body, Euler, MocapBody, MocapNav, Nav, Rot, Vec3};
use crate::identify::fit::start::ClockWindow;
use crate::identify::input::joined::{Stream, Streams};
use crate::identify::input::mapping::Mapping;
use crate::identify::input::series::Series;
use crate::rng::{Component, Stream as Rng};
use crate::scenario::ranges;
use crate::vehicle::params::GRAVITY;
use nalgebra::{UnitQuaternion, Vector3};
use std::f64::consts::TAU;

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
    /// above zero ([`bound`](super::bound) gives none).
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
    pub(super) fn at(&self, t: f64) -> [f64; 3] {
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

/// The IMU body's attitude (body FRD → world NED), body rate and its derivative (rad/s, rad/s²,
/// body FRD) at t, from the Euler waves (see the module doc).
pub fn attitude(euler: &[Wave; 3], t: f64) -> (Rot<Body, Nav>, Vec3<Body>, Vec3<Body>) {
    let [[phi, dphi, ddphi], [th, dth, ddth], [psi, dpsi, ddpsi]] = [euler[0].at(t), euler[1].at(t), euler[2].at(t)];
    let (sf, cf) = phi.sin_cos();
    let (st, ct) = th.sin_cos();
    let w = Vec3::new(dphi - dpsi * st, dth * cf + dpsi * ct * sf, -dth * sf + dpsi * ct * cf);
    let dw = Vec3::new(
        ddphi - ddpsi * st - dpsi * dth * ct,
        ddth * cf - dth * dphi * sf + ddpsi * ct * sf - dpsi * dth * st * sf + dpsi * dphi * ct * cf,
        -ddth * sf - dth * dphi * cf + ddpsi * ct * cf - dpsi * dth * st * cf - dpsi * dphi * ct * sf,
    );
    (Rot::from_euler(Euler::new(phi, th, psi)), w, dw)
}

/// A trial's hidden calibration in SI units and typed frames.
pub(super) struct Calibration {
    /// The body offset R_off: marker body → IMU body.
    pub(super) body_offset: Rot<MocapBody, Body>,
    /// The world tilt R_w: world NED → mocap world.
    pub(super) world_tilt: Rot<Nav, MocapNav>,
    /// The lever arm r from the tracked point to the IMU (m, IMU body FRD).
    pub(super) lever_arm: Vec3<Body>,
    /// The mocap delay τ (s).
    pub(super) delay_s: f64,
}

impl Trial {
    /// The hidden calibration ([`Truth`]) in SI units and typed frames.
    pub(super) fn calibration(&self) -> Calibration {
        let [r, p, y] = self.truth.body_offset_deg.map(f64::to_radians);
        let [tx, ty] = self.truth.world_tilt_deg.map(f64::to_radians);
        Calibration {
            body_offset: Rot::from_euler(Euler::new(r, p, y)),
            world_tilt: Rot::from_euler(Euler::new(tx, ty, 0.0)),
            lever_arm: Vec3::from_array(self.truth.lever_arm_mm) * 1e-3,
            delay_s: self.truth.mocap_delay_ms * 1e-3,
        }
    }

    /// The two streams as a rig records them: mocap poses (NED, quaternion x, y, z, w) at their
    /// stamps and IMU samples (gyro, then accelerometer, FRD) at theirs, stamps in ns.
    /// Also returns the biases as the log holds them ([`BiasTruth`]).
    pub(super) fn streams(&self, set: &Setting) -> (Streams, BiasTruth) {
        let Calibration { body_offset: r_off, world_tilt: r_w, lever_arm: lever, delay_s: delay } = self.calibration();
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
            let (att, w, dw) = attitude(&self.euler, t);
            let acc = Vec3::<Nav>::from_raw(Vector3::from_fn(|k, _| self.position[k].at(t)[2]));
            let f =
                att.inverse().apply(acc - Vec3::new(0.0, 0.0, GRAVITY)) + dw.cross(&lever) + w.cross(&w.cross(&lever));
            let gyro = w.raw() + bg + normal3(&mut rng) * (set.gyro_noise_density / dt.sqrt());
            let accel = f.raw() + ba + normal3(&mut rng) * (set.accel_noise_density / dt.sqrt());
            let _ = imu.push(ns(t), [gyro.x, gyro.y, gyro.z, accel.x, accel.y, accel.z]);
            bg += normal3(&mut rng) * (set.gyro_bias_walk * dt.sqrt()) + Vector3::from(set.gyro_bias_drift) * dt;
            ba += normal3(&mut rng) * (set.accel_bias_walk * dt.sqrt()) + Vector3::from(set.accel_bias_drift) * dt;
        }
        let mut rng = Rng::new(self.noise_seed, Component::MocapNoise, 0);
        let mut pose = Stream::new();
        let n_mocap = (set.duration_s * set.mocap_hz).round() as i64;
        for k in 0..=n_mocap {
            let t = k as f64 / set.mocap_hz;
            let (att, _, _) = attitude(&self.euler, t);
            let p =
                Vec3::<Nav>::new(0.0, 0.0, -1.2) + Vec3::from_raw(Vector3::from_fn(|k, _| self.position[k].at(t)[0]));
            let p_m: Vec3<MocapNav> = r_w.apply(p) + Vec3::from_raw(normal3(&mut rng) * set.mocap_pos_sd_m);
            let noise = Rot::<MocapBody, MocapBody>::from_rotation_vector(Vec3::from_raw(
                normal3(&mut rng) * set.mocap_att_sd_rad,
            ));
            let att_m: Rot<MocapBody, MocapNav> = r_w * att * r_off * noise;
            let q_m = att_m.quaternion();
            let p_m = p_m.raw();
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
    pub(super) fn read(&self, streams: &Streams, clock: &ClockWindow) -> Result<Series, crate::identify::InputError> {
        crate::identify::fit::start::joined(&mapping(), streams, clock, &format!("handheld flight {}", self.index))
    }
}

/// The time t (s) as integer nanoseconds.
fn ns(t: f64) -> i128 {
    (t * 1e9).round() as i128
}

/// `mappings/handheld.yaml`, as shipped.
pub fn mapping() -> Mapping {
    Mapping::parse(include_str!("../../../../mappings/handheld.yaml"), std::path::Path::new("mappings/handheld.yaml"))
        .expect("the shipped mapping parses")
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
            let w_fd = Vec3::<Body>::from_raw((q0.inverse() * q1).rotation_vector().raw() / (2.0 * h));
            let dw_fd =
                Vec3::from_raw((attitude(&trial.euler, t + h).1 - attitude(&trial.euler, t - h).1).raw() / (2.0 * h));
            assert!((w - w_fd).norm() < 1e-6 && w.norm() > 0.1, "t {t}: ω {w:?} against {w_fd:?}");
            assert!((dw - dw_fd).norm() < 1e-5 && dw.norm() > 0.1, "t {t}: ω̇ {dw:?} against {dw_fd:?}");
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

    /// A trial is a pure function of (seed, index): the same log twice, another for another index.
    #[test]
    fn a_trial_is_a_function_of_seed_and_index() {
        let set = Setting { duration_s: 2.0, ..Setting::default() };
        assert_eq!(draw(5, 1).log(&set), draw(5, 1).log(&set));
        assert_ne!(draw(5, 1).log(&set), draw(5, 2).log(&set));
    }
}

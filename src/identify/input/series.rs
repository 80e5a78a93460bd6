//! The data `identify` works on, in flyarena's frames whatever the source: one sample per mocap
//! frame, times in seconds, the mocap pose in the mocap world (NED, z down), the IMU in the body
//! frame (FRD), and the collective thrust the declared model expects from the logged commands.
//!
//! The frames are in the types ([`crate::frames`]): the mocap's pose is a [`Vec3<MocapNav>`] and a
//! [`Rot<MocapBody, MocapNav>`], the IMU's readings [`Vec3<Body>`]; the corrections map between
//! them, so a correction applied the wrong way round does not compile:
//!
//! ```compile_fail,E0277
//! use flyarena::identify::{Series, series::Corrections};
//! # fn f(s: &Series, c: &Corrections) {
//! // the body offset maps the markers' frame into the body frame; composing it onto the mocap's
//! // attitude from the wrong side mixes the frames
//! let wrong = s.att_mocap[0] * c.body_offset;
//! # }
//! ```
//!
//! The right way round turns the mocap's attitude into the true body's (what the design does to
//! every row before it differentiates):
//!
//! ```
//! use flyarena::frames::{Body, Nav, Rot};
//! use flyarena::identify::{Series, series::Corrections};
//! fn body_attitude(s: &Series, c: &Corrections, i: usize) -> Rot<Body, Nav> {
//!     c.world_tilt.inverse() * s.att_mocap[i] * c.body_offset.inverse()
//! }
//! ```

use crate::frames::{Body, Frame, MocapBody, MocapNav, Nav, Rot, Vec3};
use nalgebra::UnitQuaternion;

/// What the nominal (declared) model knows about the vehicle.
#[derive(Clone, Debug, serde::Serialize)]
pub struct NominalModel {
    /// Vehicle name (the scenario's, or the mapping's).
    pub vehicle: String,
    /// Declared mass (kg).
    pub mass_kg: f64,
    /// Declared rotor drag, specific force −k·v along body x and y (1/s).
    pub rotor_drag_per_s: [f64; 2],
    /// Rotor radius (m), for the ground-effect regressor.
    pub rotor_radius_m: f64,
    /// Reference battery voltage for the thrust–voltage regressor (V).
    pub vbat_ref_v: f64,
    /// Gravity (m/s²).
    pub gravity_m_s2: f64,
    /// Relative 1σ accuracy of the thrust the model predicts from the commands, as a systematic
    /// (one factor for the whole flight). Propagated into every interval (see
    /// `select::thrust_systematic`); 0 claims an exact thrust model.
    pub thrust_rel_sd: f64,
    /// Full scale of the vehicle's IMU (from its preset), for the data-quality gate.
    pub imu_range: crate::vehicle::params::ImuRange,
    /// The log is of a rigid body that is not a vehicle (a hand-held rig, a tool on an arm):
    /// declared without a force model, and without a floor (a vehicle's log starts at rest on
    /// the ground, a rig's anywhere), so no sample is left out for its height.
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub rigid_body: bool,
}

#[cfg(test)]
impl NominalModel {
    /// The unit tests' vehicle: 1 kg, no rotor drag, a 0.1 m rotor, no voltage reference, an
    /// exact thrust model and the X3D's IMU range, in gravity `g` (m/s²).
    pub(crate) fn for_tests(g: f64) -> NominalModel {
        NominalModel {
            vehicle: "test".into(),
            mass_kg: 1.0,
            rotor_drag_per_s: [0.0; 2],
            rotor_radius_m: 0.1,
            vbat_ref_v: 0.0,
            gravity_m_s2: g,
            thrust_rel_sd: 0.0,
            imu_range: crate::vehicle::params::ImuRange::x3d(),
            rigid_body: false,
        }
    }
}

#[cfg(test)]
impl Series {
    /// The unit tests' exact rigid body: yaw turning at Ω = 2 rad/s while it swings along north,
    /// p(t) = (A·sin νt, 0, −1) m with A = 0.5 m and ν = 2π rad/s, R = R_z(Ωt), for 20 s at
    /// 200 Hz. The IMU reads the exact specific force Rᵀ(p̈ − g·e_D) plus an alternation of
    /// ±`alternation_m_s2` on every axis (signs +, −, + at even rows) and the rate (0, 0, Ω);
    /// the thrust is m·g (1 kg, the motors run throughout: no floor, nothing masked for height),
    /// so the force channel's z residual is that alternation alone. The markers sit turned by
    /// `r_off`: v_body = R_off·v_mocap_body, so the mocap reports R·R_off.
    pub(crate) fn swing_for_tests(r_off: UnitQuaternion<f64>, alternation_m_s2: f64) -> Series {
        let (dt, n, a, nu, omega, g) = (0.005, 4000, 0.5, 2.0 * std::f64::consts::PI, 2.0, 9.81);
        let t: Vec<f64> = (0..n).map(|i| i as f64 * dt).collect();
        let att: Vec<UnitQuaternion<f64>> =
            t.iter().map(|t| UnitQuaternion::from_euler_angles(0.0, 0.0, omega * t)).collect();
        let accel = t.iter().zip(&att).enumerate().map(|(i, (t, q))| {
            let f = q.inverse()
                * (nalgebra::Vector3::new(-a * nu * nu * (nu * t).sin(), 0.0, 0.0)
                    - nalgebra::Vector3::new(0.0, 0.0, g));
            Vec3::from_raw(
                f + nalgebra::Vector3::new(1.0, -1.0, 1.0) * alternation_m_s2 * if i % 2 == 0 { 1.0 } else { -1.0 },
            )
        });
        Series {
            source: "swing".into(),
            pos_mocap_nav: t.iter().map(|t| Vec3::new(a * (nu * t).sin(), 0.0, -1.0)).collect(),
            att_mocap: att.iter().map(|q| Rot::from_quaternion(q * r_off)).collect(),
            mocap_ok: vec![true; n],
            gyro_body: vec![Vec3::new(0.0, 0.0, omega); n],
            accel_body: accel.collect(),
            thrust_n: Some(vec![g; n]),
            vbat_v: None,
            segments: vec![(0, n)],
            t_s: t,
            model: NominalModel::for_tests(g),
            repairs: Vec::new(),
            clocks: Clocks::default(),
        }
    }
}

#[cfg(test)]
impl Series {
    /// The unit tests' rig: a rigid body (no vehicle) turned about all three axes and moved, for
    /// 60 s at 200 Hz, exact (no noise, no bias, no lever arm). Z-Y-X angles
    /// φ = 0.6·sin(2π·0.31t), θ = 0.5·sin(2π·0.47t + 1), ψ = 1.2·sin(2π·0.13t + 2) and a position
    /// p = (0.3·sin(2π·0.4t), 0.2·sin(2π·0.55t + 0.5), −1 + 0.1·sin(2π·0.7t)) m; the IMU reads
    /// the body rates and f = Rᵀ(p̈ − g·e_D). The mocap reports R_w·R·R_off and R_w·p, each taken
    /// `delay_s` before the row's stamp: the markers turned by `r_off` (v_body = R_off·v_marker),
    /// the mocap's world by `r_w` (gravity's direction there R_w·e_D), its stream late by
    /// `delay_s`.
    pub(crate) fn rig_for_tests(r_off: UnitQuaternion<f64>, r_w: UnitQuaternion<f64>, delay_s: f64) -> Series {
        use nalgebra::Vector3;
        use std::f64::consts::TAU;
        let (n, dt, g) = (12_000, 0.005, 9.81);
        // a sine a·sin(2πf·t + φ) with its first two derivatives
        let sine = |a: f64, f: f64, ph: f64, t: f64| {
            let w = TAU * f;
            [a * (w * t + ph).sin(), a * w * (w * t + ph).cos(), -a * w * w * (w * t + ph).sin()]
        };
        let attitude = |t: f64| {
            let ([phi, dphi, _], [th, dth, _], [psi, dpsi, _]) =
                (sine(0.6, 0.31, 0.0, t), sine(0.5, 0.47, 1.0, t), sine(1.2, 0.13, 2.0, t));
            let (sf, cf, st, ct) = (phi.sin(), phi.cos(), th.sin(), th.cos());
            let w = Vector3::new(dphi - dpsi * st, dth * cf + dpsi * ct * sf, -dth * sf + dpsi * ct * cf);
            (UnitQuaternion::from_euler_angles(phi, th, psi), w)
        };
        let pos = |t: f64| {
            let (x, y, z) = (sine(0.3, 0.4, 0.0, t), sine(0.2, 0.55, 0.5, t), sine(0.1, 0.7, 0.0, t));
            (Vector3::new(x[0], y[0], -1.0 + z[0]), Vector3::new(x[2], y[2], z[2]))
        };
        let t: Vec<f64> = (0..n).map(|i| i as f64 * dt).collect();
        let (mut gyro, mut accel, mut p_m, mut q_m) = (vec![], vec![], vec![], vec![]);
        for &ti in &t {
            let (q, w) = attitude(ti);
            let (_, a) = pos(ti);
            gyro.push(Vec3::from_raw(w));
            accel.push(Vec3::from_raw(q.inverse() * (a - Vector3::new(0.0, 0.0, g))));
            let (qd, _) = attitude(ti - delay_s);
            let (pd, _) = pos(ti - delay_s);
            p_m.push(Vec3::from_raw(r_w * pd));
            q_m.push(Rot::from_quaternion(r_w * qd * r_off));
        }
        Series {
            source: "rig".into(),
            pos_mocap_nav: p_m,
            att_mocap: q_m,
            mocap_ok: vec![true; n],
            gyro_body: gyro,
            accel_body: accel,
            thrust_n: None,
            vbat_v: None,
            segments: vec![(0, n)],
            t_s: t,
            model: NominalModel { rigid_body: true, mass_kg: 0.0, ..NominalModel::for_tests(g) },
            repairs: Vec::new(),
            clocks: Clocks::default(),
        }
    }
}

/// One flight, resampled to nothing: samples as logged, each with a validity flag.
#[derive(Clone, Debug)]
pub struct Series {
    /// Where the flight came from (file name).
    pub source: String,
    /// Sample times (s).
    pub t_s: Vec<f64>,
    /// Mocap position in the mocap world, NED (m).
    pub pos_mocap_nav: Vec<Vec3<MocapNav>>,
    /// Mocap attitude: the markers' body frame → mocap world.
    pub att_mocap: Vec<Rot<MocapBody, MocapNav>>,
    /// The pose of this row is real (the vehicle was seen); otherwise it is a copy of the last.
    pub mocap_ok: Vec<bool>,
    /// IMU angular rate, body FRD (rad/s).
    pub gyro_body: Vec<Vec3<Body>>,
    /// IMU specific force, body FRD (m/s²).
    pub accel_body: Vec<Vec3<Body>>,
    /// Collective thrust the declared model predicts from the logged commands (N), if known.
    pub thrust_n: Option<Vec<f64>>,
    /// Battery voltage (V), if logged.
    pub vbat_v: Option<Vec<f64>>,
    /// Row ranges [start, end) between gaps.
    pub segments: Vec<(usize, usize)>,
    /// What the declared model knows.
    pub model: NominalModel,
    /// What the readers did: repairs, and the stamps read; `Display` gives each one's sentence.
    pub repairs: Vec<crate::identify::ReadNote>,
    /// How the series' clock stands against the logs' (the IMU's stamps, and the join's shift
    /// of the poses).
    pub clocks: Clocks,
}

/// How a series' clock stands against the logs': where its zero lies on the IMU's clock, and how
/// the poses were joined onto it.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Clocks {
    /// The IMU clock's reading at the series' t = 0 (ns): a row at t was stamped t + origin by
    /// the IMU. 0 where the log's own times are kept (a CSV read through a column mapping).
    pub imu_origin_ns: i128,
    /// The pose joined to the row at t is the one the mocap stamped t + shift (s): the share of
    /// the mocap delay that the join of two streams took out (the clock search's offset, when it
    /// lies beyond the fine fit's reach; 0 otherwise and for a log joined elsewhere).
    pub pose_shift_s: f64,
    /// The clock search made where two streams were joined (`None` for a log joined elsewhere:
    /// the global start searches its rows).
    pub search: Option<crate::identify::fit::start::ClockStart>,
}

impl Series {
    /// The same samples, bit for bit (times, poses, IMU, thrust, battery), whatever the source's
    /// name: a log copied under another name. The readers' repairs and the model are not
    /// compared.
    pub(crate) fn same_samples(&self, other: &Series) -> bool {
        fn same(a: impl IntoIterator<Item = f64>, b: impl IntoIterator<Item = f64>) -> bool {
            a.into_iter().map(f64::to_bits).eq(b.into_iter().map(f64::to_bits))
        }
        fn v3<F: Frame>(v: &[Vec3<F>]) -> impl Iterator<Item = f64> + '_ {
            v.iter().flat_map(|x| x.to_array())
        }
        fn q4<A: Frame, B: Frame>(v: &[Rot<A, B>]) -> impl Iterator<Item = f64> + '_ {
            v.iter().map(Rot::quaternion).flat_map(|q| [q.w, q.i, q.j, q.k])
        }
        let opt = |a: &Option<Vec<f64>>, b: &Option<Vec<f64>>| match (a, b) {
            (Some(a), Some(b)) => same(a.iter().copied(), b.iter().copied()),
            (None, None) => true,
            _ => false,
        };
        same(self.t_s.iter().copied(), other.t_s.iter().copied())
            && same(v3(&self.pos_mocap_nav), v3(&other.pos_mocap_nav))
            && same(q4(&self.att_mocap), q4(&other.att_mocap))
            && self.mocap_ok == other.mocap_ok
            && same(v3(&self.gyro_body), v3(&other.gyro_body))
            && same(v3(&self.accel_body), v3(&other.accel_body))
            && opt(&self.thrust_n, &other.thrust_n)
            && opt(&self.vbat_v, &other.vbat_v)
            && self.segments == other.segments
    }

    /// Number of rows.
    pub fn len(&self) -> usize {
        self.t_s.len()
    }
    /// No rows.
    pub fn is_empty(&self) -> bool {
        self.t_s.is_empty()
    }
    /// Median sampling interval (s).
    pub fn dt(&self) -> f64 {
        // the readers drop repeated timestamps, so every interval is positive
        crate::log::median_interval(&self.t_s).unwrap_or(0.01)
    }
    /// Keeps the rows in [from, to) (for cut-outs and benchmarks).
    pub fn slice(&self, from: usize, to: usize) -> Series {
        let cut = |s: &(usize, usize)| (s.0.max(from).min(to) - from, s.1.min(to).max(from) - from);
        Series {
            source: self.source.clone(),
            t_s: self.t_s[from..to].to_vec(),
            pos_mocap_nav: self.pos_mocap_nav[from..to].to_vec(),
            att_mocap: self.att_mocap[from..to].to_vec(),
            mocap_ok: self.mocap_ok[from..to].to_vec(),
            gyro_body: self.gyro_body[from..to].to_vec(),
            accel_body: self.accel_body[from..to].to_vec(),
            thrust_n: self.thrust_n.as_ref().map(|v| v[from..to].to_vec()),
            vbat_v: self.vbat_v.as_ref().map(|v| v[from..to].to_vec()),
            segments: self.segments.iter().map(cut).filter(|s| s.1 > s.0).collect(),
            model: self.model.clone(),
            repairs: self.repairs.clone(),
            clocks: self.clocks.clone(),
        }
    }
}

/// The coordinates of `v` without their frame, for the numerical work (smoothing,
/// differentiation, least squares) that follows the frames' bookkeeping.
pub(crate) fn raw_vecs<F: Frame>(v: &[Vec3<F>]) -> Vec<nalgebra::Vector3<f64>> {
    v.iter().map(|x| *x.raw()).collect()
}

/// The unit quaternions of `r` without their frames (see [`raw_vecs`]).
pub(crate) fn raw_rots<A: Frame, B: Frame>(r: &[Rot<A, B>]) -> Vec<UnitQuaternion<f64>> {
    r.iter().map(|x| *x.quaternion()).collect()
}

/// The floor (NED z of the resting vehicle, m) for the heights `z_down` (NED z, m) of the log's rows: the
/// lowest point (largest z) while the motors are off; without a thrust column, the lowest point
/// of the first half second of the first segment (a log is taken to start at rest). None for a
/// log that starts in the air with the motors on, and for a rigid body's (no floor).
pub(crate) fn floor_z(s: &Series, z_down: &[f64]) -> Option<f64> {
    let n = s.len();
    if s.model.rigid_body {
        return None;
    }
    match &s.thrust_n {
        Some(t) => (0..n).filter(|&i| t[i] == 0.0).map(|i| z_down[i]).reduce(f64::max),
        None => {
            let first = s.segments.first().map_or(0, |s| s.0);
            let settle = ((0.5 / s.dt()) as usize).max(1);
            z_down[first..(first + settle).min(n)].iter().copied().reduce(f64::max)
        }
    }
}

/// The attitude a fraction `t` of the way from `a` to `b` (normalised linear interpolation along
/// the shorter arc). q and −q are the same attitude and sources flip between them (flyarena's
/// mocap keeps w ≥ 0, so its sign flips where the rotation angle passes π, e.g. at a heading of
/// 180°); interpolating across a flip without aligning the signs gives nonsense.
pub fn interpolate_attitude<A: Frame, B: Frame>(a: &Rot<A, B>, b: &Rot<A, B>, t: f64) -> Rot<A, B> {
    let (a, b) = (a.quaternion(), b.quaternion());
    let b = if a.coords.dot(&b.coords) < 0.0 { UnitQuaternion::new_unchecked(-b.into_inner()) } else { *b };
    Rot::from_quaternion(a.nlerp(&b, t))
}

/// Exact (not linearised) corrections of the mocap stream, as the nonlinear effects define them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Corrections {
    /// Body offset R_off: v_body = R_off·v_mocap_body (the paper's marker offset).
    pub body_offset: Rot<MocapBody, Body>,
    /// Mocap world tilt R_w: p_mocap = R_w·p_nav (camera calibration error).
    pub world_tilt: Rot<Nav, MocapNav>,
    /// The mocap stream is late by this much against the IMU (s): the pose stamped t was taken at t − τ.
    pub mocap_delay_s: f64,
    /// Lever arm r from the point the mocap tracks to the IMU, body FRD (m): the corrected
    /// position is the IMU's, p_imu = p_tracked + R·r, so that its second derivative is what the
    /// accelerometer feels and its velocity what the drag sees (a rigid body's point r moves with
    /// v + ω×r and accelerates with a + ω̇×r + ω×(ω×r)).
    pub lever_arm_m: Vec3<Body>,
    /// The gyro stream is late by this much against the accelerometer (s): the gyro sample
    /// stamped t was taken at t − τ_g; the corrected gyro at t is the stream read at t + τ_g.
    pub gyro_delay_s: f64,
    /// The share of the mocap delay that the rows already carry (s; [`Clocks::pose_shift_s`]):
    /// the join of two streams read the poses this much later. The correction leaves it alone (the
    /// rows hold it); the delay a report gives is `mocap_delay_s` plus it.
    pub pose_shift_s: f64,
}

impl Default for Corrections {
    fn default() -> Self {
        Corrections {
            body_offset: Rot::identity(),
            world_tilt: Rot::identity(),
            mocap_delay_s: 0.0,
            lever_arm_m: Vec3::zeros(),
            gyro_delay_s: 0.0,
            pose_shift_s: 0.0,
        }
    }
}

/// Row i of segment [a, b) read `shift` rows later (fractional): the two rows to interpolate
/// between and the fraction, `None` where that reaches outside the segment.
fn shifted(i: usize, shift: f64, a: usize, b: usize) -> Option<(usize, usize, f64)> {
    let x = i as f64 + shift;
    let k0 = x.floor();
    let frac = x - k0;
    let k0 = k0 as isize;
    if k0 >= a as isize && (k0 as usize) < b && (frac == 0.0 || ((k0 + 1) as usize) < b) {
        let k0 = k0 as usize;
        Some((k0, if frac == 0.0 { k0 } else { k0 + 1 }, frac))
    } else {
        None
    }
}

/// The gyro with a delay τ (s) taken out: row i reads the stream at t_i + τ (linear
/// interpolation inside the row's segment), and `ok[i]` turns false where that reaches outside
/// it. τ = 0 returns the stream itself.
pub(crate) fn gyro_advanced(s: &Series, delay_s: f64, ok: &mut [bool]) -> Vec<Vec3<Body>> {
    if delay_s == 0.0 {
        return s.gyro_body.clone();
    }
    let shift = delay_s / s.dt();
    let mut out = s.gyro_body.clone();
    for &(a, b) in &s.segments {
        for i in a..b {
            match shifted(i, shift, a, b) {
                Some((k0, k1, frac)) => out[i] = s.gyro_body[k0] * (1.0 - frac) + s.gyro_body[k1] * frac,
                None => ok[i] = false,
            }
        }
    }
    out
}

/// The mocap stream with the corrections applied: true-body attitude (body → nav) and nav
/// position, sampled at the IMU times. `ok` is false where the delay reaches outside a segment
/// or a pose was missing.
pub struct Corrected {
    /// Corrected mocap position, nav NED (m).
    pub pos_nav: Vec<Vec3<Nav>>,
    /// Corrected attitude: true body → nav.
    pub att_body: Vec<Rot<Body, Nav>>,
    /// The row's corrected pose is usable.
    pub ok: Vec<bool>,
}

/// Applies the corrections (body offset, world tilt, mocap delay, lever arm) to the mocap stream.
pub(crate) fn correct(s: &Series, c: &Corrections) -> Corrected {
    let n = s.len();
    let dt = s.dt();
    let shift = c.mocap_delay_s / dt;
    let mut pos_nav = Vec::with_capacity(n);
    let mut att_body = Vec::with_capacity(n);
    let mut ok = vec![false; n];
    let w_inv = c.world_tilt.inverse();
    let off_inv = c.body_offset.inverse();
    for &(a, b) in &s.segments {
        for i in a..b {
            // the pose taken at t_i carries the stamp t_i + τ: read the stream there
            let (p, q, good) = if let Some((k0, k1, frac)) = shifted(i, shift, a, b) {
                let p = s.pos_mocap_nav[k0] * (1.0 - frac) + s.pos_mocap_nav[k1] * frac;
                let q = interpolate_attitude(&s.att_mocap[k0], &s.att_mocap[k1], frac);
                (p, q, s.mocap_ok[k0] && s.mocap_ok[k1])
            } else {
                (s.pos_mocap_nav[i], s.att_mocap[i], false)
            };
            let att = w_inv * q * off_inv;
            pos_nav.push(w_inv.apply(p) + att.apply(c.lever_arm_m));
            att_body.push(att);
            ok[i] = good;
        }
    }
    // rows outside every segment (none from the readers) keep their raw values, invalid: the
    // mocap's frames taken for the true ones, as nothing reads them
    if pos_nav.len() != n {
        let mut p2: Vec<Vec3<Nav>> = s.pos_mocap_nav.iter().map(|p| p.assume_same_as()).collect();
        let mut q2: Vec<Rot<Body, Nav>> = s.att_mocap.iter().map(|q| q.assume_frames()).collect();
        let mut k = 0;
        for &(a, b) in &s.segments {
            for i in a..b {
                p2[i] = pos_nav[k];
                q2[i] = att_body[k];
                k += 1;
            }
        }
        return Corrected { pos_nav: p2, att_body: q2, ok };
    }
    Corrected { pos_nav, att_body, ok }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A row read `shift` rows later stays inside its segment [10, 20): row 18 + 1.5 reads
    /// between rows 19 and 20, which is outside; 18 + 1 is row 19 exactly; 19 + 1 is row 20, the
    /// next segment's first, so nothing; 10 − 0.5 reads before the segment, nothing.
    #[test]
    fn a_shifted_row_stays_inside_its_segment() {
        assert_eq!(shifted(18, 1.0, 10, 20), Some((19, 19, 0.0)));
        assert_eq!(shifted(18, 0.25, 10, 20), Some((18, 19, 0.25)));
        assert_eq!(shifted(18, 1.5, 10, 20), None);
        assert_eq!(shifted(19, 1.0, 10, 20), None);
        assert_eq!(shifted(10, -0.5, 10, 20), None);
        assert_eq!(shifted(11, -1.0, 10, 20), Some((10, 10, 0.0)));
    }

    fn model() -> NominalModel {
        NominalModel {
            vehicle: "test".into(),
            mass_kg: 1.0,
            rotor_drag_per_s: [0.0; 2],
            rotor_radius_m: 0.1,
            vbat_ref_v: 3.7,
            gravity_m_s2: 9.81,
            thrust_rel_sd: 0.0,
            imu_range: crate::vehicle::params::ImuRange::x3d(),
            rigid_body: false,
        }
    }

    /// Regression: the glitch detector and the delay correction interpolated attitudes with a
    /// plain nlerp, so a quaternion sign flip between neighbours (same attitude, q vs −q) read as a
    /// ~180° jump: every flip became a "mocap glitch" and a delayed pose there was garbage.
    #[test]
    fn quaternion_sign_flips_are_not_glitches_and_interpolate_correctly() {
        let n = 200;
        // a slow yaw through 180°, each sample with w ≥ 0 as flyarena's mocap gives it: the sign
        // flips once, where the rotation angle passes π
        let yaw = |i: usize| 3.0 + 0.002 * i as f64;
        let att: Vec<UnitQuaternion<f64>> = (0..n)
            .map(|i| {
                let q = UnitQuaternion::from_euler_angles(0.01, -0.02, yaw(i));
                if q.w < 0.0 { UnitQuaternion::new_unchecked(-q.into_inner()) } else { q }
            })
            .collect();
        assert!(att.windows(2).filter(|w| w[0].coords.dot(&w[1].coords) < 0.0).count() == 1, "the test needs one flip");
        let s = Series {
            source: "flips".into(),
            t_s: (0..n).map(|i| i as f64 * 0.005).collect(),
            pos_mocap_nav: (0..n).map(|i| Vec3::new(0.001 * i as f64, 0.0, -1.0)).collect(),
            att_mocap: att.iter().map(|q| Rot::from_quaternion(*q)).collect(),
            mocap_ok: vec![true; n],
            gyro_body: vec![Vec3::zeros(); n],
            accel_body: vec![Vec3::new(0.0, 0.0, -9.81); n],
            thrust_n: None,
            vbat_v: None,
            segments: vec![(0, n)],
            model: model(),
            repairs: vec![],
            clocks: Clocks::default(),
        };
        assert!(
            crate::identify::fit::design::glitches(&s).is_empty(),
            "{:?}",
            crate::identify::fit::design::glitches(&s)
        );
        // half a sample of delay: the attitude halfway between neighbours
        let c = correct(&s, &Corrections { mocap_delay_s: 0.0025, ..Corrections::default() });
        for i in 10..n - 10 {
            let expected = UnitQuaternion::from_euler_angles(0.01, -0.02, yaw(i) + 0.001);
            assert!(
                c.att_body[i].quaternion().angle_to(&expected) < 1e-6,
                "row {i}: {}",
                c.att_body[i].quaternion().angle_to(&expected)
            );
        }
    }

    /// A copy under another name has the same samples; one bit changed in any one stream (a
    /// position, an attitude, a gyro or an accelerometer sample) makes it another flight.
    #[test]
    fn the_same_samples_are_bit_for_bit() {
        let a = Series::swing_for_tests(UnitQuaternion::identity(), 0.01);
        let mut b = a.clone();
        b.source = "copy".into();
        assert!(a.same_samples(&b));
        let nudge = |x: f64| f64::from_bits(x.to_bits() + 1);
        type Change = fn(&mut Series, &dyn Fn(f64) -> f64);
        let changed: [Change; 4] = [
            |s, f| {
                s.pos_mocap_nav[7] =
                    Vec3::new(f(s.pos_mocap_nav[7].x()), s.pos_mocap_nav[7].y(), s.pos_mocap_nav[7].z())
            },
            |s, f| {
                s.att_mocap[7] = Rot::from_quaternion(UnitQuaternion::new_unchecked(nalgebra::Quaternion::new(
                    f(s.att_mocap[7].quaternion().w),
                    0.0,
                    0.0,
                    s.att_mocap[7].quaternion().k,
                )))
            },
            |s, f| s.gyro_body[7] = Vec3::new(s.gyro_body[7].x(), s.gyro_body[7].y(), f(s.gyro_body[7].z())),
            |s, f| s.accel_body[7] = Vec3::new(s.accel_body[7].x(), f(s.accel_body[7].y()), s.accel_body[7].z()),
        ];
        for (k, change) in changed.iter().enumerate() {
            let mut c = a.clone();
            change(&mut c, &nudge);
            assert!(!a.same_samples(&c), "stream {k}");
        }
    }
}

//! Finding the rests (before take-off, the spin-up, after landing) and reading the tilt the
//! accelerometer shows against the markers over each.

use crate::frames::{Body, MocapBody, MocapNav, Nav, Rot, Vec3};
use crate::identify::input::series::Series;

/// The tilt the accelerometer reads against the markers while the vehicle rests on the floor before
/// take-off (the rotation from the gravity the mocap predicts to the one the accelerometer
/// measures, about the body axes level at rest, deg).
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct GroundCheck {
    /// Tilt of the accelerometer's frame against the mocap body frame about the first level axis
    /// (the roll, about x, when z is up; [`UpAxis::level`]), deg.
    pub roll_deg: f64,
    /// Tilt about the second level axis (the pitch, about y, when z is up), deg.
    pub pitch_deg: f64,
    /// Standard error of the mean, from the sample scatter (deg).
    pub roll_se_deg: f64,
    /// Standard error of the pitch mean (deg).
    pub pitch_se_deg: f64,
    /// The body axis nearest the vertical at rest (left out of the JSON when it is z).
    #[serde(skip_serializing_if = "UpAxis::is_z")]
    pub up_axis: UpAxis,
    /// Rows averaged.
    pub samples: usize,
    /// Standard deviation of the mocap's own tilt over these rows, roll and pitch (deg, per
    /// sample): the still vehicle's pose scatter. Markers partly hidden on the floor scatter it
    /// (and may bias it) where a clear view leaves a few thousandths of a degree.
    pub mocap_sd_deg: [f64; 2],
}

impl GroundCheck {
    /// The tilt about level axis `k` (0 the roll, 1 the pitch) and its standard error (deg).
    pub(super) fn axis(&self, k: usize) -> (f64, f64) {
        if k == 0 { (self.roll_deg, self.roll_se_deg) } else { (self.pitch_deg, self.pitch_se_deg) }
    }
}

/// The body axis nearest the vertical while the body rests; the ground check's two tilts are
/// rotations about the other two, in cyclic order ([`UpAxis::level`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum UpAxis {
    /// x up (a rig on its back or front face): tilts about y and z.
    X,
    /// y up (a rig on its side): tilts about z and x.
    Y,
    /// z up (a vehicle on its legs, or upside down): roll about x and pitch about y.
    #[default]
    Z,
}

impl UpAxis {
    /// z is up.
    pub fn is_z(&self) -> bool {
        *self == UpAxis::Z
    }

    /// The body axes the two tilts are about (0 = x, 1 = y, 2 = z), in cyclic order after the
    /// up axis: (x, y) for z, (y, z) for x, (z, x) for y.
    pub fn level(self) -> [usize; 2] {
        let k = self as usize;
        [(k + 1) % 3, (k + 2) % 3]
    }

    /// The names of the two tilts: roll and pitch for z up, else the axes they turn about.
    pub fn tilt_names(self) -> [&'static str; 2] {
        match self {
            UpAxis::Z => ["roll", "pitch"],
            UpAxis::X => ["about y", "about z"],
            UpAxis::Y => ["about z", "about x"],
        }
    }
}

/// A rest the ground check reads: rows [start, end) and the body axis that is up there.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Rest {
    /// First row.
    pub start: usize,
    /// One past the last row.
    pub end: usize,
    /// The body axis nearest the vertical.
    pub up: UpAxis,
}

/// The ground check as the accelerometer reads it, with no bias removed.
pub fn ground_check(s: &Series) -> Option<GroundCheck> {
    tilt_at_rest(s, Vec3::zeros())
}

/// The rotation that takes the direction of `a` to that of `b`, as a rotation vector (rad): axis
/// a × b / |a × b|, angle atan2(|a × b|, a·b), exact at any angle below 180°; zero for parallel
/// (or opposite) vectors. For small angles it is a × b / (|a|·|b|).
pub fn rotation_between(a: &nalgebra::Vector3<f64>, b: &nalgebra::Vector3<f64>) -> nalgebra::Vector3<f64> {
    let c = a.cross(b);
    let n = c.norm();
    if n == 0.0 {
        return nalgebra::Vector3::zeros();
    }
    c * (n.atan2(a.dot(b)) / n)
}

/// The rest before take-off: rows [start, end) inside the first segment, ≥ 0.5 s.
fn rest(s: &Series) -> Option<(usize, usize)> {
    // the log's first pose (without a thrust column, resting is staying at its height)
    let z0 = s.pos_mocap_nav[s.mocap_ok.iter().position(|ok| *ok)?].z();
    let resting = |i: usize| match &s.thrust_n {
        Some(t) => t[i] == 0.0,
        None => (s.pos_mocap_nav[i].z() - z0).abs() < 0.01,
    };
    // the rest before take-off, inside the first segment (the data-quality gate may have cut
    // its start or its end), from its first pose: a log whose mocap starts a frame after its
    // IMU (a stream that is late against the IMU) still rests from there
    let (first, seg_end) = *s.segments.first()?;
    let start = (first..seg_end).find(|&i| s.mocap_ok[i])?;
    if start > 0 && !resting(start) {
        return None;
    }
    let end = (start..seg_end).find(|&i| !resting(i) || !s.mocap_ok[i]).unwrap_or(seg_end);
    // leave the last 0.2 s before the motors start out (spin-up)
    let end = end.saturating_sub((0.2 / s.dt()) as usize).max(start);
    if ((end - start) as f64) * s.dt() < 0.5 {
        return None;
    }
    Some((start, end))
}

/// The rest after landing: the trailing rows of the last segment where the vehicle sits still
/// where it ended (within [`FLOOR_M`] of its last height; with a thrust column also motors off,
/// under 1 % of the weight),
/// from [`SETTLE_AFTER_LANDING_S`] after they begin (the rotors spin down, the legs settle) to the
/// end, ≥ 0.5 s; only if it ended on the floor (its last height within [`LANDED_M`] of the rest
/// before take-off, or [`FLOOR_M`] without a thrust column to say the motors are off) and left the
/// floor in between. A landing spot may sit a centimetre or two off the take-off's.
/// `before` is the rest before take-off's rows ([`rest`]).
fn rest_after_landing(s: &Series, (before, before_end): (usize, usize)) -> Option<(usize, usize)> {
    let floor = s.pos_mocap_nav[before..before_end].iter().map(|p| p.z()).sum::<f64>() / (before_end - before) as f64;
    let (seg_start, end) = *s.segments.last()?;
    let last = s.pos_mocap_nav[end.checked_sub(1)?].z();
    let landed = if s.thrust_n.is_some() { LANDED_M } else { FLOOR_M };
    if (last - floor).abs() > landed {
        return None;
    }
    // motors off: under 1 % of the weight (a thrust model with the rotors' lag decays toward
    // zero without reaching it)
    let off = 0.01 * s.model.mass_kg * s.model.gravity_m_s2;
    let still = |i: usize| {
        s.mocap_ok[i]
            && (s.pos_mocap_nav[i].z() - last).abs() < FLOOR_M
            && s.thrust_n.as_ref().is_none_or(|t| t[i] < off)
    };
    let mut start = end;
    while start > seg_start.max(before_end) && still(start - 1) {
        start -= 1;
    }
    // it flew in between: a row off the floor (or with the motors on) before the trailing run
    if !(before_end..start).any(|i| !still(i)) {
        return None;
    }
    let start = start + (SETTLE_AFTER_LANDING_S / s.dt()).round() as usize;
    if start >= end || ((end - start) as f64) * s.dt() < 0.5 {
        return None;
    }
    Some((start, end))
}

/// The ground check again after landing, with `accel_bias` removed as for the rest before.
/// Its tilts are about the level axes of the rest before take-off.
pub fn tilt_after_landing(s: &Series, accel_bias: Vec3<Body>) -> Option<GroundCheck> {
    let (before, Rest { up, .. }) = checked_rest(s)?;
    let (start, end) = rest_after_landing(s, before)?;
    let (start, end) = still_accel(s, start, end)?;
    Some(tilt_over(s, Rest { start, end, up }, accel_bias))
}

/// A still vehicle's accelerometer reads the same specific force row after row, its noise aside.
/// An IMU stream that ramps or jumps while the markers sit still (a logger that extrapolates a
/// dead sensor: the last 0.2 s of B6 linear ramp 2 drift by 0.1 g, and a published NanoBench
/// flight ramps to 4 g after landing) is no rest, and its
/// tilt would be a number made of corrupted samples. Keeps the longest run of rows within
/// `max(`[`REST_ACCEL_TOL_M_S2`]`, 8·σ)` of the rows' component-wise median on every axis, σ the
/// sample-to-sample noise (median |first difference|·1.4826/√2, largest axis: a ramp or a step
/// does not inflate it); `None` when under 0.5 s remain.
fn still_accel(s: &Series, start: usize, end: usize) -> Option<(usize, usize)> {
    // (fewer than 2 rows are no 0.5 s run: None below)
    let f = &crate::identify::input::series::raw_vecs(&s.accel_body[start..end]);
    let median = |v: Vec<f64>| crate::identify::fit::stats::median(v).unwrap_or(0.0);
    let mid = nalgebra::Vector3::from_fn(|k, _| median(f.iter().map(|x| x[k]).collect()));
    let sigma = (0..3)
        .map(|k| median(f.windows(2).map(|w| (w[1][k] - w[0][k]).abs()).collect()) * 1.4826 / std::f64::consts::SQRT_2)
        .fold(0.0, f64::max);
    let tol = REST_ACCEL_TOL_M_S2.max(8.0 * sigma);
    let (mut best, mut run_start) = ((0, 0), 0);
    for i in 0..=f.len() {
        // (a non-finite reading is not still either)
        if i == f.len() || !(f[i] - mid).iter().all(|d| d.abs() <= tol) {
            if i - run_start > best.1 - best.0 {
                best = (run_start, i);
            }
            run_start = i + 1;
        }
    }
    ((best.1 - best.0) as f64 * s.dt() >= 0.5).then_some((start + best.0, start + best.1))
}

/// Rows of a rest whose specific force strays further than this from the rest's median (on any
/// axis, m/s²) are not still: 0.01 g, 0.6° of tilt, which a vehicle sitting on the floor does
/// not turn by; 10–20 times the Crazyflie's sample-to-sample noise at rest (σ 0.005–0.01 m/s²
/// on the NanoBench flights), and a noisier IMU widens it to 8 σ.
pub const REST_ACCEL_TOL_M_S2: f64 = 0.098;

/// Still: within this height of where it ended (m); without a thrust column, also the landed
/// tolerance.
pub const FLOOR_M: f64 = 0.01;
/// Landed: its last height within this of the rest before take-off (m), motors off.
pub const LANDED_M: f64 = 0.05;
/// Rows this long after landing are left out of the rest after it (s).
pub const SETTLE_AFTER_LANDING_S: f64 = 0.5;

/// The specific force the mocap predicts at rest in the marker frame, f̂ = R_mᵀ·(−g·e_D) (m/s²).
fn predicted_at_rest(s: &Series, i: usize) -> nalgebra::Vector3<f64> {
    s.att_mocap[i].quaternion().inverse_transform_vector(&nalgebra::Vector3::new(0.0, 0.0, -s.model.gravity_m_s2))
}

/// The body axis nearest the vertical over rows [start, end) and how far from it the vertical is
/// (deg): the mean of the up direction the mocap gives, R_mᵀ·(−e_D), against its largest
/// component's axis.
fn up_over(s: &Series, start: usize, end: usize) -> (UpAxis, f64) {
    let up = (start..end)
        .map(|i| s.att_mocap[i].quaternion().inverse_transform_vector(&-nalgebra::Vector3::z()))
        .sum::<nalgebra::Vector3<f64>>();
    let k = up.iamax();
    let mut axis = nalgebra::Vector3::zeros();
    axis[k] = up[k].signum();
    let up_axis = [UpAxis::X, UpAxis::Y, UpAxis::Z][k];
    (up_axis, up.angle(&axis).to_degrees())
}

/// How far the vertical is from the body axis nearest it at rest (deg, the mean over the rest):
/// 0 for a vehicle level on its legs or a rig lying on any face, at most 54.7° (the vertical
/// along a body diagonal). `None` without a rest.
pub fn rest_off_axis_deg(s: &Series) -> Option<f64> {
    rest(s).map(|(start, end)| up_over(s, start, end).1)
}

/// The rest beyond which the ground check is left out (deg between the vertical and the body axis
/// nearest it): its two tilts are rotations about the other two body axes, and a vertical far
/// from every axis leaves neither of them level, so gravity shows only a mix of them.
pub const MAX_REST_OFF_AXIS_DEG: f64 = 30.0;

/// The rest before take-off as the ground check reads it: its still rows (the longest run the
/// accelerometer holds still) and its up axis. `None` without a rest, or when the vertical is
/// more than [`MAX_REST_OFF_AXIS_DEG`] from every body axis there.
pub fn rest_before_takeoff(s: &Series) -> Option<Rest> {
    checked_rest(s).map(|(_, r)| r)
}

/// The rest before take-off in one scan: its rows as [`rest`] finds them (the spin-up and the
/// rest after landing measure heights from them) and [`rest_before_takeoff`]'s still rows.
fn checked_rest(s: &Series) -> Option<((usize, usize), Rest)> {
    let (start, end) = rest(s)?;
    let (up, off) = up_over(s, start, end);
    if off > MAX_REST_OFF_AXIS_DEG {
        return None;
    }
    let (a, b) = still_accel(s, start, end)?;
    Some(((start, end), Rest { start: a, end: b, up }))
}

/// The ground check with an accelerometer bias `accel_bias` (m/s², IMU body) removed from
/// every sample first: the rotation from f̂ to f − b. `None` without a rest
/// ([`rest_before_takeoff`]).
pub fn tilt_at_rest(s: &Series, accel_bias: Vec3<Body>) -> Option<GroundCheck> {
    rest_before_takeoff(s).map(|r| tilt_over(s, r, accel_bias))
}

/// The tilt a model of the frames predicts over `rest`'s rows, about its level axes (rad): the
/// mean of the rotation from f̂_i to the specific force the model says the IMU reads there,
/// f_i = O·R_m,iᵀ·W·(−g·e_D) + b, with O the body offset (marker frame → IMU frame), W the world
/// tilt (the mocap world's gravity direction W·e_D) and b the accelerometer bias: the IMU's
/// attitude is C = W⁻¹·R_m·O⁻¹ and at rest it reads Cᵀ·(−g·e_D) + b. The ground check reads the
/// same rotation with the measured f, so the two compare exactly, whatever an offset's yaw does
/// to the direction of its tilt.
pub fn predicted_tilt(
    s: &Series,
    rest: &Rest,
    offset: &Rot<MocapBody, Body>,
    world: &Rot<Nav, MocapNav>,
    accel_bias: Vec3<Body>,
) -> [f64; 2] {
    let down: Vec3<MocapNav> = world.apply(Vec3::new(0.0, 0.0, -s.model.gravity_m_s2));
    let [a, b] = rest.up.level();
    let mut sum = [0.0; 2];
    for i in rest.start..rest.end {
        let f = offset.apply(s.att_mocap[i].inverse().apply(down)) + accel_bias;
        let d = rotation_between(&predicted_at_rest(s, i), f.raw());
        sum = [sum[0] + d[a], sum[1] + d[b]];
    }
    let m = (rest.end - rest.start) as f64;
    sum.map(|x| x / m)
}

/// The rotation from f̂ to f − b averaged over `rest`'s rows (≥ 2 rows), about its level axes,
/// with its standard error.
fn tilt_over(s: &Series, rest: Rest, accel_bias: Vec3<Body>) -> GroundCheck {
    let Rest { start, end, up } = rest;
    let [a, b] = up.level();
    // the up axis as a signed unit vector of the body (−z for a vehicle on its legs)
    let mut axis_up = nalgebra::Vector3::zeros();
    axis_up[up as usize] = predicted_at_rest(s, start)[up as usize].signum();
    let mut rp: Vec<(f64, f64)> = Vec::with_capacity(end - start);
    // the mocap's tilt alone: the rotation from the up axis to f̂'s direction
    let mut mocap: Vec<[f64; 2]> = Vec::with_capacity(end - start);
    for i in start..end {
        let f_hat = predicted_at_rest(s, i);
        let d = rotation_between(&f_hat, (s.accel_body[i] - accel_bias).raw());
        rp.push((d[a], d[b]));
        let u = rotation_between(&axis_up, &f_hat);
        mocap.push([u[a], u[b]]);
    }
    let mocap_sd_deg = [0, 1].map(|k| {
        let m = mocap.len() as f64;
        let mean = mocap.iter().map(|x| x[k]).sum::<f64>() / m;
        (mocap.iter().map(|x| (x[k] - mean).powi(2)).sum::<f64>() / (m - 1.0)).sqrt().to_degrees()
    });
    let m = rp.len() as f64;
    let (mr, mp) = rp.iter().fold((0.0, 0.0), |a, x| (a.0 + x.0 / m, a.1 + x.1 / m));
    let (vr, vp) =
        rp.iter().fold((0.0, 0.0), |a, x| (a.0 + (x.0 - mr).powi(2) / (m - 1.0), a.1 + (x.1 - mp).powi(2) / (m - 1.0)));
    GroundCheck {
        roll_deg: mr.to_degrees(),
        pitch_deg: mp.to_degrees(),
        roll_se_deg: (vr / m).sqrt().to_degrees(),
        pitch_se_deg: (vp / m).sqrt().to_degrees(),
        up_axis: up,
        samples: rp.len(),
        mocap_sd_deg,
    }
}

/// The spin-up: the motors on, the vehicle still on the floor. Between the rest and the lift-off
/// the rotors spin at a fraction of hover thrust while the floor holds the vehicle still, so the
/// accelerometer reads the same frame tilt as at rest *plus* whatever spinning rotors add to it —
/// a DC offset from vibration (rectification in the sensor or its filter), a frame or an IMU
/// mount that bends under thrust. In flight all of that reads as a tilt (an offset that grows
/// with thrust points like the thrust, and a hover cannot tell it from a turned frame), so the
/// spin-up is the ground check to compare a flight with when the two ground checks differ.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct SpinUp {
    /// The tilt with the motors on (bias removed as for the agreement's ground check).
    pub check: GroundCheck,
    /// Mean thrust over the rows, as a fraction of the weight m·g.
    pub thrust_fraction: f64,
    /// Length of the spin-up rows (s).
    pub duration_s: f64,
}

/// Spin-up rows: from [`SPIN_UP_SKIP_S`] after the first row with thrust until the vehicle leaves
/// the floor (more than [`LIFT_M`] above its rest height), the mocap drops or the segment ends.
/// Needs a thrust column and the rest before it; `None` when fewer than [`SPIN_UP_MIN_S`] remain.
pub fn spin_up(s: &Series, accel_bias: Vec3<Body>) -> Option<SpinUp> {
    let thrust = s.thrust_n.as_ref()?;
    let ((start, _), Rest { up, .. }) = checked_rest(s)?;
    let seg_end = s.segments.first()?.1;
    let on = (start..seg_end).find(|&i| thrust[i] > 0.0)?;
    let z_rest = s.pos_mocap_nav[start..on].iter().map(|p| p.z()).sum::<f64>() / (on - start) as f64;
    let from = on + (SPIN_UP_SKIP_S / s.dt()).round() as usize;
    let to = (from..seg_end)
        .find(|&i| thrust[i] <= 0.0 || !s.mocap_ok[i] || (s.pos_mocap_nav[i].z() - z_rest).abs() > LIFT_M)
        .unwrap_or(seg_end);
    if to <= from || ((to - from) as f64) * s.dt() < SPIN_UP_MIN_S {
        return None;
    }
    let weight = s.model.mass_kg * s.model.gravity_m_s2;
    Some(SpinUp {
        check: tilt_over(s, Rest { start: from, end: to, up }, accel_bias),
        thrust_fraction: thrust[from..to].iter().sum::<f64>() / (to - from) as f64 / weight,
        duration_s: (to - from) as f64 * s.dt(),
    })
}

/// The first rows after the motors start are left out: the rotors accelerate and the vehicle
/// settles on its legs (s).
pub const SPIN_UP_SKIP_S: f64 = 0.05;
/// Shorter spin-ups are not used (s): at 100 Hz the mean of fewer rows scatters by > 0.2°.
pub const SPIN_UP_MIN_S: f64 = 0.3;
/// Above this height over the rest the vehicle has left the floor (m).
pub const LIFT_M: f64 = 0.003;

//! An independent check of the roll/pitch misalignment: the vehicle resting on the floor before
//! take-off. There the accelerometer reads f = −g·C_n^b·e_D in the IMU frame and the mocap
//! predicts f̂ = −g·R_mᵀ·e_D in the marker frame; the rotation from f̂ to f ([`rotation_between`]:
//! axis f̂ × f, angle atan2(|f̂ × f|, f̂·f), exact at any size) is the marker offset's tilt (its
//! rotation about the vertical is unobservable at rest). Its two components are about the body
//! axes that are level at rest ([`UpAxis`]: roll and pitch for a vehicle on its legs, z up; a rig
//! may rest with any axis up); a body whose nearest axis is more than [`MAX_REST_OFF_AXIS_DEG`]
//! from the vertical gets no ground check. The flight's side is the same rotation between f̂ and
//! the f the fitted frames predict ([`predicted_tilt`]), so the two compare like with like
//! whatever the sizes of the offset, the world tilt and the bias.
//!
//! It assumes no accelerometer bias: a bias b reads as a tilt of b/g rad (0.1 m/s² ≈ 0.58°), and
//! the check cannot tell them apart. It needs ≥ 0.5 s of rest (thrust zero, or within 1 cm of
//! the floor without a thrust column).
//!
//! Two more readings of the same tilt bracket the flight: the spin-up ([`spin_up`]: motors on,
//! still on the floor) and the rest after landing ([`tilt_after_landing`]: still again, motors
//! off). The rests before and after tell how far the reference itself moves over one flight;
//! their mean is the reference of a tilt that moves between them ([`LandedAxis`]). The mocap's
//! own tilt scatter at rest ([`GroundCheck::mocap_sd_deg`]) tells a still pose that the
//! cameras see badly.

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
    let median = |v: Vec<f64>| super::stats::median(v).unwrap_or(0.0);
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

/// One axis of [`GroundAgreement`] (degrees at this edge).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct TiltAgreement {
    /// The ground check as measured.
    pub ground_deg: f64,
    /// The tilt that the fitted accelerometer bias reads as at rest (b_y/g for roll, −b_x/g for
    /// pitch; 0 when no bias was fitted).
    pub bias_tilt_deg: f64,
    /// The ground check with the fitted bias removed: the accelerometer's tilt against the markers.
    pub ground_corrected_deg: f64,
    /// The flight's frame tilt at rest: its body offset plus its world tilt as seen at the rest
    /// yaw (0 when neither was selected: the model then says "no offset").
    pub flight_deg: f64,
    /// ground_corrected − flight = ground − (offset + bias tilt).
    pub difference_deg: f64,
    /// 95 % half-width of the difference: the ground's scatter and the flight's covariance of
    /// offset + bias tilt (the combination a hover determines, far better than either part),
    /// widened where the flight cannot tell two models apart.
    pub ci95_deg: f64,
    /// |difference| ≤ ci95, and the bias tilt is one a sensor can have (|bias tilt| ≤
    /// asin(2 m/s² / g) = 11.8°): a rotation of 100° at rest never agrees because a bias of 1.6 g
    /// explains it away.
    pub covers: bool,
}

/// The largest tilt an accelerometer bias can read as at rest (deg): asin(b_max/g) for the
/// largest bias a sensor has ([`MAX_ACCEL_BIAS_M_S2`](crate::effects::MAX_ACCEL_BIAS_M_S2)).
pub fn max_bias_tilt_deg() -> f64 {
    (crate::effects::MAX_ACCEL_BIAS_M_S2 / crate::vehicle::params::GRAVITY).asin().to_degrees()
}

/// The ground check against the flight's model. At rest the accelerometer reads
/// f = −g·C·e_D + b, so the ground check sees the frame tilt (body offset δ, and a world tilt
/// turned by the rest yaw) *plus* the tilt b/g of a bias: the two are compared as ground − b/g
/// against the frame tilt (equivalently ground against frame tilt + b/g).
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct GroundAgreement {
    /// Roll: ground − bias tilt against the flight's frame tilt.
    pub roll: TiltAgreement,
    /// Pitch: ground − bias tilt against the flight's frame tilt.
    pub pitch: TiltAgreement,
    /// A body offset or a world tilt was selected (or forced).
    pub frame_fitted: bool,
    /// An accelerometer bias was selected (its tilt b/g is removed from the ground check).
    pub accel_bias_fitted: bool,
    /// The same comparison with the spin-up (motors on, still on the floor) as the ground check,
    /// when the log has one.
    pub spin_up: Option<SpinUpAgreement>,
    /// The rest after landing against the rest before and against the flight, when the log has
    /// one.
    pub after_landing: Option<LandedAgreement>,
    /// The still vehicle's mocap tilt scatter at rest, roll and pitch (deg per sample;
    /// [`GroundCheck::mocap_sd_deg`]).
    pub rest_pose_sd_deg: [f64; 2],
    /// The still pose scatters in roll by more than [`STILL_POSE_SD_DEG`]: the cameras see the
    /// markers badly at rest, and the rest's tilt is not a reliable reference.
    pub rest_pose_scatters: bool,
    /// The body axis nearest the vertical at rest: roll and pitch are the tilts about the other
    /// two ([`UpAxis::level`]; left out of the JSON when it is z).
    #[serde(skip_serializing_if = "UpAxis::is_z")]
    pub up_axis: UpAxis,
}

/// A still vehicle's mocap roll that scatters by more than this per sample (deg) is a pose the
/// cameras see badly at rest: a marker hidden near the floor, the fit flickering between
/// subsets of markers. On the ten shared NanoBench flights a clear view scatters by
/// 0.005–0.014°, and the three flights above 0.09° were the ones whose two rests both disagree
/// with the flight in roll. The threshold was set there; on 68 held-out flights (docs/nanobench.md, *A still
/// pose that scatters*, with its caveat) the ground check disagrees with the flight by a median
/// 0.33° in roll above it and 0.08° below it, one-sided Mann–Whitney p = 1·10⁻⁴.
pub const STILL_POSE_SD_DEG: f64 = 0.02;

/// The rest after landing: a second ground check that brackets the flight with the first.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct LandedAgreement {
    /// Rows averaged after landing.
    pub samples: usize,
    /// Roll after landing.
    pub roll: LandedAxis,
    /// Pitch after landing.
    pub pitch: LandedAxis,
}

/// One axis of [`LandedAgreement`] (degrees at this edge): the second rest checked as the
/// spin-up is ([`CheckAxis`]), and the two rests' mean against the flight.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct LandedAxis {
    /// The tilt after landing against the rest before take-off and against the flight. Its
    /// change, after − before, is how far the accelerometer's tilt against the markers moved
    /// over the flight (a bias that drifts as the IMU warms, a mount that creeps, markers
    /// bumped).
    #[serde(flatten)]
    pub check: CheckAxis,
    /// The two rests' mean − flight: the reference for a tilt that moves between the rests (a
    /// monotonic drift puts the flight's average between them).
    pub bracket_difference_deg: f64,
    /// 95 % half-width: the two means' and the flight's scatter, plus half the change (the
    /// flight's tilt may sit anywhere between the rests), plus the flight's widening.
    pub bracket_ci95_deg: f64,
    /// The bracket's interval covers zero.
    pub bracket_covers: bool,
}

/// The spin-up against the rest and against the flight.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct SpinUpAgreement {
    /// Mean thrust over the spin-up as a fraction of the weight.
    pub thrust_fraction: f64,
    /// Length of the spin-up rows (s).
    pub duration_s: f64,
    /// Roll during the spin-up.
    pub roll: CheckAxis,
    /// Pitch during the spin-up.
    pub pitch: CheckAxis,
}

/// One axis of a ground check other than the rest before take-off (the spin-up, the rest
/// after landing), against that rest and against the flight (degrees at this edge).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct CheckAxis {
    /// The check's tilt with the fitted bias removed.
    pub ground_corrected_deg: f64,
    /// Check − rest before take-off: for the spin-up what the spinning rotors add to the
    /// accelerometer's tilt, after landing what moved over the flight.
    pub change_deg: f64,
    /// 95 % half-width of the change (the two means' standard errors).
    pub change_ci95_deg: f64,
    /// Check − flight frame tilt.
    pub difference_deg: f64,
    /// 95 % half-width of that difference, built as the rest's.
    pub ci95_deg: f64,
    /// The interval covers zero: the check agrees with the flight.
    pub covers: bool,
}

impl CheckAxis {
    /// A check's tilt `on` (its standard error `on_se`) against the rest before take-off
    /// (`rest`, standard error `rest_se`) and the flight, whose frame tilt scatters by
    /// `sd_flight` and is widened by `widen` (degrees).
    fn new(on: f64, on_se: f64, rest: &TiltAgreement, rest_se: f64, sd_flight: f64, widen: f64) -> CheckAxis {
        let difference = on - rest.flight_deg;
        let ci95 = (Z * on_se).hypot(Z * sd_flight) + widen;
        CheckAxis {
            ground_corrected_deg: on,
            change_deg: on - rest.ground_corrected_deg,
            change_ci95_deg: Z * on_se.hypot(rest_se),
            difference_deg: difference,
            ci95_deg: ci95,
            covers: difference.abs() <= ci95,
        }
    }
}

/// Z_{0.975}
const Z: f64 = 1.959963984540054;

/// The flight's side of the agreement: its frame tilt at rest (body offset + world tilt, roll and
/// pitch), what it fitted.
#[derive(Clone, Copy, Debug)]
pub struct FlightTilt {
    /// The frame tilt (rad).
    pub offset_rad: [f64; 2],
    /// Standard deviation of offset + bias tilt (rad).
    pub sd_rad: [f64; 2],
    /// Extra half-width from models the flight cannot tell apart (rad).
    pub widen_rad: [f64; 2],
    /// A body offset or a world tilt was fitted.
    pub frame_fitted: bool,
    /// An accelerometer bias was fitted.
    pub accel_bias_fitted: bool,
}

/// Builds the agreement from the raw ground check, the bias-corrected one, the flight's tilt, and
/// the spin-up and the rest after landing (both bias-corrected), where the log has them.
pub fn agreement(
    raw: &GroundCheck,
    corrected: &GroundCheck,
    flight: &FlightTilt,
    spin: Option<&SpinUp>,
    landed: Option<&GroundCheck>,
) -> GroundAgreement {
    let FlightTilt { offset_rad, sd_rad, widen_rad, frame_fitted, accel_bias_fitted } = *flight;
    let axis = |k: usize| {
        let (g, gc, se) = if k == 0 {
            (raw.roll_deg, corrected.roll_deg, raw.roll_se_deg)
        } else {
            (raw.pitch_deg, corrected.pitch_deg, raw.pitch_se_deg)
        };
        let flight = offset_rad[k].to_degrees();
        let difference = gc - flight;
        let ci95 = (Z * se).hypot(Z * sd_rad[k].to_degrees()) + widen_rad[k].to_degrees();
        TiltAgreement {
            ground_deg: g,
            bias_tilt_deg: g - gc,
            ground_corrected_deg: gc,
            flight_deg: flight,
            difference_deg: difference,
            ci95_deg: ci95,
            covers: difference.abs() <= ci95 && (g - gc).abs() <= max_bias_tilt_deg(),
        }
    };
    let (roll, pitch) = (axis(0), axis(1));
    let spin_up = spin.map(|sp| {
        let spin_axis = |k: usize, rest: &TiltAgreement| {
            let (on, on_se, rest_se) = if k == 0 {
                (sp.check.roll_deg, sp.check.roll_se_deg, corrected.roll_se_deg)
            } else {
                (sp.check.pitch_deg, sp.check.pitch_se_deg, corrected.pitch_se_deg)
            };
            CheckAxis::new(on, on_se, rest, rest_se, sd_rad[k].to_degrees(), widen_rad[k].to_degrees())
        };
        SpinUpAgreement {
            thrust_fraction: sp.thrust_fraction,
            duration_s: sp.duration_s,
            roll: spin_axis(0, &roll),
            pitch: spin_axis(1, &pitch),
        }
    });
    let after_landing = landed.map(|l| {
        let landed_axis = |k: usize, rest: &TiltAgreement| {
            let (after, after_se, rest_se) = if k == 0 {
                (l.roll_deg, l.roll_se_deg, corrected.roll_se_deg)
            } else {
                (l.pitch_deg, l.pitch_se_deg, corrected.pitch_se_deg)
            };
            let (sd_flight, widen) = (sd_rad[k].to_degrees(), widen_rad[k].to_degrees());
            let check = CheckAxis::new(after, after_se, rest, rest_se, sd_flight, widen);
            let bracket = 0.5 * (after + rest.ground_corrected_deg) - rest.flight_deg;
            let bracket_ci95 =
                (Z * 0.5 * after_se.hypot(rest_se)).hypot(Z * sd_flight) + 0.5 * check.change_deg.abs() + widen;
            LandedAxis {
                check,
                bracket_difference_deg: bracket,
                bracket_ci95_deg: bracket_ci95,
                bracket_covers: bracket.abs() <= bracket_ci95,
            }
        };
        LandedAgreement { samples: l.samples, roll: landed_axis(0, &roll), pitch: landed_axis(1, &pitch) }
    });
    GroundAgreement {
        roll,
        pitch,
        frame_fitted,
        accel_bias_fitted,
        spin_up,
        after_landing,
        rest_pose_sd_deg: raw.mocap_sd_deg,
        rest_pose_scatters: raw.mocap_sd_deg[0] > STILL_POSE_SD_DEG,
        up_axis: raw.up_axis,
    }
}

/// Over several flights: is the rest or the spin-up the ground check a flight agrees with, per
/// axis? If the spinning rotors add an offset that the flights carry too (in flight it reads as a
/// tilt), the spin-up moves the ground check toward the flight: the sign test counts the flights
/// where spin-up − rest points the way flight − rest does (p: one-sided binomial, ½ under "the
/// change is unrelated to the flight").
#[derive(Clone, Debug, serde::Serialize)]
pub struct SpinUpSummary {
    /// Flights with a spin-up.
    pub flights: usize,
    /// Roll over the flights.
    pub roll: SpinUpAxisSummary,
    /// Pitch over the flights.
    pub pitch: SpinUpAxisSummary,
}

/// One axis of [`SpinUpSummary`] (degrees).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct SpinUpAxisSummary {
    /// Median |rest − bias tilt − flight| over the flights with a spin-up.
    pub median_rest_deg: f64,
    /// Median |spin-up − bias tilt − flight|.
    pub median_spin_up_deg: f64,
    /// Flights where the spin-up's change points toward the flight.
    pub toward_flight: usize,
    /// P(≥ toward_flight of `flights` by chance), each flight ½.
    pub sign_test_p: f64,
}

/// The summary over the agreements that have a spin-up; `None` when fewer than 3 do.
pub fn spin_up_summary<'a>(agreements: impl IntoIterator<Item = &'a GroundAgreement>) -> Option<SpinUpSummary> {
    let pairs: Vec<(&GroundAgreement, &SpinUpAgreement)> =
        agreements.into_iter().filter_map(|a| Some((a, a.spin_up.as_ref()?))).collect();
    let n = pairs.len();
    if n < 3 {
        return None;
    }
    let axis = |pick: fn(&GroundAgreement) -> &TiltAgreement, pick_spin: fn(&SpinUpAgreement) -> &CheckAxis| {
        let rest: Vec<f64> = pairs.iter().map(|(a, _)| pick(a).difference_deg.abs()).collect();
        let spin: Vec<f64> = pairs.iter().map(|(_, sp)| pick_spin(sp).difference_deg.abs()).collect();
        // the flight lies at rest − difference: toward it is a change of the opposite sign
        let toward = pairs.iter().filter(|(a, sp)| pick_spin(sp).change_deg * pick(a).difference_deg < 0.0).count();
        SpinUpAxisSummary {
            median_rest_deg: super::stats::median(rest).unwrap_or(f64::NAN),
            median_spin_up_deg: super::stats::median(spin).unwrap_or(f64::NAN),
            toward_flight: toward,
            sign_test_p: binomial_upper_tail(n, toward),
        }
    };
    Some(SpinUpSummary { flights: n, roll: axis(|a| &a.roll, |s| &s.roll), pitch: axis(|a| &a.pitch, |s| &s.pitch) })
}

/// Over several flights: the two rests that bracket each flight, against each other and
/// against the flight (degrees). The reference of a flight is the mean of its rests where the
/// log has both, else the rest before take-off.
#[derive(Clone, Debug, serde::Serialize)]
pub struct LandedSummary {
    /// Flights with a ground agreement, and those with a rest after landing too.
    pub flights: usize,
    /// Flights with both rests.
    pub with_both: usize,
    /// Roll over the flights.
    pub roll: LandedAxisSummary,
    /// Pitch over the flights.
    pub pitch: LandedAxisSummary,
}

/// One axis of [`LandedSummary`].
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct LandedAxisSummary {
    /// Median and largest |after − before| over the flights with both rests: the ground check's
    /// own repeatability over one flight.
    pub median_change_deg: f64,
    /// Largest |after − before|.
    pub max_change_deg: f64,
    /// Over the flights with both rests: median |before − flight| and |mean of the rests − flight|.
    pub median_before_deg: f64,
    /// Median |mean of the two rests − flight|.
    pub median_bracket_deg: f64,
    /// Flights whose frame tilt lies between their two rests (their differences of opposite sign).
    pub between: usize,
    /// Over every flight, with its reference: median |reference − flight|, how many beyond 1°,
    /// and how many of those the reference's interval covers.
    pub median_reference_deg: f64,
    /// Flights whose |reference − flight| exceeds 1°.
    pub beyond_1deg: usize,
    /// Of those, the ones whose interval covers the difference.
    pub beyond_1deg_covered: usize,
}

/// The summary over the agreements; `None` when fewer than 3 have a rest after landing.
pub fn landed_summary<'a>(agreements: impl IntoIterator<Item = &'a GroundAgreement>) -> Option<LandedSummary> {
    let all: Vec<&GroundAgreement> = agreements.into_iter().collect();
    let both: Vec<(&GroundAgreement, &LandedAgreement)> =
        all.iter().filter_map(|a| Some((*a, a.after_landing.as_ref()?))).collect();
    if both.len() < 3 {
        return None;
    }
    let median = |v: Vec<f64>| super::stats::median(v).unwrap_or(f64::NAN);
    let axis = |pick: fn(&GroundAgreement) -> &TiltAgreement, pick_l: fn(&LandedAgreement) -> &LandedAxis| {
        let reference = |a: &GroundAgreement| match &a.after_landing {
            Some(l) => (pick_l(l).bracket_difference_deg, pick_l(l).bracket_covers),
            None => (pick(a).difference_deg, pick(a).covers),
        };
        let beyond: Vec<(f64, bool)> = all.iter().map(|a| reference(a)).filter(|(d, _)| d.abs() > 1.0).collect();
        LandedAxisSummary {
            median_change_deg: median(both.iter().map(|(_, l)| pick_l(l).check.change_deg.abs()).collect()),
            max_change_deg: both.iter().map(|(_, l)| pick_l(l).check.change_deg.abs()).fold(0.0, f64::max),
            median_before_deg: median(both.iter().map(|(a, _)| pick(a).difference_deg.abs()).collect()),
            median_bracket_deg: median(both.iter().map(|(_, l)| pick_l(l).bracket_difference_deg.abs()).collect()),
            // before − flight and after − flight of opposite signs
            between: both.iter().filter(|(a, l)| pick(a).difference_deg * pick_l(l).check.difference_deg < 0.0).count(),
            median_reference_deg: median(all.iter().map(|a| reference(a).0.abs()).collect()),
            beyond_1deg: beyond.len(),
            beyond_1deg_covered: beyond.iter().filter(|(_, c)| *c).count(),
        }
    };
    Some(LandedSummary {
        flights: all.len(),
        with_both: both.len(),
        roll: axis(|a| &a.roll, |l| &l.roll),
        pitch: axis(|a| &a.pitch, |l| &l.pitch),
    })
}

/// Over several flights: do the flights whose still pose scatters at rest
/// ([`GroundAgreement::rest_pose_scatters`]) disagree with the ground check more than the
/// others? Per axis, the median |rest − bias tilt − flight| of each group, the flights beyond 1°
/// (and how many of them their interval covers), and the one-sided Mann–Whitney p of "the
/// scattering flights' differences are larger" (normal approximation, ties averaged).
#[derive(Clone, Debug, serde::Serialize)]
pub struct RestPoseSummary {
    /// Flights whose still pose scatters.
    pub scattering: usize,
    /// Flights whose still pose does not.
    pub still: usize,
    /// Roll over the two groups.
    pub roll: RestPoseAxisSummary,
    /// Pitch over the two groups.
    pub pitch: RestPoseAxisSummary,
}

/// One axis of [`RestPoseSummary`] (degrees).
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct RestPoseAxisSummary {
    /// Median |difference| over the still flights.
    pub median_still_deg: f64,
    /// Median |difference| over the scattering flights.
    pub median_scattering_deg: f64,
    /// Still flights beyond 1°.
    pub still_beyond_1deg: usize,
    /// Of those, the ones whose interval covers the difference.
    pub still_beyond_1deg_covered: usize,
    /// Scattering flights beyond 1°.
    pub scattering_beyond_1deg: usize,
    /// One-sided Mann–Whitney p (normal approximation, ties averaged).
    pub mann_whitney_p: f64,
}

/// The summary; `None` unless both groups have at least 2 flights.
pub fn rest_pose_summary<'a>(agreements: impl IntoIterator<Item = &'a GroundAgreement>) -> Option<RestPoseSummary> {
    let all: Vec<&GroundAgreement> = agreements.into_iter().collect();
    let (hi, lo): (Vec<&GroundAgreement>, Vec<&GroundAgreement>) = all.iter().partition(|a| a.rest_pose_scatters);
    if hi.len() < 2 || lo.len() < 2 {
        return None;
    }
    let median = |v: Vec<f64>| super::stats::median(v).unwrap_or(f64::NAN);
    let axis = |pick: fn(&GroundAgreement) -> &TiltAgreement| {
        let d = |g: &[&GroundAgreement]| g.iter().map(|a| pick(a).difference_deg.abs()).collect::<Vec<f64>>();
        let beyond = |g: &[&GroundAgreement]| {
            g.iter().filter(|a| pick(a).difference_deg.abs() > 1.0).map(|a| pick(a).covers).collect::<Vec<bool>>()
        };
        RestPoseAxisSummary {
            median_still_deg: median(d(&lo)),
            median_scattering_deg: median(d(&hi)),
            still_beyond_1deg: beyond(&lo).len(),
            still_beyond_1deg_covered: beyond(&lo).iter().filter(|c| **c).count(),
            scattering_beyond_1deg: beyond(&hi).len(),
            mann_whitney_p: mann_whitney_greater(&d(&hi), &d(&lo)),
        }
    };
    Some(RestPoseSummary { scattering: hi.len(), still: lo.len(), roll: axis(|a| &a.roll), pitch: axis(|a| &a.pitch) })
}

/// Pooled samples up to this size get the exact permutation distribution of U; larger ones the
/// normal approximation (R's `wilcox.test` draws the line at 50 too).
pub(crate) const MANN_WHITNEY_EXACT_MAX_N: usize = 50;

/// One-sided Mann–Whitney test that `a` tends to be larger than `b`: U = R_a − n_a(n_a + 1)/2
/// (R_a the rank sum of `a` in the pooled sample, ties given their average rank); returns
/// P(U′ ≥ U) under "both come from one distribution", where every choice of n_a of the pooled
/// ranks for `a` is equally likely.
///
/// Up to [`MANN_WHITNEY_EXACT_MAX_N`] pooled samples that probability is exact: the number of
/// n_a-subsets of the (mid)ranks with each rank sum, counted by dynamic programming over doubled
/// ranks (integers even with ties), divided by C(n, n_a); 3 against 6 has 84 subsets, so its
/// smallest p is 1/84. Above it, U ~ N(n_a·n_b/2, n_a·n_b·(n + 1)/12 − tie term), P(Z ≥ z) (no
/// continuity correction), through χ²₁: P(Z ≥ z) = ½·P(χ²₁ ≥ z²) for z ≥ 0.
pub(crate) fn mann_whitney_greater(a: &[f64], b: &[f64]) -> f64 {
    let (na, nb) = (a.len() as f64, b.len() as f64);
    let mut pooled: Vec<(f64, bool)> = a.iter().map(|x| (*x, true)).chain(b.iter().map(|x| (*x, false))).collect();
    pooled.sort_by(|x, y| x.0.total_cmp(&y.0));
    let (mut rank_a, mut ties) = (0.0, 0.0);
    // doubled ranks, integers: each run of equal values shares the mean of its ranks start + 1 ..= start + t
    let mut ranks2: Vec<usize> = Vec::with_capacity(pooled.len());
    let mut start = 0usize;
    for run in pooled.chunk_by(|x, y| x.0 == y.0) {
        let t = run.len() as f64;
        let rank = start as f64 + (t + 1.0) / 2.0;
        ties += t * t * t - t;
        rank_a += rank * run.iter().filter(|p| p.1).count() as f64;
        ranks2.extend(std::iter::repeat_n(2 * start + run.len() + 1, run.len()));
        start += run.len();
    }
    if a.is_empty() || b.is_empty() {
        return 1.0;
    }
    if pooled.len() <= MANN_WHITNEY_EXACT_MAX_N {
        return exact_rank_sum_tail(&ranks2, a.len(), (2.0 * rank_a).round() as usize);
    }
    let u = rank_a - na * (na + 1.0) / 2.0;
    let nn = na + nb;
    let var = na * nb / 12.0 * ((nn + 1.0) - ties / (nn * (nn - 1.0)));
    if var <= 0.0 {
        return 1.0;
    }
    let z = (u - na * nb / 2.0) / var.sqrt();
    let tail = 0.5 * super::stats::chi2_sf(z * z, 1.0);
    if z >= 0.0 { tail } else { 1.0 - tail }
}

/// The share of the k-subsets of `ranks2` (doubled ranks) whose sum is at least `observed2`:
/// count[j][s], the number of j-subsets of the ranks seen so far with doubled sum s, grows one
/// rank at a time (count[j][s] += count[j − 1][s − r], j downwards), then the tail is summed.
fn exact_rank_sum_tail(ranks2: &[usize], k: usize, observed2: usize) -> f64 {
    let max_sum: usize = ranks2.iter().sum();
    let mut count = vec![vec![0.0f64; max_sum + 1]; k + 1];
    count[0][0] = 1.0;
    for &r in ranks2 {
        for j in (1..=k).rev() {
            let (lower, upper) = count.split_at_mut(j);
            for s in (r..=max_sum).rev() {
                upper[0][s] += lower[j - 1][s - r];
            }
        }
    }
    let total: f64 = count[k].iter().sum();
    count[k][observed2.min(max_sum + 1)..].iter().sum::<f64>() / total
}

/// P(X ≥ k) for X ~ Binomial(n, ½).
fn binomial_upper_tail(n: usize, k: usize) -> f64 {
    let mut c = 1.0f64; // C(n, 0)
    let mut sum = 0.0;
    for i in 0..=n {
        if i >= k {
            sum += c;
        }
        c = c * (n - i) as f64 / (i + 1) as f64;
    }
    sum / 2f64.powi(n as i32)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frames::{Rot, Vec3};
    use crate::identify::fit::note::Note;
    use crate::identify::input::series::NominalModel;
    use nalgebra::{UnitQuaternion, Vector3};

    /// The report's notes on agreement `a`, as sentences.
    fn agreement_notes(a: &GroundAgreement) -> Vec<String> {
        crate::identify::fit::note::of_ground_agreement(a).iter().map(ToString::to_string).collect()
    }

    const G: f64 = 9.81;

    /// 1 s at rest (motors off), 0.6 s spinning at `fraction` of the weight on the floor, then a
    /// climb; 100 Hz, level markers. The accelerometer reads a frame tilt of `rest_deg` (roll,
    /// pitch) at rest and `spin_deg` more while the motors run.
    fn flight(rest_deg: [f64; 2], spin_deg: [f64; 2], fraction: f64) -> Series {
        let n = 300;
        let dt = 0.01;
        let (rest_rows, spin_rows) = (100, 60);
        let tilt = |i: usize| {
            let extra = if i >= rest_rows { spin_deg } else { [0.0; 2] };
            // the accelerometer's frame turned by (roll, pitch) against the markers, in the sign
            // the ground check reports (δ = f̂ × f / |f̂|²): f = C·(−g·e_D), C the small rotation
            let c = UnitQuaternion::from_euler_angles(
                (rest_deg[0] + extra[0]).to_radians(),
                (rest_deg[1] + extra[1]).to_radians(),
                0.0,
            );
            c.transform_vector(&Vector3::new(0.0, 0.0, -G))
        };
        Series {
            source: "spin".into(),
            t_s: (0..n).map(|i| i as f64 * dt).collect(),
            pos_mocap_nav: (0..n)
                .map(|i| {
                    Vec3::new(
                        0.0,
                        0.0,
                        if i < rest_rows + spin_rows { 0.0 } else { -0.01 * (i - rest_rows - spin_rows) as f64 },
                    )
                })
                .collect(),
            att_mocap: vec![Rot::identity(); n],
            mocap_ok: vec![true; n],
            gyro_body: vec![Vec3::zeros(); n],
            // a little alternating noise so that the standard errors are finite
            accel_body: (0..n)
                .map(|i| Vec3::from_raw(tilt(i) + Vector3::new(0.01, -0.01, 0.0) * if i % 2 == 0 { 1.0 } else { -1.0 }))
                .collect(),
            thrust_n: Some((0..n).map(|i| if i < rest_rows { 0.0 } else { fraction * G }).collect()),
            vbat_v: None,
            segments: vec![(0, n)],
            // no battery column: the voltage reference is never read
            model: NominalModel::for_tests(G),
            repairs: vec![],
            clocks: Default::default(),
        }
    }

    /// The spin-up reads the rest's tilt plus what the spinning rotors add, over the rows from
    /// 50 ms after the motors start until the lift (rows 105..161, the first climbing row at 161:
    /// 0.56 s), at the thrust's fraction of the
    /// weight; the rest keeps its own tilt.
    #[test]
    fn the_spin_up_reads_what_the_rotors_add() {
        let s = flight([0.4, -1.0], [0.0, 0.5], 0.9);
        let rest = ground_check(&s).unwrap();
        assert!((rest.roll_deg - 0.4).abs() < 1e-3 && (rest.pitch_deg + 1.0).abs() < 1e-3, "{rest:?}");
        let sp = spin_up(&s, Vec3::zeros()).unwrap();
        assert!((sp.check.roll_deg - 0.4).abs() < 1e-3 && (sp.check.pitch_deg + 0.5).abs() < 1e-3, "{sp:?}");
        assert!((sp.thrust_fraction - 0.9).abs() < 1e-12);
        assert!((sp.duration_s - 0.56).abs() < 1e-9 && sp.check.samples == 56, "{sp:?}");
        // a bias removed from every sample moves both alike: b_y/g in roll
        let b = spin_up(&s, Vec3::new(0.0, 0.0981, 0.0)).unwrap();
        assert!((sp.check.roll_deg - b.check.roll_deg - 0.0981f64.atan2(G).to_degrees()).abs() < 0.01, "{b:?}");
    }

    /// The markers' frame turned by `turn` over the whole flight, and the IMU offset from it by
    /// `c`: the mocap reports R_m = turn and the accelerometer reads c·R_mᵀ·(−g·e_D), noise-free.
    fn turned(turn: UnitQuaternion<f64>, c: UnitQuaternion<f64>) -> Series {
        let mut s = flight([0.0; 2], [0.0; 2], 0.9);
        for i in 0..s.len() {
            s.att_mocap[i] = Rot::from_quaternion(turn);
            s.accel_body[i] = Vec3::from_raw(c * turn.inverse_transform_vector(&Vector3::new(0.0, 0.0, -G)));
        }
        s
    }

    /// The ground check is the exact rotation between the two forces, about the body axes that
    /// are level at rest, whichever axis is up: an IMU turned from the markers by α = 6° about a
    /// level axis n reads α·n, by hand (a rotation about an axis perpendicular to gravity turns
    /// it by exactly its angle), where the small-angle f̂ × f/|f̂|² read sin α (0.02° less). With
    /// the markers level (z up) n = (cos β, sin β, 0) reads as roll and pitch; with the body on
    /// its front face (turned 90° about y: x up) n = (0, cos β, sin β) reads about y and z; on its
    /// side (turned −90° about x: y up) n = (sin β, 0, cos β) reads about z and x.
    #[test]
    fn the_ground_check_is_the_exact_rotation_about_the_level_axes() {
        let (alpha, beta) = (6f64.to_radians(), 0.7_f64);
        let (cb, sb) = (beta.cos(), beta.sin());
        for (turn, n, up) in [
            (UnitQuaternion::identity(), Vector3::new(cb, sb, 0.0), UpAxis::Z),
            (UnitQuaternion::from_euler_angles(0.0, 90f64.to_radians(), 0.0), Vector3::new(0.0, cb, sb), UpAxis::X),
            (UnitQuaternion::from_euler_angles(-90f64.to_radians(), 0.0, 0.0), Vector3::new(sb, 0.0, cb), UpAxis::Y),
        ] {
            let s = turned(turn, UnitQuaternion::from_scaled_axis(n * alpha));
            let g = ground_check(&s).unwrap();
            let [a, b] = up.level();
            let want = [n[a], n[b]].map(|x| (x * alpha).to_degrees());
            assert_eq!(g.up_axis, up);
            assert!(
                (g.roll_deg - want[0]).abs() < 1e-9 && (g.pitch_deg - want[1]).abs() < 1e-9,
                "{up:?} up: {g:?} against {want:?}"
            );
            assert!(rest_off_axis_deg(&s).unwrap() < 1e-9);
        }
        assert_eq!(UpAxis::X.tilt_names(), ["about y", "about z"]);
        // the JSON names the up axis only when it is not z
        let json =
            |turn| serde_json::to_string(&ground_check(&turned(turn, UnitQuaternion::identity())).unwrap()).unwrap();
        assert!(json(UnitQuaternion::from_euler_angles(0.0, 90f64.to_radians(), 0.0)).contains(r#""up_axis":"x""#));
        assert!(!json(UnitQuaternion::identity()).contains("up_axis"));
    }

    /// The flight's side reads what the ground check reads when the frames are the model's: an
    /// accelerometer that measures Cᵀ·(−g·e_D) + b, C the IMU attitude the corrections give
    /// (series::correct: W⁻¹·R_m·O⁻¹), at a rest turned 35° in yaw, with an offset of 5° roll,
    /// −4° pitch and 30° yaw, a 6° world tilt and a 0.3 m/s² bias. The ground check of f − b is
    /// the frame part, that of f the whole; a frame
    /// composed the other way round (O·R_mᵀ·W⁻¹) misses by degrees.
    #[test]
    fn the_predicted_tilt_is_what_the_ground_check_reads_of_the_model() {
        use crate::identify::input::series::{Corrections, correct};
        let turn = UnitQuaternion::from_euler_angles(0.0, 0.0, 35f64.to_radians());
        let offset = UnitQuaternion::from_euler_angles(5f64.to_radians(), -4f64.to_radians(), 30f64.to_radians());
        let world = UnitQuaternion::from_euler_angles(6f64.to_radians(), -2f64.to_radians(), 0.0);
        let bias = Vector3::new(0.3, -0.2, 0.1);
        let mut s = turned(turn, UnitQuaternion::identity());
        let corr = Corrections {
            body_offset: Rot::from_quaternion(offset),
            world_tilt: Rot::from_quaternion(world),
            ..Corrections::default()
        };
        let att = correct(&s, &corr).att_body;
        for i in 0..s.len() {
            s.accel_body[i] =
                Vec3::from_raw(att[i].quaternion().inverse_transform_vector(&Vector3::new(0.0, 0.0, -G)) + bias);
        }
        let rest = rest_before_takeoff(&s).unwrap();
        let (offset, world, bias) = (corr.body_offset, corr.world_tilt, Vec3::<Body>::from_raw(bias));
        for (b, read) in [(Vec3::zeros(), tilt_at_rest(&s, bias).unwrap()), (bias, ground_check(&s).unwrap())] {
            let p = predicted_tilt(&s, &rest, &offset, &world, b).map(f64::to_degrees);
            assert!(
                (p[0] - read.roll_deg).abs() < 1e-9 && (p[1] - read.pitch_deg).abs() < 1e-9,
                "{p:?} against {read:?}"
            );
            // the world tilt's inverse, which the model does not make
            let swapped = predicted_tilt(&s, &rest, &offset, &world.inverse().assume_frames(), b).map(f64::to_degrees);
            assert!((swapped[0] - read.roll_deg).abs().max((swapped[1] - read.pitch_deg).abs()) > 1.0, "{swapped:?}");
        }
    }

    /// A body whose vertical is far from every body axis at rest gets no ground check: turned
    /// 40° about x the vertical is 40° from z, where neither y nor z is level and gravity shows
    /// only a mix of the tilts about them; 20° still reads, about x and y, the part of the
    /// accelerometer's 0.4°/−1° offset that gravity shows (the offset's rotation vector less its
    /// component along the body's up, to second order in 1.1°: 0.02°).
    #[test]
    fn a_body_resting_between_its_axes_gets_no_ground_check() {
        let c = UnitQuaternion::from_euler_angles(0.4f64.to_radians(), -1f64.to_radians(), 0.0);
        let s = turned(UnitQuaternion::from_euler_angles(20f64.to_radians(), 0.0, 0.0), c);
        let g = ground_check(&s).unwrap();
        let (gamma, up) = (c.scaled_axis(), s.att_mocap[0].quaternion().inverse_transform_vector(&-Vector3::z()));
        let want = (gamma - up * gamma.dot(&up)).map(f64::to_degrees);
        assert!(
            (g.roll_deg - want.x).abs() < 0.02 && (g.pitch_deg - want.y).abs() < 0.02 && want.y.abs() > 0.5,
            "{g:?} against {want:?}"
        );
        let turn = UnitQuaternion::from_euler_angles(40f64.to_radians(), 0.0, 0.0);
        let s = turned(turn, c);
        let off = rest_off_axis_deg(&s).unwrap();
        assert!((off - 40.0).abs() < 1e-9, "{off}");
        assert!(ground_check(&s).is_none());
        let r = crate::identify::identify(&climbing(s), &crate::identify::Options::default()).unwrap();
        assert!(
            r.ground_check.is_none()
                && r.notes.iter().any(|n| n
                    .to_string()
                    .starts_with("the log rests with the vertical 40° from the nearest body axis")),
            "{:?}",
            r.notes
        );
        // a level rest that gets no check for another reason (its accelerometer ramps by
        // 0.01 m/s² a row: no 0.5 s of still rows) is not said to rest off its axes
        let mut s = turned(UnitQuaternion::identity(), c);
        for i in 0..100 {
            s.accel_body[i] += Vec3::new(0.01 * i as f64, 0.0, 0.0);
        }
        let r = crate::identify::identify(&climbing(s), &crate::identify::Options::default()).unwrap();
        assert!(
            r.ground_check.is_none() && !r.notes.iter().any(|n| matches!(n, Note::RestOffAxis { .. })),
            "{:?}",
            r.notes
        );
    }

    /// `s` with its climb carried on to 43 s, long enough to select (a note comes with a full
    /// report).
    fn climbing(mut s: Series) -> Series {
        let n = 4300;
        let turn = s.att_mocap[0];
        for i in s.len()..n {
            s.t_s.push(i as f64 * 0.01);
            s.pos_mocap_nav.push(Vec3::new(0.0, 0.0, -0.01 * (i - 160) as f64));
            s.att_mocap.push(turn);
            s.mocap_ok.push(true);
            s.gyro_body.push(Vec3::zeros());
            s.accel_body.push(s.accel_body[i - 2]);
            s.thrust_n.as_mut().unwrap().push(0.9 * G);
        }
        s.segments = vec![(0, n)];
        s
    }

    /// No spin-up without a thrust column, or when the vehicle lifts within 0.3 s of the motors.
    #[test]
    fn no_spin_up_without_thrust_or_time_on_the_floor() {
        let mut s = flight([0.0; 2], [0.0; 2], 0.9);
        s.thrust_n = None;
        assert!(spin_up(&s, Vec3::zeros()).is_none());
        let mut s = flight([0.0; 2], [0.0; 2], 0.9);
        // lifts 0.3 s after the motors start: 0.25 s of usable rows
        for i in 130..s.len() {
            s.pos_mocap_nav[i] = Vec3::new(s.pos_mocap_nav[i].x(), s.pos_mocap_nav[i].y(), -0.004);
        }
        assert!(spin_up(&s, Vec3::zeros()).is_none());
    }

    /// The lift is measured from the floor's own height: on a platform 0.5 m up (z = −0.5 m in
    /// NED) the spin-up is the same 56 rows as on the floor.
    #[test]
    fn the_lift_is_measured_from_the_rest_height() {
        let mut s = flight([0.0; 2], [0.0, 0.5], 0.9);
        for p in &mut s.pos_mocap_nav {
            *p += Vec3::new(0.0, 0.0, -0.5);
        }
        let sp = spin_up(&s, Vec3::zeros()).unwrap();
        assert_eq!(sp.check.samples, 56, "{sp:?}");
    }

    /// A flight's frame tilt (deg) with a tight interval.
    fn tilt(deg: [f64; 2]) -> FlightTilt {
        FlightTilt {
            offset_rad: deg.map(f64::to_radians),
            sd_rad: [0.001; 2],
            widen_rad: [0.0; 2],
            frame_fitted: true,
            accel_bias_fitted: false,
        }
    }

    /// A rotation at rest never agrees because a bias no sensor has explains it: the ground
    /// reads a 104° pitch, a fitted bias of 1.6 g takes it to 0°, the flight's frames say 0°, and
    /// the agreement is a DISAGREE. A bias tilt of 5° (0.85 m/s²) that does the same agrees.
    #[test]
    fn an_impossible_bias_makes_no_agreement() {
        let check = |pitch: f64| GroundCheck {
            roll_deg: 0.0,
            pitch_deg: pitch,
            roll_se_deg: 0.01,
            pitch_se_deg: 0.01,
            up_axis: UpAxis::Z,
            samples: 100,
            mocap_sd_deg: [0.01; 2],
        };
        let flight = FlightTilt {
            offset_rad: [0.0; 2],
            sd_rad: [0.001; 2],
            widen_rad: [0.0; 2],
            frame_fitted: true,
            accel_bias_fitted: true,
        };
        let a = agreement(&check(104.0), &check(0.0), &flight, None, None);
        assert!(!a.pitch.covers && a.roll.covers, "{a:?}");
        let a = agreement(&check(5.0), &check(0.0), &flight, None, None);
        assert!(a.pitch.covers, "{a:?}");
        assert!((max_bias_tilt_deg() - (2.0f64 / crate::vehicle::params::GRAVITY).asin().to_degrees()).abs() < 1e-12);
    }

    /// The agreement's spin-up: change = spin-up − rest, difference = spin-up − flight.
    #[test]
    fn the_spin_up_agreement_compares_with_rest_and_flight() {
        let s = flight([0.4, -1.0], [0.0, 0.5], 0.9);
        let (raw, sp) = (ground_check(&s).unwrap(), spin_up(&s, Vec3::zeros()).unwrap());
        // a flight that pins its tilt down only to ±2.2° (σ 0.02 rad) covers a 1.2° difference,
        // and the note says so at the interval's precision
        let loose = FlightTilt { sd_rad: [0.02; 2], ..tilt([0.4, 0.2]) };
        let notes = agreement_notes(&agreement(&raw, &raw, &loose, None, None));
        assert_eq!(
            notes,
            [
                "ground check and flight differ by -1.2 ± 2.2° in pitch, within what this flight determines: the flight cannot pin its tilt down to 1°"
            ]
        );
        let a = agreement(&raw, &raw, &tilt([0.4, -0.6]), Some(&sp), None);
        let su = a.spin_up.unwrap();
        assert!((su.pitch.change_deg - 0.5).abs() < 1e-3 && su.roll.change_deg.abs() < 1e-3, "{su:?}");
        // the report names the reference that agrees where the rest does not: a flight at the
        // spin-up's pitch disagrees with the rest by 0.5° and agrees with the spin-up
        let notes = agreement_notes(&agreement(&raw, &raw, &tilt([0.4, -0.5]), Some(&sp), None));
        assert_eq!(notes.len(), 1, "{notes:?}");
        assert!(
            notes[0].contains("disagree in pitch")
                && notes[0].contains("the spin-up (motors on, still on the floor) moved +0.501 ± 0.020°")
                && notes[0].contains("agrees with it (+0.00 ±"),
            "{notes:?}"
        );
        assert!((su.pitch.difference_deg - 0.1).abs() < 1e-3 && (a.pitch.difference_deg + 0.4).abs() < 1e-3, "{a:?}");
        // with a bias removed from both checks the change is the same (the bias cancels) and
        // the difference moves by the bias tilt
        let b = Vec3::new(0.0981, 0.0, 0.0);
        let (rc, spc) = (tilt_at_rest(&s, b).unwrap(), spin_up(&s, b).unwrap());
        let ab = agreement(&raw, &rc, &tilt([0.4, -0.6]), Some(&spc), None);
        let sb = ab.spin_up.unwrap();
        assert!((sb.pitch.change_deg - 0.5).abs() < 1e-3, "{sb:?}");
        assert!(
            (sb.pitch.difference_deg - su.pitch.difference_deg - ab.pitch.bias_tilt_deg.abs()).abs() < 1e-3
                || (sb.pitch.difference_deg - su.pitch.difference_deg + ab.pitch.bias_tilt_deg.abs()).abs() < 1e-3,
            "{sb:?} {ab:?}"
        );
        assert!(ab.pitch.bias_tilt_deg.abs() > 0.5, "{ab:?}");
    }

    /// The sign test against the binomial by hand: P(X ≥ 8 | n = 9, ½) = (9 + 1)/512;
    /// P(X ≥ 0) = 1; P(X ≥ 5 | 9) = ½.
    #[test]
    fn binomial_tail_by_hand() {
        assert!((binomial_upper_tail(9, 8) - 10.0 / 512.0).abs() < 1e-15);
        assert_eq!(binomial_upper_tail(9, 0), 1.0);
        assert!((binomial_upper_tail(9, 5) - 0.5).abs() < 1e-15);
        assert!((binomial_upper_tail(4, 4) - 1.0 / 16.0).abs() < 1e-15);
    }

    /// The summary counts a change as toward the flight when it has the opposite sign of
    /// rest − flight, and takes the medians of both differences.
    #[test]
    fn the_summary_counts_moves_toward_the_flight() {
        let s = flight([0.0, 0.0], [0.0, 0.5], 0.9);
        let (raw, sp) = (ground_check(&s).unwrap(), spin_up(&s, Vec3::zeros()).unwrap());
        // flights at pitch 0.4 (toward: rest − flight = −0.4, change +0.5), and one at −0.4 (away)
        let at = |p: f64| agreement(&raw, &raw, &tilt([0.0, p]), Some(&sp), None);
        let v = [at(0.4), at(0.4), at(-0.4)];
        let sum = spin_up_summary(v.iter()).unwrap();
        assert_eq!((sum.flights, sum.pitch.toward_flight), (3, 2));
        assert!(
            (sum.pitch.median_rest_deg - 0.4).abs() < 1e-3 && (sum.pitch.median_spin_up_deg - 0.1).abs() < 1e-3,
            "{sum:?}"
        );
        assert!((sum.pitch.sign_test_p - 0.5).abs() < 1e-12);
        assert!(spin_up_summary(v[..2].iter()).is_none());
    }

    /// Mann–Whitney by hand. a = {3, 4, 5}, b = {1, 2}: ranks 3 + 4 + 5 = 12, U = 12 − 6 = 6,
    /// mean 3, variance 3·2·6/12 = 3, z = √3, P = 0.04163. With ties, a = {2, 2}, b = {1, 2}:
    /// ranks 1 | 3, 3, 3, R_a = 6, U = 3, mean 2, tie term 3³ − 3 = 24, variance
    /// (4/12)·(5 − 24/12) = 1, z = 1, P = 0.15866. The same sample twice: z = 0, P = ½; the
    /// other way round: 1 − 0.04163.
    #[test]
    fn mann_whitney_matches_a_hand_computed_value() {
        // exact, by counting: {3, 4, 5} above {1, 2} is the one arrangement of C(5, 3) = 10 with
        // the largest rank sum, p = 1/10
        assert!((mann_whitney_greater(&[3.0, 4.0, 5.0], &[1.0, 2.0]) - 0.1).abs() < 1e-12);
        // ties: pooled 1, 2, 2, 2 has midranks 1, 3, 3, 3; a = {2, 2} has rank sum 6, and of the
        // C(4, 2) = 6 pairs, three sum to 6 ({3, 3}) and three to 4 ({1, 3}): p = 3/6
        assert!((mann_whitney_greater(&[2.0, 2.0], &[1.0, 2.0]) - 0.5).abs() < 1e-12);
        // a = {1, 2} of pooled 1, 1, 2, 2 (midranks 1.5, 1.5, 3.5, 3.5): sum 5; of 6 pairs, one
        // sums to 3, four to 5, one to 7: P(≥ 5) = 5/6
        assert!((mann_whitney_greater(&[1.0, 2.0], &[1.0, 2.0]) - 5.0 / 6.0).abs() < 1e-12);
        // below: {1, 2} against {3, 4, 5} is the smallest sum, every arrangement reaches it
        assert!((mann_whitney_greater(&[1.0, 2.0], &[3.0, 4.0, 5.0]) - 1.0).abs() < 1e-12);
        // 3 against 6, the three largest: 1 of C(9, 3) = 84
        assert!((mann_whitney_greater(&[7.0, 8.0, 9.0], &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0]) - 1.0 / 84.0).abs() < 1e-12);
        // the normal approximation above 50 pooled samples: 26 against 25 with a's ranks 26..=51,
        // U = 650 − 0, mean 325, sd √(650·52/12) = 53.07: z = 6.124, p = 4.6e-10
        let a: Vec<f64> = (26..52).map(f64::from).collect();
        let b: Vec<f64> = (1..26).map(f64::from).collect();
        let p = mann_whitney_greater(&a, &b);
        assert!((p / 4.57e-10 - 1.0).abs() < 0.02, "{p}");
        // with ties above 50: thirty 1s against fifteen 0s and fifteen 1s; midranks 8 and 38,
        // U = 30·38 − 465 = 675, mean 450, tie term Σ(t³ − t) = 3360 + 91080 over 60·59, so
        // var = (900/12)·(61 − 26.678) = 2574.2, z = 4.4347, p = 4.610e-6 (without the tie term
        // z = 3.327, p = 4.4e-4)
        let b: Vec<f64> = [0.0; 15].into_iter().chain([1.0; 15]).collect();
        let p = mann_whitney_greater(&[1.0; 30], &b);
        assert!((p / 4.6098e-6 - 1.0).abs() < 1e-3, "{p}");
    }

    /// The test's size: under "both from one distribution" (uniform draws; 31 against 37 as the
    /// held-out split, normal approximation), p < 0.05 in about 5 % of 4000 draws (binomial 95 %
    /// band 4.3–5.7 %) and p < 0.01 in about 1 %. 3 against 6 (the shared split) is exact: its p
    /// takes the values k/84, and P(p ≤ 4/84) = 4/84 = 4.76 % exactly, P(p < 0.01) = 0.
    #[test]
    fn mann_whitney_holds_its_level_under_the_null() {
        for (na, nb) in [(3, 6), (31, 37)] {
            let mut rng = crate::rng::Stream::new(7, crate::rng::Component::Sweep, na);
            let (mut at5, mut at1, n) = (0, 0, 4000);
            for _ in 0..n {
                let a: Vec<f64> = (0..na).map(|_| rng.uniform()).collect();
                let b: Vec<f64> = (0..nb).map(|_| rng.uniform()).collect();
                let p = mann_whitney_greater(&a, &b);
                at5 += usize::from(p < 0.05);
                at1 += usize::from(p < 0.01);
            }
            let (f5, f1) = (at5 as f64 / n as f64, at1 as f64 / n as f64);
            if na == 3 {
                // binomial 95 % band of 4000 draws around 4/84
                assert!((f5 - 4.0 / 84.0).abs() < 0.007 && at1 == 0, "{na} vs {nb}: {f5} at 5 %, {f1} at 1 %");
            } else {
                assert!(
                    (f5 - 0.05).abs() < 0.007 && (f1 - 0.01).abs() < 0.004,
                    "{na} vs {nb}: {f5} at 5 %, {f1} at 1 %"
                );
            }
        }
    }

    /// A rest whose mocap roll scatters by more than STILL_POSE_SD_DEG is flagged, its
    /// disagreement says why the rest is unreliable, and the summary splits the flights by it:
    /// still flights at roll 0.1, 0.2 (ground 0, so |difference| 0.1, 0.2: median 0.15), scattering
    /// ones at 0.6, 0.8 and 1.2 (median 0.8, one beyond 1°).
    #[test]
    fn a_rest_whose_pose_scatters_is_flagged_and_summarised_apart() {
        let raw = ground_check(&flight([0.0, 0.0], [0.0; 2], 0.9)).unwrap();
        let scatter = GroundCheck { mocap_sd_deg: [0.1, 0.1], ..raw };
        let edge = GroundCheck { mocap_sd_deg: [STILL_POSE_SD_DEG, 0.5], ..raw };
        assert!(
            !agreement(&edge, &edge, &tilt([0.0, 0.0]), None, None).rest_pose_scatters,
            "the threshold itself is still, pitch does not count"
        );
        let at = |g: &GroundCheck, roll: f64| agreement(g, g, &tilt([roll, 0.0]), None, None);
        let v = [at(&raw, 0.1), at(&raw, 0.2), at(&scatter, 0.6), at(&scatter, 0.8), at(&scatter, 1.2)];
        assert!(!v[0].rest_pose_scatters && v[2].rest_pose_scatters);
        let notes = agreement_notes(&v[2]);
        assert!(notes.iter().any(|n| n.contains("disagree in roll") && n.contains("scatters by 0.100°")), "{notes:?}");
        assert!(!agreement_notes(&at(&raw, 0.6)).iter().any(|n| n.contains("scatters")));
        // with two still flights more, at 0.05° and 0.3° (their median stays 0.15°)
        let w: Vec<GroundAgreement> = v.iter().cloned().chain([at(&raw, 0.05), at(&raw, 0.3)]).collect();
        let sum = rest_pose_summary(w.iter()).unwrap();
        assert_eq!(
            (sum.still, sum.scattering, sum.roll.still_beyond_1deg, sum.roll.scattering_beyond_1deg),
            (4, 3, 0, 1)
        );
        // (the constructed rest reads 0.0007° of roll from its noise)
        assert!(
            (sum.roll.median_still_deg - 0.15).abs() < 2e-3 && (sum.roll.median_scattering_deg - 0.8).abs() < 2e-3,
            "{sum:?}"
        );
        // every scattering difference above every still one: exact, 1 of C(7, 3) = 35 arrangements
        assert!((sum.roll.mann_whitney_p - 1.0 / 35.0).abs() < 1e-12, "{sum:?}");
        // 3 against 2 cannot be significant: its smallest p is 1/10
        let few = rest_pose_summary(v.iter()).unwrap();
        assert!((few.roll.mann_whitney_p - 0.1).abs() < 1e-12, "{few:?}");
        assert!(rest_pose_summary(v[1..].iter()).is_none(), "one still flight is too few");
        // two in each group is enough, one scattering flight is too few
        assert!(rest_pose_summary(v[..4].iter()).is_some_and(|s| (s.still, s.scattering) == (2, 2)));
        assert!(rest_pose_summary(v[..3].iter()).is_none(), "one scattering flight is too few");
    }

    /// `flight` followed by a landing: from row 300 back on the floor (z = `end_z`, NED), motors
    /// off, 100 rows whose accelerometer reads a frame tilt of `after_deg` (the rest before
    /// keeps `before_deg`).
    fn landed(before_deg: [f64; 2], after_deg: [f64; 2], end_z: f64) -> Series {
        let mut s = flight(before_deg, [0.0; 2], 0.9);
        let c = UnitQuaternion::from_euler_angles(after_deg[0].to_radians(), after_deg[1].to_radians(), 0.0);
        for i in 0..100 {
            s.t_s.push((300 + i) as f64 * 0.01);
            s.pos_mocap_nav.push(Vec3::new(0.0, 0.0, end_z));
            s.att_mocap.push(Rot::identity());
            s.mocap_ok.push(true);
            s.gyro_body.push(Vec3::zeros());
            s.accel_body.push(Vec3::from_raw(
                c.transform_vector(&Vector3::new(0.0, 0.0, -G))
                    + Vector3::new(0.01, -0.01, 0.0) * if i % 2 == 0 { 1.0 } else { -1.0 },
            ));
            s.thrust_n.as_mut().unwrap().push(0.0);
        }
        s.segments = vec![(0, 400)];
        s
    }

    /// A rest whose accelerometer ramps while the markers sit still (as every NanoBench log's
    /// last 0.2–0.3 s do: the logger extrapolates past the sensor's last sample) is read over its
    /// still rows only: a ramp of 0.05 m/s² per row from row 60 of the rest's 0..81 is read over
    /// rows 0..64, where it stays within the tolerance max(0.098, 8σ) = 0.168 m/s² (σ = 0.021
    /// m/s² from the ±0.01 alternation). The three ramp rows inside it leak
    /// (0.05 + 0.10 + 0.15)/64/g rad = 0.027° into pitch (f_x reads as −pitch); all 21 ramp rows
    /// would move it by 0.76°. A ramp over the whole rest leaves no still run of 0.5 s: no
    /// ground check.
    #[test]
    fn a_rest_whose_accelerometer_ramps_is_read_over_its_still_rows() {
        let clean = ground_check(&flight([0.4, -1.0], [0.0; 2], 0.9)).unwrap();
        assert_eq!(clean.samples, 81);
        let mut s = flight([0.4, -1.0], [0.0; 2], 0.9);
        for i in 60..100 {
            s.accel_body[i] += Vec3::new(0.05 * (i - 60) as f64, 0.0, 0.0);
        }
        let rest = ground_check(&s).unwrap();
        assert_eq!(rest.samples, 64, "{rest:?}");
        let leak = (0.30 / 64.0 / G).to_degrees();
        assert!((rest.roll_deg - 0.4).abs() < 1e-3 && (rest.pitch_deg - (-1.0 - leak)).abs() < 1e-3, "{rest:?}");
        for i in 0..100 {
            s.accel_body[i] += Vec3::new(0.05 * i as f64, 0.0, 0.0);
        }
        assert!(ground_check(&s).is_none());
        // a non-finite reading is not still: the rest is read after it (rows 11..81)
        let mut s = flight([0.4, -1.0], [0.0; 2], 0.9);
        s.accel_body[10] = Vec3::new(s.accel_body[10].x(), f64::NAN, s.accel_body[10].z());
        let rest = ground_check(&s).unwrap();
        assert!(rest.samples == 70 && (rest.roll_deg - 0.4).abs() < 1e-3, "{rest:?}");
    }

    /// The rest after landing reads its own tilt over the rows from 0.5 s after the landing (50
    /// of 100), wherever the landing spot is within 5 cm of the take-off's; the agreement's
    /// bracket is the two rests' mean against the flight, its interval at least half their change.
    #[test]
    fn the_rest_after_landing_reads_its_own_tilt_and_brackets_the_flight() {
        for end_z in [0.0, 0.02, -0.04] {
            let s = landed([0.4, -1.0], [0.2, -0.4], end_z);
            let after = tilt_after_landing(&s, Vec3::zeros()).unwrap();
            assert!(
                (after.roll_deg - 0.2).abs() < 1e-3 && (after.pitch_deg + 0.4).abs() < 1e-3 && after.samples == 50,
                "{after:?}"
            );
        }
        let s = landed([0.4, -1.0], [0.2, -0.4], 0.0);
        let (raw, after) = (ground_check(&s).unwrap(), tilt_after_landing(&s, Vec3::zeros()).unwrap());
        let a = agreement(&raw, &raw, &tilt([0.3, -0.9]), None, Some(&after));
        let l = a.after_landing.unwrap();
        // after − before, after − flight, (before + after)/2 − flight
        assert!((l.roll.check.change_deg + 0.2).abs() < 1e-3 && (l.pitch.check.change_deg - 0.6).abs() < 1e-3, "{l:?}");
        assert!(
            (l.roll.check.difference_deg + 0.1).abs() < 1e-3 && (l.pitch.check.difference_deg - 0.5).abs() < 1e-3,
            "{l:?}"
        );
        assert!(
            l.roll.bracket_difference_deg.abs() < 1e-3 && (l.pitch.bracket_difference_deg - 0.2).abs() < 1e-3,
            "{l:?}"
        );
        assert!(l.pitch.bracket_ci95_deg >= 0.3 && l.pitch.bracket_covers && !l.pitch.check.covers, "{l:?}");
        // the change's interval is the two rests' standard errors combined, 1.96·√(se_a² + se_b²)
        let change_ci = 1.959964 * after.roll_se_deg.hypot(raw.roll_se_deg);
        assert!(
            change_ci > 0.0 && (l.roll.check.change_ci95_deg / change_ci - 1.0).abs() < 1e-5,
            "{l:?} vs {change_ci}"
        );
        // this flight sits between its rests (before − flight: +0.1 roll, −0.1 pitch; after −
        // flight: −0.1, +0.5); one at pitch −1.2 does not in pitch (+0.2, +0.8; bracket +0.5)
        // a flight at pitch −0.6 disagrees with the rest before (−0.4) and agrees with the
        // mean of the two rests (−0.1 ± at least 0.3): the report says so
        let notes = agreement_notes(&agreement(&raw, &raw, &tilt([0.4, -0.6]), None, Some(&after)));
        assert_eq!(notes.len(), 1, "{notes:?}");
        assert!(
            notes[0].contains("disagree in pitch")
                && notes[0].contains("the mean of the rests before and after the flight agrees with it (-0.10 ±"),
            "{notes:?}"
        );
        let out = agreement(&raw, &raw, &tilt([0.3, -1.2]), None, Some(&after));
        let b = [a, out, agreement(&raw, &raw, &tilt([1.9, -0.9]), None, None)];
        assert!(landed_summary(b.iter()).is_none(), "fewer than 3 flights with both rests");
        let b = [b[0], b[0], b[1], b[2]];
        let sum = landed_summary(b.iter()).unwrap();
        assert_eq!((sum.flights, sum.with_both, sum.roll.between, sum.pitch.between), (4, 3, 3, 2));
        assert!(
            (sum.pitch.median_change_deg - 0.6).abs() < 1e-3 && (sum.pitch.median_bracket_deg - 0.2).abs() < 1e-3,
            "{sum:?}"
        );
        // the flight without a rest after landing is judged by its rest before: 0.4 − 1.9
        assert_eq!((sum.roll.beyond_1deg, sum.roll.beyond_1deg_covered), (1, 0));
    }

    /// No rest after landing when the log ends in the air, 6 cm off the take-off's floor, with
    /// the motors on, after less than 0.5 s still (beyond the settling), or without a flight.
    #[test]
    fn no_rest_after_landing_unless_it_landed_and_stayed() {
        assert!(tilt_after_landing(&landed([0.0; 2], [0.0; 2], -0.5), Vec3::zeros()).is_none());
        assert!(tilt_after_landing(&landed([0.0; 2], [0.0; 2], -0.06), Vec3::zeros()).is_none());
        let mut s = landed([0.0; 2], [0.0; 2], 0.0);
        s.thrust_n.as_mut().unwrap()[399] = 1.0;
        assert!(tilt_after_landing(&s, Vec3::zeros()).is_none());
        let s = landed([0.0; 2], [0.0; 2], 0.0).slice(0, 399);
        assert!(tilt_after_landing(&s, Vec3::zeros()).is_none(), "0.49 s still after the settling");
        let s = landed([0.0; 2], [0.0; 2], 0.0).slice(0, 400);
        assert!(tilt_after_landing(&s, Vec3::zeros()).is_some());
        // a log that never leaves the floor has no landing
        let mut s = landed([0.0; 2], [0.0; 2], 0.0);
        s.thrust_n = Some(vec![0.0; 400]);
        s.pos_mocap_nav.iter_mut().for_each(|p| *p = Vec3::new(p.x(), p.y(), 0.0));
        assert!(tilt_after_landing(&s, Vec3::zeros()).is_none());
    }

    /// The mocap's own tilt scatter at rest, by hand: a pose rolled +0.1° and −0.1° on
    /// alternate rows (pitch still) over m rows (m odd: one more +0.1°, mean 0.1°/m) has a
    /// per-sample standard deviation of 0.1°·√((m − 1/m)/(m − 1)) in roll and 0 in pitch,
    /// whatever the accelerometer reads; a still pose has 0.
    #[test]
    fn the_mocap_scatter_at_rest_is_the_poses_own() {
        let mut s = flight([0.3, -0.2], [0.0; 2], 0.9);
        assert_eq!(ground_check(&s).unwrap().mocap_sd_deg, [0.0, 0.0]);
        for i in 0..100 {
            s.att_mocap[i] = Rot::from_quaternion(UnitQuaternion::from_euler_angles(
                if i % 2 == 0 { 0.1f64 } else { -0.1 }.to_radians(),
                0.0,
                0.0,
            ));
        }
        let g = ground_check(&s).unwrap();
        let m = g.samples as f64;
        assert_eq!(g.samples % 2, 1);
        assert!(
            (g.mocap_sd_deg[0] - 0.1 * ((m - 1.0 / m) / (m - 1.0)).sqrt()).abs() < 1e-6
                && g.mocap_sd_deg[1].abs() < 1e-9,
            "{g:?}"
        );
    }
}

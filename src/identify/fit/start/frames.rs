//! The frames' start, once the clocks agree: the rotation from the mocap body to the IMU, the
//! mocap world's gravity, the lever arm and the biases, each in closed form.
//!
//! **The rotation** (Wahba's problem on the rates). The gyro reads ω_imu = R·ω̂ + b_g, with ω̂ the
//! mocap's body rates (marker frame) and R = R_off the rotation mocap body → IMU body. With the
//! bias removed by centring, R minimises Σ‖(ω_imu − ω̄_imu) − R·(ω̂ − ω̄̂)‖²: for
//! B = Σ (ω_imu − ω̄_imu)(ω̂ − ω̄̂)ᵀ = U·S·Vᵀ (SVD), R = U·diag(1, 1, det U·det V)·Vᵀ. It holds for
//! any R in SO(3): half-turns, axis permutations, anything; it needs rotation about two axes at
//! least. Samples whose residual exceeds five times the median are left out and R solved once
//! more (a mocap glitch, a saturated gyro). b_g = ω̄_imu − R·ω̄̂. Its spread, approximately: with
//! e the residual and σ² = mean‖e‖²/3, the information on a small error δ (R → Exp(δ)·R) is
//! Σ [v]ₓᵀ[v]ₓ/σ², v = R·(ω̂ − ω̄̂), over samples one smoothing σ apart (neighbours correlate a
//! little, so it is somewhat optimistic).
//!
//! **Gravity, lever arm and accelerometer bias** (one linear solve). At that R the accelerometer
//! reads, for a point r (IMU body) from the tracked one and a gravity g⃗ in the mocap world
//! (g⃗ = g·R_w·e_D, the world's tilt R_w unknown),
//!
//! f_imu − R·R_mᵀ·p̈ = −R·R_mᵀ·g⃗ + ([ω̇]ₓ + [ω]ₓ²)·r + b_a,
//!
//! linear in (g⃗, r, b_a): nine unknowns by least squares over the same samples, with ω, ω̇ the
//! smoothed gyro (less b_g) and its derivative. ‖g⃗‖ must come out near g: a wrong unit or scale
//! of the accelerometer, or frames still apart, show there. (A rig that stays near one attitude
//! trades ‖g⃗‖ against the bias along its vertical, so r and b_a are solved once more with g⃗
//! held at g·u.) The world tilt is the tilt-only
//! rotation R_y(θ)·R_x(φ) that takes e_D to u = g⃗/‖g⃗‖ (φ = −asin u_y, θ = atan2(u_x, u_z)):
//! any direction, a world whose up is y or upside down included.
//!
//! Everything is smoothed by the design's Gaussian first and read one σ apart, as the fine fit
//! reads it ([`crate::identify::fit::design`]).

use crate::frames::{Body, MocapBody, MocapNav, Nav, Rot, Vec3};
use crate::identify::fit::design::{
    body_rates, central_difference, gaussian_kernel, glitches, second_difference, smooth_vec3_rows,
};
use crate::identify::input::series::{Corrections, Series, correct, raw_rots, raw_vecs};
use nalgebra::{DMatrix, DVector, Matrix3, UnitQuaternion, Vector3};

/// The frames as the closed forms give them.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct FrameStart {
    /// The rotation mocap body → IMU body (Wahba on the rates).
    #[serde(serialize_with = "crate::identify::fit::start::serialize_rot")]
    pub body_offset: Rot<MocapBody, Body>,
    /// Its approximate standard deviation about the IMU's x, y, z (rad).
    pub body_offset_sd_rad: [f64; 3],
    /// The gyro's residual against R·ω̂ + b_g, rms per axis (rad/s): what the best rotation of
    /// the mocap's rates leaves of the gyro (their noise together, when the clocks agree).
    pub gyro_residual_rad_s: f64,
    /// The gyro's rms about its mean over the same samples (rad/s).
    pub gyro_rms_rad_s: f64,
    /// The mocap world's tilt: gravity's direction there is R_w·e_D.
    #[serde(serialize_with = "crate::identify::fit::start::serialize_rot")]
    pub world_tilt: Rot<Nav, MocapNav>,
    /// ‖g⃗‖ as the linear solve finds it (m/s²).
    pub gravity_m_s2: f64,
    /// The lever arm, tracked point → IMU (m, IMU body), solved again with ‖g⃗‖ = g.
    pub lever_arm_m: Vec3<Body>,
    /// The accelerometer's bias (m/s², IMU body), solved again with ‖g⃗‖ = g.
    pub accel_bias_m_s2: Vec3<Body>,
    /// The gyro's bias (rad/s, IMU body).
    pub gyro_bias_rad_s: Vec3<Body>,
    /// Samples the closed forms used (one per smoothing σ).
    pub samples: usize,
}

impl FrameStart {
    /// The rates fix the rotation: its spread is below
    /// [`ROTATION_SD_MAX_DEG`](super::ROTATION_SD_MAX_DEG) about every axis and it explains
    /// the gyro to within [`ROTATION_RESIDUAL_MAX`](super::ROTATION_RESIDUAL_MAX) of its rms.
    pub fn rotation_determined(&self) -> bool {
        self.body_offset_sd_rad.iter().all(|sd| sd.to_degrees() <= super::ROTATION_SD_MAX_DEG)
            && self.gyro_residual_rad_s <= super::ROTATION_RESIDUAL_MAX * self.gyro_rms_rad_s
    }
}

/// Fewer samples than this and there is no start of the frames.
const MIN_SAMPLES: usize = 50;

/// The rotation R = U·diag(1, 1, det U·det V)·Vᵀ that maximises tr(Rᵀ·B) (Wahba, by SVD);
/// `None` if the SVD does not converge.
pub(crate) fn wahba(b: &Matrix3<f64>) -> Option<Matrix3<f64>> {
    let svd = nalgebra::SVD::try_new(*b, true, true, f64::EPSILON, 200)?;
    let (u, v_t) = (svd.u?, svd.v_t?);
    let d = (u.determinant() * v_t.determinant()).signum();
    Some(u * Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, d)) * v_t)
}

/// The rotation of the mocap body onto the IMU from paired rates (IMU, mocap): the Wahba
/// solution on the centred pairs, once more without pairs whose residual is beyond five times
/// the median. Returns R, the gyro bias, the residual's and the gyro's rms and the kept pairs.
fn rotation(pairs: &[(Vector3<f64>, Vector3<f64>)]) -> Option<(Matrix3<f64>, Vector3<f64>, Vec<bool>)> {
    let mut keep = vec![true; pairs.len()];
    let mut r = Matrix3::identity();
    for pass in 0..2 {
        let m = keep.iter().filter(|k| **k).count() as f64;
        let (mi, mm) = pairs
            .iter()
            .zip(&keep)
            .filter(|x| *x.1)
            .fold((Vector3::zeros(), Vector3::zeros()), |a, (p, _)| (a.0 + p.0 / m, a.1 + p.1 / m));
        let b: Matrix3<f64> =
            pairs.iter().zip(&keep).filter(|x| *x.1).map(|(p, _)| (p.0 - mi) * (p.1 - mm).transpose()).sum();
        r = wahba(&b)?;
        let res: Vec<f64> = pairs.iter().map(|p| ((p.0 - mi) - r * (p.1 - mm)).norm()).collect();
        if pass == 0 {
            let med = crate::identify::fit::stats::median(res.clone())?;
            keep = res.iter().map(|e| *e <= 5.0 * med).collect();
        }
    }
    let m = keep.iter().filter(|k| **k).count() as f64;
    let bias = pairs.iter().zip(&keep).filter(|x| *x.1).map(|(p, _)| (p.0 - r * p.1) / m).sum();
    Some((r, bias, keep))
}

/// What the closed forms read, at the log's rows: smoothed by the design's Gaussian, the rows
/// one σ apart where every pose in the filter's reach is seen and clean.
struct Signals {
    rows: Vec<usize>,
    gyro: Vec<Vector3<f64>>,
    accel: Vec<Vector3<f64>>,
    /// The mocap's body rates (marker frame).
    rates: Vec<Vector3<f64>>,
    omega_dot: Vec<Vector3<f64>>,
    /// K*(R_mᵀ·e_j) for the mocap world's axes (marker frame).
    nav_axes: [Vec<Vector3<f64>>; 3],
    /// K*(R_mᵀ·p̈) (marker frame), to second order in σ·ω.
    acc_marker: Vec<Vector3<f64>>,
}

/// The signals of `s` read `delay_s` later, smoothed by σ = `smoothing_s`; `None` with fewer than
/// [`MIN_SAMPLES`] rows.
fn signals(s: &Series, delay_s: f64, smoothing_s: f64) -> Option<Signals> {
    let (n, dt) = (s.len(), s.dt());
    let c = correct(s, &Corrections { mocap_delay_s: delay_s, ..Corrections::default() });
    let (pos, att, mut ok) = (raw_vecs(&c.pos_nav), raw_rots(&c.att_body), c.ok);
    let shift = (delay_s / dt).round() as isize;
    for g in glitches(s) {
        let k = g as isize - shift;
        if k >= 0 && (k as usize) < n {
            ok[k as usize] = false;
        }
    }
    let kernel = gaussian_kernel(smoothing_s / dt);
    let reach = kernel.len() / 2 + 2;
    let segs = &s.segments;
    let stride = ((smoothing_s / dt).round() as usize).max(1);
    let mut rows = Vec::new();
    for &(a, b) in segs {
        if b - a > 2 * reach {
            rows.extend((a + reach..b - reach).filter(|i| i % stride == 0 && (i - reach..=i + reach).all(|k| ok[k])));
        }
    }
    if rows.len() < MIN_SAMPLES {
        return None;
    }
    // smoothed only where a closed form reads: the rows used and the two on either side (the
    // second difference of the positions and its own difference reach that far)
    let mut near = vec![false; n];
    for &i in &rows {
        near[i.saturating_sub(2)..(i + 3).min(n)].iter_mut().for_each(|x| *x = true);
    }
    let at_rows = |x: &[Vector3<f64>]| smooth_vec3_rows(x, segs, &kernel, |i| near[i]);
    let pos_s = at_rows(&pos);
    let gyro = at_rows(&raw_vecs(&s.gyro_body));
    let rates = at_rows(&body_rates(&att, &s.t_s, segs));
    // the accelerometer smooths what it reads in its own frame: the mocap's body-frame images are
    // smoothed after the rotation, as the design does it (nav axes exactly; p̈ to second order
    // in σ·ω, with the mocap's own rates ω_m: K*(Rᵀx) = Rᵀ(K*x) − σ²·ω_m×(Rᵀẋ)
    // + (σ²/2)·(ω_m×(ω_m×Rᵀx) − ω̇_m×Rᵀx))
    let nav_axes: [Vec<Vector3<f64>>; 3] = std::array::from_fn(|j| {
        let e = Vector3::from_fn(|r, _| f64::from(u8::from(r == j)));
        at_rows(&att.iter().map(|q| q.inverse_transform_vector(&e)).collect::<Vec<_>>())
    });
    let mut acc_nav = vec![Vector3::zeros(); n];
    for &(a, b) in segs {
        for i in a + 1..b.saturating_sub(1) {
            acc_nav[i] = second_difference(&pos_s, &s.t_s, i);
        }
    }
    let jerk_nav = central_difference(&acc_nav, &s.t_s, segs);
    let rates_dot = central_difference(&rates, &s.t_s, segs);
    let sigma2 = smoothing_s * smoothing_s;
    let mut acc_marker = vec![Vector3::zeros(); n];
    for &i in &rows {
        let (w, wd) = (rates[i], rates_dot[i]);
        let rx = att[i].inverse_transform_vector(&acc_nav[i]);
        let rj = att[i].inverse_transform_vector(&jerk_nav[i]);
        acc_marker[i] = rx - sigma2 * w.cross(&rj) + 0.5 * sigma2 * (w.cross(&w.cross(&rx)) - wd.cross(&rx));
    }
    Some(Signals {
        omega_dot: central_difference(&gyro, &s.t_s, segs),
        accel: at_rows(&raw_vecs(&s.accel_body)),
        rows,
        gyro,
        rates,
        nav_axes,
        acc_marker,
    })
}

/// The spread of R over the `kept` rows: the residual's rms per axis, the gyro's rms about its
/// mean, and the standard deviations about x, y, z from the information Σ[v]ₓᵀ[v]ₓ/σ².
fn spread(x: &Signals, kept: &[usize], r: &Matrix3<f64>) -> (f64, f64, [f64; 3]) {
    let m = kept.len() as f64;
    let mean_gyro = kept.iter().map(|&i| x.gyro[i]).sum::<Vector3<f64>>() / m;
    let mean_rate = kept.iter().map(|&i| x.rates[i]).sum::<Vector3<f64>>() / m;
    let (mut e2, mut w2, mut info) = (0.0, 0.0, Matrix3::zeros());
    for &i in kept {
        let v = r * (x.rates[i] - mean_rate);
        e2 += ((x.gyro[i] - mean_gyro) - v).norm_squared();
        w2 += (x.gyro[i] - mean_gyro).norm_squared();
        let vx = v.cross_matrix();
        info += vx.transpose() * vx;
    }
    let sigma2 = (e2 / (3.0 * m)).max(1e-30);
    let sd = (info / sigma2).try_inverse().map_or([f64::INFINITY; 3], |c| [0, 1, 2].map(|k| c[(k, k)].max(0.0).sqrt()));
    ((e2 / (3.0 * m)).sqrt(), (w2 / (3.0 * m)).sqrt(), sd)
}

/// Gravity in the mocap world, the lever arm and the accelerometer bias at R (one linear solve),
/// then the lever arm and the bias again with gravity's magnitude held at `g` (a rig that stays
/// near one attitude trades ‖g⃗‖ against the bias along the vertical; the direction u is what the
/// tilt needs). Returns g⃗, r and b_a.
fn gravity_lever_bias(
    x: &Signals,
    kept: &[usize],
    r: &Matrix3<f64>,
    gyro_bias: &Vector3<f64>,
    g: f64,
) -> Option<(Vector3<f64>, Vector3<f64>, Vector3<f64>)> {
    let rows_of: Vec<(Matrix3<f64>, Matrix3<f64>, Vector3<f64>)> = kept
        .iter()
        .map(|&i| {
            let w = x.gyro[i] - gyro_bias;
            let lever = x.omega_dot[i].cross_matrix() + w.cross_matrix() * w.cross_matrix();
            // the column of g⃗_j is −R·K*(R_mᵀe_j)
            let gravity =
                Matrix3::from_columns(&[-(r * x.nav_axes[0][i]), -(r * x.nav_axes[1][i]), -(r * x.nav_axes[2][i])]);
            (gravity, lever, x.accel[i] - r * x.acc_marker[i])
        })
        .collect();
    let solve = |with_gravity: bool, g_fixed: &Vector3<f64>| -> Option<DVector<f64>> {
        let k = if with_gravity { 9 } else { 6 };
        let (mut gm, mut y) = (DMatrix::<f64>::zeros(k, k), DVector::<f64>::zeros(k));
        for (gravity, lever, lhs) in &rows_of {
            let mut a = DMatrix::<f64>::zeros(3, k);
            let o = if with_gravity { 3 } else { 0 };
            if with_gravity {
                a.view_mut((0, 0), (3, 3)).copy_from(gravity);
            }
            a.view_mut((0, o), (3, 3)).copy_from(lever);
            a.view_mut((0, o + 3), (3, 3)).copy_from(&Matrix3::identity());
            let rhs = lhs - gravity * g_fixed;
            gm += a.transpose() * &a;
            y += a.transpose() * DVector::from_column_slice(rhs.as_slice());
        }
        crate::identify::fit::stats::solve_spd(&gm, &y)
    };
    let x9 = solve(true, &Vector3::zeros())?;
    let g_vec = Vector3::new(x9[0], x9[1], x9[2]);
    let x6 = solve(false, &(g_vec.normalize() * g))?;
    Some((g_vec, Vector3::new(x6[0], x6[1], x6[2]), Vector3::new(x6[3], x6[4], x6[5])))
}

/// The start of the frames on `s` read `delay_s` later (the clock's start), its signals smoothed
/// by σ = `smoothing_s`. `None` with too few usable samples, or when a closed form does not
/// converge or gives something not finite.
pub(crate) fn frames(s: &Series, delay_s: f64, smoothing_s: f64) -> Option<FrameStart> {
    let x = signals(s, delay_s, smoothing_s)?;
    let pairs: Vec<(Vector3<f64>, Vector3<f64>)> = x.rows.iter().map(|&i| (x.gyro[i], x.rates[i])).collect();
    let (r, gyro_bias, keep) = rotation(&pairs)?;
    let kept: Vec<usize> = x.rows.iter().zip(&keep).filter(|k| *k.1).map(|k| *k.0).collect();
    let (residual, rms, sd) = spread(&x, &kept, &r);
    let (g_vec, lever, accel_bias) = gravity_lever_bias(&x, &kept, &r, &gyro_bias, s.model.gravity_m_s2)?;
    let u = g_vec.normalize();
    let world_tilt = UnitQuaternion::from_euler_angles(-u.y.clamp(-1.0, 1.0).asin(), u.x.atan2(u.z), 0.0);
    let finite = |v: &Vector3<f64>| v.iter().all(|x| x.is_finite());
    if !(finite(&g_vec) && finite(&lever) && finite(&accel_bias) && finite(&gyro_bias)) {
        return None;
    }
    Some(FrameStart {
        body_offset: Rot::from_matrix(&r),
        body_offset_sd_rad: sd,
        gyro_residual_rad_s: residual,
        gyro_rms_rad_s: rms,
        world_tilt: Rot::from_quaternion(world_tilt),
        gravity_m_s2: g_vec.norm(),
        lever_arm_m: Vec3::from_raw(lever),
        accel_bias_m_s2: Vec3::from_raw(accel_bias),
        gyro_bias_rad_s: Vec3::from_raw(gyro_bias),
        samples: kept.len(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Wahba's solution recovers a half-turn about (1, 0, 1)/√2 and an axis permutation from
    /// exact pairs v_i ↦ R·v_i, where any small-angle method starting at the identity is lost.
    #[test]
    fn wahba_recovers_any_rotation_from_exact_pairs() {
        let half = UnitQuaternion::from_scaled_axis(Vector3::new(1.0, 0.0, 1.0).normalize() * std::f64::consts::PI);
        let perm = Matrix3::new(0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0);
        for r in [half.to_rotation_matrix().into_inner(), perm] {
            let v = [Vector3::new(1.0, 0.2, -0.3), Vector3::new(-0.5, 1.0, 0.4), Vector3::new(0.3, -0.7, 1.1)];
            let b: Matrix3<f64> = v.iter().map(|x| (r * x) * x.transpose()).sum();
            let got = wahba(&b).unwrap();
            assert!((got - r).norm() < 1e-12, "{got} vs {r}");
        }
    }
}

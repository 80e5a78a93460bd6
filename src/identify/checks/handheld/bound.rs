//! The floor of a hand-held calibration: the Cramér–Rao bound of a trial, and the errors an
//! efficient estimator would make, drawn from it.

use super::rig::{Setting, Trial, attitude};
use crate::frames::{Body, Nav, Rot, Vec3};
use crate::rng::{Component, Stream as Rng};
use crate::vehicle::params::GRAVITY;
use nalgebra::{DMatrix, DVector, Matrix3xX, Vector3};

/// Draws per rig of an efficient estimator's errors in the batch table's Cramér–Rao column.
pub const BOUND_DRAWS: usize = 1000;

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
    blocks(fisher(trial, set))
}

/// The Fisher information F of [`bound`], in the order rotation δ (3), tilt (2), time offset,
/// lever arm (3), accelerometer bias (3), gyro bias (3).
fn fisher(trial: &Trial, set: &Setting) -> DMatrix<f64> {
    let dt = 1.0 / set.imu_hz;
    let (wa, wg) = (dt / set.accel_noise_density.powi(2), dt / set.gyro_noise_density.powi(2));
    let n = (set.duration_s * set.imu_hz).round() as i64;
    let lever = trial.calibration().lever_arm;
    let mut fisher = DMatrix::<f64>::zeros(15, 15);
    for k in 0..=n {
        let s = Sample::at(trial, lever, k as f64 * dt);
        fisher += s.ja.tr_mul(&s.ja) * wa + s.jg.tr_mul(&s.jg) * wg;
    }
    fisher
}

/// A trial's truth at one instant and the IMU's sensitivities to θ there (the table of
/// [`bound`]), in the order of [`fisher`].
pub(super) struct Sample {
    /// The IMU body's attitude (body FRD → world NED).
    pub(super) att: Rot<Body, Nav>,
    /// Body rate and its derivative (rad/s, rad/s², IMU body FRD).
    pub(super) w: Vec3<Body>,
    pub(super) dw: Vec3<Body>,
    /// The tracked point's specific force Rᵀ(p̈ − g·e_D) (m/s², IMU body FRD), without the lever
    /// arm's terms.
    pub(super) f_point: Vec3<Body>,
    /// ∂(accelerometer reading)/∂θ and ∂(gyro reading)/∂θ.
    pub(super) ja: Matrix3xX<f64>,
    pub(super) jg: Matrix3xX<f64>,
}

impl Sample {
    /// The truth and sensitivities at time t (s) of `trial`, whose lever arm is `lever` (m, IMU
    /// body; its calibration's, taken once by the caller).
    pub(super) fn at(trial: &Trial, lever: Vec3<Body>, t: f64) -> Sample {
        let g = Vec3::<Nav>::new(0.0, 0.0, GRAVITY);
        // the attitude, the body rate and its derivative, the point's and the IMU's specific force
        let state = |t: f64| {
            let (att, w, dw) = attitude(&trial.euler, t);
            let acc = Vec3::<Nav>::from_raw(Vector3::from_fn(|k, _| trial.position[k].at(t)[2]));
            let f_point = att.inverse().apply(acc - g);
            (att, w, dw, f_point, f_point + dw.cross(&lever) + w.cross(&w.cross(&lever)))
        };
        let h = 1e-4;
        let (att, w, dw, f_point, f) = state(t);
        let df = (state(t + h).4.raw() - state(t - h).4.raw()) / (2.0 * h);
        let (mut ja, mut jg) = (Matrix3xX::<f64>::zeros(15), Matrix3xX::<f64>::zeros(15));
        for j in 0..3 {
            // the j-th axis of the IMU body (rotation, lever arm, biases) and of the world (tilt)
            let e = Vec3::<Body>::from_raw(Vector3::ith(j, 1.0));
            ja.set_column(j, e.cross(&f).raw());
            jg.set_column(j, e.cross(&w).raw());
            if j < 2 {
                let e_world = Vec3::<Nav>::from_raw(Vector3::ith(j, 1.0));
                ja.set_column(3 + j, att.inverse().apply(g.cross(&e_world)).raw());
            }
            ja.set_column(6 + j, (dw.cross(&e) + w.cross(&w.cross(&e))).raw());
            ja.set_column(9 + j, e.raw());
            jg.set_column(12 + j, e.raw());
        }
        ja.set_column(5, &df);
        jg.set_column(5, dw.raw());
        Sample { att, w, dw, f_point, ja, jg }
    }
}

/// The calibration blocks of an information matrix's inverse (the order of [`fisher`]); `None`
/// when it is singular.
pub(super) fn blocks(information: DMatrix<f64>) -> Option<Bound> {
    let cov = information.cholesky()?.inverse();
    let block = |i: usize, n: usize| cov.view((i, i), (n, n)).clone_owned();
    let (rotation, tilt, lever) = (block(0, 3), block(3, 2), block(6, 3));
    Some(Bound {
        rotation: [0, 1, 2].map(|i| [0, 1, 2].map(|j| rotation[(i, j)])),
        tilt: [0, 1].map(|i| [0, 1].map(|j| tilt[(i, j)])),
        delay: cov[(5, 5)],
        lever: [0, 1, 2].map(|i| [0, 1, 2].map(|j| lever[(i, j)])),
    })
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
    /// as [`Outcome`](super::Outcome) scores the fit's. `None` where a block is not positive definite.
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::identify::checks::handheld::rig::{Wave, draw};
    use crate::identify::output::handheld::quantile;
    use std::f64::consts::TAU;

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
}

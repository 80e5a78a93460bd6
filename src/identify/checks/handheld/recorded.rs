//! The floor of a hand-held calibration on the log as recorded: the trajectory a nuisance that
//! the noisy mocap measures and the IMU senses, the biases walking.

use super::banded::BandedSchur;
use super::bound::{Bound, Sample, blocks};
use super::rig::{Setting, Trial};
use nalgebra::{DMatrix, Matrix3, Vector3};

/// The Cramér–Rao bound of a trial's calibration with everything its log leaves unknown: the
/// [`bound`](super::bound) of the perfect mocap, raised by the mocap's noise and the biases'
/// walks. It is the floor the fit's errors are measured against: no unbiased estimator that
/// does not know the motion beforehand goes below it.
///
/// **Unknowns.** θ, the fifteen of [`bound`](super::bound) (the biases their values at the
/// start), and a nuisance per IMU sample k (Δt apart): the trajectory's error, δp_k (m, world
/// NED) of the tracked point and φ_k (rad, IMU body FRD, R_k·Exp(φ_k)) of the attitude, and
/// the biases' walks since the start, d_a,k and d_g,k (d_0 = 0). A block whose noise is zero
/// in the setting is known and left out.
///
/// **Measurements**, linearized at the truth (ω, ω̇, R and r the truth's, F = Rᵀ(p̈ − g·e_D)
/// the tracked point's specific force, \[v×\] the cross-product matrix):
/// - the gyro at k, of variance σ_g²/Δt: J_g·δθ + δω_k + d_g,k, with
///   δω_k = φ̇_k + ω × φ_k (the rate of R·Exp(φ)) and φ̇_k = (φ_k+1 − φ_k−1)/(2Δt);
/// - the accelerometer at k, of variance σ_a²/Δt: J_a·δθ + Rᵀ·δp̈_k + \[F×\]·φ_k − \[r×\]·δω̇_k
///   − (\[(ω × r)×\] + \[ω×\]\[r×\])·δω_k + d_a,k, with δp̈_k = (δp_k+1 − 2δp_k + δp_k−1)/Δt² and
///   δω̇_k = φ̈_k + ω̇ × φ_k + ω × φ̇_k (the first-order change of f = F + ω̇ × r + ω × (ω × r));
/// - the mocap at each frame, between samples k and k + 1 at a fraction u: (1 − u)·δp_k +
///   u·δp_k+1 of variance σ_p² per axis and (1 − u)·φ_k + u·φ_k+1 of variance σ_φ² (its noise
///   is isotropic, so the frame it is added in does not change the information);
/// - each walk's step, d_k+1 − d_k of variance σ_b²·Δt per axis (a hybrid bound: the walk is
///   random with this prior, the rest deterministic).
///
/// The IMU samples at the log's two ends, which have no neighbour for the differences, are left
/// out. The information left for θ is the Schur complement of the nuisance,
/// J = B − Cᵀ·A⁻¹·C, with A banded (a sample's rows reach its two neighbours) and eliminated
/// as it streams (a row-by-row banded Cholesky factor); the bound is J⁻¹. The mocap's frames are placed on its own
/// clock from the log's start: its delay shifts them by a fraction of a sample, which moves
/// nothing a bound resolves.
///
/// `None` where [`bound`](super::bound) is, or when the motion leaves a parameter unseen.
pub fn bound_as_recorded(trial: &Trial, set: &Setting) -> Option<Bound> {
    if !set.imu_has_white_noise() {
        return None;
    }
    blocks(information(trial, set)?)
}

/// J of [`bound_as_recorded`], in the order of [`bound`](super::bound)'s information; `None`
/// when the nuisance is not seen.
fn information(trial: &Trial, set: &Setting) -> Option<DMatrix<f64>> {
    let dt = 1.0 / set.imu_hz;
    let n = (set.duration_s * set.imu_hz).round() as usize;
    // the nuisance blocks of a sample, in order, each three wide; a known one has none
    let on =
        [set.mocap_pos_sd_m > 0.0, set.mocap_att_sd_rad > 0.0, set.accel_bias_walk > 0.0, set.gyro_bias_walk > 0.0];
    let offset = |block: usize| if on[block] { Some(3 * on[..block].iter().filter(|x| **x).count()) } else { None };
    let [pos, att, walk_a, walk_g] = [0, 1, 2, 3].map(offset);
    let stride = 3 * on.iter().filter(|x| **x).count();
    let index = |k: usize, block: Option<usize>, axis: usize| block.map(|b| k * stride + b + axis);
    let (wa, wg) = (dt / set.accel_noise_density.powi(2), dt / set.gyro_noise_density.powi(2));
    let lever_arm = trial.calibration().lever_arm;
    let lever = lever_arm.raw().clone_owned();
    let zero = [0.0; 15];
    let mut schur = BandedSchur::new(15, (3 * stride).max(1) - 1);
    let mut frame = 0usize;
    let mut terms: Vec<(usize, f64)> = Vec::with_capacity(3 * stride + 1);
    for k in 0..=n {
        if (1..n).contains(&k) {
            let s = Sample::at(trial, lever_arm, k as f64 * dt);
            let Sensed { gyro_dphi: dw_dphi, accel_dphi: da_dphi, accel_dp: rt } = sensed(&s, &lever, dt);
            for axis in 0..3 {
                // the gyro's row
                terms.clear();
                for (m, d) in dw_dphi.iter().enumerate() {
                    for c in 0..3 {
                        terms.extend(index(k + m - 1, att, c).map(|i| (i, d[(axis, c)])));
                    }
                }
                terms.extend(index(k, walk_g, axis).map(|i| (i, 1.0)));
                let h: Vec<f64> = s.jg.row(axis).iter().copied().collect();
                schur.add(&terms, &h, wg);
                // the accelerometer's row
                terms.clear();
                for (m, d) in da_dphi.iter().enumerate() {
                    for c in 0..3 {
                        terms.extend(index(k + m - 1, att, c).map(|i| (i, d[(axis, c)])));
                        terms.extend(index(k + m - 1, pos, c).map(|i| (i, rt[m][(axis, c)])));
                    }
                }
                terms.extend(index(k, walk_a, axis).map(|i| (i, 1.0)));
                let h: Vec<f64> = s.ja.row(axis).iter().copied().collect();
                schur.add(&terms, &h, wa);
            }
        }
        // the mocap's frames in [k, k + 1) samples
        loop {
            let u = frame as f64 * set.imu_hz / set.mocap_hz - k as f64;
            if u >= 1.0 {
                break;
            }
            frame += 1;
            if k == n && u > 0.0 {
                continue;
            }
            for (block, sd) in [(pos, set.mocap_pos_sd_m), (att, set.mocap_att_sd_rad)] {
                for c in 0..3 {
                    terms.clear();
                    terms.extend(index(k, block, c).map(|i| (i, 1.0 - u)));
                    terms.extend(index(k + 1, block, c).filter(|_| u > 0.0).map(|i| (i, u)));
                    if !terms.is_empty() {
                        schur.add(&terms, &zero, 1.0 / (sd * sd));
                    }
                }
            }
        }
        // each walk's step from k to k + 1; d_0 = 0 is known, its variable a placeholder
        for (block, sd) in [(walk_a, set.accel_bias_walk), (walk_g, set.gyro_bias_walk)] {
            for c in 0..3 {
                if let Some(i) = index(0, block, c).filter(|_| k == 0) {
                    schur.add(&[(i, 1.0)], &zero, 1.0);
                }
                if k < n {
                    terms.clear();
                    terms.extend(index(k + 1, block, c).map(|i| (i, 1.0)));
                    terms.extend(index(k, block, c).filter(|_| k > 0).map(|i| (i, -1.0)));
                    if !terms.is_empty() {
                        schur.add(&terms, &zero, 1.0 / (sd * sd * dt));
                    }
                }
            }
        }
        // no later row reaches a sample before k
        schur.factor_until(k * stride)?;
    }
    schur.finish((n + 1) * stride)
}

/// How the IMU at sample k senses the trajectory's errors at samples k − 1, k, k + 1 (index
/// m = 0, 1, 2): the gyro's and the accelerometer's change per φ_k−1+m, and the accelerometer's
/// per δp_k−1+m (the measurements of [`bound_as_recorded`]).
struct Sensed {
    gyro_dphi: [Matrix3<f64>; 3],
    accel_dphi: [Matrix3<f64>; 3],
    accel_dp: [Matrix3<f64>; 3],
}

/// [`Sensed`] at the truth `s`, lever arm `r` (m, IMU body), samples `dt` apart.
fn sensed(s: &Sample, r: &Vector3<f64>, dt: f64) -> Sensed {
    let (w, dw, f) = (s.w.raw(), s.dw.raw(), s.f_point.raw());
    let (wx, rx, i3) = (w.cross_matrix(), r.cross_matrix(), Matrix3::identity());
    // δω = φ̇ + ω × φ and δω̇ = φ̈ + ω̇ × φ + ω × φ̇, by central differences
    let gyro_dphi = [-i3 / (2.0 * dt), wx, i3 / (2.0 * dt)];
    let dww_dphi =
        [i3 / (dt * dt) - wx / (2.0 * dt), -2.0 * i3 / (dt * dt) + dw.cross_matrix(), i3 / (dt * dt) + wx / (2.0 * dt)];
    // δ(ω × (ω × r)) = −([(ω × r)×] + [ω×][r×])·δω
    let g = -(w.cross(r).cross_matrix() + wx * rx);
    let accel_dphi = [0, 1, 2].map(|m| {
        let own = if m == 1 { f.cross_matrix() } else { Matrix3::zeros() };
        own - rx * dww_dphi[m] + g * gyro_dphi[m]
    });
    let rt = s.att.inverse().matrix();
    let accel_dp = [1.0, -2.0, 1.0].map(|c| rt * (c / (dt * dt)));
    Sensed { gyro_dphi, accel_dphi, accel_dp }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::identify::checks::handheld::bound;
    use crate::identify::checks::handheld::rig::{Wave, draw};
    use std::f64::consts::TAU;

    /// The time offset's information in closed form on a rig that only yaws, ψ = A·sin Ωt, with
    /// no lever arm and the mocap at the IMU's rate. The offset is seen only in the gyro's z,
    /// J_g = ψ̈, and only the yaw's error φ_z and the z bias's walk reach that axis, so its
    /// information is Σ ψ̈²/S at Ω, S the per-sample spectrum of what the gyro z is compared
    /// against: σ_g²/Δt of its own noise, σ_φ²·sin²(ΩΔt)/Δt² of the mocap's yaw noise through
    /// the central difference, and σ_b²·Δt/(4·sin²(ΩΔt/2)) of a walking bias. Each case is held
    /// to 2 %; the perfect mocap's σ_g²/Δt alone is 2–4× off, a difference without 1/(2Δt) or a
    /// walk's step without Δt by orders of magnitude.
    #[test]
    fn the_yaws_information_is_the_closed_form_with_mocap_noise_and_a_walk() {
        let (a, hz, duration) = (0.8, 0.5, 64.0);
        let mut trial = draw(1, 0);
        trial.truth.lever_arm_mm = [0.0; 3];
        trial.euler = [Wave(vec![]), Wave(vec![]), Wave(vec![[a, hz, 0.0]])];
        trial.position = [Wave(vec![]), Wave(vec![]), Wave(vec![])];
        let base = Setting {
            duration_s: duration,
            mocap_hz: 500.0,
            mocap_pos_sd_m: 0.0,
            mocap_att_sd_rad: 0.0,
            accel_bias_walk: 0.0,
            gyro_bias_walk: 0.0,
            ..Setting::default()
        };
        let (w, dt) = (TAU * hz, 1.0 / base.imu_hz);
        let n = duration / dt - 1.0;
        let white = base.gyro_noise_density.powi(2) / dt;
        for (set, s) in [
            (Setting { mocap_att_sd_rad: 0.01, ..base }, white + (0.01 * (w * dt).sin() / dt).powi(2)),
            (
                Setting { gyro_bias_walk: 2.6e-3, ..base },
                white + 2.6e-3f64.powi(2) * dt / (4.0 * (w * dt / 2.0).sin().powi(2)),
            ),
        ] {
            let j = information(&trial, &set).expect("every nuisance is seen");
            let want = n * (a * w * w).powi(2) / 2.0 / s;
            assert!((j[(5, 5)] / want - 1.0).abs() < 0.02, "{} against {want} ({set:?})", j[(5, 5)]);
            assert!(want * 1.9 < n * (a * w * w).powi(2) / 2.0 / white, "the mocap's or the walk's share is seen");
        }
    }

    /// The same on a rig that only translates, p = A·sin Ωt along x, with the mocap's position
    /// noise: the offset is seen in the accelerometer's x, J_a = ḟ = −AΩ³·cos Ωt, against
    /// σ_a²/Δt + σ_p²·(2 − 2·cos ΩΔt)²/Δt⁴ (the mocap's position through the second
    /// difference). A second difference without 1/Δt² or in the world instead of the body
    /// (here the same) would be off by orders of magnitude.
    #[test]
    fn the_translations_information_is_the_closed_form_with_mocap_noise() {
        let (a, hz, duration, sd) = (0.05, 2.0, 32.0, 0.003);
        let mut trial = draw(1, 0);
        trial.euler = [Wave(vec![]), Wave(vec![]), Wave(vec![])];
        trial.position = [Wave(vec![[a, hz, 0.0]]), Wave(vec![]), Wave(vec![])];
        let set = Setting {
            duration_s: duration,
            mocap_hz: 500.0,
            mocap_pos_sd_m: sd,
            mocap_att_sd_rad: 0.0,
            accel_bias_walk: 0.0,
            gyro_bias_walk: 0.0,
            ..Setting::default()
        };
        let (w, dt) = (TAU * hz, 1.0 / set.imu_hz);
        let n = duration / dt - 1.0;
        let white = set.accel_noise_density.powi(2) / dt;
        let s = white + (sd * (2.0 - 2.0 * (w * dt).cos()) / (dt * dt)).powi(2);
        let j = information(&trial, &set).expect("every nuisance is seen");
        let want = n * (a * w.powi(3)).powi(2) / 2.0 / s;
        assert!((j[(5, 5)] / want - 1.0).abs() < 0.02, "{} against {want}", j[(5, 5)]);
        assert!(s > 1.9 * white, "the mocap's share is seen");
    }

    /// What the IMU senses of a trajectory's error is its exact first-order change: on a drawn
    /// rig (every axis turning, a lever arm of 0.1–0.2 m), the attitude R·Exp(φ(t)) and the
    /// position p + δp(t) with smooth errors of 10⁻⁴ at 2–3 Hz give a body rate (from
    /// Log(R(t − h)ᵀ·R(t + h))/2h, h = 1 ms) and a specific force F + ω̇ × r + ω × (ω × r) whose changes,
    /// over the errors' size, match [`sensed`] applied to the errors at the three samples
    /// within 1 % of their largest component, at ten instants. A sign of the lever arm's terms,
    /// a missing \[F×\] or a transposed Rᵀ is off by the whole term.
    #[test]
    fn the_sensed_change_is_the_kinematics_first_order_change() {
        use crate::frames::{Rot, Vec3};
        use crate::vehicle::params::GRAVITY;
        let trial = draw(1, 2);
        let r = trial.calibration().lever_arm.raw().clone_owned();
        let (eps, dt, h) = (1e-4, 1.0 / 500.0, 1e-3);
        let phi = |t: f64| Vector3::new((12.0 * t).sin(), (17.0 * t + 0.5).cos(), (14.0 * t + 1.0).sin()) * eps;
        let dp = |t: f64| Vector3::new((15.0 * t).cos(), (13.0 * t).sin(), (19.0 * t + 2.0).sin()) * eps;
        let ddp = |t: f64| {
            Vector3::new(-225.0 * (15.0 * t).cos(), -169.0 * (13.0 * t).sin(), -361.0 * (19.0 * t + 2.0).sin()) * eps
        };
        // the exact body rate, its derivative and the IMU's specific force of a perturbed motion
        let rot = |t: f64, on: f64| {
            let (att, _, _) = crate::identify::checks::handheld::attitude(&trial.euler, t);
            att.matrix()
                * Rot::<crate::frames::Body, crate::frames::Body>::from_rotation_vector(Vec3::from_raw(phi(t) * on))
                    .matrix()
        };
        let rate = |t: f64, on: f64| {
            let m = rot(t - h, on).transpose() * rot(t + h, on);
            nalgebra::Rotation3::from_matrix_unchecked(m).scaled_axis() / (2.0 * h)
        };
        let imu = |t: f64, on: f64| {
            let w = rate(t, on);
            let dw = (rate(t + h, on) - rate(t - h, on)) / (2.0 * h);
            let acc = Vector3::from_fn(|k, _| trial.position[k].at(t)[2]) + ddp(t) * on;
            let f =
                rot(t, on).transpose() * (acc - Vector3::new(0.0, 0.0, GRAVITY)) + dw.cross(&r) + w.cross(&w.cross(&r));
            (w, f)
        };
        for k in (0..10).map(|i| 1000 + 731 * i) {
            let t = k as f64 * dt;
            let s = Sample::at(&trial, trial.calibration().lever_arm, t);
            let sensed = sensed(&s, &r, dt);
            let (w0, f0) = imu(t, 0.0);
            let (w1, f1) = imu(t, 1.0);
            let (exact_w, exact_f) = ((w1 - w0) / eps, (f1 - f0) / eps);
            let (mut lin_w, mut lin_f) = (Vector3::zeros(), Vector3::zeros());
            for m in 0..3 {
                let tm = t + (m as f64 - 1.0) * dt;
                lin_w += sensed.gyro_dphi[m] * phi(tm) / eps;
                lin_f += (sensed.accel_dphi[m] * phi(tm) + sensed.accel_dp[m] * dp(tm)) / eps;
            }
            assert!((lin_w - exact_w).amax() < 0.01 * exact_w.amax(), "t {t}: gyro {lin_w} against {exact_w}");
            assert!((lin_f - exact_f).amax() < 0.01 * exact_f.amax(), "t {t}: accel {lin_f} against {exact_f}");
        }
    }

    /// A log's own floor is never below the perfect mocap's (each parameter's variance at least
    /// as large: a nuisance only takes information away), and it comes down to it as the
    /// mocap's noise and the walks vanish: within 0.1 % at 10⁻⁸ m, 10⁻⁸ rad and walks of 10⁻¹².
    #[test]
    fn the_floor_as_recorded_lies_above_the_perfect_mocaps_and_meets_it_in_the_limit() {
        let trial = draw(1, 3);
        let set = Setting { duration_s: 16.0, ..Setting::default() };
        let perfect = bound(&trial, &set).unwrap();
        let diag = |b: &Bound| {
            [
                b.rotation[0][0],
                b.rotation[1][1],
                b.rotation[2][2],
                b.tilt[0][0],
                b.tilt[1][1],
                b.delay,
                b.lever[0][0],
                b.lever[1][1],
                b.lever[2][2],
            ]
        };
        let recorded = bound_as_recorded(&trial, &set).unwrap();
        for (r, p) in diag(&recorded).into_iter().zip(diag(&perfect)) {
            assert!(r >= p, "{r} below the perfect mocap's {p}");
        }
        assert!(diag(&recorded)[5] > 1.1 * diag(&perfect)[5], "the mocap's attitude noise costs the offset");
        let tiny = Setting {
            mocap_pos_sd_m: 1e-8,
            mocap_att_sd_rad: 1e-8,
            accel_bias_walk: 1e-12,
            gyro_bias_walk: 1e-12,
            ..set
        };
        for (r, p) in diag(&bound_as_recorded(&trial, &tiny).unwrap()).into_iter().zip(diag(&perfect)) {
            assert!((r / p - 1.0).abs() < 1e-3, "{r} against the perfect mocap's {p}");
        }
    }
}

//! Rigid-body fit of marker positions (Kabsch / Horn, least squares).
//!
//! Given template points m_i (frame `A`) and observed points y_i (frame `B`), find the rotation R
//! and translation t minimising Σ‖R·m_i + t − y_i‖². With centroids m̄, ȳ and the cross-covariance
//! H = Σ (m_i − m̄)(y_i − ȳ)ᵀ = U·S·Vᵀ, the optimum is R = V·diag(1, 1, det(V·Uᵀ))·Uᵀ and
//! t = ȳ − R·m̄ (the sign fix makes R a proper rotation even for nearly planar sets).
//!
//! The Vicon system runs this on the visible markers of each vehicle; flyarena also runs it on the
//! template against the displaced markers *in body coordinates* to get the true mocap offset.

use crate::frames::{Frame, Rot, Vec3};
use nalgebra::{Matrix3, Quaternion, Rotation3, UnitQuaternion, Vector3};

/// Result of a rigid fit: `y ≈ rotation·m + translation`.
#[derive(Clone, Copy, Debug)]
pub struct RigidFit<A: Frame, B: Frame> {
    /// The rotation from the template's frame A to the observation's frame B.
    pub rotation: Rot<A, B>,
    /// The template's origin in B (m).
    pub translation: Vec3<B>,
    /// Root-mean-square residual of the fit (m).
    pub rms_residual: f64,
}

/// Minimum spread for a fit: the second singular value of the centred template must exceed this
/// (m²); below it the points are (nearly) collinear and the rotation about their line is unknown.
const MIN_SPREAD_M2: f64 = 1e-8;

/// Fits `template[i]` onto `observed[i]` for the indices where `visible[i]`. `None` when fewer than
/// three points are visible or they are collinear.
pub fn rigid_fit<A: Frame, B: Frame>(
    template: &[Vec3<A>],
    observed: &[Vec3<B>],
    visible: &[bool],
) -> Option<RigidFit<A, B>> {
    rigid_fit_near(template, observed, visible, None)
}

/// [`rigid_fit`] started from `guess`, a rotation near the answer (the previous frame's, 5 ms
/// earlier): Newton's method on SO(3) ([`refine_rotation`]) reaches the same optimum in two or
/// three cheap steps. Without a guess, or when Newton does not converge, it is [`kabsch`].
pub fn rigid_fit_near<A: Frame, B: Frame>(
    template: &[Vec3<A>],
    observed: &[Vec3<B>],
    visible: &[bool],
    guess: Option<Rot<A, B>>,
) -> Option<RigidFit<A, B>> {
    let n = visible.iter().zip(template).filter(|(v, _)| **v).count();
    if n < 3 || template.len() != observed.len() || template.len() != visible.len() {
        return None;
    }
    let mut cm = Vector3::zeros();
    let mut cy = Vector3::zeros();
    for i in (0..template.len()).filter(|&i| visible[i]) {
        cm += template[i].raw();
        cy += observed[i].raw();
    }
    cm /= n as f64;
    cy /= n as f64;
    let mut h = Matrix3::zeros();
    let mut spread = Matrix3::zeros();
    for i in (0..template.len()).filter(|&i| visible[i]) {
        let a = template[i].raw() - cm;
        let b = observed[i].raw() - cy;
        h += a * b.transpose();
        spread += a * a.transpose();
    }
    // collinear ⇔ the spread's second eigenvalue λ₂ vanishes. Without an eigen-decomposition
    // (this runs 200 times a second per vehicle): with λ₁ ≥ λ₂ ≥ λ₃ ≥ 0, the sum of the principal
    // 2×2 minors c₂ = λ₁λ₂ + λ₁λ₃ + λ₂λ₃ lies in [λ₁λ₂, 3λ₁λ₂] and λ₁ ∈ [tr/3, tr], so
    // c₂/tr ∈ [λ₂/3, 3λ₂]: the test c₂/tr < MIN_SPREAD_M2 is λ₂'s within a factor of 3.
    let c2 = spread[(0, 0)] * spread[(1, 1)] - spread[(0, 1)] * spread[(1, 0)] + spread[(0, 0)] * spread[(2, 2)]
        - spread[(0, 2)] * spread[(2, 0)]
        + spread[(1, 1)] * spread[(2, 2)]
        - spread[(1, 2)] * spread[(2, 1)];
    let tr = spread.trace();
    if !(tr > 0.0 && c2 / tr >= MIN_SPREAD_M2) {
        return None;
    }
    let q = match guess.and_then(|g| refine_rotation(&h, g.quaternion())) {
        Some(q) => q,
        None => UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(kabsch(&h)?)),
    };
    // one sign for the output, whichever path found it: w ≥ 0 (a rotation by at most π)
    let q = if q.w < 0.0 { UnitQuaternion::new_unchecked(-q.into_inner()) } else { q };
    let r = *q.to_rotation_matrix().matrix();
    let t = cy - r * cm;
    let mut ss = 0.0;
    for i in (0..template.len()).filter(|&i| visible[i]) {
        ss += (r * template[i].raw() + t - observed[i].raw()).norm_squared();
    }
    Some(RigidFit {
        rotation: Rot::from_quaternion(q),
        translation: Vec3::from_raw(t),
        rms_residual: (ss / n as f64).sqrt(),
    })
}

/// The rotation R maximising tr(R·H) for the cross-covariance H = Σ a_i·b_iᵀ, i.e. minimising
/// Σ‖R·a_i − b_i‖² over proper rotations (Kabsch; Wahba's problem for weighted vectors):
/// H = U·S·Vᵀ, R = V·diag(1, 1, det(V·Uᵀ))·Uᵀ. `None` if the SVD does not converge.
///
/// Fast path: when det(H) is clearly positive, R is the orthogonal polar factor of Hᵀ
/// (Hᵀ = V·S·Uᵀ = (V·Uᵀ)·(U·S·Uᵀ)), found by Higham's scaled Newton iteration
/// X ← ½(γ·X + γ⁻¹·X⁻ᵀ), γ = (‖X⁻¹‖_F/‖X‖_F)^½, which converges quadratically; it is checked for
/// orthogonality. Rank-deficient or reflected H (three markers, coplanar sets, degenerate data)
/// take the SVD.
pub fn kabsch(h: &Matrix3<f64>) -> Option<Matrix3<f64>> {
    if let Some(r) = polar_rotation(&h.transpose()) {
        return Some(r);
    }
    kabsch_svd(h)
}

/// Newton's method for Wahba's problem on SO(3) from a nearby rotation `guess`: maximise
/// f(R) = tr(R·H). Writing R = exp(\[δ\]×)·R₀ and A = R₀·H,
///
/// ```text
/// f ≈ tr A + gᵀδ − ½·δᵀ(tr(A)·I − S)·δ,   g = (A₁₂ − A₂₁, A₂₀ − A₀₂, A₀₁ − A₁₀),  S = (A + Aᵀ)/2
/// ```
///
/// (exact to second order: exp(\[δ\]×) = I + \[δ\]× + ½\[δ\]×² + …, \[δ\]×² = δδᵀ − |δ|²I), so the step is
/// δ = (tr(A)·I − S)⁻¹·g, applied with the retraction q ← normalise(q + ½·(0, δ)⊗q). Convergence is
/// quadratic; it stops when |δ| < 1e-9 rad (the next error is ~1e-18). At the optimum A is
/// symmetric with eigenvalues σ₁ ≥ σ₂ ≥ σ₃ (σ₃ < 0 for a reflected H), and the Hessian
/// tr(A)·I − S has eigenvalues σᵢ + σⱼ > 0 unless the points are collinear: it is checked positive
/// definite (its leading minors) at every step, so the iteration cannot settle on a saddle. `None` (the
/// caller falls back to [`kabsch`]) when it is not, or after 8 steps.
pub fn refine_rotation(h: &Matrix3<f64>, guess: &UnitQuaternion<f64>) -> Option<UnitQuaternion<f64>> {
    let mut q = *guess;
    for _ in 0..8 {
        let a = q.to_rotation_matrix().matrix() * h;
        let g = Vector3::new(a[(1, 2)] - a[(2, 1)], a[(2, 0)] - a[(0, 2)], a[(0, 1)] - a[(1, 0)]);
        let delta =
            solve_positive_definite(&(Matrix3::from_diagonal_element(a.trace()) - (a + a.transpose()) * 0.5), &g)?;
        q = UnitQuaternion::new_normalize(q.into_inner() + Quaternion::from_imag(delta) * q.into_inner() * 0.5);
        if delta.norm() < 1e-9 {
            return Some(q);
        }
    }
    None
}

/// x = M⁻¹·b for a symmetric 3×3 M, by the adjugate; `None` unless M is positive definite
/// (Sylvester: the leading minors are positive) and x is finite.
fn solve_positive_definite(m: &Matrix3<f64>, b: &Vector3<f64>) -> Option<Vector3<f64>> {
    let (a, d, f) = (m[(0, 0)], m[(1, 1)], m[(2, 2)]);
    let (b_, c, e) = (m[(0, 1)], m[(0, 2)], m[(1, 2)]);
    // cofactors of the symmetric matrix [[a, b, c], [b, d, e], [c, e, f]]
    let (c00, c01, c02) = (d * f - e * e, c * e - b_ * f, b_ * e - c * d);
    let (c11, c12, c22) = (a * f - c * c, b_ * c - a * e, a * d - b_ * b_);
    let det = a * c00 + b_ * c01 + c * c02;
    if !(a > 0.0 && c22 > 0.0 && det > 0.0) {
        return None;
    }
    let x = Vector3::new(
        c00 * b[0] + c01 * b[1] + c02 * b[2],
        c01 * b[0] + c11 * b[1] + c12 * b[2],
        c02 * b[0] + c12 * b[1] + c22 * b[2],
    ) / det;
    x.iter().all(|v| v.is_finite()).then_some(x)
}

fn polar_rotation(m: &Matrix3<f64>) -> Option<Matrix3<f64>> {
    let scale = m.norm();
    if !(scale > 0.0 && scale.is_finite()) || m.determinant() <= 1e-9 * scale * scale * scale {
        return None;
    }
    let mut x = m / scale;
    for _ in 0..40 {
        let inv = x.try_inverse()?;
        let g = (inv.norm() / x.norm()).sqrt();
        let next = (x * g + inv.transpose() / g) * 0.5;
        let step = (next - x).norm();
        x = next;
        if step < 1e-15 {
            break;
        }
    }
    ((x.transpose() * x - Matrix3::identity()).norm() < 1e-12).then_some(x)
}

/// Kabsch by the SVD (any H).
fn kabsch_svd(h: &Matrix3<f64>) -> Option<Matrix3<f64>> {
    let svd = h.svd(true, true);
    let (u, v_t) = (svd.u?, svd.v_t?);
    let v = v_t.transpose();
    let d = (v * u.transpose()).determinant().signum();
    Some(v * Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, d)) * u.transpose())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The degeneracy test of the polar decomposition is relative to the matrix's scale: a
    /// rotation scaled by 10⁻⁵ (markers a few µm apart in the cross-covariance's units) is as
    /// good a rotation as the unscaled one.
    #[test]
    fn polar_rotation_does_not_depend_on_the_scale() {
        let r = *nalgebra::Rotation3::from_euler_angles(0.3, -0.2, 1.0).matrix();
        for k in [1.0, 1e-5, 1e3] {
            let got = polar_rotation(&(r * k)).unwrap_or_else(|| panic!("scale {k}: refused"));
            assert!((got - r).abs().max() < 1e-12, "scale {k}");
        }
        assert!(polar_rotation(&(r * 0.0)).is_none());
    }

    /// The fast path is the polar factor, not a rotation it happened to be handed: for M = R·S
    /// with S symmetric positive definite (here a stretch by 3, 1 and 0.2 along tilted axes),
    /// the orthogonal polar factor of M is R, in closed form. Newton needs several steps from
    /// such an M (the first step leaves X far from orthogonal), so an iteration that stops
    /// early falls back to the SVD and returns `None` here.
    #[test]
    fn polar_rotation_of_a_stretched_rotation_is_the_rotation() {
        let r = *nalgebra::Rotation3::from_euler_angles(0.3, -0.2, 1.0).matrix();
        let axes = *nalgebra::Rotation3::from_euler_angles(-0.7, 0.4, 0.1).matrix();
        let s = axes * Matrix3::from_diagonal(&Vector3::new(3.0, 1.0, 0.2)) * axes.transpose();
        let got = polar_rotation(&(r * s)).expect("a well-conditioned M takes the fast path");
        assert!((got - r).abs().max() < 1e-12, "{got} against {r}");
    }
    use crate::frames::{Body, Euler, MocapBody, Nav};

    /// An asymmetric four-marker template (body frame, m).
    const FOUR_MARKERS: [Vec3<Body>; 4] = [
        Vec3::new(0.2, 0.0, -0.03),
        Vec3::new(0.0, 0.17, -0.03),
        Vec3::new(-0.13, 0.0, -0.03),
        Vec3::new(0.0, -0.1, -0.05),
    ];

    #[test]
    fn recovers_a_known_pose_exactly() {
        let m = FOUR_MARKERS;
        let r: Rot<Body, Nav> = Rot::from_euler(Euler::new(0.3, -0.2, 2.5));
        let t = Vec3::<Nav>::new(1.0, -2.0, -1.5);
        let y: Vec<_> = m.iter().map(|p| r.apply(*p) + t).collect();
        let fit = rigid_fit(&m, &y, &[true; 4]).unwrap();
        assert!((fit.rotation.inverse() * r).angle() < 1e-12);
        assert!((fit.translation - t).norm() < 1e-12);
        // any single marker may be lost
        let fit3 = rigid_fit(&m, &y, &[true, false, true, true]).unwrap();
        assert!((fit3.rotation.inverse() * r).angle() < 1e-12);
        assert!(rigid_fit(&m, &y, &[true, false, false, true]).is_none());
    }

    /// The Newton polar path and the SVD agree on random cross-covariances, near-coplanar ones
    /// included; a rank-2 H (three markers) goes to the SVD and still gives a rotation.
    #[test]
    fn polar_path_equals_the_svd() {
        let mut r = crate::rng::Stream::new(5, crate::rng::Component::MocapNoise, 0);
        for k in 0..2000 {
            let flat = [1.0, 1.0, if k % 2 == 0 { 1e-3 } else { 1.0 }];
            let a = Matrix3::from_fn(|_, j| r.normal() * flat[j]);
            let rot = Rot::<Body, Nav>::from_euler(Euler::new(r.normal(), r.normal(), 3.0 * r.normal())).matrix();
            let h = a * a.transpose() * rot.transpose() + Matrix3::from_fn(|_, _| 1e-4 * r.normal());
            let (fast, svd) = (kabsch(&h).unwrap(), kabsch_svd(&h).unwrap());
            assert!((fast - svd).norm() < 1e-9, "case {k}: {}", (fast - svd).norm());
        }
        let m = [Vector3::new(0.1, 0.0, 0.0), Vector3::new(0.0, 0.1, 0.0), Vector3::new(-0.1, -0.1, 0.0)];
        let h: Matrix3<f64> = m.iter().map(|a| a * a.transpose()).sum();
        assert!(polar_rotation(&h.transpose()).is_none());
        let r = kabsch(&h).unwrap();
        assert!((r.transpose() * r - Matrix3::identity()).norm() < 1e-12 && (r.determinant() - 1.0).abs() < 1e-12);
    }

    /// Marker-like point sets (the built-in patterns, 1 mm noise, ten times the default):
    /// Newton from a guess up to 0.3 rad away converges to the SVD's optimum. On random,
    /// possibly nearly collinear cross-covariances it may decline (and the caller uses Kabsch),
    /// but whatever it returns is the optimum.
    #[test]
    fn newton_from_a_nearby_guess_equals_the_svd() {
        let mut r = crate::rng::Stream::new(9, crate::rng::Component::MocapNoise, 0);
        let rand_vec = |r: &mut crate::rng::Stream| Vec3::<Nav>::new(r.normal(), r.normal(), r.normal());
        for k in 0..2000 {
            let pattern = crate::mocap::builtin_pattern(k % 8);
            let truth =
                Rot::<MocapBody, Nav>::from_euler(Euler::new(0.5 * r.normal(), 0.5 * r.normal(), 3.0 * r.normal()));
            let y: Vec<Vec3<Nav>> = pattern.iter().map(|m| truth.apply(*m) + rand_vec(&mut r) * 1e-3).collect();
            let n = rand_vec(&mut r);
            let guess = Rot::<Nav, Nav>::from_rotation_vector(n * (0.3 * r.uniform() / n.norm())) * truth;
            let near = rigid_fit_near(&pattern, &y, &[true; 4], Some(guess)).unwrap();
            let (cm, cy) = (
                pattern.iter().map(|m| *m.raw()).sum::<Vector3<f64>>() / 4.0,
                y.iter().map(|m| *m.raw()).sum::<Vector3<f64>>() / 4.0,
            );
            let h: Matrix3<f64> =
                pattern.iter().zip(&y).map(|(m, y)| (m.raw() - cm) * (y.raw() - cy).transpose()).sum();
            assert!(refine_rotation(&h, guess.quaternion()).is_some(), "case {k}: Newton declined");
            let err = (near.rotation.matrix() - kabsch_svd(&h).unwrap()).norm();
            assert!(err < 1e-12, "case {k}: {err}");
        }
        let mut declined = 0;
        for k in 0..2000 {
            let flat = [1.0, 1.0, if k % 2 == 0 { 1e-3 } else { 1.0 }];
            let a = Matrix3::from_fn(|_, j| r.normal() * flat[j]);
            let truth = Rot::<Body, Nav>::from_euler(Euler::new(r.normal(), r.normal(), 3.0 * r.normal()));
            let h = a * a.transpose() * truth.matrix().transpose() + Matrix3::from_fn(|_, _| 1e-3 * r.normal());
            let n = rand_vec(&mut r);
            let guess = Rot::<Nav, Nav>::from_rotation_vector(n * (0.3 * r.uniform() / n.norm())) * truth;
            match refine_rotation(&h, guess.quaternion()) {
                Some(q) => {
                    let err = (*q.to_rotation_matrix().matrix() - kabsch_svd(&h).unwrap()).norm();
                    // as in polar_path_equals_the_svd: near-rank-deficient H are ill-conditioned
                    assert!(err < 1e-9, "random case {k}: {err}");
                }
                None => declined += 1,
            }
        }
        assert!(declined < 200, "Newton declined {declined} of 2000 random cases");
        // a guess half a turn away: declined, and the fit still finds the pose
        let m = FOUR_MARKERS;
        let truth: Rot<Body, Nav> = Rot::from_euler(Euler::new(0.3, -0.2, 2.5));
        let y: Vec<Vec3<Nav>> = m.iter().map(|p| truth.apply(*p)).collect();
        let far = Rot::<Nav, Nav>::from_euler(Euler::new(std::f64::consts::PI, 0.0, 0.0)) * truth;
        let fit = rigid_fit_near(&m, &y, &[true; 4], Some(far)).unwrap();
        assert!((fit.rotation.inverse() * truth).angle() < 1e-12);
        // three markers (rank-2 H, where the polar path gives up) converge too
        let fit3 = rigid_fit_near(&m, &y, &[true, true, false, true], Some(truth)).unwrap();
        assert!((fit3.rotation.inverse() * truth).angle() < 1e-12);
    }

    /// An exact rigid motion away from the origin, y_i = R·m_i + t with t = (1, 2, 3) m: the fit
    /// returns R and t, and its RMS residual √(Σ‖R·m_i + t − y_i‖²/n) is 0 (to rounding). A bug it
    /// catches: the residual with −t (2‖t‖ = 7.5 m here).
    #[test]
    fn an_exact_motion_away_from_the_origin_leaves_no_residual() {
        let truth: Rot<Body, Nav> = Rot::from_euler(Euler::new(0.3, -0.2, 2.5));
        let t = Vec3::<Nav>::new(1.0, 2.0, 3.0);
        let y: Vec<Vec3<Nav>> = FOUR_MARKERS.iter().map(|p| Vec3::from_raw(truth.apply(*p).raw() + t.raw())).collect();
        let fit = rigid_fit(&FOUR_MARKERS, &y, &[true; 4]).unwrap();
        assert!((fit.rotation.inverse() * truth).angle() < 1e-12);
        assert!((fit.translation.raw() - t.raw()).norm() < 1e-12, "{:?}", fit.translation);
        assert!(fit.rms_residual < 1e-12, "rms residual {} m", fit.rms_residual);
    }

    /// A pattern grown by 1 + ε about its centroid and then moved, y_i = R·(1 + ε)·m_i + t: the
    /// cross-covariance is (1 + ε)·S·Rᵀ with S = Σ a_i·a_iᵀ (a_i = m_i − m̄), so the fit is R, each
    /// residual is −ε·R·a_i and the RMS residual is ε·√(Σ‖a_i‖²/n). A square of half-side 0.1 m
    /// with ε = 0.02: 2 mm. Three of its markers (centroid (0, 0.1/3, 0)): Σ‖a_i‖² = 0.08/3 m², so
    /// 0.02·√(0.08/9) = 1.8856 mm (a growth about another point is one about the visible markers'
    /// centroid plus a shift, which the translation absorbs). A bug it catches: the RMS over n as
    /// √(ss % n) (2× for four markers).
    #[test]
    fn a_grown_pattern_leaves_its_growth_as_the_rms_residual() {
        let square = [
            Vec3::<Body>::new(0.1, 0.0, 0.0),
            Vec3::new(0.0, 0.1, 0.0),
            Vec3::new(-0.1, 0.0, 0.0),
            Vec3::new(0.0, -0.1, 0.0),
        ];
        let truth: Rot<Body, Nav> = Rot::from_euler(Euler::new(0.3, -0.2, 2.5));
        let t = Vec3::<Nav>::new(1.0, 2.0, 3.0);
        let y: Vec<Vec3<Nav>> = square.iter().map(|p| Vec3::from_raw(truth.apply(*p).raw() * 1.02 + t.raw())).collect();
        for (visible, rms) in [([true; 4], 0.002), ([true, true, true, false], 0.0018856180831641267)] {
            let fit = rigid_fit(&square, &y, &visible).unwrap();
            assert!((fit.rotation.inverse() * truth).angle() < 1e-12);
            assert!(
                (fit.rms_residual - rms).abs() < 1e-12,
                "{visible:?}: rms residual {} m, not {rms} m",
                fit.rms_residual
            );
        }
    }

    /// Markers on one line, whichever its direction (an axis, a diagonal in each coordinate
    /// plane, a general one), leave the rotation about it unknown: no fit. The spread test sums
    /// the three principal 2×2 minors of the spread, each of which is zero for a line, and a
    /// diagonal line makes exactly one pair of off-diagonal terms non-zero in each minor it
    /// enters. Off the line by 1 cm, the same markers fit.
    #[test]
    fn collinear_markers_are_rejected() {
        for dir in [[1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [1.0, 0.0, 1.0], [0.0, 1.0, 1.0], [1.0, 2.0, 3.0]] {
            let d = Vec3::<Body>::new(dir[0], dir[1], dir[2]);
            let m = [d * 0.0, d * 0.1, d * 0.3];
            let y: Vec<Vec3<Nav>> = m.iter().map(|p| p.assume_same_as()).collect();
            assert!(rigid_fit(&m, &y, &[true; 3]).is_none(), "{dir:?}");
            let off = Vector3::new(dir[0], dir[1], dir[2]).cross(&Vector3::z()).normalize() * 0.01;
            let bent = [m[0], m[1] + Vec3::new(off.x, off.y, off.z), m[2]];
            let y: Vec<Vec3<Nav>> = bent.iter().map(|p| p.assume_same_as()).collect();
            assert!(rigid_fit(&bent, &y, &[true; 3]).is_some(), "{dir:?} bent");
        }
    }

    /// A fit needs three visible markers and one observation and one visibility flag per template
    /// marker: three visible fit, two visible or a list one entry short (any of the three) is no
    /// fit, with a guess or without. A bug it catches: the length checks joined by `&&` let a list
    /// one entry short through.
    #[test]
    fn a_fit_needs_three_visible_markers_and_one_entry_per_marker() {
        let r: Rot<Body, Nav> = Rot::from_euler(Euler::from_degrees(10.0, -20.0, 30.0));
        let m: Vec<Vec3<Body>> = crate::mocap::builtin_pattern(0).iter().map(|p| p.assume_same_as()).collect();
        let y: Vec<Vec3<Nav>> = m.iter().map(|p| r.apply(*p)).collect();
        for guess in [None, Some(r)] {
            assert!(rigid_fit_near(&m, &y, &[true; 4], guess).is_some(), "all four");
            assert!(rigid_fit_near(&m, &y, &[true, true, false, true], guess).is_some(), "three visible");
            assert!(rigid_fit_near(&m, &y, &[true, false, true, false], guess).is_none(), "two visible");
            assert!(rigid_fit_near(&m, &y[..3], &[true; 4], guess).is_none(), "an observation short");
            assert!(rigid_fit_near(&m, &y, &[true; 3], guess).is_none(), "a visibility flag short");
            assert!(rigid_fit_near(&m[..3], &y, &[true; 4], guess).is_none(), "a template marker short");
        }
    }

    /// One sign for the output whichever path found it: a guess given as −q (w < 0; the same
    /// rotation) is refined to −q, and the fit turns it to w ≥ 0, as the Kabsch path gives (a bug
    /// it catches: `w < 0` as `w == 0` kept the guess's sign).
    #[test]
    fn the_fitted_quaternion_has_w_at_least_zero_whatever_the_guess() {
        let r: Rot<Body, Nav> = Rot::from_euler(Euler::from_degrees(10.0, -20.0, 30.0));
        let m: Vec<Vec3<Body>> = crate::mocap::builtin_pattern(0).iter().map(|p| p.assume_same_as()).collect();
        let y: Vec<Vec3<Nav>> = m.iter().map(|p| r.apply(*p)).collect();
        let flipped: Rot<Body, Nav> = Rot::from_quaternion(UnitQuaternion::new_unchecked(-r.quaternion().into_inner()));
        let kabsch = rigid_fit(&m, &y, &[true; 4]).unwrap().rotation;
        let near = rigid_fit_near(&m, &y, &[true; 4], Some(flipped)).unwrap().rotation;
        assert!(r.quaternion().w > 0.0 && flipped.quaternion().w < 0.0);
        for q in [kabsch.quaternion(), near.quaternion()] {
            assert!(
                q.w > 0.0 && (q.into_inner() - r.quaternion().into_inner()).norm() < 1e-12,
                "{q:?} against {:?}",
                r.quaternion()
            );
        }
    }

    /// The collinearity test is on λ₂ (m²), not on c₂ (m⁴): markers (±a, 0, 0) and (0, h, 0) have
    /// the spread diag(2a², 2h²/3, 0), so c₂/tr = λ₁λ₂/(λ₁ + λ₂). With a = 0.1 m (λ₁ = 0.02 m²), a
    /// height giving λ₂ = 3e-8 m² (h = 0.21 mm) passes the 1e-8 m² bound (c₂/tr = 3.0e-8) and one
    /// giving λ₂ = 3e-9 m² does not; the product c₂ = λ₁λ₂ = 6e-10 would refuse both (a bug it
    /// catches: `c₂ / tr` as `c₂ % tr`, which is c₂ below tr).
    #[test]
    fn the_collinearity_bound_is_on_the_second_spread_eigenvalue() {
        let fits = |lambda2: f64| {
            let h = (1.5 * lambda2).sqrt();
            let m = [Vec3::<Body>::new(-0.1, 0.0, 0.0), Vec3::new(0.1, 0.0, 0.0), Vec3::new(0.0, h, 0.0)];
            let y: Vec<Vec3<Nav>> = m.iter().map(|p| p.assume_same_as()).collect();
            rigid_fit(&m, &y, &[true; 3]).is_some()
        };
        assert!(fits(3e-8) && !fits(3e-9));
    }
}

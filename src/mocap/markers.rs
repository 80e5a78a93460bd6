//! Marker sets: the stored template, the markers as actually mounted, and the offset they produce.
//!
//! The template m_i is what the Vicon system stored when the object was defined, in
//! [`MocapBody`] coordinates (at that moment identical to the body frame). After a knock the
//! markers sit at b_i = R_rot·m_i + d_i in the true [`Body`] frame: a whole-frame rotation R_rot
//! and/or individual displacements d_i. The mocap then reports R_m = R·R_off, p_m = p + R·t_off,
//! where (R_off, t_off) is the rigid fit of the template onto the b_i (see `physics-notes.md`).
//! R_off, as `Rot<MocapBody, Body>`, is the *true offset* the calibration must recover; its Euler
//! angles are what the measured roll, pitch and yaw exceed the true ones by at hover.

use super::fit::rigid_fit;
use crate::frames::{Body, Euler, MocapBody, Rot, Vec3};

/// Number of built-in unique 4-marker patterns.
pub const BUILTIN_PATTERNS: usize = 8;

/// Built-in 4-marker template number `k` (m, body FRD, markers 3–5 cm above the arms).
/// Every pattern is asymmetric (no two pairwise distances equal), and pattern k moves the fourth
/// marker 15 mm further out than pattern k−1, so no two patterns are alike.
pub fn builtin_pattern(k: usize) -> [Vec3<MocapBody>; 4] {
    let k = k as f64;
    [
        Vec3::new(0.21, 0.0, -0.03),
        Vec3::new(0.0, 0.17, -0.03),
        Vec3::new(-0.13, 0.0, -0.03),
        Vec3::new(0.0, -0.10 - 0.015 * k, -0.05),
    ]
}

/// Sorted pairwise distances: the signature by which a mocap system tells patterns apart.
pub fn pattern_signature(template: &[Vec3<MocapBody>]) -> Vec<f64> {
    let mut d = Vec::new();
    for i in 0..template.len() {
        for j in i + 1..template.len() {
            d.push((template[i] - template[j]).norm());
        }
    }
    d.sort_by(f64::total_cmp);
    d
}

/// Two patterns are confusable if their signatures agree within `tol_m` everywhere.
pub fn patterns_confusable(a: &[Vec3<MocapBody>], b: &[Vec3<MocapBody>], tol_m: f64) -> bool {
    let (sa, sb) = (pattern_signature(a), pattern_signature(b));
    sa.len() == sb.len() && sa.iter().zip(&sb).all(|(x, y)| (x - y).abs() < tol_m)
}

/// A vehicle's markers: template and mounted positions.
#[derive(Clone, Debug)]
pub struct MarkerSet {
    /// The stored template: where the mocap believes the markers are (m, MocapBody).
    pub template: Vec<Vec3<MocapBody>>,
    /// Where they are on the vehicle (m, body FRD from the centre of mass).
    pub mounted: Vec<Vec3<Body>>,
}

/// The offset the mounted markers produce (the truth for requirement R1).
#[derive(Clone, Copy, Debug)]
pub struct TrueOffset {
    /// R_off: maps template coordinates into body coordinates.
    pub rotation: Rot<MocapBody, Body>,
    /// t_off (m, body frame).
    pub translation: Vec3<Body>,
    /// Euler angles of R_off: the measured-minus-true angles at hover.
    pub euler: Euler,
    /// RMS misfit of the template to the mounted markers (m): 0 for a rigid displacement.
    pub rms_misfit_m: f64,
}

impl MarkerSet {
    /// `rotation` is applied about the body origin, then each displacement `d_i` (body frame, m).
    pub fn displaced(template: Vec<Vec3<MocapBody>>, rotation: Euler, displacement: &[Vec3<Body>]) -> Self {
        let r: Rot<MocapBody, Body> = Rot::from_euler(rotation);
        let mounted = template.iter().zip(displacement).map(|(m, d)| r.apply(*m) + *d).collect();
        MarkerSet { template, mounted }
    }

    /// `None` if the template is degenerate (fewer than 3 markers or collinear).
    pub fn true_offset(&self) -> Option<TrueOffset> {
        let visible = vec![true; self.template.len()];
        let fit = rigid_fit(&self.template, &self.mounted, &visible)?;
        Some(TrueOffset {
            rotation: fit.rotation,
            translation: fit.translation,
            euler: fit.rotation.euler(),
            rms_misfit_m: fit.rms_residual,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The signature by hand: a square of side 0.1 m has four sides and two diagonals,
    /// (0.1, 0.1, 0.1, 0.1, 0.1·√2, 0.1·√2), each pair once and no marker against itself.
    #[test]
    fn the_signature_is_each_pairwise_distance_once_sorted() {
        let square =
            [Vec3::new(0.0, 0.0, 0.0), Vec3::new(0.1, 0.0, 0.0), Vec3::new(0.1, 0.1, 0.0), Vec3::new(0.0, 0.1, 0.0)];
        let d = 0.1 * 2f64.sqrt();
        let want = [0.1, 0.1, 0.1, 0.1, d, d];
        let got = pattern_signature(&square);
        assert_eq!(got.len(), want.len(), "{got:?}");
        assert!(got.iter().zip(want).all(|(g, w)| (g - w).abs() < 1e-15), "{got:?}");
    }

    #[test]
    fn a_whole_frame_rotation_is_the_offset() {
        let t = builtin_pattern(0).to_vec();
        let ms = MarkerSet::displaced(t, Euler::from_degrees(3.0, 3.0, 0.0), &[Vec3::zeros(); 4]);
        let off = ms.true_offset().unwrap();
        assert!((off.euler.roll.to_degrees() - 3.0).abs() < 1e-10);
        assert!((off.euler.pitch.to_degrees() - 3.0).abs() < 1e-10);
        assert!(off.euler.yaw.abs() < 1e-10 && off.rms_misfit_m < 1e-12);
    }

    #[test]
    fn lifting_the_right_marker_gives_a_negative_roll_offset() {
        // Marker 1 sits on the right arm (y = +0.17 m). Lift it 5 mm (−z): the fitted frame's
        // right side comes up, a negative roll, smaller than atan(5 mm / 0.17 m) = 1.68° because
        // the other three markers hold the fit back.
        let t = builtin_pattern(0).to_vec();
        let mut d = [Vec3::zeros(); 4];
        d[1] = Vec3::new(0.0, 0.0, -0.005);
        let off = MarkerSet::displaced(t, Euler::ZERO, &d).true_offset().unwrap();
        assert!(off.euler.roll < 0.0 && off.euler.roll.to_degrees() > -1.7, "{:?}", off.euler);
        assert!(off.rms_misfit_m > 0.0);
    }

    /// Pairwise distances do not change under a rotation, a translation or a relabelling of the
    /// markers, so such a copy is confusable however small the tolerance. Scaling a pattern by 1 +
    /// k moves its distance d by k·d, the largest d_max most: confusable exactly when tol >
    /// k·d_max. A pattern with another number of markers never is. (a bug it catches:
    /// `patterns_confusable` returning false.)
    #[test]
    fn a_pattern_moved_rigidly_and_relabelled_is_confusable_one_scaled_only_within_the_tolerance() {
        let a = builtin_pattern(0).to_vec();
        let r: Rot<MocapBody, MocapBody> = Rot::from_euler(Euler::from_degrees(20.0, -35.0, 110.0));
        let mut moved: Vec<Vec3<MocapBody>> = a.iter().map(|m| r.apply(*m) + Vec3::new(0.3, -1.2, 0.7)).collect();
        moved.rotate_left(1);
        assert!(patterns_confusable(&a, &moved, 1e-9));
        let k = 0.01;
        let scaled: Vec<Vec3<MocapBody>> = a.iter().map(|m| *m * (1.0 + k)).collect();
        let d_max = pattern_signature(&a).last().copied().unwrap();
        assert!(patterns_confusable(&a, &scaled, 1.01 * k * d_max));
        assert!(!patterns_confusable(&a, &scaled, 0.99 * k * d_max));
        assert!(!patterns_confusable(&a, &a[..3], 1.0), "3 markers against 4");
    }

    #[test]
    fn builtin_patterns_are_unique() {
        for a in 0..BUILTIN_PATTERNS {
            for b in a + 1..BUILTIN_PATTERNS {
                assert!(!patterns_confusable(&builtin_pattern(a), &builtin_pattern(b), 0.005));
            }
        }
    }
}

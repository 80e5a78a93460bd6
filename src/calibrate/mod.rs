//! The paper's offset calibration (Sec. IV): hover averaging for roll and pitch, the straight
//! flight (6) with its validity check (7) and the least-squares fit (8)–(9) for yaw, batch and
//! recursive; and, beyond the paper, the full 3-axis offset from body-rate telemetry ([`gyro`]).
//!
//! Sign convention: an offset is what the *measured* angle exceeds the true one by
//! (φ_m = φ + φ_off). The estimate is a rotation `Rot<MocapBody, Body>` (R_off); the attitude the
//! controller uses is R̂ = R_m·R̂_offᵀ (exact), or, with [`Compensation::Euler`], the paper's
//! subtraction φ = φ_m − φ_off, θ = θ_m − θ_off, ψ = ψ_m − ψ_off (its small-angle form).
//!
//! Yaw: while the yaw loop holds the measured heading at ψ_com = 0, the true heading is −ψ_off,
//! so the track satisfies X_E = tan(−ψ_off)·X_N + X_E,0. Equation (9) gives the *course*
//! tan⁻¹(S_xy/S_xx) of that track; in this convention ψ̂_off = −tan⁻¹(S_xy/S_xx).

pub mod gyro;

pub use gyro::{ClockFit, ClockSearch, GyroAlignment, GyroFit};

use crate::frames::{Body, Euler, MocapBody, MocapNav, Rot, wrap_pi};
use nalgebra::{Matrix2, Vector2};

/// How the estimated offset is removed from the measured attitude.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Compensation {
    /// R̂ = R_m·R̂_offᵀ: exact for any offset.
    Rotation,
    /// The paper's φ_m − φ_off, θ_m − θ_off, ψ_m − ψ_off.
    Euler,
}

/// The current offset estimate (identity before calibration).
#[derive(Clone, Copy, Debug)]
pub struct OffsetEstimate {
    /// The offset as Z-Y-X angles (rad): the rotation from the body FRD to the markers' frame.
    pub euler: Euler,
    rotation: Rot<MocapBody, Body>,
}

impl Default for OffsetEstimate {
    /// No offset (written out rather than by `from_euler`: a `from_euler` that returned
    /// `Default::default()` made the two call each other for ever).
    fn default() -> Self {
        OffsetEstimate { euler: Euler::ZERO, rotation: Rot::identity() }
    }
}

impl OffsetEstimate {
    /// The estimate of these angles.
    pub fn from_euler(euler: Euler) -> Self {
        OffsetEstimate { euler, rotation: Rot::from_euler(euler) }
    }

    /// R_off: markers' frame to body.
    pub fn rotation(&self) -> Rot<MocapBody, Body> {
        self.rotation
    }

    /// The attitude the controller uses: the measured attitude with the estimated offset removed.
    pub fn compensate(&self, measured: Rot<MocapBody, MocapNav>, mode: Compensation) -> Rot<Body, MocapNav> {
        match mode {
            Compensation::Rotation => measured * self.rotation.inverse(),
            Compensation::Euler => {
                let m = measured.euler();
                let o = self.euler;
                Rot::from_euler(Euler::new(m.roll - o.roll, m.pitch - o.pitch, wrap_pi(m.yaw - o.yaw)))
            }
        }
    }
}

/// Roll/pitch offsets by averaging the measured angles during a hover (Sec. IV.A).
#[derive(Clone, Debug, Default)]
pub struct HoverAverager {
    sum_roll: f64,
    sum_pitch: f64,
    n: u64,
}

impl HoverAverager {
    /// One measured attitude taken in the hover window.
    pub fn add(&mut self, measured: Euler) {
        self.sum_roll += measured.roll;
        self.sum_pitch += measured.pitch;
        self.n += 1;
    }
    /// Attitudes averaged so far.
    pub fn samples(&self) -> u64 {
        self.n
    }
    /// (φ̄_m, θ̄_m), or `None` before the first sample.
    pub fn mean(&self) -> Option<(f64, f64)> {
        (self.n > 0).then(|| (self.sum_roll / self.n as f64, self.sum_pitch / self.n as f64))
    }
}

/// Result of the line fit X_E = slope·X_N + X_E,0.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct LineFit {
    /// dX_E/dX_N of the flown line.
    pub slope: f64,
    /// X̂_E,0 (m).
    pub x_e0: f64,
    /// ψ̂_off = −tan⁻¹(slope) (rad), see the module doc for the sign.
    pub psi_offset: f64,
    /// Samples fitted.
    pub n: usize,
}

fn line(slope: f64, x_e0: f64, n: usize) -> LineFit {
    LineFit { slope, x_e0, psi_offset: -slope.atan(), n }
}

/// Batch least squares, equation (9) verbatim. `None` with fewer than two distinct X_N.
pub fn batch_ls(north: &[f64], east: &[f64]) -> Option<LineFit> {
    let n = north.len();
    if n < 2 || east.len() != n {
        return None;
    }
    let mn = north.iter().sum::<f64>() / n as f64;
    let me = east.iter().sum::<f64>() / n as f64;
    let (mut sxx, mut sxy) = (0.0, 0.0);
    for (x, y) in north.iter().zip(east) {
        sxx += (x - mn) * (x - mn);
        sxy += (y - me) * (x - mn);
    }
    if sxx <= 0.0 {
        return None;
    }
    let slope = sxy / sxx;
    Some(line(slope, me - slope * mn, n))
}

/// Recursive least squares for (8) with forgetting factor 1.
///
/// Until the regressor has spread enough to determine both parameters, it accumulates the
/// information matrix ΦᵀΦ and Φᵀy (constant memory); then it initialises P₀ = (ΦᵀΦ)⁻¹,
/// θ₀ = P₀Φᵀy — the batch solution of those samples — and continues with the standard update
/// K = Pφ/(1 + φᵀPφ), θ ← θ + K(y − φᵀθ), P ← (I − Kφᵀ)P(I − Kφᵀ)ᵀ + KKᵀ (Joseph form, keeps P
/// symmetric positive definite). Initialised so, it reproduces batch LS to rounding, with no
/// prior (a P₀ = d·I start would solve a ridge problem instead). The regressor is X_N − X_N,first
/// for conditioning; the intercept is shifted back on output.
#[derive(Clone, Debug)]
pub struct Rls {
    origin: Option<f64>,
    info: Matrix2<f64>,
    info_y: Vector2<f64>,
    /// (P, θ) once initialised.
    state: Option<(Matrix2<f64>, Vector2<f64>)>,
    min_spread_m: f64,
    n: usize,
    min_x: f64,
    max_x: f64,
}

impl Rls {
    /// `min_spread_m`: how far X_N must have moved before the recursion starts (m).
    pub fn new(min_spread_m: f64) -> Self {
        Rls {
            origin: None,
            info: Matrix2::zeros(),
            info_y: Vector2::zeros(),
            state: None,
            min_spread_m,
            n: 0,
            min_x: f64::INFINITY,
            max_x: f64::NEG_INFINITY,
        }
    }

    /// One mocap position (m, mocap NED) of the straight flight.
    pub fn update(&mut self, north: f64, east: f64) {
        let x0 = *self.origin.get_or_insert(north);
        let phi = Vector2::new(north - x0, 1.0);
        self.n += 1;
        match &mut self.state {
            None => {
                self.info += phi * phi.transpose();
                self.info_y += phi * east;
                self.min_x = self.min_x.min(north);
                self.max_x = self.max_x.max(north);
                if self.max_x - self.min_x >= self.min_spread_m
                    && let Some(p) = self.info.try_inverse()
                {
                    let theta = p * self.info_y;
                    self.state = Some((p, theta));
                }
            }
            Some((p, theta)) => {
                let pphi = *p * phi;
                let k = pphi / (1.0 + phi.dot(&pphi));
                *theta += k * (east - phi.dot(theta));
                let a = Matrix2::identity() - k * phi.transpose();
                *p = a * *p * a.transpose() + k * k.transpose();
            }
        }
    }

    /// The current estimate, once the recursion has started.
    pub fn estimate(&self) -> Option<LineFit> {
        let (_, theta) = self.state.as_ref()?;
        let x0 = self.origin?;
        Some(line(theta[0], theta[1] - theta[0] * x0, self.n))
    }
}

/// Equation (7): the flight is valid if the mean measured yaw and roll are within bounds.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Validity {
    /// Mean measured yaw over the flight (rad).
    pub mean_yaw: f64,
    /// Mean measured roll (rad).
    pub mean_roll: f64,
    /// The bound on |mean yaw| (rad).
    pub eps_yaw: f64,
    /// The bound on |mean roll| (rad).
    pub eps_roll: f64,
    /// Both means within their bounds (and at least one sample).
    pub accepted: bool,
}

/// The running means of (7) during the straight flight.
#[derive(Clone, Debug, Default)]
pub struct ValidityCheck {
    sum_yaw: f64,
    sum_roll: f64,
    n: u64,
}

impl ValidityCheck {
    /// One measured attitude of the straight flight.
    pub fn add(&mut self, measured: Euler) {
        self.sum_yaw += wrap_pi(measured.yaw);
        self.sum_roll += measured.roll;
        self.n += 1;
    }
    /// (7) with these bounds (rad).
    pub fn verdict(&self, eps_yaw: f64, eps_roll: f64) -> Validity {
        let n = self.n.max(1) as f64;
        let (mean_yaw, mean_roll) = (self.sum_yaw / n, self.sum_roll / n);
        Validity {
            mean_yaw,
            mean_roll,
            eps_yaw,
            eps_roll,
            accepted: self.n > 0 && mean_yaw.abs() < eps_yaw && mean_roll.abs() < eps_roll,
        }
    }
}

/// Total least squares heading of a track (leading singular vector of the centred [N E]): no
/// attenuation bias from noise on X_N, valid for any heading. Returns the course angle (rad).
pub fn tls_course(north: &[f64], east: &[f64]) -> Option<f64> {
    let n = north.len();
    if n < 2 {
        return None;
    }
    let mn = north.iter().sum::<f64>() / n as f64;
    let me = east.iter().sum::<f64>() / n as f64;
    let (mut sxx, mut syy, mut sxy) = (0.0, 0.0, 0.0);
    for (x, y) in north.iter().zip(east) {
        sxx += (x - mn) * (x - mn);
        syy += (y - me) * (y - me);
        sxy += (x - mn) * (y - me);
    }
    (sxx + syy > 0.0).then(|| 0.5 * (2.0 * sxy).atan2(sxx - syy))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Sec. IV.A by hand: the offsets are the plain means of the measured roll and pitch over
    /// the hover, (1° + 3° + 8°)/3 = 4° and (−2° + 4° + 1°)/3 = 1°; yaw does not enter; before
    /// the first sample there is no estimate (not a zero one).
    #[test]
    fn the_hover_average_is_the_mean_roll_and_pitch() {
        let mut h = HoverAverager::default();
        assert_eq!(h.mean(), None);
        for (r, p, y) in [(1.0, -2.0, 30.0), (3.0, 4.0, -170.0), (8.0, 1.0, 90.0)] {
            h.add(Euler::from_degrees(r, p, y));
        }
        let (roll, pitch) = h.mean().expect("three samples");
        assert_eq!(h.samples(), 3);
        assert!(
            (roll.to_degrees() - 4.0).abs() < 1e-12 && (pitch.to_degrees() - 1.0).abs() < 1e-12,
            "{}°, {}°",
            roll.to_degrees(),
            pitch.to_degrees()
        );
    }

    /// A track that does not move has no heading: every point equal (a hover, or one point
    /// repeated) gives `None`, not the course 0 that atan2(0, 0) would make of it; two distinct
    /// points give their direction, and so does a track along one axis only. A bug it catches: `sxx +
    /// syy > 0` as `>=`, as `sxx − syy` and as `sxx · syy`.
    #[test]
    fn a_track_that_does_not_move_has_no_course() {
        assert_eq!(tls_course(&[1.0, 1.0, 1.0], &[-2.0, -2.0, -2.0]), None);
        assert_eq!(tls_course(&[1.0], &[-2.0]), None);
        let northeast = tls_course(&[0.0, 1.0], &[0.0, 1.0]).expect("a track that moves");
        assert!((northeast - std::f64::consts::FRAC_PI_4).abs() < 1e-15, "{northeast}");
        // a track along one axis has no spread across it (and none along the other axis)
        assert_eq!(tls_course(&[0.0, 1.0, 2.0], &[3.0, 3.0, 3.0]), Some(0.0), "due north");
        let east = tls_course(&[3.0, 3.0, 3.0], &[0.0, 1.0, 2.0]).expect("due east");
        assert!((east - std::f64::consts::FRAC_PI_2).abs() < 1e-15, "{east}");
    }

    #[test]
    fn ls_recovers_the_heading_of_a_straight_track() {
        // true heading −ψ_off = −2°: the measured heading 0 hides it
        let psi_off = 2f64.to_radians();
        let north: Vec<f64> = (0..500).map(|k| k as f64 * 0.01).collect();
        let east: Vec<f64> = north.iter().map(|n| 0.3 + n * (-psi_off).tan()).collect();
        let fit = batch_ls(&north, &east).unwrap();
        assert!((fit.psi_offset - psi_off).abs() < 1e-12 && (fit.x_e0 - 0.3).abs() < 1e-12);
        assert!((tls_course(&north, &east).unwrap() + psi_off).abs() < 1e-12);
    }

    /// The recursion of (8) on a straight track that starts 1 m north (its regressor is taken from
    /// the first X_N and the intercept shifted back): no estimate until X_N has spread 0.5 m (32
    /// samples of 1/64 m, exact in binary), then the line itself; with a wobble of ±1 cm in X_E,
    /// which the recursion's updates must follow, batch LS (9) to rounding. A bug it catches:
    /// `update` as a no-op (only the property test `rls_equals_batch_ls` caught it).
    #[test]
    fn rls_starts_once_the_track_spreads_and_then_equals_batch_ls() {
        let psi_off = 2f64.to_radians();
        let north: Vec<f64> = (0..500).map(|k| 1.0 + k as f64 / 64.0).collect();
        for wobble in [0.0, 0.01] {
            let east: Vec<f64> = north
                .iter()
                .enumerate()
                .map(|(k, n)| 0.3 + n * (-psi_off).tan() + wobble * (7.0 * k as f64).sin())
                .collect();
            let mut rls = Rls::new(0.5);
            for (k, (n, e)) in north.iter().zip(&east).enumerate() {
                rls.update(*n, *e);
                assert_eq!(rls.estimate().is_some(), k >= 32, "sample {k}");
            }
            let (got, want) = (rls.estimate().unwrap(), batch_ls(&north, &east).unwrap());
            assert_eq!(got.n, 500);
            assert!(
                (got.slope - want.slope).abs() < 1e-12 && (got.x_e0 - want.x_e0).abs() < 1e-12,
                "wobble {wobble}: {got:?} vs {want:?}"
            );
            if wobble == 0.0 {
                assert!((got.psi_offset - psi_off).abs() < 1e-12 && (got.x_e0 - 0.3).abs() < 1e-12, "{got:?}");
            } else {
                assert!((got.psi_offset - psi_off).abs() > 1e-6, "the wobble moves the fit: {got:?}");
            }
        }
    }

    /// No line from what determines none: fewer than two points, one X_N repeated, or X_N and X_E
    /// of different lengths (a fit over the shorter one would pair the wrong samples; a bug it catches: `||` as `&&` returned a line for 3 north and 2 east samples).
    #[test]
    fn ls_refuses_what_determines_no_line() {
        assert_eq!(batch_ls(&[], &[]), None);
        assert_eq!(batch_ls(&[1.0], &[2.0]), None);
        assert_eq!(batch_ls(&[1.0, 1.0, 1.0], &[0.0, 1.0, 2.0]), None);
        assert_eq!(batch_ls(&[0.0, 1.0, 2.0], &[0.0, 1.0]), None);
        assert_eq!(batch_ls(&[0.0, 1.0], &[0.0, 1.0, 2.0]), None);
        // two distinct points make a line: slope 1 through the origin, ψ̂_off = −45°
        let fit = batch_ls(&[0.0, 1.0], &[0.0, 1.0]).unwrap();
        assert!(
            (fit.slope - 1.0).abs() < 1e-15
                && fit.x_e0.abs() < 1e-15
                && (fit.psi_offset + std::f64::consts::FRAC_PI_4).abs() < 1e-15
                && fit.n == 2
        );
    }

    #[test]
    fn validity_rejects_a_yawed_flight() {
        let mut v = ValidityCheck::default();
        for _ in 0..100 {
            v.add(Euler::from_degrees(0.0, 0.0, 3.0));
        }
        assert!(!v.verdict(1f64.to_radians(), 1f64.to_radians()).accepted);
        let mut ok = ValidityCheck::default();
        ok.add(Euler::from_degrees(0.2, 0.0, -0.3));
        assert!(ok.verdict(1f64.to_radians(), 1f64.to_radians()).accepted);
        // no sample is no verdict to accept, though its means read 0 (a bug it catches: n > 0 as >=
        // 0)
        let none = ValidityCheck::default().verdict(1f64.to_radians(), 1f64.to_radians());
        assert!(!none.accepted && none.mean_yaw == 0.0 && none.mean_roll == 0.0, "{none:?}");
        // (7)'s inequalities are strict: a mean exactly at its bound fails (four samples of 0.5 rad
        // average to 0.5 exactly; a bug it catches: the yaw's `<` as `<=` accepted it)
        for (yaw, roll) in [(0.5, 0.0), (0.0, 0.5)] {
            let mut edge = ValidityCheck::default();
            for _ in 0..4 {
                edge.add(Euler::new(roll, 0.0, yaw));
            }
            let v = edge.verdict(0.5, 0.5);
            assert!(!v.accepted && v.mean_yaw == yaw && v.mean_roll == roll, "{v:?}");
        }
    }

    #[test]
    fn compensation_removes_a_known_offset_exactly() {
        let off = OffsetEstimate::from_euler(Euler::from_degrees(3.0, -2.0, 5.0));
        // the markers' offset built apart from the estimate (an estimate whose rotation ignored
        // its angles would otherwise compensate its own identity)
        let r_off: Rot<MocapBody, Body> = Rot::from_euler(Euler::from_degrees(3.0, -2.0, 5.0));
        assert!((off.rotation().inverse() * r_off).angle() < 1e-15 && r_off.angle() > 0.1);
        let truth: Rot<Body, MocapNav> = Rot::from_euler(Euler::new(0.1, 0.2, -1.0));
        let measured = truth * r_off;
        let back = off.compensate(measured, Compensation::Rotation);
        assert!((back.inverse() * truth).angle() < 1e-12);
        // the paper's subtraction is exact at level attitude and close for small angles
        let level: Rot<Body, MocapNav> = Rot::from_euler(Euler::new(0.0, 0.0, 0.7));
        let e = off.compensate(level * r_off, Compensation::Euler);
        assert!((e.inverse() * level).angle() < 1e-12);
    }
}

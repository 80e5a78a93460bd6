//! The statistics `identify` needs, written out so that every number in a report can be traced:
//! least squares on normal equations, autoregressive prewhitening, the Ljung–Box test, and the
//! F, χ² and normal distributions.
//!
//! Why prewhitening: the residual of a model against differentiated mocap data is coloured (the
//! derivative filter and the smoothing correlate neighbouring samples), so ordinary least squares
//! would report confidence intervals and F statistics as if there were ten times more independent
//! samples than there are. Fitting an AR(p) model e_k = Σ a_i·e_{k−i} + σ·w_k to the residual and
//! filtering both the residual and every regressor with A(z) = 1 − Σ a_i·z^{−i} (then dividing by
//! σ) turns the problem into one with white, unit-variance errors: generalised least squares with
//! AR errors (Cochrane–Orcutt). Tests and intervals are then computed on the filtered problem.

use nalgebra::{DMatrix, DVector};

/// ln Γ(x) for x > 0 (Lanczos, g = 7, 9 terms; relative error < 1e-14).
fn ln_gamma(x: f64) -> f64 {
    const G: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        // reflection
        return (std::f64::consts::PI / (std::f64::consts::PI * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let mut a = G[0];
    let t = x + 7.5;
    for (i, g) in G.iter().enumerate().skip(1) {
        a += g / (x + i as f64);
    }
    0.5 * (2.0 * std::f64::consts::PI).ln() + (x + 0.5) * t.ln() - t + a.ln()
}

/// Keeps the modified Lentz algorithm's C and D away from zero.
const LENTZ_TINY: f64 = 1e-300;

fn lentz_guard(v: f64) -> f64 {
    if v.abs() < LENTZ_TINY { LENTZ_TINY } else { v }
}

/// One term (a, b) of a continued fraction … a/(b + …) by the modified Lentz algorithm
/// (Numerical Recipes §5.2): D ← 1/(b + a·D), C ← b + a/C, both guarded away from zero;
/// returns Δ = C·D, the factor by which the convergent changes.
fn lentz_step(c: &mut f64, d: &mut f64, a: f64, b: f64) -> f64 {
    *d = 1.0 / lentz_guard(a * *d + b);
    *c = lentz_guard(b + a / *c);
    *d * *c
}

/// Regularised incomplete beta I_x(a, b) (continued fraction, Numerical Recipes §6.4).
fn incomplete_beta(a: f64, b: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 0.0;
    }
    if x >= 1.0 {
        return 1.0;
    }
    let ln_front = ln_gamma(a + b) - ln_gamma(a) - ln_gamma(b) + a * x.ln() + b * (1.0 - x).ln();
    let cf = |a: f64, b: f64, x: f64| {
        let (qab, qap, qam) = (a + b, a + 1.0, a - 1.0);
        let mut c = 1.0;
        let mut d = 1.0 / lentz_guard(1.0 - qab * x / qap);
        let mut h = d;
        for m in 1..400 {
            let m = m as f64;
            let m2 = 2.0 * m;
            h *= lentz_step(&mut c, &mut d, m * (b - m) * x / ((qam + m2) * (a + m2)), 1.0);
            let del = lentz_step(&mut c, &mut d, -(a + m) * (qab + m) * x / ((a + m2) * (qap + m2)), 1.0);
            h *= del;
            if (del - 1.0).abs() < 1e-15 {
                break;
            }
        }
        h
    };
    if x < (a + 1.0) / (a + b + 2.0) {
        ln_front.exp() * cf(a, b, x) / a
    } else {
        1.0 - ln_front.exp() * cf(b, a, 1.0 - x) / b
    }
}

/// Regularised lower incomplete gamma P(a, x).
fn incomplete_gamma(a: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 0.0;
    }
    let ln_front = a * x.ln() - x - ln_gamma(a);
    if x < a + 1.0 {
        let (mut sum, mut term, mut ap) = (1.0 / a, 1.0 / a, a);
        for _ in 0..1000 {
            ap += 1.0;
            term *= x / ap;
            sum += term;
            if term.abs() < sum.abs() * 1e-16 {
                break;
            }
        }
        sum * ln_front.exp()
    } else {
        // continued fraction for Q(a, x) (Lentz)
        let mut b = x + 1.0 - a;
        let mut c = 1.0 / LENTZ_TINY;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..1000 {
            b += 2.0;
            let del = lentz_step(&mut c, &mut d, -(i as f64) * (i as f64 - a), b);
            h *= del;
            if (del - 1.0).abs() < 1e-16 {
                break;
            }
        }
        1.0 - ln_front.exp() * h
    }
}

/// The median of `v` (the mean of the middle two for an even count); `None` for no values.
pub(crate) fn median(mut v: Vec<f64>) -> Option<f64> {
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    let m = v.len() / 2;
    Some(if v.len() % 2 == 1 { v[m] } else { 0.5 * (v[m - 1] + v[m]) })
}

/// P(F > f) for F ~ F(d1, d2).
pub(crate) fn f_sf(f: f64, d1: f64, d2: f64) -> f64 {
    if f <= 0.0 {
        return 1.0;
    }
    incomplete_beta(d2 / 2.0, d1 / 2.0, d2 / (d2 + d1 * f))
}

/// The 97.5 % quantile of Student's t with `nu` degrees of freedom (any positive real): t with
/// P(|T| > t) = 5 %, so t² is F(1, ν)'s 95 % quantile, found by bisection on [`f_sf`]; [`Z_975`]
/// for an infinite ν (or one too large to tell apart, over 10⁸).
pub(crate) fn t_975(nu: f64) -> f64 {
    if nu.is_nan() || nu >= 1e8 {
        return Z_975;
    }
    let (mut lo, mut hi) = (Z_975, 1e6);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if f_sf(mid * mid, 1.0, nu.max(1e-3)) > 0.05 {
            lo = mid;
        } else {
            hi = mid;
        }
        if hi - lo < 1e-12 * lo {
            break;
        }
    }
    0.5 * (lo + hi)
}

/// P(X > q) for X ~ χ²(k).
pub(crate) fn chi2_sf(q: f64, k: f64) -> f64 {
    1.0 - incomplete_gamma(k / 2.0, q / 2.0)
}

/// The 97.5 % quantile of the standard normal (95 % two-sided intervals; the prewhitened
/// problems have thousands of degrees of freedom, where Student's t equals it to 1e-3).
pub(crate) const Z_975: f64 = 1.959_963_984_540_054;
/// The 99.5 % quantile (99 % bounds of an autocorrelation).
pub(crate) const Z_995: f64 = 2.575_829_303_548_901;

/// An AR(p) model of a residual: e_k = Σ a_i·e_{k−i} + σ·w_k.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Ar {
    /// Coefficients a_1..a_p.
    pub a: Vec<f64>,
    /// Innovation standard deviation.
    pub sigma: f64,
    /// Variance of the series the model was fitted to (its marginal variance, mean square).
    pub marginal_var: f64,
}

/// Per sample k: whether samples k − p..=k are all usable (a running count of consecutive
/// usable samples, so O(1) per sample whatever p).
fn full_windows(ok: &[bool], p: usize) -> impl Iterator<Item = bool> + '_ {
    ok.iter().scan(0usize, move |run, &o| {
        *run = if o { *run + 1 } else { 0 };
        Some(*run > p)
    })
}

impl Ar {
    /// AR(0): white noise of standard deviation `sigma`.
    pub fn white(sigma: f64) -> Ar {
        Ar { a: Vec::new(), sigma, marginal_var: sigma * sigma }
    }
    /// Fits orders 0..=max_order by least squares on the samples where `ok` holds for the sample
    /// and its p predecessors, and keeps the order with the lowest BIC.
    pub fn fit(e: &[f64], ok: &[bool], max_order: usize) -> Ar {
        Ar::fit_shared(&[e], ok, max_order)
    }
    /// One model for several series of one noise (a sensor's three axes), fitted as
    /// [`Ar::fit`] fits one: their normal equations, residual sums and sample counts summed
    /// (the same rows of each), so that every series is whitened by one filter and weighed by
    /// one marginal variance, Σ_s Σ_k e_{s,k}² / (S·n).
    pub fn fit_shared(es: &[&[f64]], ok: &[bool], max_order: usize) -> Ar {
        // one common sample set (valid for the largest order), so BICs are comparable
        let rows: Vec<usize> = full_windows(ok, max_order).enumerate().filter(|(_, v)| *v).map(|(k, _)| k).collect();
        let n = (rows.len() * es.len()) as f64;
        if rows.len() < 10 * (max_order + 1) {
            let var = es.iter().flat_map(|e| rows.iter().map(|&k| e[k] * e[k])).sum::<f64>() / n.max(1.0);
            return Ar::white(var.sqrt().max(f64::MIN_POSITIVE));
        }
        // the normal equations of every order are leading blocks of the largest one's
        let pm = max_order;
        let mut g_all = DMatrix::<f64>::zeros(pm, pm);
        let mut b_all = DVector::<f64>::zeros(pm);
        let mut yy = 0.0;
        for e in es {
            for &k in &rows {
                yy += e[k] * e[k];
                for i in 0..pm {
                    let xi = e[k - 1 - i];
                    b_all[i] += xi * e[k];
                    for j in 0..=i {
                        g_all[(i, j)] += xi * e[k - 1 - j];
                    }
                }
            }
        }
        for i in 0..pm {
            for j in 0..i {
                g_all[(j, i)] = g_all[(i, j)];
            }
        }
        let mut best: Option<(f64, Ar)> = None;
        for p in 0..=max_order {
            let g = g_all.view((0, 0), (p, p)).into_owned();
            let b = b_all.rows(0, p).into_owned();
            let a = if p == 0 { DVector::zeros(0) } else { solve_spd(&g, &b).unwrap_or_else(|| DVector::zeros(p)) };
            let rss = (yy - a.dot(&b)).max(yy * 1e-15).max(f64::MIN_POSITIVE);
            let bic = n * (rss / n).ln() + p as f64 * n.ln();
            if best.as_ref().is_none_or(|(b0, _)| bic < *b0) {
                best =
                    Some((bic, Ar { a: a.iter().copied().collect(), sigma: (rss / n).sqrt(), marginal_var: yy / n }));
            }
        }
        best.map(|b| b.1).unwrap_or(Ar::white(1.0))
    }
    /// The order p.
    pub fn order(&self) -> usize {
        self.a.len()
    }
    /// Filters x with A(z)/σ; samples whose window leaves `ok` come out as NaN.
    pub fn whiten(&self, x: &[f64], ok: &[bool], out: &mut Vec<f64>) {
        out.clear();
        let p = self.order();
        for (k, full) in full_windows(ok, p).enumerate().take(x.len()) {
            if !full {
                out.push(f64::NAN);
                continue;
            }
            let mut v = x[k];
            for (i, a) in self.a.iter().enumerate() {
                v -= a * x[k - 1 - i];
            }
            out.push(v / self.sigma);
        }
    }
}

/// Solves G·x = b for a symmetric positive (semi)definite G: Cholesky, or a pseudo-inverse
/// when G is singular. None if nothing finite comes out.
pub(crate) fn solve_spd(g: &DMatrix<f64>, b: &DVector<f64>) -> Option<DVector<f64>> {
    if g.nrows() == 0 {
        return Some(DVector::zeros(0));
    }
    if let Some(c) = g.clone().cholesky() {
        let x = c.solve(b);
        if x.iter().all(|v| v.is_finite()) {
            return Some(x);
        }
    }
    if !g.iter().chain(b.iter()).all(|v| v.is_finite()) {
        return None;
    }
    // bounded iterations: nalgebra's `svd` loops forever on some inputs
    let svd = nalgebra::SVD::try_new(g.clone(), true, true, f64::EPSILON, 500)?;
    let x = svd.solve(b, 1e-12 * svd.singular_values.max()).ok()?;
    x.iter().all(|v| v.is_finite()).then_some(x)
}

/// Inverse of a symmetric positive definite matrix (pseudo-inverse if singular).
pub(crate) fn inverse_spd(g: &DMatrix<f64>) -> DMatrix<f64> {
    if let Some(c) = g.clone().cholesky() {
        return c.inverse();
    }
    let zero = || DMatrix::zeros(g.nrows(), g.ncols());
    if !g.iter().all(|v| v.is_finite()) {
        return zero();
    }
    nalgebra::SVD::try_new(g.clone(), true, true, f64::EPSILON, 500)
        .and_then(|svd| {
            let eps = 1e-12 * svd.singular_values.max();
            svd.pseudo_inverse(eps).ok()
        })
        .unwrap_or_else(zero)
}

/// The Schur complement G/G_OO = G_CC − G_CO·G_OO⁻¹·G_OC of a symmetric matrix G, C its first
/// `k` rows and columns and O the rest (G_OO pseudo-inverted if singular, see [`inverse_spd`]):
/// for a Gram matrix, the information on C's parameters that is left once O's are fitted too.
/// With no O it is G itself.
pub(crate) fn schur_complement(g: &DMatrix<f64>, k: usize) -> DMatrix<f64> {
    let o = g.nrows() - k;
    let gco = g.view((0, k), (k, o));
    g.view((0, 0), (k, k)) - gco * inverse_spd(&g.view((k, k), (o, o)).into_owned()) * gco.transpose()
}

/// Sample autocorrelation of x at lags 1..=max_lag over the finite samples (lags across NaN
/// holes are skipped).
pub fn autocorrelation(x: &[f64], max_lag: usize) -> (Vec<f64>, usize) {
    let finite: Vec<usize> = (0..x.len()).filter(|&k| x[k].is_finite()).collect();
    let n = finite.len();
    if n < 2 {
        return (vec![0.0; max_lag], n);
    }
    let mean = finite.iter().map(|&k| x[k]).sum::<f64>() / n as f64;
    let var = finite.iter().map(|&k| (x[k] - mean).powi(2)).sum::<f64>();
    let r = (1..=max_lag)
        .map(|l| {
            let mut s = 0.0;
            for k in l..x.len() {
                if x[k].is_finite() && x[k - l].is_finite() {
                    s += (x[k] - mean) * (x[k - l] - mean);
                }
            }
            if var > 0.0 { s / var } else { 0.0 }
        })
        .collect();
    (r, n)
}

/// Bartlett's effective sample size of n pairs whose series have the autocorrelations rx, ry
/// (lags 1..): n / (1 + 2·Σ ρ_x(k)·ρ_y(k)), clamped to [2, n]. Under it the Pearson correlation
/// of two independent autocorrelated series is approximately N(0, 1/n_eff).
pub(crate) fn effective_n(n: usize, rx: &[f64], ry: &[f64]) -> f64 {
    let inflation: f64 = 1.0 + 2.0 * rx.iter().zip(ry).map(|(a, b)| a * b).sum::<f64>();
    (n as f64 / inflation.max(1e-9)).clamp(2.0, n as f64)
}

/// The Ljung–Box portmanteau test: Q = n(n+2)·Σ_{k=1..h} ρ_k²/(n−k), compared with χ²(h − fitted).
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct LjungBox {
    /// The statistic Q.
    pub q: f64,
    /// Lags h summed over.
    pub lags: usize,
    /// Degrees of freedom h − fitted.
    pub dof: usize,
    /// P(χ²_dof ≥ Q): small when the series is not white.
    pub p_value: f64,
}

/// Ljung–Box of `x` over `lags` lags, with `fitted` parameters (an AR's order) taken from the
/// degrees of freedom.
pub(crate) fn ljung_box(x: &[f64], lags: usize, fitted: usize) -> LjungBox {
    let (r, n) = autocorrelation(x, lags);
    let n = n as f64;
    let q = n * (n + 2.0) * r.iter().enumerate().map(|(k, rk)| rk * rk / (n - (k + 1) as f64)).sum::<f64>();
    let dof = lags.saturating_sub(fitted).max(1);
    LjungBox { q, lags, dof, p_value: chi2_sf(q, dof as f64) }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_median_of_an_even_count_is_the_mean_of_the_middle_two() {
        assert_eq!(median(vec![3.0, 1.0, 2.0, 10.0]), Some(2.5));
        assert_eq!(median(vec![3.0, 1.0, 2.0]), Some(2.0));
        assert_eq!(median(vec![]), None);
    }

    /// The Lentz guard by hand: zero and anything smaller in size than 10⁻³⁰⁰ (either sign) becomes
    /// 10⁻³⁰⁰, anything else passes unchanged. A bug it catches: `|v| < tiny` as `|v| == tiny` let
    /// an exact zero through, to be divided by.
    #[test]
    fn the_lentz_guard_by_hand() {
        assert_eq!([0.0, -0.0, 1e-310, -5e-301].map(lentz_guard), [LENTZ_TINY; 4]);
        assert_eq!([LENTZ_TINY, -LENTZ_TINY, 0.5, -2.0].map(lentz_guard), [LENTZ_TINY, -LENTZ_TINY, 0.5, -2.0]);
    }

    /// A constant series has no variance to normalise by: its autocorrelations are 0, not 0/0 (a
    /// bug it catches: `var > 0` as `>= 0` returned NaN).
    #[test]
    fn the_autocorrelation_of_a_constant_is_zero() {
        let (r, n) = autocorrelation(&[3.0; 10], 3);
        assert!(n == 10 && r == [0.0; 3], "{r:?}");
    }

    /// The AR order chosen by BIC does not depend on the series' unit: an AR(2) in metres and the
    /// same series in micrometres (where the residual sum of squares far exceeds the sample
    /// count) get the same order and the same coefficients, and σ scales with the unit.
    #[test]
    fn ar_order_and_coefficients_do_not_depend_on_the_unit() {
        let mut x = vec![0.0f64; 4000];
        let mut state = 7u64;
        let mut noise = || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((state >> 11) as f64 / (1u64 << 53) as f64) - 0.5
        };
        for k in 2..x.len() {
            x[k] = 1.2 * x[k - 1] - 0.5 * x[k - 2] + noise();
        }
        let ok = vec![true; x.len()];
        let m = Ar::fit(&x, &ok, 6);
        let big: Vec<f64> = x.iter().map(|v| v * 1e6).collect();
        let b = Ar::fit(&big, &ok, 6);
        assert_eq!(m.a.len(), 2, "{:?}", m.a);
        assert_eq!(b.a.len(), m.a.len(), "{:?} vs {:?}", b.a, m.a);
        for (p, q) in m.a.iter().zip(&b.a) {
            assert!((p - q).abs() < 1e-9, "{p} vs {q}");
        }
        assert!((b.sigma / m.sigma - 1e6).abs() < 1e-3);
    }

    /// Bartlett's formula in closed form: two AR(1) series with φ_x, φ_y have
    /// Σ_{k≥1} φ_x^k φ_y^k = φ_xφ_y/(1 − φ_xφ_y), so n_eff = n(1 − φ_xφ_y)/(1 + φ_xφ_y); white
    /// series keep n; a clamp keeps n_eff in [2, n].
    #[test]
    fn effective_n_is_bartletts_closed_form() {
        let acf = |phi: f64| (1..=2000).map(|k| phi.powi(k)).collect::<Vec<f64>>();
        let n = 10_000;
        for (px, py) in [(0.5, 0.5), (0.9, 0.3), (0.8, 0.0)] {
            let want = n as f64 * (1.0 - px * py) / (1.0 + px * py);
            let got = effective_n(n, &acf(px), &acf(py));
            assert!((got / want - 1.0).abs() < 1e-9, "φ {px}, {py}: {got} vs {want}");
        }
        assert_eq!(effective_n(n, &[0.0; 50], &[0.3; 50]), n as f64);
        // anti-correlated lags would inflate n: clamped to n; strongly persistent ones: at least 2
        assert_eq!(effective_n(n, &acf(-0.9), &acf(0.9)), n as f64);
        assert_eq!(effective_n(10, &[1.0; 50], &[1.0; 50]), 2.0);
    }
    use crate::rng::{Component, Stream};

    #[test]
    fn special_functions_match_tabulated_values() {
        // Γ(5) = 24, Γ(1/2) = √π
        assert!((ln_gamma(5.0) - 24f64.ln()).abs() < 1e-13);
        assert!((ln_gamma(0.5) - std::f64::consts::PI.sqrt().ln()).abs() < 1e-13);
        // below 1/2 by the reflection Γ(x)·Γ(1 − x) = π / sin(πx): Γ(1/4) = 3.625609908221908,
        // Γ(1/10) = 9.513507698668732 (tabulated)
        assert!((ln_gamma(0.25) - 3.625_609_908_221_908f64.ln()).abs() < 1e-13);
        assert!((ln_gamma(0.1) - 9.513_507_698_668_732f64.ln()).abs() < 1e-13);
        // χ²(1): P(X > 3.841459) = 0.05; χ²(10): P(X > 23.209251) = 0.01
        assert!((chi2_sf(3.841_459, 1.0) - 0.05).abs() < 1e-6);
        assert!((chi2_sf(23.209_251, 10.0) - 0.01).abs() < 1e-6);
        // F(3, 100): 95 % point 2.695534; F(1, 1e6) → χ²(1)
        assert!((f_sf(2.695_534, 3.0, 100.0) - 0.05).abs() < 1e-6);
        assert!((f_sf(3.841_459, 1.0, 1e6) - 0.05).abs() < 1e-4);
        // I_x(1, 1) = x
        assert!((incomplete_beta(1.0, 1.0, 0.3) - 0.3).abs() < 1e-14);
    }

    /// The branches the table above does not reach, against closed forms: P(x < a + 1) takes
    /// the series of the incomplete gamma, x above (a + 1)/(a + b + 2) the symmetric continued
    /// fraction I_x(a, b) = 1 − I_{1−x}(b, a).
    #[test]
    fn chi2_series_and_symmetric_beta_branches_match_closed_forms() {
        // χ²(10) lower quantiles (tabulated): P(X > 2.558212) = 0.99, P(X > 3.940299) = 0.95;
        // a = 5, x = 1.28 and 1.97 < a + 1: the series branch
        assert!((chi2_sf(2.558_212, 10.0) - 0.99).abs() < 1e-6, "{}", chi2_sf(2.558_212, 10.0));
        assert!((chi2_sf(3.940_299, 10.0) - 0.95).abs() < 1e-6);
        // χ²(2) is exponential: P(X > q) = e^{−q/2}, in both branches (x = 0.5 < 2, x = 4 > 2)
        for q in [1.0, 8.0] {
            assert!((chi2_sf(q, 2.0) - (-q / 2.0f64).exp()).abs() < 1e-13, "{q}");
        }
        // I_x(a, n − a + 1) = P(Binomial(n, x) ≥ a): I_0.9(2, 3) = 1 − 0.1⁴ − 4·0.9·0.1³ = 0.9963,
        // x = 0.9 > 3/7: the symmetric branch; I_0.2(2, 3) = 1 − 0.8⁴ − 4·0.2·0.8³ = 0.1808, direct
        assert!((incomplete_beta(2.0, 3.0, 0.9) - 0.9963).abs() < 1e-13, "{}", incomplete_beta(2.0, 3.0, 0.9));
        assert!((incomplete_beta(2.0, 3.0, 0.2) - 0.1808).abs() < 1e-13);
        // the lower tail to full relative precision, which only the series keeps (1 − Q loses
        // it): P(10, 1) = e⁻¹·Σ 1/(10 + n)! = 1.1142547833872068e-7, P(3, 0.5) = 0.014387677966970687
        assert!(
            (incomplete_gamma(10.0, 1.0) / 1.114_254_783_387_206_8e-7 - 1.0).abs() < 1e-12,
            "{}",
            incomplete_gamma(10.0, 1.0)
        );
        assert!((incomplete_gamma(3.0, 0.5) / 0.014_387_677_966_970_687 - 1.0).abs() < 1e-12);
        // χ²(1), the leads' test: P(X > q) = erfc(√(q/2)). Near q = 0 (a weak correlation, p
        // near 1) only the series converges in 1000 terms: the continued fraction at a = ½,
        // x = 10⁻⁶ gives P = 0.94 instead of 0.0011
        for (q, erfc) in [(2e-6, 0.998_871_621_209_030_7), (0.01, 0.920_344_325_445_942)] {
            assert!((chi2_sf(q, 1.0) - erfc).abs() < 1e-13, "{q}: {}", chi2_sf(q, 1.0));
        }
        // Far above the switch x = (a + 1)/(a + b + 2), where only the symmetric branch is
        // accurate in 400 terms, against I_x(1, b) = 1 − (1 − x)^b and I_x(a, 1) = x^a (a = 1
        // or b = 1: the integrand is a power): b = 2000 puts the switch at 2/2003 ≈ 0.001,
        // a = 2000 at 2001/2003 ≈ 0.999. An F test on a long flight has b = d₂/2 in the
        // thousands: d₁ = 2, d₂ = 4000 and F = 20 (a clear effect) give x = d₁F/(d₁F + d₂)
        // = 0.0099, where the direct fraction would have to reach I·a/front = 1/(b·x·(1 − x)^b)
        // ≈ 2·10⁷ (it comes out 8·10⁻⁹ above 1, so the upper tail 1 − I would be negative)
        for (a, b, x) in [
            (1.0f64, 2000.0f64, 0.003f64),
            (1.0, 2000.0, 0.0099),
            (1.0, 2000.0, 0.0005),
            (2000.0, 1.0, 0.9997),
            (2000.0, 1.0, 0.99),
        ] {
            let truth = if a == 1.0 { -(b * (-x).ln_1p()).exp_m1() } else { (a * x.ln()).exp() };
            let got = incomplete_beta(a, b, x);
            assert!((got - truth).abs() < 1e-12, "I_{x}({a}, {b}) = {got}, closed form {truth}");
        }
        // F(2, 2): P(F > f) = 1/(1 + f); f = 0.25 puts x = 2/(2 + 0.5) = 0.8 above (1 + 1)/(1 + 1 + 2) = 0.5
        for f in [0.25, 4.0] {
            assert!((f_sf(f, 2.0, 2.0) - 1.0 / (1.0 + f)).abs() < 1e-13, "{f}");
        }
        // F(1, 1) is the square of a Cauchy variable: P(F > f) = (2/π)·atan(1/√f), the
        // incomplete beta at a = b = ½ and x = 1/(1 + f). A huge f puts x near 0, far below
        // the switch ½ = (½ + 1)/3, where the symmetric fraction in 1 − x ≈ 1 does not
        // converge in 400 terms (with the switch at (a − 1)/(a + b + 2) < 0, f = 10⁸ gives
        // 0.92 for 6.4·10⁻⁵). A tiny f puts x near 1, where only the symmetric fraction
        // converges (with the switch at (a + 1)/(a + 2b) = 1, f = 10⁻⁸ gives 0.08 for 0.99994)
        for f in [1e8f64, 1e4, 0.5, 1e-8] {
            let truth = std::f64::consts::FRAC_2_PI * (1.0 / f.sqrt()).atan();
            assert!((f_sf(f, 1.0, 1.0) / truth - 1.0).abs() < 1e-12, "{f}: {} against {truth}", f_sf(f, 1.0, 1.0));
        }
    }

    /// The F tests of a long flight, against a finite sum: for d₂ = 2m even, P(F > f) = I_x(m, b)
    /// with b = d₁/2, x = d₂/(d₂ + d₁f), and for integer m (integration by parts, m − 1 times)
    /// I_x(m, b) = 1 − (1 − x)^b·Σ_{j<m} (b)_j/j!·x^j. Here a = d₂/2 is large and b = d₁/2 is not
    /// an integer, so neither continued fraction terminates (with a or b = 1, as in most cases
    /// above, one does), and the switch (a + 1)/(a + b + 2) decides. Moved to (a + 1)/(a·b + 2),
    /// above 1 for b = ½ and a > 2, a one-parameter test on 4000 samples at f = 10⁻⁴ gave P = 0.29
    /// for 0.992 (an effect invented), and F(5, 4000) at f = 20 gave 0.93 for 5·10⁻¹⁵ (one missed).
    /// Moved to (a + 1)/(a − b + 2), above 1 for b > 1, F(3, 400) at f = 10⁻⁴ gave −0.38. The tests
    /// above pass both; this one fails them.
    #[test]
    fn f_tests_on_a_long_flight_match_the_finite_sum_for_even_d2() {
        let finite_sum = |d1: f64, d2: f64, f: f64| {
            let (m, b, x) = ((d2 / 2.0) as usize, d1 / 2.0, d2 / (d2 + d1 * f));
            let (mut term, mut sum) = (1.0, 0.0);
            for j in 0..m {
                sum += term;
                term *= (b + j as f64) / (j as f64 + 1.0) * x;
            }
            1.0 - (b * (-x).ln_1p()).exp() * sum
        };
        for (d1, d2) in [(1.0, 4000.0), (3.0, 400.0), (5.0, 4000.0), (7.0, 40.0)] {
            for f in [1e-4, 0.01, 0.5, 2.0, 20.0] {
                let (got, want) = (f_sf(f, d1, d2), finite_sum(d1, d2, f));
                assert!((got - want).abs() < 1e-11, "F({d1}, {d2}) at {f}: {got} against {want}");
            }
        }
    }

    /// The autocorrelation at its smallest samples, by hand: (1, 3) has mean 2, Σ(x − x̄)² = 2
    /// and lag-1 product (1 − 2)(3 − 2) = −1, so ρ₁ = −0.5 and ρ₂ = 0 (no pair); one finite
    /// sample or none has no variance and gives zeros; a NaN between them is skipped.
    #[test]
    fn the_autocorrelation_of_two_samples_by_hand() {
        assert_eq!(autocorrelation(&[1.0, 3.0], 2), (vec![-0.5, 0.0], 2));
        assert_eq!(autocorrelation(&[1.0, f64::NAN, 3.0], 2), (vec![0.0, -0.5], 2));
        assert_eq!(autocorrelation(&[1.0], 2), (vec![0.0, 0.0], 1));
        assert_eq!(autocorrelation(&[], 1), (vec![0.0], 0));
    }

    /// Ljung–Box by hand: x = (1, −1, 1, −1, 1, −1) has mean 0, ρ₁ = −5/6, ρ₂ = 4/6, so
    /// Q(2) = 6·8·((25/36)/5 + (16/36)/4) = 12 and p = P(χ²(2) > 12) = e^{−6}; with one fitted
    /// parameter the degrees of freedom drop to 1: p = P(χ²(1) > 12) = 5.320055e-4 (tabulated).
    #[test]
    fn ljung_box_matches_a_hand_computed_value() {
        let x = [1.0, -1.0, 1.0, -1.0, 1.0, -1.0];
        let lb = ljung_box(&x, 2, 0);
        assert!((lb.q - 12.0).abs() < 1e-12, "{lb:?}");
        assert_eq!(lb.dof, 2);
        assert!((lb.p_value - (-6.0f64).exp()).abs() < 1e-14, "{lb:?}");
        let lb1 = ljung_box(&x, 2, 1);
        assert_eq!(lb1.dof, 1);
        assert!((lb1.p_value - 5.320_055e-4).abs() < 1e-9, "{lb1:?}");
        // NaN holes are skipped, not counted: the same six values with holes give the same Q
        // only at lag pairs that exist; here a hole at the end changes nothing
        let with_hole = [1.0, -1.0, 1.0, -1.0, 1.0, -1.0, f64::NAN];
        assert!((ljung_box(&with_hole, 2, 0).q - 12.0).abs() < 1e-12);
    }

    /// A singular Gram matrix (two identical columns, one independent: [[1, 1, 0], [1, 1, 0],
    /// [0, 0, 4]]) has no Cholesky factor; its Moore–Penrose pseudo-inverse is
    /// [[¼, ¼, 0], [¼, ¼, 0], [0, 0, ¼]] (the eigenvalue 2 along (1, 1, 0)/√2 inverts to ½,
    /// i.e. ¼ per entry, and the 4 to ¼), also when rounding leaves it slightly indefinite. A
    /// non-finite entry gives zeros rather than NaN.
    #[test]
    fn a_singular_gram_matrix_gets_its_pseudo_inverse() {
        let g = DMatrix::from_row_slice(3, 3, &[1.0, 1.0, 0.0, 1.0, 1.0, 0.0, 0.0, 0.0, 4.0]);
        let want = DMatrix::from_row_slice(3, 3, &[0.25, 0.25, 0.0, 0.25, 0.25, 0.0, 0.0, 0.0, 0.25]);
        assert!((inverse_spd(&g) - &want).amax() < 1e-12, "{}", inverse_spd(&g));
        // rounding may leave such a matrix a hair indefinite (eigenvalue −1e-12 along
        // (1, −1, 0)/√2): the cut-off is relative (1e-12 of the largest singular value, 4), so
        // that direction is dropped too, not inverted to 1e12
        let h = 0.5e-12;
        let g = DMatrix::from_row_slice(3, 3, &[1.0 - h, 1.0 + h, 0.0, 1.0 + h, 1.0 - h, 0.0, 0.0, 0.0, 4.0]);
        assert!((inverse_spd(&g) - &want).amax() < 1e-9, "{}", inverse_spd(&g));
        let spd = DMatrix::from_row_slice(2, 2, &[2.0, 1.0, 1.0, 2.0]);
        assert!((inverse_spd(&spd) - DMatrix::from_row_slice(2, 2, &[2.0, -1.0, -1.0, 2.0]) / 3.0).amax() < 1e-12);
        let bad = DMatrix::from_row_slice(2, 2, &[f64::NAN, 0.0, 0.0, 1.0]);
        assert_eq!(inverse_spd(&bad), DMatrix::zeros(2, 2));
    }

    /// G/G_OO by hand: [[4, 2], [2, 2]] with C the first leaves 4 − 2·2/2 = 2; in [[4, 1, 2], [1,
    /// 3, 1], [2, 1, 2]] with C the first two, O the third (g_CO = (2, 1)): G_CC − g·gᵀ/2 = [[4 −
    /// 2, 1 − 1], [1 − 1, 3 − ½]] = [[2, 0], [0, 2.5]]; with C the first of [[5, 1, 2], [1, 2, 0],
    /// [2, 0, 4]]: 5 − 1²/2 − 2²/4 = 3.5; with no O, G itself. A bug it catches: the − as + and
    /// either · as +.
    #[test]
    fn the_schur_complement_by_hand() {
        let m = |r: usize, v: &[f64]| DMatrix::from_row_slice(r, r, v);
        assert!((schur_complement(&m(2, &[4.0, 2.0, 2.0, 2.0]), 1) - m(1, &[2.0])).amax() < 1e-15);
        let g = m(3, &[4.0, 1.0, 2.0, 1.0, 3.0, 1.0, 2.0, 1.0, 2.0]);
        assert!((schur_complement(&g, 2) - m(2, &[2.0, 0.0, 0.0, 2.5])).amax() < 1e-15, "{}", schur_complement(&g, 2));
        assert!(
            (schur_complement(&m(3, &[5.0, 1.0, 2.0, 1.0, 2.0, 0.0, 2.0, 0.0, 4.0]), 1) - m(1, &[3.5])).amax() < 1e-15
        );
        assert_eq!(schur_complement(&g, 3), g);
    }

    /// The same singular Gram matrix in a solve: x₁ + x₂ = 2 is determined and x₁, x₂ alone are
    /// not, so the fit takes the minimum-norm solution x = G⁺b = (1, 1, 1) for b = (2, 2, 4), not
    /// nothing (its callers would then set every parameter to zero, the excited ones too). The
    /// pseudo-inverse's cut-off is relative (1e-12·s_max), so G and b scaled by 10⁻⁹ or 10⁹ give
    /// the same x. A non-finite G or b gives None. A bug it catches: the finiteness guard's `!`
    /// deleted returned None for every finite singular G; and the cut-off as 1e-12/s_max
    /// dropped every singular value of G·10⁻⁹ (x = 0).
    #[test]
    fn a_singular_system_gets_the_minimum_norm_solution() {
        let g = DMatrix::from_row_slice(3, 3, &[1.0, 1.0, 0.0, 1.0, 1.0, 0.0, 0.0, 0.0, 4.0]);
        let b = DVector::from_column_slice(&[2.0, 2.0, 4.0]);
        let x = solve_spd(&g, &b).expect("a minimum-norm solution");
        assert!((x - DVector::from_element(3, 1.0)).amax() < 1e-12);
        // the cut-off is relative to the largest singular value: the same system in other units
        // (G and b scaled alike) has the same solution
        for scale in [1e-9, 1e9] {
            let x = solve_spd(&(&g * scale), &(&b * scale)).expect("a minimum-norm solution");
            assert!((&x - DVector::from_element(3, 1.0)).amax() < 1e-9, "G, b × {scale:e}: {x}");
        }
        let spd = DMatrix::from_row_slice(2, 2, &[2.0, 1.0, 1.0, 2.0]);
        let x = solve_spd(&spd, &DVector::from_column_slice(&[3.0, 3.0])).expect("the Cholesky solution");
        assert!((x - DVector::from_element(2, 1.0)).amax() < 1e-12);
        assert_eq!(solve_spd(&spd, &DVector::from_column_slice(&[f64::INFINITY, 0.0])), None);
        assert_eq!(solve_spd(&DMatrix::from_row_slice(2, 2, &[f64::NAN, 0.0, 0.0, 1.0]), &DVector::zeros(2)), None);
    }

    /// Ten samples per coefficient or no fit: with `max_order` 8 an AR needs 10·(8 + 1) = 90
    /// usable rows (each with its 8 predecessors). A strongly coloured AR(2) of 97 samples (89
    /// rows, one short) is modelled as white noise with σ the RMS of those rows; of 98 samples
    /// (90 rows) it gets an AR fit.
    #[test]
    fn an_ar_needs_ten_samples_per_coefficient() {
        let mut rng = Stream::new(4, Component::Sweep, 0);
        let mut e = vec![0.0; 110];
        for k in 2..e.len() {
            e[k] = 1.2 * e[k - 1] - 0.5 * e[k - 2] + 0.3 * rng.normal();
        }
        let short = &e[..97];
        let ar = Ar::fit(short, &[true; 97], 8);
        let rms = (short[8..].iter().map(|x| x * x).sum::<f64>() / 89.0).sqrt();
        assert_eq!(ar.order(), 0);
        assert!((ar.sigma - rms).abs() < 1e-15, "{} vs {rms}", ar.sigma);
        // white noise's marginal variance is its innovation variance, the series' mean square (the raw Gram's weight 1/var)
        assert!((ar.marginal_var - rms * rms).abs() < 1e-15, "{} vs {}", ar.marginal_var, rms * rms);
        assert!(Ar::fit(&e[..98], &[true; 98], 8).order() >= 1);
    }

    #[test]
    fn ar_fit_recovers_an_ar2_process_and_whitening_makes_it_white() {
        let mut rng = Stream::new(3, Component::Sweep, 0);
        let (a1, a2, s) = (1.2, -0.5, 0.3);
        let mut e = vec![0.0; 20_000];
        for k in 2..e.len() {
            e[k] = a1 * e[k - 1] + a2 * e[k - 2] + s * rng.normal();
        }
        let ok = vec![true; e.len()];
        let ar = Ar::fit(&e, &ok, 8);
        assert!(ar.order() >= 2 && ar.order() <= 4, "order {}", ar.order());
        assert!((ar.a[0] - a1).abs() < 0.03 && (ar.a[1] - a2).abs() < 0.03, "{:?}", ar.a);
        // AR(2)'s marginal variance γ₀ = σ²(1 − a₂)/((1 + a₂)((1 − a₂)² − a₁²)) = 0.09·1.5/(0.5·0.81)
        // = 1/3. The sample's, over n = 20,000 samples, has Bartlett's relative standard error
        // √(2·Σρ²/n) = 1.7 % (ρ₁ = a₁/(1 − a₂) = 0.8, ρ₂ = 0.46, ρ₃ = 0.15, …: Σ over all lags ≈ 2.85);
        // 5 % is three of them
        let gamma0 = s * s * (1.0 - a2) / ((1.0 + a2) * ((1.0 - a2).powi(2) - a1 * a1));
        assert!((gamma0 - 1.0 / 3.0).abs() < 1e-12);
        assert!((ar.marginal_var / gamma0 - 1.0).abs() < 0.05, "{} vs {gamma0}", ar.marginal_var);
        assert!((ar.sigma - s).abs() < 0.01);
        // raw: strongly coloured; whitened: passes Ljung–Box
        assert!(ljung_box(&e, 20, 0).p_value < 1e-10);
        let mut w = Vec::new();
        ar.whiten(&e, &ok, &mut w);
        let lb = ljung_box(&w, 20, ar.order());
        assert!(lb.p_value > 0.001, "{lb:?}");
    }

    /// One model for two series, by hand. Two geometric series of 30 samples, e_k = 0.5^k and
    /// f_k = 0.8^k, each an AR(1) without noise; max order 1, so the rows are k = 1..29 of each
    /// (58). Summed normal equations: a = Σ(e_k·e_{k−1} + f_k·f_{k−1})/Σ(e_{k−1}² + f_{k−1}²) =
    /// (0.5·S_e + 0.8·S_f)/(S_e + S_f) with S_x = Σ_{j=0}^{28} x^{2j} = (1 − x^58)/(1 − x²);
    /// marginal variance Σ(e_k² + f_k²)/58 = (S_e − 1 + 0.25^29 + S_f − 1 + 0.64^29)/58. Either
    /// series alone gets its own coefficient back. A bug it catches: the series fitted one after
    /// the other (the last one's 0.8), a count of rows not multiplied by the series (twice the
    /// variance), the sums of one series only.
    #[test]
    fn one_model_for_several_series_sums_their_normal_equations() {
        let e: Vec<f64> = (0..30).map(|k| 0.5f64.powi(k)).collect();
        let f: Vec<f64> = (0..30).map(|k| 0.8f64.powi(k)).collect();
        let ok = [true; 30];
        let s = |x: f64| (1.0 - x.powi(58)) / (1.0 - x * x);
        let (se, sf) = (s(0.5), s(0.8));
        let want_a = (0.5 * se + 0.8 * sf) / (se + sf);
        let want_var = (se - 1.0 + 0.25f64.powi(29) + sf - 1.0 + 0.64f64.powi(29)) / 58.0;
        let ar = Ar::fit_shared(&[&e, &f], &ok, 1);
        assert_eq!(ar.order(), 1);
        assert!((ar.a[0] - want_a).abs() < 1e-12, "{} vs {want_a}", ar.a[0]);
        assert!((ar.marginal_var - want_var).abs() < 1e-12, "{} vs {want_var}", ar.marginal_var);
        for (x, a) in [(&e, 0.5), (&f, 0.8)] {
            let alone = Ar::fit(x, &ok, 1);
            assert!((alone.a[0] - a).abs() < 1e-12, "{:?}", alone.a);
            assert_eq!(alone, Ar::fit_shared(&[x], &ok, 1));
        }
    }
}

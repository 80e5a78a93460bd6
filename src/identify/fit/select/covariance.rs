//! The covariance of the estimates: Newey–West (Bartlett) over the weighted scores summed per
//! time sample, the prewhitened (GLS) parameters' share from the residual's autocovariance over
//! the whole flight, plus the systematic of the nominal thrust.

use super::WholeCovariance;
use super::gram::{Gram, active, cols_of, residual_of, split, sub, system, system_raw};
use crate::effects::{Channel, Effect};
use crate::identify::fit::design::Design;
use crate::identify::fit::stats::{Ar, Z_975, inverse_spd, t_975};
use nalgebra::{DMatrix, DMatrixView, DVector};
use std::borrow::Cow;

/// The window of the residual's autocovariance in [`stationary_gls`] (s): the prewhitened
/// residual of a mocap log stays correlated over a good part of a second (the spectral dip
/// that [`stationary_gls`] explains), and the Parzen weights fall to ½ at a third of the window.
pub(super) const GLS_WINDOW_S: f64 = 2.0;

/// The covariance of the parameters of [`fit`](super::gram::fit): [`newey_west_cov`], and on a
/// fit of every usable sample (`whole` set, [`WholeCovariance::Larger`]) the larger (in the positive semidefinite order,
/// [`loewner_max`]) of it and [`stationary_full`], two estimates of one sandwich, each blind
/// where the other sees (or, as `whole` asks, [`stationary_full`] alone or Newey–West with
/// [`Kernel::Parzen`] weights over the window, each variance raised by
/// [`parzen_small_sample`]).
///
/// The errors are linear in the scores, δ = A·Σ_t s_t (see [`newey_west_cov`] for s_t and A).
/// - [`newey_west_cov`] sums the products of the scores themselves over `lags` samples: a noise
///   whose size or correlation changes through the flight (a real flight's misfit, large where
///   the vehicle moves) is in it, a correlation longer than `lags` is not.
/// - [`stationary_full`] takes the residuals' auto- and cross-covariances over the whole
///   flight, Parzen over `window_s`: correlations as long as the window are in it, a noise that
///   changes size is not. On a hand-held rig the smoothing kernel colours the accelerometer's
///   residual over more than `lags` samples, and the Bartlett weights of `lags` = 12 (already
///   ½ at lag 6) leave part of the variance of the tilt, the lever arm and the accelerometer
///   bias out (docs/calibration.md, "What each choice bought").
///
/// So no interval is narrower than either. Why only on a fit of every usable sample: on the
/// training part (two thirds of a hand-held log) Newey–West's intervals already cover 94–97 %
/// (docs/calibration.md, "What each choice bought"), and the trials' and the closed-loop
/// delay's coverage were measured with them.
#[allow(clippy::too_many_arguments)]
pub(super) fn hac(
    d: &Design,
    train: &[bool],
    gs: &[Gram],
    ars: &[Ar],
    set: &[usize],
    theta: &[f64],
    lags: usize,
    window_s: f64,
    whole: Option<WholeCovariance>,
) -> DMatrix<f64> {
    let step = if d.t.len() > 1 { d.t[1] - d.t[0] } else { 0.0 };
    let window = if step > 0.0 { (window_s / step).round() as usize } else { 0 };
    let newey_west = |kernel| newey_west_cov(d, train, gs, ars, set, theta, kernel, window);
    let stationary = || {
        let (dp, op) = split(set);
        let a = if dp.is_empty() { inverse_spd(&system_raw(gs, set).0) } else { error_map(gs, set, &dp, &op).a };
        stationary_full(d, train, gs, ars, set, theta, &a, window)
    };
    match whole {
        None => newey_west(Kernel::Bartlett(lags)),
        Some(WholeCovariance::Larger) => loewner_max(&stationary(), &newey_west(Kernel::Bartlett(lags))),
        Some(WholeCovariance::Stationary) => stationary(),
        Some(WholeCovariance::Parzen) => {
            let a = (window / 2).max(1);
            let cov = newey_west(Kernel::Parzen(a));
            let c = parzen_small_sample(d, train, gs, set, a);
            DMatrix::from_fn(cov.nrows(), cov.ncols(), |i, j| cov[(i, j)] * (c[i] * c[j]).sqrt())
        }
    }
}

/// What a Parzen sum of fitted scores over a short window leaves out, per parameter of `set`, as
/// a factor on its variance (a congruence by their square roots keeps the covariance positive
/// semidefinite): the share the fitted parameters take out of the scores, and the sum's own
/// scatter. Both are read off a working model in which each channel axis's residual is white
/// with the variance its weight w_q assumes (1/w_q), so that a sample's score
/// u_t = Σ_q w_q·x_{q,t}·e_{q,t} has covariance P_t = Σ_q w_q·x_{q,t}·x_{q,t}ᵀ and
/// G = Σ_t P_t; w_l are the lag weights of [`Kernel::Parzen`]`(a)` ([`parzen_lags`]).
///
/// - **The fitted parameters.** The residuals are e − X·δ (δ = G⁻¹·Σ_s u_s), and over a window
///   the sum of the fitted scores misses what δ explains there: E[Ŝ] = G − K with
///   K = Σ_{t,s} w_{t−s}·P_t·G⁻¹·P_s (the kernel's analogue of HC2's leverage 1 − h_tt). The
///   factor is f_j = [G⁻¹]_jj / [G⁻¹·(G − K)·G⁻¹]_jj: about 1 + Σ_l w_l / T for a parameter
///   whose information is spread over a log of T samples (1.5 s of 64 s: 2 %), more where
///   it comes from fewer moments.
/// - **The sum's scatter.** Parameter j's variance is a quadratic form of the scores; with
///   v_t = [G⁻¹·P_t·G⁻¹]_jj its degrees of freedom are (Satterthwaite)
///   ν_j = (Σ_t v_t)² / Σ_{t,s} w_{t−s}²·v_t·v_s (about T/Σ_l w_l², 50 on a hand-held log
///   of 64 s). The estimate over its standard error is then Student's t with ν_j degrees, and
///   the factor (t_{ν_j, 97.5 %} / z_{97.5 %})² makes ±1.96·σ the t interval.
///
/// Measured on the hand-held Monte Carlo (docs/calibration.md, "What each choice bought"):
/// the two together widen the intervals by 3.5–4.5 %.
fn parzen_small_sample(d: &Design, train: &[bool], gs: &[Gram], set: &[usize], a: usize) -> Vec<f64> {
    let k = set.len();
    let p = sample_information(d, train, gs, set);
    let mut g = DMatrix::<f64>::zeros(k, k);
    for pt in p.iter().flatten() {
        g += pt;
    }
    let ginv = inverse_spd(&g);
    let w = parzen_lags(a);
    // K = Σ_t P_t·G⁻¹·P̃_t with P̃_t = Σ_s w_{t−s}·P_s: the weights are the box of `a` taps
    // four times over (the triangle autocorrelated) divided by r(0), centred 2(a − 1) on
    let flat: Vec<DVector<f64>> = p
        .iter()
        .map(|pt| pt.as_ref().map_or_else(|| DVector::zeros(k * k), |m| DVector::from_column_slice(m.as_slice())))
        .collect();
    let boxed = (0..4).fold(flat, |x, _| running_sum(&x, a));
    let r0 = parzen_energy(a);
    let mut kk = DMatrix::<f64>::zeros(k, k);
    for (t, pt) in p.iter().enumerate() {
        if let Some(pt) = pt {
            kk += pt * &ginv * DMatrix::from_column_slice(k, k, boxed[t + 2 * (a - 1)].as_slice()) / r0;
        }
    }
    let kk = (&kk + kk.transpose()) * 0.5;
    let narrowed = &ginv * (&g - kk) * &ginv;
    (0..k)
        .map(|j| {
            let v: Vec<f64> =
                p.iter().map(|pt| pt.as_ref().map_or(0.0, |pt| (ginv.row(j) * pt * ginv.column(j))[(0, 0)])).collect();
            let total: f64 = v.iter().sum();
            let mut spread = 0.0;
            for (t, vt) in v.iter().enumerate().filter(|(_, vt)| **vt != 0.0) {
                for (l, wl) in w.iter().enumerate().take(v.len() - t) {
                    spread += if l == 0 { 1.0 } else { 2.0 } * wl * wl * vt * v[t + l];
                }
            }
            let leverage = if narrowed[(j, j)] > 0.0 { ginv[(j, j)] / narrowed[(j, j)] } else { 1.0 };
            let dof = if spread > 0.0 { total * total / spread } else { f64::INFINITY };
            leverage.max(1.0) * (t_975(dof) / Z_975).powi(2)
        })
        .collect()
}

/// Per time sample, the working model's score covariance P_t = Σ_q w_q·x_{q,t}·x_{q,t}ᵀ over
/// the channel axes with a residual and every column of `set` they carry there (training rows;
/// `None` where no axis has one), as [`scores`] sums them.
fn sample_information(d: &Design, train: &[bool], gs: &[Gram], set: &[usize]) -> Vec<Option<DMatrix<f64>>> {
    let k = set.len();
    let mut p: Vec<Option<DMatrix<f64>>> = vec![None; d.n];
    for ((c, ax), gr) in active(d).into_iter().zip(gs) {
        let cols = set_columns(d, c, ax, set);
        if cols.is_empty() {
            continue;
        }
        let e = d.residual(c, ax);
        let mut x = DVector::<f64>::zeros(k);
        for (t, pt) in p.iter_mut().enumerate() {
            if !train[t] || !e[t].is_finite() {
                continue;
            }
            x.fill(0.0);
            for (q, col) in &cols {
                if col[t].is_finite() {
                    x[*q] = col[t];
                }
            }
            pt.get_or_insert_with(|| DMatrix::zeros(k, k)).ger(gr.w_r, &x, &x, 1.0);
        }
    }
    p
}

/// The lag weights w_0, w_1, … of [`Kernel::Parzen`]`(a)`: the autocorrelation of the triangle
/// of `a` taps each side over its energy r(0), 2a − 1 of them (zero beyond).
fn parzen_lags(a: usize) -> Vec<f64> {
    let tri: Vec<f64> = (1..a).chain((1..=a).rev()).map(|j| j as f64).collect();
    (0..tri.len()).map(|l| tri[l..].iter().zip(&tri).map(|(x, y)| x * y).sum::<f64>() / parzen_energy(a)).collect()
}

/// The energy r(0) = Σ h_j² = 2·Σ_{j ≤ a} j² − a² of the triangle of `a` taps each side.
fn parzen_energy(a: usize) -> f64 {
    (1..=a).map(|j| (j * j) as f64).sum::<f64>() * 2.0 - (a * a) as f64
}

/// Newey–West covariance of the parameters of [`fit`](super::gram::fit), the lagged products
/// weighed by `kernel` (Bartlett over `hac_lags` unless the fit of every sample asks for
/// [`WholeCovariance::Parzen`]).
///
/// With least squares alone: (XᵀWX)⁻¹·S·(XᵀWX)⁻¹ with S = Σ_l w_l Σ_t (u_t u_{t−l}ᵀ +
/// u_{t−l} u_tᵀ) (l = 0 counted once), w_l the kernel's weights, and u_t = Σ_{channel axes}
/// w·x_t·e_t the score of time sample t summed over every channel axis. Summing per time sample
/// (not per channel axis) lets the channels' noises be correlated: `accel_kin` and `force`
/// share the accelerometer's noise, and their rows are not independent information about,
/// say, an accelerometer bias.
///
/// With [`prewhitened`](super::gram::prewhitened) columns D (the others O), the errors are
/// linear in two sums of scores: the GLS ones ũ_t = Σ x̃_t·ẽ_t (prewhitened columns and
/// residual) and the raw ones u_t above, θ_D − θ_D* = [G̃⁻¹]_D·Σũ and θ_O − θ_O* =
/// G_OO⁻¹·(Σu_O − G_OD·(θ_D − θ_D*)). The covariance is A·S·Aᵀ with S the Newey–West sum of
/// the stacked scores (ũ_t, u_t), which carries the correlation of the two estimates, and A
/// that linear map. The GLS errors' own covariance is then raised to [`stationary_gls`]'s
/// (over `window` samples) where that is larger, and what the least-squares estimates inherit
/// from them follows (see [`with_gls_covariance`]), so the delay's interval is never narrower
/// than either.
#[allow(clippy::too_many_arguments)]
fn newey_west_cov(
    d: &Design,
    train: &[bool],
    gs: &[Gram],
    ars: &[Ar],
    set: &[usize],
    theta: &[f64],
    kernel: Kernel,
    window: usize,
) -> DMatrix<f64> {
    let (dp, op) = split(set);
    if dp.is_empty() {
        let u = scores(d, train, gs, None, set, theta);
        let ginv = inverse_spd(&system_raw(gs, set).0);
        return &ginv * newey_west(&u, kernel) * &ginv;
    }
    let k = set.len();
    let uw = scores(d, train, gs, Some(ars), set, theta);
    let ur = scores(d, train, gs, None, set, theta);
    let stacked: Vec<Option<DVector<f64>>> = uw
        .iter()
        .zip(&ur)
        .map(|(w, r)| match (w, r) {
            (None, None) => None,
            (w, r) => {
                let mut v = DVector::zeros(2 * k);
                if let Some(w) = w {
                    v.rows_mut(0, k).copy_from(w);
                }
                if let Some(r) = r {
                    v.rows_mut(k, k).copy_from(r);
                }
                Some(v)
            }
        })
        .collect();
    let ErrorMap { a, from_gls, carry } = error_map(gs, set, &dp, &op);
    let cov = &a * newey_west(&stacked, kernel) * a.transpose();
    let stationary = stationary_gls(d, train, ars, set, theta, &from_gls, window);
    let v = loewner_max(&stationary, &sub(&cov, &dp, &dp));
    with_gls_covariance(&cov, &dp, &op, &v, &carry)
}

/// One channel axis's share of the scores in [`stationary`]: its residual e_t (NaN where the
/// sample has no score) and z_t = M·x_t, the parameters' error map applied to its columns at
/// sample t (`k` values per sample, zero where e_t is NaN).
type ScoreSeries = (Vec<f64>, Vec<f64>);

/// The covariance of δ = Σ_q Σ_t z_{q,t}·e_{q,t} when the residuals are stationary:
/// Var(δ) = Σ_{q,r} Σ_{|l|≤L} w_l·γ_qr(l)·Σ_t z_{q,t}·z_{r,t−l}ᵀ, γ_qr(l) the mean of
/// e_{q,t}·e_{r,t−l} over the samples where both exist, w_l the Parzen weights over
/// L = `window` samples ([`parzen`]). Computed as Σ_q Σ_t z_{q,t}·y_{q,t}ᵀ with
/// y_{q,t} = Σ_r Σ_l w_l·γ_qr(l)·z_{r,t−l}, so that each lag costs n·k, not n·k².
fn stationary(series: &[ScoreSeries], k: usize, n: usize, window: usize) -> DMatrix<f64> {
    // residuals with 0 where absent and the presence as 0/1, so that every lag's sums are
    // plain dot products over contiguous ranges
    let present: Vec<(Vec<f64>, Vec<f64>)> = series
        .iter()
        .map(|(e, _)| {
            let m: Vec<f64> = e.iter().map(|v| f64::from(u8::from(v.is_finite()))).collect();
            (e.iter().map(|v| if v.is_finite() { *v } else { 0.0 }).collect(), m)
        })
        .collect();
    let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
    let mut v = DMatrix::<f64>::zeros(k, k);
    let mut y = vec![0.0; n * k];
    for ((eq, mq), (_, zq)) in present.iter().zip(series) {
        y.iter_mut().for_each(|x| *x = 0.0);
        for ((er, mr), (_, zr)) in present.iter().zip(series) {
            for l in -(window as isize)..=window as isize {
                // t in lo..hi pairs with s = t − l in lo − l..hi − l
                let lo = l.max(0) as usize;
                let hi = (n as isize + l.min(0)) as usize;
                let (slo, shi) = ((lo as isize - l) as usize, (hi as isize - l) as usize);
                let count = dot(&mq[lo..hi], &mr[slo..shi]);
                if count == 0.0 {
                    continue;
                }
                let h = parzen(l.unsigned_abs(), window) * dot(&eq[lo..hi], &er[slo..shi]) / count;
                for (a, b) in y[lo * k..hi * k].iter_mut().zip(&zr[slo * k..shi * k]) {
                    *a += h * b;
                }
            }
        }
        for (zt, yt) in zq.chunks_exact(k.max(1)).zip(y.chunks_exact(k.max(1))) {
            for (i, a) in zt.iter().enumerate().filter(|(_, a)| **a != 0.0) {
                for (j, b) in yt.iter().enumerate() {
                    v[(i, j)] += a * b;
                }
            }
        }
    }
    (&v + v.transpose()) * 0.5
}

/// A channel axis's [`ScoreSeries`]: residual `e` (NaN where the sample has no score) and the
/// columns `cols` (position in `set`, series) mapped by `m` (k × |set|, column p for the set's
/// p-th parameter), each scaled by `weight`. `None` when the axis has none of the set's columns.
fn score_series<X: AsRef<[f64]>>(
    e: Vec<f64>,
    cols: &[(usize, X)],
    m: DMatrixView<f64>,
    weight: f64,
) -> Option<ScoreSeries> {
    if cols.is_empty() {
        return None;
    }
    let (n, k) = (e.len(), m.nrows());
    let mut z = vec![0.0; n * k];
    for (p, x) in cols {
        for (t, xv) in x.as_ref().iter().enumerate() {
            if xv.is_finite() && e[t].is_finite() {
                for i in 0..k {
                    z[t * k + i] += m[(i, *p)] * weight * xv;
                }
            }
        }
    }
    Some((e, z))
}

/// The columns of `set` that channel axis (c, a) has, by their position in `set`.
fn set_columns<'d>(d: &'d Design, c: usize, a: usize, set: &[usize]) -> Vec<(usize, &'d [f64])> {
    set.iter()
        .enumerate()
        .filter_map(|(p, j)| d.columns[c][a].iter().find(|x| x.0 == *j).map(|x| (p, x.1.as_slice())))
        .collect()
}

/// The GLS errors' covariance when the prewhitened residuals are stationary ([`stationary`]
/// with z_{q,t} = [G̃⁻¹]_D·x̃_{q,t}, `from_gls` (k_D × k) applied to the prewhitened columns of
/// channel axis q, and e the prewhitened residuals over the training samples).
///
/// Why not Newey–West of the scores: an AR of order ≤ `max_ar_order` cannot follow a spectral
/// zero, and the twice-differentiated positions and once-differentiated attitudes put one at
/// zero frequency in the `accel_kin` and `gyro` residuals. The prewhitened residual is then
/// short of power at the lowest frequencies and has too much just above them, which is where
/// the delay's columns live, and its autocovariance reaches past `hac_lags`. Newey–West over
/// the per-sample scores cuts it off there, and over a longer window it loses what the fitted
/// parameters take out of the scores near the few moments that carry the delay (at the
/// estimate they sum to zero). The residual's autocovariance, averaged over the whole flight
/// instead of over those moments, keeps the long lags without that loss
/// (`tests::a_correlation_beyond_the_newey_west_lags_is_in_the_gls_variance`; measured in
/// closed loop in docs/px4.md, "How far to trust EKF2_EV_DELAY").
fn stationary_gls(
    d: &Design,
    train: &[bool],
    ars: &[Ar],
    set: &[usize],
    theta: &[f64],
    from_gls: &DMatrix<f64>,
    window: usize,
) -> DMatrix<f64> {
    let series: Vec<ScoreSeries> = active(d)
        .into_iter()
        .enumerate()
        .filter_map(|(q, (c, a))| {
            let cols = whitened(&ars[q], train, &set_columns(d, c, a, set));
            let e = whitened_residual(&ars[q], train, &residual_of(d, c, a, theta));
            score_series(e, &cols, from_gls.as_view(), 1.0)
        })
        .collect();
    stationary(&series, from_gls.nrows(), d.n, window)
}

/// Every parameter's covariance when the residuals are stationary ([`stationary`]): the error
/// map `a` (k × 2k, on the prewhitened scores and then the raw ones, [`error_map`]; k × k on
/// the raw ones alone when nothing is GLS) applied to each channel axis twice, once to its
/// prewhitened columns and residual (z = A_{:, ..k}·x̃, e = ẽ) and once to its raw weighted ones
/// (z = A_{:, k..}·w·x, e the residual over the training samples). Both halves of an axis, and
/// every pair of axes, are cross-correlated through γ_qr, as the stacked scores of
/// [`newey_west_cov`] are. On the GLS block it is [`stationary_gls`] (the raw half's rows
/// there are zero).
#[allow(clippy::too_many_arguments)]
fn stationary_full(
    d: &Design,
    train: &[bool],
    gs: &[Gram],
    ars: &[Ar],
    set: &[usize],
    theta: &[f64],
    a: &DMatrix<f64>,
    window: usize,
) -> DMatrix<f64> {
    let k = set.len();
    let gls = a.ncols() == 2 * k;
    let raw_map = a.columns(if gls { k } else { 0 }, k);
    let mut series = Vec::new();
    for (q, ((c, ax), gr)) in active(d).into_iter().zip(gs).enumerate() {
        let cols = set_columns(d, c, ax, set);
        let r = residual_of(d, c, ax, theta);
        if gls {
            let e = whitened_residual(&ars[q], train, &r);
            series.extend(score_series(e, &whitened(&ars[q], train, &cols), a.columns(0, k), 1.0));
        }
        let e = r.iter().zip(train).map(|(v, tr)| if *tr { *v } else { f64::NAN }).collect();
        series.extend(score_series(e, &cols, raw_map, gr.w_r));
    }
    stationary(&series, k, d.n, window)
}

/// Columns prewhitened by a channel axis's noise model (NaN where its window is short).
fn whitened(ar: &Ar, train: &[bool], cols: &[(usize, &[f64])]) -> Vec<(usize, Vec<f64>)> {
    cols.iter()
        .map(|(p, x)| {
            let mut w = Vec::new();
            ar.whiten(x, train, &mut w);
            (*p, w)
        })
        .collect()
}

/// A residual prewhitened by a channel axis's noise model.
fn whitened_residual(ar: &Ar, train: &[bool], r: &[f64]) -> Vec<f64> {
    let mut e = Vec::new();
    ar.whiten(r, train, &mut e);
    e
}

/// The Parzen weight of lag `l` in a window of `lags`: with x = l/(lags + 1), 1 − 6x² + 6x³ up
/// to x = ½ and 2(1 − x)³ beyond (1 at lag 0, ¼ at x = ½, 0 from lags + 1 on). Its spectral
/// window is never negative, so the covariance it weighs stays positive semidefinite.
fn parzen(l: usize, lags: usize) -> f64 {
    let x = l as f64 / (lags as f64 + 1.0);
    if x <= 0.5 {
        1.0 - 6.0 * x * x + 6.0 * x * x * x
    } else if x < 1.0 {
        2.0 * (1.0 - x).powi(3)
    } else {
        0.0
    }
}

/// The covariance `cov` (parameters of `set`, GLS at positions `dp`, least squares given them
/// at `op`) with the GLS errors' covariance replaced by `v` and what the least-squares errors
/// carry of them (δ_O = `carry`·δ_D + G_OO⁻¹Σu_O) following: δ_D → M·δ_D with
/// M = v^½·V⁻½ (V the GLS block of `cov`), δ_O → δ_O + carry·(M − I)·δ_D, so that the GLS
/// block becomes v and its correlation with the least-squares errors is kept. A congruence, so
/// the result stays positive semidefinite. Unchanged when v is V, or either is not positive
/// definite.
fn with_gls_covariance(
    cov: &DMatrix<f64>,
    dp: &[usize],
    op: &[usize],
    v: &DMatrix<f64>,
    carry: &DMatrix<f64>,
) -> DMatrix<f64> {
    let old = sub(cov, dp, dp);
    if *v == old {
        return cov.clone();
    }
    let (Some(vh), Some(nh)) = (spd_power(v, 0.5), spd_power(&old, -0.5)) else {
        return cov.clone();
    };
    let m = vh * nh;
    let k = cov.nrows();
    let mut q = DMatrix::<f64>::identity(k, k);
    let moved = carry * (&m - DMatrix::<f64>::identity(dp.len(), dp.len()));
    for (i, &p) in dp.iter().enumerate() {
        for (j, &r) in dp.iter().enumerate() {
            q[(p, r)] = m[(i, j)];
        }
    }
    for (i, &p) in op.iter().enumerate() {
        for (j, &r) in dp.iter().enumerate() {
            q[(p, r)] = moved[(i, j)];
        }
    }
    &q * cov * q.transpose()
}

/// The smallest matrix (in the positive semidefinite order) that is at least `b` and at least
/// `a` in every direction where `a` exceeds it: b + (a − b)₊, the negative eigenvalues of a − b
/// set to zero. For 1 × 1 matrices, the larger of the two; for 0 × 0 (no parameter), empty.
fn loewner_max(a: &DMatrix<f64>, b: &DMatrix<f64>) -> DMatrix<f64> {
    if b.is_empty() {
        return b.clone();
    }
    let eig = nalgebra::SymmetricEigen::new(((a - b) + (a - b).transpose()) * 0.5);
    let d = DMatrix::from_diagonal(&eig.eigenvalues.map(|l| l.max(0.0)));
    b + &eig.eigenvectors * d * eig.eigenvectors.transpose()
}

/// A symmetric positive definite matrix to the power `power` (by its eigenvalues); `None` if an
/// eigenvalue is not positive.
fn spd_power(m: &DMatrix<f64>, power: f64) -> Option<DMatrix<f64>> {
    let eig = nalgebra::SymmetricEigen::new((m + m.transpose()) * 0.5);
    if eig.eigenvalues.iter().any(|l| l.is_nan() || *l <= 0.0 || l.is_infinite()) {
        return None;
    }
    let d = DMatrix::from_diagonal(&eig.eigenvalues.map(|l| l.powf(power)));
    Some(&eig.eigenvectors * d * eig.eigenvectors.transpose())
}

/// The map A (k × 2k) from the summed scores (Σũ prewhitened, Σu raw) to the parameters' error
/// when the columns at positions `dp` of `set` are GLS and those at `op` least squares given
/// them: rows D = [G̃⁻¹]_D on Σũ; rows O = −G_OO⁻¹·G_OD·[G̃⁻¹]_D on Σũ and G_OO⁻¹ on Σu_O.
/// Its two factors are kept: `from_gls` = [G̃⁻¹]_D (k_D × k) and `carry` = −G_OO⁻¹·G_OD
/// (k_O × k_D), what the least-squares errors carry of the GLS ones.
struct ErrorMap {
    a: DMatrix<f64>,
    from_gls: DMatrix<f64>,
    carry: DMatrix<f64>,
}

fn error_map(gs: &[Gram], set: &[usize], dp: &[usize], op: &[usize]) -> ErrorMap {
    let k = set.len();
    let gw_inv = inverse_spd(&system(gs, set).0);
    let gr = system_raw(gs, set).0;
    let goo_inv = inverse_spd(&sub(&gr, op, op));
    let from_gls = sub(&gw_inv, dp, &(0..k).collect::<Vec<_>>());
    let mut a = DMatrix::<f64>::zeros(k, 2 * k);
    for (i, &p) in dp.iter().enumerate() {
        a.view_mut((p, 0), (1, k)).copy_from(&from_gls.row(i));
    }
    let carry = -&goo_inv * sub(&gr, op, dp);
    let carried = &carry * &from_gls;
    for (i, &p) in op.iter().enumerate() {
        a.view_mut((p, 0), (1, k)).copy_from(&carried.row(i));
        for (j, &q) in op.iter().enumerate() {
            a[(p, k + q)] = goo_inv[(i, j)];
        }
    }
    ErrorMap { a, from_gls, carry }
}

/// The score of each time sample summed over the channel axes, on the columns `set`: raw and
/// weighted, Σ w·x_t·e_t (training rows), or with the noise models `ars` prewhitened, Σ x̃_t·ẽ_t
/// (the rows where the prewhitened residual exists). `None` where the sample has no score.
fn scores(
    d: &Design,
    train: &[bool],
    gs: &[Gram],
    ars: Option<&[Ar]>,
    set: &[usize],
    theta: &[f64],
) -> Vec<Option<DVector<f64>>> {
    let k = set.len();
    let mut u: Vec<Option<DVector<f64>>> = (0..d.n).map(|t| train[t].then(|| DVector::zeros(k))).collect();
    let mut present = vec![false; d.n];
    let mut white = Vec::new();
    for (q, ((c, a), gr)) in active(d).into_iter().zip(gs).enumerate() {
        let e = residual_of(d, c, a, theta);
        let cols: Vec<Option<&Vec<f64>>> =
            set.iter().map(|j| d.columns[c][a].iter().find(|x| x.0 == *j).map(|x| &x.1)).collect();
        if cols.iter().all(Option::is_none) {
            continue;
        }
        // the raw columns are read in place; only the prewhitened ones are new series
        let (e, cols, w): (Vec<f64>, Columns, f64) = match ars {
            None => (e, cols.iter().map(|c| c.map(|c| Cow::Borrowed(c.as_slice()))).collect(), gr.w_r),
            Some(ars) => {
                ars[q].whiten(&e, train, &mut white);
                let e = std::mem::take(&mut white);
                let cols = cols
                    .iter()
                    .map(|c| {
                        c.map(|c| {
                            let mut v = Vec::new();
                            ars[q].whiten(c, train, &mut v);
                            Cow::Owned(v)
                        })
                    })
                    .collect();
                (e, cols, 1.0)
            }
        };
        for (t, ut) in u.iter_mut().enumerate() {
            if let Some(ut) = ut {
                if !e[t].is_finite() {
                    continue;
                }
                present[t] = true;
                for (p, col) in cols.iter().enumerate() {
                    if let Some(v) = col {
                        ut[p] += w * v[t] * e[t];
                    }
                }
            }
        }
    }
    if ars.is_some() {
        for (ut, p) in u.iter_mut().zip(present) {
            if !p {
                *ut = None;
            }
        }
    }
    u
}

/// A channel axis's columns of a set (`None` where the axis has none), raw or prewhitened.
type Columns<'a> = Vec<Option<Cow<'a, [f64]>>>;

/// The weights w_l of the lagged products in a Newey–West sum.
#[derive(Clone, Copy, Debug)]
enum Kernel {
    /// Bartlett over `lags` samples ([`bartlett`]).
    Bartlett(usize),
    /// Parzen over a window of 2·a samples, in its discrete form: w_l = r(l)/r(0), with r the
    /// autocorrelation of the triangle of a taps each side (h = box_a ∗ box_a), which tends to
    /// [`parzen`]'s 1 − 6x² + 6x³, 2(1 − x)³ (x = l/2a) as a grows. Computed as
    /// Σ_t v_t v_tᵀ / r(0) with v = h ∗ u (two running sums), so a window of any length costs
    /// n·k²; and being a sum of outer products it is positive semidefinite.
    Parzen(usize),
}

/// The Newey–West sum S = Σ_l w_l Σ_t (u_t u_{t−l}ᵀ + u_{t−l} u_tᵀ) (l = 0 once), over the
/// samples that have a score (a sample without one counts as zero), weights by `kernel`.
fn newey_west(u: &[Option<DVector<f64>>], kernel: Kernel) -> DMatrix<f64> {
    let lags = match kernel {
        Kernel::Bartlett(lags) => lags,
        Kernel::Parzen(a) => return parzen_sum(u, a.max(1)),
    };
    let k = u.iter().flatten().next().map_or(0, |v| v.len());
    let mut sm = DMatrix::<f64>::zeros(k, k);
    for l in 0..=lags {
        let w = bartlett(l, lags);
        for t in l..u.len() {
            if let (Some(ut), Some(ul)) = (&u[t], &u[t - l]) {
                let m = ut * ul.transpose();
                if l == 0 {
                    sm += m;
                } else {
                    sm += (&m + m.transpose()) * w;
                }
            }
        }
    }
    sm
}

/// [`Kernel::Parzen`]'s sum: the scores filtered by the triangle of `a` taps each side, their
/// outer products summed and divided by the triangle's energy r(0) = Σ h_j².
fn parzen_sum(u: &[Option<DVector<f64>>], a: usize) -> DMatrix<f64> {
    let k = u.iter().flatten().next().map_or(0, |v| v.len());
    let scores: Vec<DVector<f64>> = u.iter().map(|v| v.clone().unwrap_or_else(|| DVector::zeros(k))).collect();
    let mut sm = DMatrix::<f64>::zeros(k, k);
    for v in &running_sum(&running_sum(&scores, a), a) {
        sm.ger(1.0, v, v, 1.0);
    }
    sm / parzen_energy(a)
}

/// The sums of `a` consecutive vectors of `x` over the full convolution's length
/// (x.len() + a − 1: the window entering at the first and leaving after the last).
fn running_sum(x: &[DVector<f64>], a: usize) -> Vec<DVector<f64>> {
    let mut acc = DVector::<f64>::zeros(x.first().map_or(0, |v| v.len()));
    (0..x.len() + a - 1)
        .map(|t| {
            if let Some(v) = x.get(t) {
                acc += v;
            }
            if t >= a {
                acc -= &x[t - a];
            }
            acc.clone()
        })
        .collect()
}

/// The Bartlett weight of lag `l` among `lags`: w_l = 1 − l/(lags + 1), 1 at lag 0, falling
/// by 1/(lags + 1) a lag to 1/(lags + 1) at the last (positive, so S stays positive
/// semidefinite).
fn bartlett(l: usize, lags: usize) -> f64 {
    1.0 - l as f64 / (lags as f64 + 1.0)
}

/// The covariance a systematic relative error ε ~ N(0, σ_T²) of the nominal thrust adds to the
/// weighted least-squares parameters. Such an error adds ε·(−T/m) to the force channel's z
/// residual, which is ε times the thrust-scale column c, so the parameters move by
/// ε·(XᵀWX)⁻¹XᵀWc (W the channel-axis weights): onto the thrust
/// scale alone when it is in the model, otherwise onto whatever explains a vertical force (an
/// accelerometer bias z, a constant force D). The same ε holds for the whole flight, so no
/// amount of data averages it away: it is added to the statistical covariance, not divided
/// by n. σ_T is the model's own resolution ([`NominalModel::thrust_rel_sd`]).
pub(super) fn thrust_systematic(
    d: &Design,
    train: &[bool],
    gs: &[Gram],
    ars: &[Ar],
    set: &[usize],
    rel_sd: f64,
) -> DMatrix<f64> {
    let k = set.len();
    let (c, a) = (Channel::Force.index(), 2);
    let ts = cols_of(Effect::ThrustScale).start;
    let thrust_col = d.columns[c][a].iter().find(|x| x.0 == ts).map(|x| &x.1);
    let (Some(tc), true) = (thrust_col, rel_sd > 0.0) else { return DMatrix::zeros(k, k) };
    let Some(q) = active(d).iter().position(|x| *x == (c, a)) else { return DMatrix::zeros(k, k) };
    let w = gs[q].w_r;
    let mut xc = DVector::<f64>::zeros(k);
    for (p, j) in set.iter().enumerate() {
        if let Some((_, col)) = d.columns[c][a].iter().find(|x| x.0 == *j) {
            xc[p] = w * (0..d.n).filter(|&i| train[i]).map(|i| col[i] * tc[i]).sum::<f64>();
        }
    }
    let (dp, op) = split(set);
    let shift = if dp.is_empty() {
        inverse_spd(&system_raw(gs, set).0) * xc
    } else {
        // the same error, prewhitened by the axis's noise model, moves the GLS part
        let (mut tw, mut xw) = (Vec::new(), Vec::new());
        ars[q].whiten(tc, train, &mut tw);
        let mut both = DVector::<f64>::zeros(2 * k);
        for (p, j) in set.iter().enumerate() {
            if let Some((_, col)) = d.columns[c][a].iter().find(|x| x.0 == *j) {
                ars[q].whiten(col, train, &mut xw);
                both[p] = xw.iter().zip(&tw).filter(|(x, t)| x.is_finite() && t.is_finite()).map(|(x, t)| x * t).sum();
            }
        }
        both.rows_mut(k, k).copy_from(&xc);
        error_map(gs, set, &dp, &op).a * both
    };
    &shift * shift.transpose() * (rel_sd * rel_sd)
}

#[cfg(test)]
mod tests {
    use super::super::{Ar, N_COLUMNS, grams};
    use super::*;

    /// The sandwich of the delay by GLS and a bias by least squares given it is the spread of
    /// those estimates over noise draws. 800 draws of 400 samples: residual 0.3·x_D + 0.5 + e with
    /// AR(1) noise e (φ = 0.3, innovations σ = 1), x_D a fixed draw of 1 + N(0, 1) (so that it shares a mean with the bias), a column of
    /// ones. The mean Newey–West variance of each estimate must match its variance across draws
    /// within 15 % (the sampling error of 800 draws is ±5 %). A bug it catches: the error map's
    /// least-squares rows without the delay's share (the bias's variance falls short by half),
    /// the GLS rows read off the raw Gram, and the prewhitened scores left unwhitened.
    #[test]
    fn the_split_fits_covariance_is_its_spread_over_draws() {
        use crate::rng::{Component, Stream};
        let (n, draws, phi) = (400, 800, 0.3);
        let c = Channel::AccelKin.index();
        let (delay, bias) = (cols_of(Effect::MocapDelay).start, cols_of(Effect::AccelBias).start);
        let mut rng = Stream::new(7, Component::Sweep, 0);
        let x: Vec<f64> = (0..n).map(|_| 1.0 + rng.normal()).collect();
        let ar = Ar { a: vec![phi], sigma: 1.0, marginal_var: 1.0 / (1.0 - phi * phi) };
        let set = [bias, delay];
        let (mut est, mut var) = (vec![Vec::new(); 2], [0.0; 2]);
        for _ in 0..draws {
            let mut e = 0.0;
            let y: Vec<f64> = x
                .iter()
                .map(|xi| {
                    e = phi * e + rng.normal();
                    0.3 * xi + 0.5 + e
                })
                .collect();
            let mut d = Design { n, ..Design::default() };
            d.measured[c][0] = y;
            d.predicted[c][0] = vec![0.0; n];
            d.columns[c][0] = vec![(delay, x.clone()), (bias, vec![1.0; n])];
            let train = vec![true; n];
            let gs = grams(&d, &train, &vec![false; n], std::slice::from_ref(&ar));
            let f = super::super::gram::fit(&gs, &set);
            let cov = hac(&d, &train, &gs, std::slice::from_ref(&ar), &set, &f.theta, 12, 1.0, None);
            for (k, j) in set.iter().enumerate() {
                est[k].push(f.theta[*j]);
                var[k] += cov[(k, k)] / draws as f64;
            }
        }
        for (k, name) in ["bias", "delay"].iter().enumerate() {
            let m = est[k].iter().sum::<f64>() / draws as f64;
            let spread = est[k].iter().map(|v| (v - m).powi(2)).sum::<f64>() / (draws - 1) as f64;
            assert!((var[k] / spread - 1.0).abs() < 0.15, "{name}: Newey–West {} against the draws' {spread}", var[k]);
        }
    }

    /// The thrust error with a delay in the model (given a column on force z too, so that the
    /// prewhitened half of the map sees it): the error is the thrust scale's own column (force z,
    /// prewhitened there by an AR(1) of φ = ½ as the delay's GLS fit sees it), so the thrust
    /// scale moves by ε and the delay not at all: σ_T² and zeros, as
    /// without the delay. A bug it catches: the prewhitened sums taken unwhitened (the delay
    /// then moves) and the raw half of the map left out (the thrust scale does not move).
    #[test]
    fn a_thrust_error_moves_the_thrust_scale_and_not_a_gls_delay() {
        let n = 6;
        let (k, f, z) = (Channel::AccelKin.index(), Channel::Force.index(), 2);
        let (ts, delay) = (cols_of(Effect::ThrustScale).start, cols_of(Effect::MocapDelay).start);
        let mut d = Design { n, ..Design::default() };
        d.measured[k][0] = vec![0.3, -0.1, 0.2, 0.0, 0.1, -0.2];
        d.predicted[k][0] = vec![0.0; n];
        d.columns[k][0] = vec![(delay, vec![1.0, -2.0, 0.5, 3.0, -1.0, 2.0])];
        d.measured[f][z] = vec![0.1, -0.2, 0.05, 0.0, 0.3, -0.1];
        d.predicted[f][z] = vec![0.0; n];
        d.columns[f][z] =
            vec![(ts, vec![-9.0, -10.0, -11.0, -9.5, -10.5, -12.0]), (delay, vec![0.2, 0.1, -0.3, 0.4, 0.0, 0.1])];
        let train = [true; 6];
        let ars = [Ar::white(0.5), Ar { a: vec![0.5], sigma: 0.5, marginal_var: 0.25 }];
        let gs = grams(&d, &train, &[false; 6], &ars);
        let sd = 0.05;
        let m = thrust_systematic(&d, &train, &gs, &ars, &[ts, delay], sd);
        let close = |got: f64, want: f64| assert!((got - want).abs() < 1e-12, "{got} for {want}: {m}");
        close(m[(0, 0)], sd * sd);
        for (p, q) in [(0, 1), (1, 0), (1, 1)] {
            close(m[(p, q)], 0.0);
        }
    }

    /// The GLS errors' covariance from the residual's autocovariance, by hand. One channel axis,
    /// white noise model (σ = 1), the delay column x = (1, 2, 0, −1), so G = 6 and z = x/6;
    /// residual e = (1, −1, 2, 0); a window of one lag (Parzen ¼ there). γ(0) = 6/4 = 3/2,
    /// γ(±1) = (−1 − 2 + 0)/3 = −1; Σz² = 1/6, Σz_t·z_{t−1} = 2/36, so
    /// v = 3/2·1/6 + 2·¼·(−1)·2/36 = 2/9. With row 2 out of the training part: γ(0) = 2/3 over
    /// the three rows left and γ(±1) = −1 over the one pair left (not over every row),
    /// v = 2/3·1/6 − 1/36 = 1/12. A bug it catches: the means taken over all rows, or over pairs
    /// that leave the training part, the lags' weights or their sign.
    #[test]
    fn the_gls_variance_from_the_residuals_autocovariance_by_hand() {
        let n = 4;
        let c = Channel::AccelKin.index();
        let delay = cols_of(Effect::MocapDelay).start;
        let mut d = Design { n, t: vec![0.0, 0.02, 0.04, 0.06], ..Design::default() };
        d.measured[c][0] = vec![1.0, -1.0, 2.0, 0.0];
        d.predicted[c][0] = vec![0.0; n];
        d.columns[c][0] = vec![(delay, vec![1.0, 2.0, 0.0, -1.0])];
        let theta = vec![0.0; N_COLUMNS];
        let from_gls = DMatrix::from_element(1, 1, 1.0 / 6.0);
        for (train, want) in [([true; 4], 2.0 / 9.0), ([true, true, false, true], 1.0 / 12.0)] {
            let v = stationary_gls(&d, &train, &[Ar::white(1.0)], &[delay], &theta, &from_gls, 1);
            assert!((v[(0, 0)] - want).abs() < 1e-15, "{} for {want}", v[(0, 0)]);
            // the whole covariance with the map on the prewhitened half alone is the same
            let gs = grams(&d, &train, &[false; 4], &[Ar::white(1.0)]);
            let a = DMatrix::from_row_slice(1, 2, &[1.0 / 6.0, 0.0]);
            let v = stationary_full(&d, &train, &gs, &[Ar::white(1.0)], &[delay], &theta, &a, 1);
            assert!((v[(0, 0)] - want).abs() < 1e-15, "whole: {} for {want}", v[(0, 0)]);
        }
    }

    /// The error map by hand: a bias by least squares given a GLS delay, set = [bias, delay].
    /// Whitened Gram G̃ = [[2, 1], [1, 2]], so [G̃⁻¹]_D = (−1, 2)/3; raw Gram G = [[4, 2], [2, 3]],
    /// so the bias carries −G_OD/G_OO = −½ of the delay's error. The delay's row of A is
    /// ((−1, 2)/3 on Σũ, 0 on Σu); the bias's is (−½·(−1, 2)/3 on Σũ, (¼, 0) on Σu). A bug it
    /// catches: the carry's sign (the bias would move with the delay's error instead of against
    /// it), the GLS rows read off the raw Gram, or the raw inverse left out.
    #[test]
    fn the_error_map_by_hand() {
        let (bias, delay) = (cols_of(Effect::AccelBias).start, cols_of(Effect::MocapDelay).start);
        let mut g = Gram::zeros(vec![bias, delay], 1.0);
        g.g_w = DMatrix::from_row_slice(2, 2, &[2.0, 1.0, 1.0, 2.0]);
        g.g_r = DMatrix::from_row_slice(2, 2, &[4.0, 2.0, 2.0, 3.0]);
        let set = [bias, delay];
        let ErrorMap { a, from_gls, carry } = error_map(std::slice::from_ref(&g), &set, &[1], &[0]);
        let want = DMatrix::from_row_slice(2, 4, &[1.0 / 6.0, -1.0 / 3.0, 0.25, 0.0, -1.0 / 3.0, 2.0 / 3.0, 0.0, 0.0]);
        assert!((&a - &want).abs().max() < 1e-15, "{a} for {want}");
        assert!((from_gls - DMatrix::from_row_slice(1, 2, &[-1.0 / 3.0, 2.0 / 3.0])).abs().max() < 1e-15);
        assert!((carry[(0, 0)] + 0.5).abs() < 1e-15, "{carry}");
    }

    /// The simplest fit of the small-sample tests: one channel axis whose five samples
    /// (0.3, −0.1, 0.2, 0, 0.1), `step` seconds apart, are fitted by a constant column (a bias);
    /// the design and the bias's column.
    fn five_sample_bias_fit(step: f64) -> (Design, usize) {
        let n = 5;
        let c = Channel::AccelKin.index();
        let bias = cols_of(Effect::AccelBias).start;
        let mut d = Design { n, t: (0..n).map(|i| step * i as f64).collect(), ..Design::default() };
        d.measured[c][0] = vec![0.3, -0.1, 0.2, 0.0, 0.1];
        d.predicted[c][0] = vec![0.0; n];
        d.columns[c][0] = vec![(bias, vec![1.0; n])];
        (d, bias)
    }

    /// The Parzen sum's small-sample factor, by hand, on the simplest fit: one channel axis,
    /// a constant column (a bias), 5 samples, white noise model. With a = 2 the lag weights are
    /// 1, 2/3, 1/6 (`the_parzen_sum_by_hand`). Leverage: G = 5, P_t = 1,
    /// K = Σ_{t,s} w_{t−s}/5 = (5 + 8·2/3 + 6·1/6)/5 = 34/15, so f = (1/5)/((5 − 34/15)/25) = 75/41.
    /// Degrees of freedom: v_t = 1/25, Σ_{t,s} w² = 5 + 8·4/9 + 6/36 = 157/18, so
    /// ν = (1/5)² / (157/18 / 625) = 450/157 and t_{97.5 %} = 3.268136 (scipy's `t.ppf`); the
    /// factor (75/41)·(3.268136/1.959964)² = 5.086060. With a = 1 (lag 0 alone): K = 1,
    /// f = 5/4 (HC2's n/(n − 1)), ν = 5, t = 2.570582, factor 2.150189. A bug it catches: the
    /// leverage's sign or its G⁻¹ sandwich, the lags' weights (squared for ν, not for K), a
    /// side of the lags counted once, the smoothed P off-centre.
    #[test]
    fn the_parzen_small_sample_factor_by_hand() {
        let (d, bias) = five_sample_bias_fit(0.02);
        let train = [true; 5];
        let gs = grams(&d, &train, &[false; 5], &[Ar::white(0.7)]);
        for (a, want) in [(2, 5.086_060_200_822_067), (1, 2.150_189_316_785_830_6)] {
            let got = parzen_small_sample(&d, &train, &gs, &[bias], a)[0];
            assert!((got - want).abs() < 1e-9, "a = {a}: {got} for {want}");
        }
    }

    /// A calibration's covariance (`WholeCovariance::Parzen`) on the fit of
    /// `the_parzen_small_sample_factor_by_hand`, by hand: the bias 0.1 leaves the residual
    /// ê = (0.2, −0.2, 0.1, −0.1, 0), whose Parzen sum over a = 2 (a window of 2 s at
    /// samples 0.5 s apart: weights 1, 2/3, 1/6) is w²·(0.10 − 2·(2/3)·0.07 + 2·(1/6)·0.04)
    /// = 0.02·w² with G = 5·w, so 0.02/25 = 8·10⁻⁴, raised by the factor 5.086060 to
    /// 4.068848·10⁻³. A bug it catches: the factor left out, divided by, or taken on another
    /// window than the sum's.
    #[test]
    fn a_calibrations_parzen_covariance_by_hand() {
        let (d, bias) = five_sample_bias_fit(0.5);
        let train = [true; 5];
        let ars = [Ar::white(0.7)];
        let gs = grams(&d, &train, &[false; 5], &ars);
        let mut theta = vec![0.0; N_COLUMNS];
        theta[bias] = 0.1;
        let v = hac(&d, &train, &gs, &ars, &[bias], &theta, 12, 2.0, Some(WholeCovariance::Parzen))[(0, 0)];
        let want = 8e-4 * 5.086_060_200_822_067;
        assert!((v - want).abs() < 1e-12, "{v} for {want}");
    }

    /// Student's t quantile against scipy's `t.ppf(0.975, ν)`: 12.706205 (ν = 1), 4.302653 (2),
    /// 2.228139 (10), 2.042272 (30), 1.979930 (120), and 1.959964 for an infinite ν.
    #[test]
    fn the_t_quantile_is_students() {
        for (nu, want) in [
            (1.0, 12.706_204_736_174_694),
            (2.0, 4.302_652_729_749_462),
            (10.0, 2.228_138_851_986_274),
            (30.0, 2.042_272_456_301_238),
            (120.0, 1.979_930_405_082_440_6),
            (f64::INFINITY, Z_975),
        ] {
            assert!((t_975(nu) - want).abs() < 1e-9, "ν = {nu}: {} for {want}", t_975(nu));
        }
    }

    /// The discrete Parzen sum, by hand, with a = 2: the triangle h = (1, 2, 1), whose
    /// autocorrelation is r = (6, 4, 1), so the weights are 1, 2/3 and 1/6. For u = (1, −1, 2):
    /// Σu² = 6, Σu_t·u_{t−1} = −3, Σu_t·u_{t−2} = 2, S = 6 − 2·(2/3)·3 + 2·(1/6)·2 = 8/3. A sample
    /// without a score counts as zero: u = (1, –, 2) gives 5 + 2·(1/6)·2 = 17/3. With a = 1 it is
    /// Σu² alone (6). A bug it catches: the triangle's energy r(0) wrong (a² instead of
    /// 2·Σj² − a²), a box of a + 1 taps, the missing sample skipped instead of counted as zero.
    #[test]
    fn the_parzen_sum_by_hand() {
        let u = |v: &[Option<f64>]| -> Vec<Option<DVector<f64>>> {
            v.iter().map(|x| x.map(|x| DVector::from_element(1, x))).collect()
        };
        let close = |m: DMatrix<f64>, want: f64| assert!((m[(0, 0)] - want).abs() < 1e-12, "{} vs {want}", m[(0, 0)]);
        close(newey_west(&u(&[Some(1.0), Some(-1.0), Some(2.0)]), Kernel::Parzen(2)), 8.0 / 3.0);
        close(newey_west(&u(&[Some(1.0), None, Some(2.0)]), Kernel::Parzen(2)), 17.0 / 3.0);
        close(newey_west(&u(&[Some(1.0), Some(-1.0), Some(2.0)]), Kernel::Parzen(1)), 6.0);
        // and Bartlett over one lag, for comparison: 6 + 2·½·(−3) = 3
        close(newey_west(&u(&[Some(1.0), Some(-1.0), Some(2.0)]), Kernel::Bartlett(1)), 3.0);
    }

    /// The larger of two covariances, by hand. 1 × 1: max(4, 9) = 9 and max(9, 4) = 9. 2 × 2:
    /// a = diag(4, 1), b = diag(1, 2): a − b = diag(3, −1), so b + diag(3, 0) = diag(4, 2), at
    /// least each in every direction. A bug it catches: the difference's negative part kept
    /// (diag(4, 1), below b on the second axis), or the order of the two swapped.
    #[test]
    fn the_larger_covariance_by_hand() {
        let one = |v: f64| DMatrix::from_element(1, 1, v);
        assert_eq!(loewner_max(&one(4.0), &one(9.0)), one(9.0));
        assert_eq!(loewner_max(&one(9.0), &one(4.0)), one(9.0));
        let a = DMatrix::from_diagonal(&DVector::from_vec(vec![4.0, 1.0]));
        let b = DMatrix::from_diagonal(&DVector::from_vec(vec![1.0, 2.0]));
        let want = DMatrix::from_diagonal(&DVector::from_vec(vec![4.0, 2.0]));
        assert!((loewner_max(&a, &b) - want).abs().max() < 1e-12);
        assert_eq!(loewner_max(&DMatrix::zeros(0, 0), &DMatrix::zeros(0, 0)).shape(), (0, 0));
    }

    /// The Parzen weights by hand: x = l/(L + 1); 1 at lag 0; ¼ at x = ½ (lag 1 of 1);
    /// 1 − 6/16 + 6/64 = 0.71875 at x = ¼; 2·(¼)³ = 1/32 at x = ¾; 0 from x = 1. A bug it
    /// catches: the two branches swapped, the cube as a square, the window's end off by one.
    #[test]
    fn parzen_weights_by_hand() {
        assert_eq!(parzen(0, 5), 1.0);
        assert_eq!(parzen(1, 1), 0.25);
        assert_eq!(parzen(1, 3), 0.71875);
        assert_eq!(parzen(3, 3), 0.03125);
        assert_eq!(parzen(4, 3), 0.0);
    }

    /// Replacing the GLS block, by hand. δ_D and δ_O with covariance [[4, 2], [2, 3]] and
    /// δ_O = ½·δ_D + w: w has variance 3 − 2 + 1 = 2 and no covariance with δ_D. The GLS variance
    /// becomes 9 (δ_D scaled by 3/2), so δ_O = ½·δ_D + w has variance ¼·9 + 2 = 4.25 and
    /// covariance ½·9 = 4.5 with δ_D. A new variance that is not positive leaves it as it was.
    /// A bug it catches: the least-squares errors left as they were (3 and 3) or scaled with the
    /// GLS ones, M as V^½·v^−½.
    #[test]
    fn the_gls_block_is_replaced_and_the_least_squares_errors_follow() {
        let cov = DMatrix::from_row_slice(2, 2, &[4.0, 2.0, 2.0, 3.0]);
        let carry = DMatrix::from_element(1, 1, 0.5);
        let got = with_gls_covariance(&cov, &[0], &[1], &DMatrix::from_element(1, 1, 9.0), &carry);
        let want = DMatrix::from_row_slice(2, 2, &[9.0, 4.5, 4.5, 4.25]);
        assert!((&got - &want).abs().max() < 1e-12, "{got}");
        assert_eq!(with_gls_covariance(&cov, &[0], &[1], &DMatrix::zeros(1, 1), &carry), cov);
    }

    /// A noise the noise model misses, correlated over 20 samples (0.4 s): e_t = n_t + 0.9·n_{t−20},
    /// whitened as if white. The delay's column is four bursts like a flight's manoeuvres,
    /// x_t = sin(2πt/120)·exp(−((t mod 200) − 100)²/(2·20²)) (800 samples, 20 ms apart), and its
    /// variance is Σ_{t,s} x_t·x_s·γ(t − s)/G² with γ(0) = 1.81 and γ(±20) = 0.9 (closed form).
    /// Over 100 draws the mean of the reported variance must be within 15 % of it (about 0.89
    /// of it is expected: the Parzen window of 2 s weighs lag 20 by 0.81, and the fitted delay
    /// takes a little out of the residual). Without the window, the larger of Newey–West over
    /// 12 lags and γ(0) alone, which both miss lag 20, gives about three quarters of it and must
    /// stay under 0.8. A bug it catches: the window left out, or read in samples instead of
    /// seconds (2 lags), and the GLS block not raised.
    #[test]
    fn a_correlation_beyond_the_newey_west_lags_is_in_the_gls_variance() {
        let (mean, short, want) = beyond_the_lags(Effect::MocapDelay, 11, false);
        assert!((mean / want - 1.0).abs() < 0.15, "{mean} for {want}: {}", mean / want);
        assert!(short / want < 0.8, "without the window: {short} for {want}: {}", short / want);
    }

    /// The flight of the two tests of a correlation beyond the Newey–West lags: `effect`'s
    /// first column four bursts, its residual 0.3 of it plus e_t = n_t + 0.9·n_{t−20} (the noise
    /// model white), 100 draws from `seed`. The mean reported variance with the 2 s window and
    /// without it (`hac(…, whole)`), and the closed form Σ_{t,s} x_t·x_s·γ(t − s)/G².
    fn beyond_the_lags(effect: Effect, seed: u64, whole: bool) -> (f64, f64, f64) {
        use crate::rng::{Component, Stream};
        let (n, draws, lag, b) = (800, 100, 20, 0.9);
        let c = Channel::AccelKin.index();
        let col = cols_of(effect).start;
        let burst = |t: usize| {
            let u = (t % 200) as f64 - 100.0;
            (2.0 * std::f64::consts::PI * t as f64 / 120.0).sin() * (-0.5 * (u / 20.0).powi(2)).exp()
        };
        let x: Vec<f64> = (0..n).map(burst).collect();
        let g: f64 = x.iter().map(|v| v * v).sum();
        let lagged: f64 = (lag..n).map(|t| x[t] * x[t - lag]).sum();
        let want = ((1.0 + b * b) * g + 2.0 * b * lagged) / (g * g);
        let mut rng = Stream::new(seed, Component::Sweep, 0);
        let ar = Ar::white(1.0);
        let train = vec![true; n];
        let mut d = Design { n, t: (0..n).map(|t| t as f64 * 0.02).collect(), ..Design::default() };
        d.predicted[c][0] = vec![0.0; n];
        d.columns[c][0] = vec![(col, x.clone())];
        let (mut mean, mut short) = (0.0, 0.0);
        for _ in 0..draws {
            let noise: Vec<f64> = (0..n + lag).map(|_| rng.normal()).collect();
            d.measured[c][0] = (0..n).map(|t| 0.3 * x[t] + noise[t + lag] + b * noise[t]).collect();
            let gs = grams(&d, &train, &vec![false; n], std::slice::from_ref(&ar));
            let f = super::super::gram::fit(&gs, &[col]);
            let whole = whole.then_some(WholeCovariance::Larger);
            let v = |w| hac(&d, &train, &gs, std::slice::from_ref(&ar), &[col], &f.theta, 12, w, whole)[(0, 0)];
            mean += v(2.0) / draws as f64;
            short += v(0.0) / draws as f64;
        }
        (mean, short, want)
    }

    /// The Bartlett weights by hand for 3 lags: 1, 3/4, 1/2, 1/4. A bug it catches: `lags + 1` as
    /// `lags − 1` (1, 1/2, 0, −1/2: S no longer positive semidefinite) and as `lags · 1` (1, 2/3,
    /// 1/3, 0).
    #[test]
    fn bartlett_weights_by_hand() {
        assert_eq!((0..4).map(|l| bartlett(l, 3)).collect::<Vec<_>>(), [1.0, 0.75, 0.5, 0.25]);
        assert_eq!(bartlett(0, 0), 1.0);
    }

    /// Newey–West by hand for one parameter: two channel axes carry its column, a constant 2 (θ is
    /// half the mean); the second also carries another column, which the score must not use. Axis
    /// weights w = 1/σ² are ¼ (σ = 2) and 1; residuals at θ = 0 are e₁ = (0.5, 0, 0, 1, −0.5) and
    /// e₂ = (1, 2, 7, −1, 3); row 2 is held out. The scores summed per time sample, u_t = 2·(¼·e₁ +
    /// e₂), are 2·(1.125, 2, held out, −0.75, 2.875), and G = Σ w·2²·n = (¼ + 1)·4·4 = 20, so var =
    /// S/G² = 4·s/400 with s the sum for ¼·e₁ + e₂: Σu² = 14.09375 (0 lags); + 2·½·(u₁u₀ + u₄u₃) =
    /// 0.09375 (1 lag: pairs across the held-out row do not count); with 2 lags ⅔ on lag 1 and ⅓ on
    /// u₃u₁ = −1.5: s = 14.09375 + 0.125 − 1 = 13.21875. A bug it catches: every mutant of `hac`
    /// (the column lookup's `==` as `!=`, the score's and S's sums).
    #[test]
    fn the_variance_of_a_mean_summed_per_time_sample_with_bartlett_lags() {
        let n = 5;
        let f = Channel::Force.index();
        let (one, other) = (cols_of(Effect::AccelBias).start, cols_of(Effect::ThrustScale).start);
        let mut d = Design { n, ..Design::default() };
        d.measured[f][0] = vec![0.5, 0.0, 0.0, 1.0, -0.5];
        d.measured[f][2] = vec![1.0, 2.0, 7.0, -1.0, 3.0];
        for a in [0, 2] {
            d.predicted[f][a] = vec![0.0; n];
        }
        d.columns[f][0] = vec![(one, vec![2.0; n])];
        d.columns[f][2] = vec![(other, vec![0.5, -1.0, 4.0, 2.0, 1.0]), (one, vec![2.0; n])];
        let train = [true, true, false, true, true];
        let test: Vec<bool> = train.iter().map(|t| !t).collect();
        let ars = [Ar::white(2.0), Ar::white(1.0)];
        let gs = grams(&d, &train, &test, &ars);
        let theta = vec![0.0; N_COLUMNS];
        for (lags, s) in [(0, 14.09375), (1, 14.1875), (2, 13.21875)] {
            let v = newey_west_cov(&d, &train, &gs, &ars, &[one], &theta, Kernel::Bartlett(lags), 0);
            assert_eq!(v.shape(), (1, 1));
            assert!((v[(0, 0)] - s / 100.0).abs() < 1e-14, "{lags} lags: {} for {}", v[(0, 0)], s / 100.0);
        }
    }

    /// The stationary covariance of a least-squares parameter, by hand, on the flight of
    /// `the_variance_of_a_mean_summed_per_time_sample_with_bartlett_lags`: G = 20, so the error
    /// map applied to the weighted columns is z₁ = 2·¼/20 = 1/40 and z₂ = 2/20 = 1/10 on the
    /// training rows (0, 1, 3, 4). Lag 0: γ₁₁ = 1.5/4, γ₂₂ = 15/4, γ₁₂ = −2/4, so
    /// v = 4·(0.375/1600 + 3.75/100 − 2·0.5/400) = 0.1409375 (Newey–West's at lag 0: with a
    /// constant column the two agree). Lag ±1 (a window of one lag, Parzen ¼) has two pairs
    /// inside the training part, (1, 0) and (4, 3): γ₁₁(1) = −¼, γ₂₂(1) = −½, γ₁₂(1) = ¼,
    /// γ₂₁(1) = 2, adding 2·¼·2·Σ_qr γ_qr(1)·z_q·z_r = 0.00046875, so v = 0.14140625. `hac` is
    /// the larger of this and Newey–West on a fit of every sample: 0.141875 with one Bartlett
    /// lag, this with two (0.1321875); on a fit with a held-out part, Newey–West's. A bug it
    /// catches: the raw half's weight left out, the residual's mean taken over pairs that leave
    /// the training part, a cross-covariance's lag read the wrong way, the smaller of the two
    /// taken.
    #[test]
    fn the_stationary_variance_of_a_least_squares_mean_by_hand() {
        let n = 5;
        let f = Channel::Force.index();
        let one = cols_of(Effect::AccelBias).start;
        let mut d = Design { n, t: (0..n).map(|t| t as f64 * 0.02).collect(), ..Design::default() };
        d.measured[f][0] = vec![0.5, 0.0, 0.0, 1.0, -0.5];
        d.measured[f][2] = vec![1.0, 2.0, 7.0, -1.0, 3.0];
        for a in [0, 2] {
            d.predicted[f][a] = vec![0.0; n];
            d.columns[f][a] = vec![(one, vec![2.0; n])];
        }
        let train = [true, true, false, true, true];
        let test: Vec<bool> = train.iter().map(|t| !t).collect();
        let ars = [Ar::white(2.0), Ar::white(1.0)];
        let gs = grams(&d, &train, &test, &ars);
        let theta = vec![0.0; N_COLUMNS];
        let a = DMatrix::from_element(1, 1, 1.0 / 20.0);
        for (window, want) in [(0, 0.1409375), (1, 0.14140625)] {
            let v = stationary_full(&d, &train, &gs, &ars, &[one], &theta, &a, window);
            assert!((v[(0, 0)] - want).abs() < 1e-14, "window {window}: {} for {want}", v[(0, 0)]);
        }
        for (lags, want) in [(1, 0.141875), (2, 0.14140625)] {
            let v = hac(&d, &train, &gs, &ars, &[one], &theta, lags, 0.02, Some(WholeCovariance::Larger));
            assert!((v[(0, 0)] - want).abs() < 1e-14, "{lags} lags: {} for {want}", v[(0, 0)]);
            // the stationary estimate alone is the window's, whatever Newey–West says
            let v = hac(&d, &train, &gs, &ars, &[one], &theta, lags, 0.02, Some(WholeCovariance::Stationary));
            assert!((v[(0, 0)] - 0.14140625).abs() < 1e-14, "{lags} lags, stationary: {}", v[(0, 0)]);
        }
        // a fit with a held-out part keeps Newey–West's
        let v = hac(&d, &train, &gs, &ars, &[one], &theta, 2, 0.02, None);
        assert!((v[(0, 0)] - 0.1321875).abs() < 1e-14, "{}", v[(0, 0)]);
    }

    /// What the all-sample intervals of a hand-held rig missed: a least-squares parameter (no
    /// GLS in the model) under a noise the noise model misses, correlated over 20 samples
    /// (e_t = n_t + 0.9·n_{t−20}, the model white), its column four bursts
    /// (`a_correlation_beyond_the_newey_west_lags_is_in_the_gls_variance`'s). Least squares
    /// gives Var = Σ_{t,s} x_t·x_s·γ(t − s)/G² in closed form. Over 100 draws the mean reported
    /// variance must be within 15 % of it; without the window (Newey–West's 12 lags and the
    /// lag-0 stationary term, both blind to lag 20) it stays under 0.8 of it. A bug it
    /// catches: the stationary estimate left out of `hac` or run over the GLS block alone.
    #[test]
    fn a_correlation_beyond_the_newey_west_lags_is_in_a_least_squares_variance() {
        let (mean, short, want) = beyond_the_lags(Effect::AccelBias, 13, true);
        assert!((mean / want - 1.0).abs() < 0.15, "{mean} for {want}: {}", mean / want);
        assert!(short / want < 0.8, "without the window: {short} for {want}: {}", short / want);
    }

    /// The thrust error's covariance in closed form. A relative error ε of the nominal thrust adds
    /// ε times the thrust-scale column c to the force z residual. With the thrust scale in the
    /// model that is exactly its own column, so its parameter moves by ε and the others not at all:
    /// covariance σ_T² on the thrust scale, 0 elsewhere. Without it, a constant vertical force (the
    /// accelerometer bias z, a column of ones) takes the least-squares projection of c on a
    /// constant, the training mean c̄: σ_T²·c̄². The weight w_r cancels (here 1/0.5²). A bug it
    /// catches: `col·c` as `col / c` and σ_T·σ_T as σ_T + σ_T.
    #[test]
    fn a_thrust_error_moves_the_thrust_scale_by_itself_or_a_bias_by_the_mean_thrust() {
        let n = 6;
        let (f, z) = (Channel::Force.index(), 2);
        let (ts, bz) = (cols_of(Effect::ThrustScale).start, cols_of(Effect::AccelBias).start + 2);
        let mut d = Design { n, ..Design::default() };
        d.measured[f][z] = vec![0.1, -0.2, 0.05, 0.0, 0.3, -0.1];
        d.predicted[f][z] = vec![0.0; n];
        d.columns[f][z] = vec![(ts, vec![-9.0, -10.0, -11.0, -9.5, -10.5, -12.0]), (bz, vec![1.0; n])];
        // row 2 is held out: c̄ over the training rows is (−9 − 10 − 9.5 − 10.5 − 12)/5 = −10.2
        let train = [true, true, false, true, true, true];
        let test: Vec<bool> = train.iter().map(|t| !t).collect();
        let ars = [Ar::white(0.5)];
        let gs = grams(&d, &train, &test, &ars);
        let sd = 0.05;
        let close = |got: f64, want: f64| assert!((got - want).abs() < 1e-12, "{got} for {want}");
        let both = thrust_systematic(&d, &train, &gs, &ars, &[ts, bz], sd);
        close(both[(0, 0)], sd * sd);
        for (p, q) in [(0, 1), (1, 0), (1, 1)] {
            close(both[(p, q)], 0.0);
        }
        let bias = thrust_systematic(&d, &train, &gs, &ars, &[bz], sd);
        close(bias[(0, 0)], sd * sd * 10.2 * 10.2);
        // no thrust error, or no thrust-scale column in the log: nothing added
        assert_eq!(thrust_systematic(&d, &train, &gs, &ars, &[ts, bz], 0.0), DMatrix::zeros(2, 2));
        d.columns[f][z].remove(0);
        assert_eq!(thrust_systematic(&d, &train, &gs, &ars, &[bz], sd), DMatrix::zeros(1, 1));
    }
}

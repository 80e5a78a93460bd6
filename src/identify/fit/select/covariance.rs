//! The covariance of the estimates: Newey–West (Bartlett) over the weighted scores summed per
//! time sample, plus the systematic of the nominal thrust.

use super::gram::{Gram, active, cols_of, residual_of, split, sub, system, system_raw};
use crate::effects::{Channel, Effect};
use crate::identify::fit::design::Design;
use crate::identify::fit::stats::{Ar, inverse_spd};
use nalgebra::{DMatrix, DVector};
use std::borrow::Cow;

/// Newey–West (Bartlett, `lags`) covariance of the parameters of [`fit`](super::gram::fit).
///
/// With least squares alone: (XᵀWX)⁻¹·S·(XᵀWX)⁻¹ with S = Σ_l w_l Σ_t (u_t u_{t−l}ᵀ +
/// u_{t−l} u_tᵀ) (l = 0 counted once), w_l = 1 − l/(lags+1), and u_t = Σ_{channel axes}
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
/// that linear map.
pub(super) fn hac(
    d: &Design,
    train: &[bool],
    gs: &[Gram],
    ars: &[Ar],
    set: &[usize],
    theta: &[f64],
    lags: usize,
) -> DMatrix<f64> {
    let (dp, op) = split(set);
    if dp.is_empty() {
        let u = scores(d, train, gs, None, set, theta);
        let ginv = inverse_spd(&system_raw(gs, set).0);
        return &ginv * newey_west(&u, lags) * &ginv;
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
    let a = error_map(gs, set, &dp, &op);
    &a * newey_west(&stacked, lags) * a.transpose()
}

/// The map A (k × 2k) from the summed scores (Σũ prewhitened, Σu raw) to the parameters' error
/// when the columns at positions `dp` of `set` are GLS and those at `op` least squares given
/// them: rows D = [G̃⁻¹]_D on Σũ; rows O = −G_OO⁻¹·G_OD·[G̃⁻¹]_D on Σũ and G_OO⁻¹ on Σu_O.
fn error_map(gs: &[Gram], set: &[usize], dp: &[usize], op: &[usize]) -> DMatrix<f64> {
    let k = set.len();
    let gw_inv = inverse_spd(&system(gs, set).0);
    let gr = system_raw(gs, set).0;
    let goo_inv = inverse_spd(&sub(&gr, op, op));
    let from_gls = sub(&gw_inv, dp, &(0..k).collect::<Vec<_>>());
    let mut a = DMatrix::<f64>::zeros(k, 2 * k);
    for (i, &p) in dp.iter().enumerate() {
        a.view_mut((p, 0), (1, k)).copy_from(&from_gls.row(i));
    }
    let carried = -&goo_inv * sub(&gr, op, dp) * &from_gls;
    for (i, &p) in op.iter().enumerate() {
        a.view_mut((p, 0), (1, k)).copy_from(&carried.row(i));
        for (j, &q) in op.iter().enumerate() {
            a[(p, k + q)] = goo_inv[(i, j)];
        }
    }
    a
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

/// The Newey–West sum S = Σ_l w_l Σ_t (u_t u_{t−l}ᵀ + u_{t−l} u_tᵀ) (l = 0 once), Bartlett
/// weights, over the samples that have a score.
fn newey_west(u: &[Option<DVector<f64>>], lags: usize) -> DMatrix<f64> {
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
        error_map(gs, set, &dp, &op) * both
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
            let cov = hac(&d, &train, &gs, std::slice::from_ref(&ar), &set, &f.theta, 12);
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
            let v = hac(&d, &train, &gs, &ars, &[one], &theta, lags);
            assert_eq!(v.shape(), (1, 1));
            assert!((v[(0, 0)] - s / 100.0).abs() < 1e-14, "{lags} lags: {} for {}", v[(0, 0)], s / 100.0);
        }
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

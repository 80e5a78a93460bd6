//! The covariance of the estimates: Newey–West (Bartlett) over the weighted scores summed per
//! time sample, plus the systematic of the nominal thrust.

use super::gram::{Gram, active, cols_of, residual_of, system_raw};
use crate::effects::{Channel, Effect};
use crate::identify::fit::design::Design;
use crate::identify::fit::stats::inverse_spd;
use nalgebra::{DMatrix, DVector};

/// Newey–West (Bartlett, `lags`) covariance of the OLS parameters: (XᵀX)⁻¹·S·(XᵀX)⁻¹ with
/// S = Σ_l w_l Σ_t (u_t u_{t−l}ᵀ + u_{t−l} u_tᵀ) (l = 0 counted once), w_l = 1 − l/(lags+1), and
/// u_t = Σ_{channel axes} x_t·e_t the score of time sample t summed over every channel axis.
/// Summing per time sample (not per channel axis) lets the channels' noises be correlated:
/// `accel_kin` and `force` share the accelerometer's noise, and their rows are not independent
/// information about, say, an accelerometer bias.
pub(super) fn hac(d: &Design, train: &[bool], gs: &[Gram], set: &[usize], theta: &[f64], lags: usize) -> DMatrix<f64> {
    let k = set.len();
    let mut u: Vec<Option<DVector<f64>>> = (0..d.n).map(|t| train[t].then(|| DVector::zeros(k))).collect();
    for ((c, a), gr) in active(d).into_iter().zip(gs) {
        let e = residual_of(d, c, a, theta);
        let cols: Vec<Option<&Vec<f64>>> =
            set.iter().map(|j| d.columns[c][a].iter().find(|x| x.0 == *j).map(|x| &x.1)).collect();
        if cols.iter().all(Option::is_none) {
            continue;
        }
        for (t, ut) in u.iter_mut().enumerate() {
            if let Some(ut) = ut {
                for (p, col) in cols.iter().enumerate() {
                    if let Some(v) = col {
                        ut[p] += gr.w_r * v[t] * e[t];
                    }
                }
            }
        }
    }
    let mut sm = DMatrix::<f64>::zeros(k, k);
    for l in 0..=lags {
        let w = bartlett(l, lags);
        for t in l..d.n {
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
    let ginv = inverse_spd(&system_raw(gs, set).0);
    &ginv * sm * &ginv
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
pub(super) fn thrust_systematic(d: &Design, train: &[bool], gs: &[Gram], set: &[usize], rel_sd: f64) -> DMatrix<f64> {
    let k = set.len();
    let (c, a) = (Channel::Force.index(), 2);
    let ts = cols_of(Effect::ThrustScale).start;
    let thrust_col = d.columns[c][a].iter().find(|x| x.0 == ts).map(|x| &x.1);
    let (Some(tc), true) = (thrust_col, rel_sd > 0.0) else { return DMatrix::zeros(k, k) };
    let Some(w) = active(d).iter().position(|x| *x == (c, a)).map(|q| gs[q].w_r) else { return DMatrix::zeros(k, k) };
    let mut xc = DVector::<f64>::zeros(k);
    for (p, j) in set.iter().enumerate() {
        if let Some((_, col)) = d.columns[c][a].iter().find(|x| x.0 == *j) {
            xc[p] = w * (0..d.n).filter(|&i| train[i]).map(|i| col[i] * tc[i]).sum::<f64>();
        }
    }
    let shift = inverse_spd(&system_raw(gs, set).0) * xc;
    &shift * shift.transpose() * (rel_sd * rel_sd)
}

#[cfg(test)]
mod tests {
    use super::super::{Ar, N_COLUMNS, grams};
    use super::*;

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
        let gs = grams(&d, &train, &test, &[Ar::white(2.0), Ar::white(1.0)]);
        let theta = vec![0.0; N_COLUMNS];
        for (lags, s) in [(0, 14.09375), (1, 14.1875), (2, 13.21875)] {
            let v = hac(&d, &train, &gs, &[one], &theta, lags);
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
        let gs = grams(&d, &train, &test, &[Ar::white(0.5)]);
        let sd = 0.05;
        let close = |got: f64, want: f64| assert!((got - want).abs() < 1e-12, "{got} for {want}");
        let both = thrust_systematic(&d, &train, &gs, &[ts, bz], sd);
        close(both[(0, 0)], sd * sd);
        for (p, q) in [(0, 1), (1, 0), (1, 1)] {
            close(both[(p, q)], 0.0);
        }
        let bias = thrust_systematic(&d, &train, &gs, &[bz], sd);
        close(bias[(0, 0)], sd * sd * 10.2 * 10.2);
        // no thrust error, or no thrust-scale column in the log: nothing added
        assert_eq!(thrust_systematic(&d, &train, &gs, &[ts, bz], 0.0), DMatrix::zeros(2, 2));
        d.columns[f][z].remove(0);
        assert_eq!(thrust_systematic(&d, &train, &gs, &[bz], sd), DMatrix::zeros(1, 1));
    }
}

//! Least squares on Gram matrices: the training/held-out split, one Gram per channel axis
//! (prewhitened training part, raw training part, raw held-out part), fits of column sets,
//! held-out errors and canonical correlations between column sets.

use super::Options;
use crate::effects::{Channel, Effect};
use crate::identify::fit::design::{Design, N_COLUMNS, column_offsets};
use crate::identify::fit::stats::{Ar, inverse_spd, solve_spd};
use crate::identify::input::series::Series;
use nalgebra::{DMatrix, DVector};

/// Normal equations of one channel axis: whitened training part and raw held-out part.
#[derive(Clone)]
pub(super) struct Gram {
    pub(super) cols: Vec<usize>,
    pub(super) g_w: DMatrix<f64>,
    pub(super) b_w: DVector<f64>,
    pub(super) yy_w: f64,
    pub(super) n_w: usize,
    pub(super) g_t: DMatrix<f64>,
    pub(super) b_t: DVector<f64>,
    pub(super) yy_t: f64,
    pub(super) n_t: usize,
    /// raw training part, each channel axis weighted by `w_r` (weighted least squares)
    pub(super) g_r: DMatrix<f64>,
    pub(super) b_r: DVector<f64>,
    /// 1/(mean square of the residual the noise model was fitted to): puts m/s² and rad/s on
    /// one scale, and weights each channel axis by how well it measures
    pub(super) w_r: f64,
}

impl Gram {
    /// The empty sums of the columns `cols` (nothing accumulated yet), with the weight `w_r`.
    pub(super) fn zeros(cols: Vec<usize>, w_r: f64) -> Gram {
        let m = cols.len();
        let (z, v) = (DMatrix::zeros(m, m), DVector::zeros(m));
        Gram {
            cols,
            g_w: z.clone(),
            b_w: v.clone(),
            yy_w: 0.0,
            n_w: 0,
            g_t: z.clone(),
            b_t: v.clone(),
            yy_t: 0.0,
            n_t: 0,
            g_r: z,
            b_r: v,
            w_r,
        }
    }
}

#[cfg(test)]
impl Gram {
    /// The normal equations of `rows` (one sample each: the values of `cols` in that order),
    /// whitened and raw alike (tests build Grams by hand with it).
    pub(super) fn of_samples(cols: &[usize], rows: &[&[f64]]) -> Gram {
        let mut g = Gram::zeros(cols.to_vec(), 1.0);
        g.n_w = rows.len();
        for r in rows {
            let x = DVector::from_row_slice(r);
            g.g_w += &x * x.transpose();
        }
        g.g_r = g.g_w.clone();
        g
    }
}

pub(super) fn masks(s: &Series, d: &Design, o: &Options) -> (Vec<bool>, Vec<bool>) {
    let t0 = s.t_s.first().copied().unwrap_or(0.0);
    let tt = &d.t;
    let mut train = vec![false; d.n];
    let mut test = vec![false; d.n];
    for i in 0..d.n {
        if !d.ok[i] {
            continue;
        }
        let block = ((tt[i] - t0) / o.block_s).floor() as usize;
        if block % o.holdout_every == o.holdout_every - 1 {
            test[i] = true;
        } else {
            train[i] = true;
        }
    }
    (train, test)
}

/// Channel axes that have data.
pub(super) fn active(d: &Design) -> Vec<(usize, usize)> {
    let mut v = Vec::new();
    for c in Channel::ALL {
        for a in 0..3 {
            if !d.measured[c.index()][a].is_empty() {
                v.push((c.index(), a));
            }
        }
    }
    v
}

pub(super) fn residual_of(d: &Design, c: usize, a: usize, theta: &[f64]) -> Vec<f64> {
    let mut r = d.residual(c, a);
    for (j, col) in &d.columns[c][a] {
        if theta[*j] != 0.0 {
            for (ri, x) in r.iter_mut().zip(col) {
                *ri -= theta[*j] * x;
            }
        }
    }
    r
}

pub(super) fn grams(d: &Design, train: &[bool], test: &[bool], ars: &[Ar]) -> Vec<Gram> {
    let mut out = Vec::new();
    let mut wy = Vec::new();
    let mut wc: Vec<Vec<f64>> = Vec::new();
    for (k, (c, a)) in active(d).into_iter().enumerate() {
        let y = d.residual(c, a);
        let cols: Vec<usize> = d.columns[c][a].iter().map(|x| x.0).collect();
        let m = cols.len();
        ars[k].whiten(&y, train, &mut wy);
        wc.resize(m, Vec::new());
        for (q, (_, col)) in d.columns[c][a].iter().enumerate() {
            ars[k].whiten(col, train, &mut wc[q]);
        }
        let mut g = Gram::zeros(cols.clone(), 1.0 / ars[k].marginal_var.max(f64::MIN_POSITIVE));
        // accumulated in flat lower triangles (row p, column q ≤ p at p(p+1)/2 + q), each sum in
        // sample order as before
        let tri = m * (m + 1) / 2;
        let (mut gw, mut gt, mut gr) = (vec![0.0; tri], vec![0.0; tri], vec![0.0; tri]);
        let colv: Vec<&[f64]> = d.columns[c][a].iter().map(|x| x.1.as_slice()).collect();
        let mut x = vec![0.0; m];
        let accumulate = |g: &mut [f64], b: &mut DVector<f64>, x: &[f64], y: f64| {
            let mut at = 0;
            for p in 0..m {
                b[p] += x[p] * y;
                for q in 0..=p {
                    g[at] += x[p] * x[q];
                    at += 1;
                }
            }
        };
        for i in 0..d.n {
            if wy[i].is_finite() {
                let mut finite = true;
                for q in 0..m {
                    x[q] = wc[q][i];
                    finite &= x[q].is_finite();
                }
                if finite {
                    g.yy_w += wy[i] * wy[i];
                    g.n_w += 1;
                    accumulate(&mut gw, &mut g.b_w, &x, wy[i]);
                }
            }
            if train[i] || test[i] {
                for q in 0..m {
                    x[q] = colv[q][i];
                }
                if train[i] {
                    accumulate(&mut gr, &mut g.b_r, &x, y[i]);
                }
                if test[i] {
                    g.yy_t += y[i] * y[i];
                    g.n_t += 1;
                    accumulate(&mut gt, &mut g.b_t, &x, y[i]);
                }
            }
        }
        let mut at = 0;
        for p in 0..m {
            for q in 0..=p {
                g.g_w[(p, q)] = gw[at];
                g.g_t[(p, q)] = gt[at];
                g.g_r[(p, q)] = gr[at];
                at += 1;
            }
        }
        g.g_r *= g.w_r;
        g.b_r *= g.w_r;
        for p in 0..m {
            for q in 0..p {
                g.g_w[(q, p)] = g.g_w[(p, q)];
                g.g_t[(q, p)] = g.g_t[(p, q)];
                g.g_r[(q, p)] = g.g_r[(p, q)];
            }
        }
        out.push(g);
    }
    out
}

/// The pairs (p, i) with `set[p]` = `cols[i]`: where a channel axis's sums over its columns
/// `cols` go in sums over `set` (the set's columns the axis lacks are left out).
pub(super) fn positions(set: &[usize], cols: &[usize]) -> Vec<(usize, usize)> {
    set.iter().enumerate().filter_map(|(p, j)| cols.iter().position(|c| c == j).map(|i| (p, i))).collect()
}

/// Adds a channel axis's matrix `from` (over its columns) into `to` (over a set) at the pairs
/// `at` from [`positions`]: `to[(p, q)] += from[(i, j)]` for every two pairs (p, i), (q, j).
pub(super) fn add_at(to: &mut DMatrix<f64>, from: &DMatrix<f64>, at: &[(usize, usize)]) {
    for &(p, i) in at {
        for &(q, j) in at {
            to[(p, q)] += from[(i, j)];
        }
    }
}

/// The normal equations (G, b) of a set of columns summed over channel axes, from the sums
/// `sums` reads off each axis's Gram: the raw (training) ones or the whitened ones.
fn normal_equations(
    gs: &[Gram],
    set: &[usize],
    sums: impl Fn(&Gram) -> (&DMatrix<f64>, &DVector<f64>),
) -> (DMatrix<f64>, DVector<f64>) {
    let k = set.len();
    let mut g = DMatrix::zeros(k, k);
    let mut b = DVector::zeros(k);
    for gr in gs {
        let (g_axis, b_axis) = sums(gr);
        let at = positions(set, &gr.cols);
        add_at(&mut g, g_axis, &at);
        for &(p, i) in &at {
            b[p] += b_axis[i];
        }
    }
    (g, b)
}

/// The raw (training) normal equations of a set of columns, summed over channel axes.
pub(super) fn system_raw(gs: &[Gram], set: &[usize]) -> (DMatrix<f64>, DVector<f64>) {
    normal_equations(gs, set, |gr| (&gr.g_r, &gr.b_r))
}

/// The whitened normal equations of a set of columns, summed over channel axes, with the
/// whitened Σy² and sample count.
pub(super) fn system(gs: &[Gram], set: &[usize]) -> (DMatrix<f64>, DVector<f64>, f64, usize) {
    let (g, b) = normal_equations(gs, set, |gr| (&gr.g_w, &gr.b_w));
    (g, b, gs.iter().fold(0.0, |yy, gr| yy + gr.yy_w), gs.iter().map(|gr| gr.n_w).sum())
}

/// Whether effect `e` is estimated on the prewhitened problem (GLS) instead of the raw one:
/// the delays. Their regressors, the IMU's ḟ and ω̇, carry the vehicle's response to the mocap
/// noise when a controller flies on the poses, and the raw residual holds that same noise
/// smoothed over ±3σ on both sides of its sample, so least squares correlates the two (−1.1 ms
/// at 0.5 mm on a gentle Crazyflie flight, none with the noise kept out of the loop). The
/// prewhitened residual is the part of the residual its past does not predict, which the
/// vehicle has not yet had the time to answer: the estimate no longer sees the feedback. The
/// mocap delay and its drift only: the gyro's delay against the accelerometer stays least
/// squares, as the gyro's own noise reaches the motion through the rate loop within a
/// millisecond, faster than any prewhitening of 20 ms rows separates (by GLS it moved NanoBench's
/// B2 circle fast from −3.5 to −7.1 ms and left half its gyro motion unexplained).
pub(crate) fn prewhitened(e: Effect) -> bool {
    matches!(e, Effect::MocapDelay | Effect::ClockDrift)
}

/// Whether column `j` of the full design belongs to a [`prewhitened`] effect.
pub(super) fn is_prewhitened(j: usize) -> bool {
    Effect::ALL.iter().any(|e| prewhitened(*e) && cols_of(*e).contains(&j))
}

/// The positions in `set` of the [`prewhitened`] columns and of the others.
pub(super) fn split(set: &[usize]) -> (Vec<usize>, Vec<usize>) {
    (0..set.len()).partition(|&p| is_prewhitened(set[p]))
}

/// Rows `r` and columns `c` of `m`.
pub(super) fn sub(m: &DMatrix<f64>, r: &[usize], c: &[usize]) -> DMatrix<f64> {
    DMatrix::from_fn(r.len(), c.len(), |i, j| m[(r[i], c[j])])
}

/// A fit of a set of columns: the parameters (they minimise the error the report measures,
/// but for the delays: see [`prewhitened`]) and the tests on the prewhitened problem (GLS).
/// The covariance of the parameters is not here: [`super::refine`] computes the Newey–West
/// one for the final fit of each model, the only one an interval is read from.
pub(super) struct Fit {
    pub(super) set: Vec<usize>,
    /// The parameters, full length N_COLUMNS: the [`prewhitened`] ones from GLS, the others by
    /// weighted least squares on the raw training part with those held at their GLS values
    /// (plain weighted least squares when the set has no prewhitened column).
    pub(super) theta: Vec<f64>,
    /// GLS (prewhitened) parameters, full length.
    pub(super) theta_w: Vec<f64>,
    /// Prewhitened residual sum of squares and sample count (for ΔBIC and the F-test).
    pub(super) rss: f64,
    pub(super) n: usize,
}

pub(super) fn full(set: &[usize], x: &DVector<f64>) -> Vec<f64> {
    let mut theta = vec![0.0; N_COLUMNS];
    for (p, j) in set.iter().enumerate() {
        theta[*j] = x[p];
    }
    theta
}

pub(super) fn fit(gs: &[Gram], set: &[usize]) -> Fit {
    let (g, b, yy, n) = system(gs, set);
    let x = solve_spd(&g, &b).unwrap_or_else(|| DVector::zeros(set.len()));
    let rss = (yy - x.dot(&b)).max(1e-300);
    let (gr, br) = system_raw(gs, set);
    let (d, o) = split(set);
    let xo = if d.is_empty() {
        solve_spd(&gr, &br).unwrap_or_else(|| DVector::zeros(set.len()))
    } else {
        // the others by least squares on what the GLS delays leave: G_oo·θ_o = b_o − G_od·θ_d
        let theta_d = DVector::from_iterator(d.len(), d.iter().map(|&p| x[p]));
        let rhs = DVector::from_iterator(o.len(), o.iter().map(|&p| br[p])) - sub(&gr, &o, &d) * &theta_d;
        let theta_o = solve_spd(&sub(&gr, &o, &o), &rhs).unwrap_or_else(|| DVector::zeros(o.len()));
        let mut all = DVector::zeros(set.len());
        for (i, &p) in d.iter().enumerate() {
            all[p] = theta_d[i];
        }
        for (i, &p) in o.iter().enumerate() {
            all[p] = theta_o[i];
        }
        all
    };
    Fit { set: set.to_vec(), theta: full(set, &xo), theta_w: full(set, &x), rss, n }
}

/// Held-out residual energy per channel axis for parameters θ.
pub(super) fn heldout_rss(gs: &[Gram], theta: &[f64]) -> Vec<f64> {
    gs.iter()
        .map(|g| {
            let th = DVector::from_iterator(g.cols.len(), g.cols.iter().map(|j| theta[*j]));
            (g.yy_t - 2.0 * th.dot(&g.b_t) + (th.transpose() * &g.g_t * &th)[(0, 0)]).max(0.0)
        })
        .collect()
}

pub(super) fn cols_of(e: Effect) -> std::ops::Range<usize> {
    let o = column_offsets();
    o[e as usize]..o[e as usize + 1]
}

pub(super) fn set_of(effects: &[Effect]) -> Vec<usize> {
    effects.iter().flat_map(|e| cols_of(*e)).collect()
}

/// Largest canonical correlation between the column blocks A and B with S projected out.
pub(super) fn canonical_corr(gs: &[Gram], s: &[usize], a: &[usize], b: &[usize]) -> f64 {
    let all: Vec<usize> = s.iter().chain(a).chain(b).copied().collect();
    let (g, _, _, _) = system(gs, &all);
    let (ns, na, nb) = (s.len(), a.len(), b.len());
    let block = |r0: usize, nr: usize, c0: usize, nc: usize| g.view((r0, c0), (nr, nc)).into_owned();
    let cond = |r0: usize, nr: usize, c0: usize, nc: usize| {
        let m = block(r0, nr, c0, nc);
        if ns == 0 {
            return m;
        }
        let gss_inv = inverse_spd(&block(0, ns, 0, ns));
        m - block(r0, nr, 0, ns) * gss_inv * block(0, ns, c0, nc)
    };
    let gaa = cond(ns, na, ns, na);
    let gbb = cond(ns + na, nb, ns + na, nb);
    let gab = cond(ns, na, ns + na, nb);
    let (Some(ca), Some(cb)) = (gaa.clone().cholesky(), gbb.clone().cholesky()) else { return 1.0 };
    // ρ² = eig(La⁻¹ Gab Gbb⁻¹ Gba La⁻ᵀ)
    let la_inv = ca.l().try_inverse().unwrap_or_else(|| DMatrix::zeros(na, na));
    let m = &la_inv * &gab * cb.inverse() * gab.transpose() * la_inv.transpose();
    let sym = (&m + m.transpose()) * 0.5;
    if !sym.iter().all(|x| x.is_finite()) {
        return 1.0;
    }
    let Some(eig) = nalgebra::SymmetricEigen::try_new(sym, f64::EPSILON, 500) else { return 1.0 };
    eig.eigenvalues.iter().copied().fold(0.0, f64::max).clamp(0.0, 1.0).sqrt()
}

/// The AR models of the current residual, one per active channel axis (order ≤ `max_ar_order`).
/// With [`Options::mount_invariant`], the three axes of the accelerometer against the mocap
/// (`accel_kin`) share one model, and so do the gyro's ([`Ar::fit_shared`]): each axis is then
/// whitened by the same filter and weighed by the same variance, and a fit that turns the IMU's
/// readings by a rotation R turns its calibration by R and changes nothing else. A model per
/// axis weighs an axis by its own misfit, and a rotation that mixes the axes mixes those
/// weights (docs/calibration.md, "A real rig: BROAD"). The force channel keeps one per axis:
/// the thrust acts on its z alone.
pub(super) fn ar_models(d: &Design, train: &[bool], theta: &[f64], o: &Options) -> Vec<Ar> {
    let act = active(d);
    let shared = |c: usize| o.mount_invariant && c != Channel::Force.index() && (0..3).all(|a| act.contains(&(c, a)));
    let mut by_channel: [Option<Ar>; 3] = [None, None, None];
    act.iter()
        .map(|&(c, a)| {
            if !shared(c) {
                return Ar::fit(&residual_of(d, c, a, theta), train, o.max_ar_order);
            }
            by_channel[c]
                .get_or_insert_with(|| {
                    let axes: Vec<Vec<f64>> = (0..3).map(|b| residual_of(d, c, b, theta)).collect();
                    let refs: Vec<&[f64]> = axes.iter().map(Vec::as_slice).collect();
                    Ar::fit_shared(&refs, train, o.max_ar_order)
                })
                .clone()
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Canonical correlations by geometry, with four samples (e1..e4 the unit samples). Columns
    /// 0 = e1, 1 = e1 + e2, 2 = e3, 3 = 2e1 + e2 + 3e4, 4 = e2, 5 = e1 + e3.
    /// - B = {5} against A = {0, 4}: b's projection on span(e1, e2) is e1, ρ = 1/√2;
    /// - B = {3} against A = {1, 2}: the projection is (3/2)(e1 + e2), ρ = (3/√2)/√14 = 3/√28;
    /// - the same with S = {0} projected out: b becomes e2 + 3e4 and A spans e2 and e3, so
    ///   ρ = 1/√10.
    ///
    /// The samples are split over two channel axes (one Gram each, the columns in another order,
    /// the second without the columns that vanish on its samples): the system sums them. A bug it
    /// catches: B's conditioned block read at `ns − na` (S's own block: ρ = 1).
    #[test]
    fn canonical_correlations_by_geometry_with_a_block_projected_out() {
        // samples 1 and 2, columns 3, 0, 1, 2, 4, 5
        let first =
            Gram::of_samples(&[3, 0, 1, 2, 4, 5], &[&[2.0, 1.0, 1.0, 0.0, 0.0, 1.0], &[1.0, 0.0, 1.0, 0.0, 1.0, 0.0]]);
        // samples 3 and 4: columns 0, 1 and 4 are zero there and absent
        let second = Gram::of_samples(&[5, 2, 3], &[&[1.0, 1.0, 0.0], &[0.0, 0.0, 3.0]]);
        let gs = [first, second];
        let close = |got: f64, want: f64| assert!((got - want).abs() < 1e-12, "ρ = {got}, not {want}");
        close(canonical_corr(&gs, &[], &[0, 4], &[5]), 0.5f64.sqrt());
        close(canonical_corr(&gs, &[], &[1, 2], &[3]), 3.0 / 28f64.sqrt());
        close(canonical_corr(&gs, &[0], &[1, 2], &[3]), 0.1f64.sqrt());
        // symmetric in A and B (here B has two columns)
        close(canonical_corr(&gs, &[0], &[3], &[1, 2]), 0.1f64.sqrt());
        // S of two columns, {0, 2}: a = e1 + e2 becomes e2, b = 2e1 + e2 + 3e4 becomes e2 + 3e4
        close(canonical_corr(&gs, &[0, 2], &[1], &[3]), 0.1f64.sqrt());
    }

    /// Two channel axes measure one constant (column 0, all ones, 4 training samples each):
    /// residual 1 with noise σ₁ = 1 and residual 3 with σ₂ = 2. Weighted least squares over both is
    /// the inverse-variance mean, θ = (1·4·1 + ¼·4·3)/(1·4 + ¼·4) = 7/5, both in the raw weighted
    /// sums (w_r = 1/σ²: G_r = 4, 1; b_r = 4, 3) and in the whitened ones (x/σ). The whitened
    /// residual's sum of squares is 4·1² + 4·(3/2)² = 13. A bug it catches: w_r = σ² (θ = 2.6), and y·y accumulated with `-=` or `*=`.
    #[test]
    fn two_channel_axes_are_weighted_by_their_inverse_noise_variance() {
        let mut d = Design { n: 4, ..Design::default() };
        for (a, y) in [(0, 1.0), (1, 3.0)] {
            d.measured[0][a] = vec![y; 4];
            d.predicted[0][a] = vec![0.0; 4];
            d.columns[0][a] = vec![(0, vec![1.0; 4])];
        }
        let gs = grams(&d, &[true; 4], &[false; 4], &[Ar::white(1.0), Ar::white(2.0)]);
        assert_eq!(gs.len(), 2);
        assert_eq!([gs[0].w_r, gs[1].w_r], [1.0, 0.25]);
        assert_eq!([gs[0].g_r[(0, 0)], gs[0].b_r[0], gs[1].g_r[(0, 0)], gs[1].b_r[0]], [4.0, 4.0, 1.0, 3.0]);
        let (g, b) = system_raw(&gs, &[0]);
        assert!((b[0] / g[(0, 0)] - 1.4).abs() < 1e-15, "raw: {}", b[0] / g[(0, 0)]);
        let (g, b, yy, n) = system(&gs, &[0]);
        assert!((b[0] / g[(0, 0)] - 1.4).abs() < 1e-15 && n == 8, "whitened: {} from {n}", b[0] / g[(0, 0)]);
        assert!((yy - 13.0).abs() < 1e-12, "whitened y·y {yy}, not 13");
    }

    /// The delay by GLS and the rest by least squares given it, by hand. One channel axis of five
    /// training samples, AR(1) noise model φ = ½, σ = 1; the delay column x_D = (0, 2, 0, 2, 0),
    /// an accelerometer bias column of ones, residual y = (1, 3, 2, 5, 3). Prewhitened (rows 1–4,
    /// x − ½·x₋₁): x̃_D = (2, −1, 2, −1), x̃_B = ½ each, ỹ = (2.5, 0.5, 4, 0.5), so
    /// G̃ = [[10, 1], [1, 1]], b̃ = (12, 3.75) and θ_D = (12 − 3.75)/9 = 11/12. The bias is then the
    /// mean of y − θ_D·x_D, (14 − 2·2·11/12)/5 = 31/15 (GLS alone would give 17/6, least squares
    /// alone θ_D = 1 and a bias of 2). A bug it catches: the positions of the split swapped, the
    /// delay's least-squares value kept, and the bias's right-hand side without the delay's share.
    #[test]
    fn the_delay_is_gls_and_the_rest_least_squares_given_it() {
        let c = Channel::AccelKin.index();
        let (delay, bias) = (cols_of(Effect::MocapDelay).start, cols_of(Effect::AccelBias).start);
        let mut d = Design { n: 5, ..Design::default() };
        d.measured[c][0] = vec![1.0, 3.0, 2.0, 5.0, 3.0];
        d.predicted[c][0] = vec![0.0; 5];
        d.columns[c][0] = vec![(delay, vec![0.0, 2.0, 0.0, 2.0, 0.0]), (bias, vec![1.0; 5])];
        let ar = Ar { a: vec![0.5], sigma: 1.0, marginal_var: 1.0 };
        let gs = grams(&d, &[true; 5], &[false; 5], &[ar]);
        let f = fit(&gs, &[bias, delay]);
        let close = |got: f64, want: f64, what: &str| assert!((got - want).abs() < 1e-12, "{what}: {got}, not {want}");
        close(f.theta[delay], 11.0 / 12.0, "delay");
        close(f.theta[bias], 31.0 / 15.0, "bias given the delay");
        close(f.theta_w[bias], 17.0 / 6.0, "bias by GLS");
        // without a delay in the set, plain weighted least squares: the mean of y
        close(fit(&gs, &[bias]).theta[bias], 14.0 / 5.0, "bias alone");
        assert!(prewhitened(Effect::MocapDelay) && prewhitened(Effect::ClockDrift) && !prewhitened(Effect::GyroDelay));
    }

    /// The three sums by hand on one channel axis of five samples: residual y = 1, 2, 3, 4, 100 and
    /// column x = 1, 1, 2, −1, 7; samples 1–2 train, 3–4 are held out, 5 is neither. Training
    /// (white noise σ = 1, so whitened = raw): n = 2, y·y = 1 + 4 = 5, x·x = 2, x·y = 3. Held out:
    /// n = 2, y·y = 9 + 16 = 25, x·x = 4 + 1 = 5, x·y = 6 − 4 = 2. The held-out residual energy Σ
    /// (y − θx)² is 25 at θ = 0, (3 − 2)² + (4 + 1)² = 26 at θ = 1 and (3 − 0.8)² + (4 + 0.4)² =
    /// 24.2 at θ = 0.4. A bug it catches: the held-out y·y accumulated with `-=`.
    #[test]
    fn training_and_heldout_sums_by_hand() {
        let mut d = Design { n: 5, ..Design::default() };
        d.measured[0][0] = vec![1.0, 2.0, 3.0, 4.0, 100.0];
        d.predicted[0][0] = vec![0.0; 5];
        d.columns[0][0] = vec![(0, vec![1.0, 1.0, 2.0, -1.0, 7.0])];
        let (t, f) = (true, false);
        let gs = grams(&d, &[t, t, f, f, f], &[f, f, t, t, f], &[Ar::white(1.0)]);
        assert_eq!(gs.len(), 1);
        let g = &gs[0];
        assert_eq!((g.n_w, g.yy_w, g.g_w[(0, 0)], g.b_w[0]), (2, 5.0, 2.0, 3.0), "whitened training sums");
        assert_eq!((g.g_r[(0, 0)], g.b_r[0]), (2.0, 3.0), "raw training sums");
        assert_eq!((g.n_t, g.yy_t, g.g_t[(0, 0)], g.b_t[0]), (2, 25.0, 5.0, 2.0), "held-out sums");
        let energy = |th: f64| {
            let mut theta = vec![0.0; N_COLUMNS];
            theta[0] = th;
            heldout_rss(&gs, &theta)[0]
        };
        for (th, want) in [(0.0, 25.0), (1.0, 26.0), (0.4, 24.2)] {
            assert!((energy(th) - want).abs() < 1e-12, "held-out energy at θ = {th}: {}, not {want}", energy(th));
        }
    }

    /// The residual after θ by hand: measured − predicted − Σ θ_j·x_j on the channel axis's own
    /// columns, a zero θ_j skipped. A bug it catches: `θ_j != 0` as `== 0` (only the zero ones
    /// subtracted).
    #[test]
    fn the_residual_after_theta_by_hand() {
        let mut d = Design { n: 3, ..Design::default() };
        d.measured[1][2] = vec![1.0, 2.0, 3.0];
        d.predicted[1][2] = vec![0.5, 0.5, 0.5];
        d.columns[1][2] = vec![(4, vec![1.0, 0.0, 1.0]), (7, vec![0.0, 1.0, 1.0]), (9, vec![5.0, 5.0, 5.0])];
        let mut theta = vec![0.0; N_COLUMNS];
        theta[4] = 2.0;
        theta[7] = -1.0;
        // a column of another channel axis does not touch this one
        theta[2] = 10.0;
        assert_eq!(residual_of(&d, 1, 2, &theta), [0.5 - 2.0, 1.5 + 1.0, 2.5 - 2.0 + 1.0]);
    }
}

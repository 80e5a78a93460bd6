//! Grouped forward selection of effects, with prewhitened tests and held-out errors.
//!
//! Per step, with the selected set S fitted (and its rotations and delay folded into the exact
//! [`Corrections`], re-linearised `refine_iterations` times):
//! 1. an AR(p) noise model per channel axis (order by BIC, p ≤ `max_ar_order`) is fitted to the
//!    training residual of the *largest* model (S and every candidate): an AR fitted to a residual
//!    that still holds an effect would model the effect as noise and whiten it away;
//! 2. each candidate C ∉ S is fitted together with S on the training part. It *passes* when
//!    - the prewhitened F-test of C's block has p < α / (number of candidates) (Bonferroni),
//!    - ΔBIC = n·ln(RSS_{S+C}/RSS_S) + k_C·ln n < 0 (prewhitened RSS), and
//!    - the held-out error on the channel axes C has a regressor on falls by at least
//!      `min_heldout_gain` (each axis relative to its error under S; a thrust scale, which acts
//!      on force z alone, is not averaged with force x and y, which it cannot change);
//! 3. candidates that pass the F-test and ΔBIC but fail only the held-out gate are also tried in
//!    pairs (two effects that explain the residual only together each extrapolate badly alone),
//!    at a Bonferroni level over the singles and these pairs; a passing pair with a lower ΔBIC
//!    than every passing single joins as one step;
//! 4. of the passing candidates the one with the lowest ΔBIC joins S; a passing candidate whose
//!    regressors are nearly collinear with the winner's (canonical correlation > 0.99, S
//!    projected out) is reported as *not identifiable* from it by this data;
//! 5. after each step, a backward check: every linear effect of S (not the corrections, which
//!    are folded into the trajectory, nor a pair that joined together, nor a forced effect) is
//!    tested again on top of all the others with the same three gates (at the Bonferroni level
//!    of the step that would add it now). The worst that fails leaves the model for good and the
//!    forward steps go on from there. (Without it, a constant force that took a force-channel
//!    offset at step 1, before the accelerometer bias and the thrust scale that explain it
//!    joined, stayed in as an invented effect: 7 inventions in 300 flights of seed 3.)
//!
//! Estimates are weighted least squares on the raw training part, each channel axis weighted by
//! 1/(mean square of its residual under the current model): the weights make the estimate
//! independent of units (m/s² against rad/s) and let each channel count by how well it
//! measures. (Unweighted, the accelerometer's noisy ḟ column, three quarters noise on x and y
//! in simulation, outweighed the gyro's clean ω̇ one, and errors in that variable shrank the
//! mocap delay by 2 %; GLS on the prewhitened problem was tried first: with a near-unit-root
//! AR it fits the dynamics and misses the level, and on real flights the held-out errors rose.)
//! Their 95 % intervals are ±1.96·σ from the Newey–West covariance (Bartlett, `hac_lags`) of
//! the weighted scores summed over channel axes per time sample, which allows for the
//! residual's colour and for channels that share a sensor's noise, plus the systematic of the
//! nominal thrust ([`NominalModel::thrust_rel_sd`](super::series::NominalModel), one factor for
//! the whole flight, which no amount of data averages away).
//!
//! After the selection, each selected effect is compared with each effect outside the model
//! with every *other* selected effect projected out; a pair with canonical correlation > 0.99 is
//! reported not identifiable, the selected one's parameters are marked so, and the other
//! effects' intervals are widened to cover the swapped model's estimates.
//!
//! The held-out part is every `holdout_every`-th block of `block_s` seconds. The held-out gate
//! weights each channel axis by the *current* model's held-out error on it, so m/s² and rad/s
//! mix fairly and a cut on an axis that earlier steps already brought down counts as much as on
//! a fresh one. (Weighted by the nominal model's error instead, a thrust–voltage term that cut
//! the remaining force z error of a real flight by 75 % counted for 0.6 %: thrust scale had
//! already taken that axis from 3.3 to 0.26 m/s².)

use super::design::{Channel, Design, DesignOptions, Effect, N_COLUMNS, build, column_offsets};
use super::series::{Corrections, NominalModel, Series};
use super::stats::{Ar, LjungBox, Z_975, Z_995, autocorrelation, f_sf, inverse_spd, ljung_box, solve_spd};
use nalgebra::{DMatrix, DVector, UnitQuaternion, Vector3};

#[derive(Clone, Debug, serde::Serialize)]
pub struct Options {
    pub design: DesignOptions,
    /// The data-quality gate run before anything is fitted.
    pub quality: super::quality::QualityOptions,
    /// Family-wise level of the F-test (Bonferroni over the candidates of a step).
    pub alpha: f64,
    /// A candidate must cut the held-out error on the channel axes it acts on by this fraction.
    pub min_heldout_gain: f64,
    pub max_ar_order: usize,
    pub block_s: f64,
    pub holdout_every: usize,
    pub max_steps: usize,
    pub refine_iterations: usize,
    /// Bandwidth of the Newey–West covariance (decimated samples).
    pub hac_lags: usize,
    /// The candidates to consider (default: all that the data has columns for).
    pub candidates: Vec<Effect>,
    /// Effects fitted from the start, without passing the tests (the hypothesis under study,
    /// e.g. the body offset of a real flight); the others are selected on top of them.
    pub forced: Vec<Effect>,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            design: DesignOptions::default(),
            quality: super::quality::QualityOptions::default(),
            alpha: 0.01,
            min_heldout_gain: 0.10,
            max_ar_order: 12,
            block_s: 2.0,
            holdout_every: 3,
            max_steps: 8,
            refine_iterations: 3,
            hac_lags: 12,
            candidates: Effect::ALL.iter().copied().filter(|e| e.searched()).collect(),
            forced: Vec::new(),
        }
    }
}

/// One parameter, in the reported unit.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Param {
    pub name: String,
    pub value: f64,
    /// Half-width of the 95 % interval. Where the flight cannot tell an effect of the model from
    /// one outside it, the interval is widened to cover the estimate of the swapped model too.
    pub ci95: f64,
    pub unit: String,
    /// False when this effect cannot be told apart from one outside the model by this flight
    /// (see [`Report::not_identifiable`]): the value is one of several explanations, and no
    /// interval is claimed for it.
    pub identifiable: bool,
}

#[derive(Clone, Debug, serde::Serialize)]
pub struct Candidate {
    pub effect: Effect,
    pub delta_bic: f64,
    pub f: f64,
    pub p_value: f64,
    /// Relative drop of the held-out error on the candidate's channels.
    pub heldout_gain: f64,
    /// Largest |correlation| of a prewhitened regressor column with the prewhitened residual.
    pub max_corr: f64,
    pub passed: bool,
}

#[derive(Clone, Debug, serde::Serialize)]
pub struct Step {
    pub added: Effect,
    /// A second effect added in the same step: the two explain the residual only together
    /// (each alone is significant but fails the held-out gate); the step's figures are the pair's.
    pub together_with: Option<Effect>,
    pub delta_bic: f64,
    pub p_value: f64,
    pub heldout_gain: f64,
    pub candidates: Vec<Candidate>,
    /// Effects that the data cannot tell apart from the one added, with their canonical correlation.
    pub not_identifiable_from: Vec<(Effect, f64)>,
    /// The parameters right after this step.
    pub params: Vec<Param>,
}

/// An effect that left the model in the backward check after a step.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Removal {
    /// The number of steps taken when it left (it left after step `after_step`, 1-based).
    pub after_step: usize,
    /// Its gates on top of every other selected effect, at least one failed.
    pub check: Candidate,
}

#[derive(Clone, Debug, serde::Serialize)]
pub struct Found {
    pub effect: Effect,
    pub name: String,
    pub params: Vec<Param>,
}

#[derive(Clone, Debug, serde::Serialize)]
pub struct AxisError {
    pub channel: Channel,
    pub axis: char,
    pub unit: String,
    pub samples: usize,
    pub rmse_before: f64,
    pub rmse_after: f64,
    /// NRMSE fit, 100·(1 − ‖y − ŷ‖/‖y − ȳ‖) (%); None when the measured signal is constant
    /// (an ideal accelerometer's x axis without drag reads exactly zero).
    pub fit_before_pct: Option<f64>,
    pub fit_after_pct: Option<f64>,
}

#[derive(Clone, Debug, serde::Serialize)]
pub struct Whiteness {
    pub channel: Channel,
    pub axis: char,
    /// Fraction of the lags 1..=50 of the raw residual outside the 99 % bounds ±2.58/√n.
    pub raw_outside_99: f64,
    pub ar_order: usize,
    /// Ljung–Box on the residual prewhitened by its AR(p), 20 lags.
    pub ljung_box: LjungBox,
}

/// A measured signal that the residual left at the end follows.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Correlate {
    pub signal: String,
    /// Pearson correlation with the final residual over the usable samples.
    pub r: f64,
    /// Bartlett's effective sample size (both series are autocorrelated).
    pub n_eff: f64,
}

/// What is left on one channel axis once the effects are fitted: is the residual still
/// structured, and what does it follow? A lead for the next effect, not a verdict.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Left {
    pub channel: Channel,
    pub axis: char,
    /// Held-out RMSE after the effects.
    pub rmse: f64,
    pub unit: String,
    /// Ljung–Box p-value of the prewhitened final residual (from [`Whiteness`]).
    pub ljung_box_p: f64,
    /// The signals the residual follows: |r| ≥ [`LEAD_MIN_CORR`] and r ≠ 0 at the 1 % level
    /// Bonferroni-corrected over the signals (r·√n_eff against N(0, 1)), strongest first, at
    /// most [`LEAD_MAX`].
    pub correlates: Vec<Correlate>,
    /// The residual is not noise: it follows a measured signal, or fails Ljung–Box at 1 %.
    pub structured: bool,
}

/// Weaker correlations than this are not named as leads (significant but explaining < 1 % of
/// the residual's variance is no lead).
pub const LEAD_MIN_CORR: f64 = 0.1;
/// At most this many leads per channel axis.
pub const LEAD_MAX: usize = 3;

/// The measured signals of a design built with signals, masked to its usable samples, with
/// their autocorrelations (lags 1..=50), computed once for every channel axis.
struct LeadSignals<'a> {
    design: &'a Design,
    masked: Vec<Vec<f64>>,
    acf: Vec<Vec<f64>>,
}

fn lead_signals(d: &Design) -> LeadSignals<'_> {
    let masked: Vec<Vec<f64>> = d.signals.iter().map(|sg| (0..d.n).map(|i| if d.ok[i] { sg.samples[i] } else { f64::NAN }).collect()).collect();
    let acf = masked.iter().map(|x| super::stats::autocorrelation(x, 50).0).collect();
    LeadSignals { design: d, masked, acf }
}

/// The leads of one residual of channel `c`, axis `a`: the measured signals it follows (see
/// [`Left::correlates`]).
fn leads(ls: &LeadSignals, c: usize, a: usize, residual: &[f64]) -> Vec<Correlate> {
    let d = ls.design;
    let r: Vec<f64> = (0..d.n).map(|i| if d.ok[i] { residual[i] } else { f64::NAN }).collect();
    let idx: Vec<usize> = (0..d.n).filter(|&i| r[i].is_finite()).collect();
    if idx.len() < 3 {
        return Vec::new();
    }
    let (r_acf, _) = super::stats::autocorrelation(&r, 50);
    let mr = idx.iter().map(|&i| r[i]).sum::<f64>() / idx.len() as f64;
    let srr: f64 = idx.iter().map(|&i| (r[i] - mr).powi(2)).sum();
    let mut out: Vec<Correlate> = Vec::new();
    for (k, sg) in d.signals.iter().enumerate() {
        if sg.excludes.contains(&(c, a)) {
            continue;
        }
        let x = &ls.masked[k];
        let mx = idx.iter().map(|&i| x[i]).sum::<f64>() / idx.len() as f64;
        let (mut sxy, mut sxx) = (0.0, 0.0);
        for &i in &idx {
            sxy += (r[i] - mr) * (x[i] - mx);
            sxx += (x[i] - mx).powi(2);
        }
        if sxx <= 0.0 || srr <= 0.0 {
            continue;
        }
        let rho = sxy / (sxx * srr).sqrt();
        let n_eff = super::stats::effective_n(idx.len(), &r_acf, &ls.acf[k]);
        // two-sided test of r = 0 (r·√n_eff ~ N(0, 1)), Bonferroni over the signals
        let p = super::stats::chi2_sf(rho * rho * n_eff, 1.0);
        if rho.abs() >= LEAD_MIN_CORR && p < 0.01 / d.signals.len() as f64 {
            out.push(Correlate { signal: sg.name.to_string(), r: rho, n_eff });
        }
    }
    out.sort_by(|a, b| b.r.abs().total_cmp(&a.r.abs()));
    out.truncate(LEAD_MAX);
    out
}

#[derive(Clone, Debug, serde::Serialize)]
pub struct Report {
    pub source: String,
    pub samples: usize,
    pub train_samples: usize,
    pub heldout_samples: usize,
    pub model: NominalModel,
    pub options: Options,
    pub steps: Vec<Step>,
    /// The scoreboard of the last round, in which no candidate passed.
    pub final_candidates: Vec<Candidate>,
    /// Effects that joined in a step but failed the backward check (their gates re-run on top
    /// of every other selected effect), in the order they left.
    pub removed: Vec<Removal>,
    pub effects: Vec<Found>,
    pub errors: Vec<AxisError>,
    pub whiteness: Vec<Whiteness>,
    /// Per channel axis: what the effects leave unexplained and what it follows.
    pub left: Vec<Left>,
    /// Yaw spread of the flight (circular standard deviation, deg): world tilt and body offset
    /// differ only when the vehicle yaws.
    pub yaw_spread_deg: f64,
    /// Roll/pitch misalignment from the vehicle at rest before take-off (independent check).
    pub ground_check: Option<super::ground::GroundCheck>,
    /// The ground check against the flight's offset plus the tilt of its accelerometer bias.
    pub ground_agreement: Option<super::ground::GroundAgreement>,
    pub notes: Vec<String>,
    pub repairs: Vec<String>,
    /// What the data-quality gate cut out before the fit.
    pub data_quality: super::quality::DataQuality,
    /// Pairs of effects this flight cannot tell apart (canonical correlation > 0.99): the first
    /// was selected, the second would have explained the same residual.
    pub not_identifiable: Vec<(Effect, Effect, f64)>,
    #[serde(skip)]
    pub corrections: Corrections,
    /// The final linear parameters (internal units), by column.
    #[serde(skip)]
    pub theta: Vec<f64>,
}

impl Report {
    pub fn effect(&self, e: Effect) -> Option<&Found> {
        self.effects.iter().find(|f| f.effect == e)
    }
    /// A parameter value in its reported unit.
    pub fn param(&self, e: Effect, name: &str) -> Option<f64> {
        self.effect(e)?.params.iter().find(|p| p.name == name).map(|p| p.value)
    }
}

const AXES: [char; 3] = ['x', 'y', 'z'];
/// Fewer usable (decimated) training samples than this and no effect is tried.
pub const MIN_TRAIN_SAMPLES: usize = 200;

/// Normal equations of one channel axis: whitened training part and raw held-out part.
#[derive(Clone)]
struct Gram {
    cols: Vec<usize>,
    g_w: DMatrix<f64>,
    b_w: DVector<f64>,
    yy_w: f64,
    n_w: usize,
    g_t: DMatrix<f64>,
    b_t: DVector<f64>,
    yy_t: f64,
    n_t: usize,
    /// raw training part, each channel axis weighted by `w_r` (weighted least squares)
    g_r: DMatrix<f64>,
    b_r: DVector<f64>,
    /// 1/(mean square of the residual the noise model was fitted to): puts m/s² and rad/s on
    /// one scale, and weights each channel axis by how well it measures
    w_r: f64,
}

fn masks(s: &Series, d: &Design, o: &Options) -> (Vec<bool>, Vec<bool>) {
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
fn active(d: &Design) -> Vec<(usize, usize)> {
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

fn residual_of(d: &Design, c: usize, a: usize, theta: &[f64]) -> Vec<f64> {
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

fn grams(d: &Design, train: &[bool], test: &[bool], ars: &[Ar]) -> Vec<Gram> {
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
        let mut g = Gram {
            cols: cols.clone(),
            g_w: DMatrix::zeros(m, m),
            b_w: DVector::zeros(m),
            yy_w: 0.0,
            n_w: 0,
            g_t: DMatrix::zeros(m, m),
            b_t: DVector::zeros(m),
            yy_t: 0.0,
            n_t: 0,
            g_r: DMatrix::zeros(m, m),
            b_r: DVector::zeros(m),
            w_r: 1.0 / ars[k].marginal_var.max(f64::MIN_POSITIVE),
        };
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

/// The raw (training) normal equations of a set of columns, summed over channel axes.
fn system_raw(gs: &[Gram], set: &[usize]) -> (DMatrix<f64>, DVector<f64>) {
    let k = set.len();
    let mut g = DMatrix::zeros(k, k);
    let mut b = DVector::zeros(k);
    for gr in gs {
        let pos: Vec<Option<usize>> = set.iter().map(|j| gr.cols.iter().position(|c| c == j)).collect();
        for (p, ip) in pos.iter().enumerate() {
            let Some(ip) = ip else { continue };
            b[p] += gr.b_r[*ip];
            for (q, iq) in pos.iter().enumerate() {
                if let Some(iq) = iq {
                    g[(p, q)] += gr.g_r[(*ip, *iq)];
                }
            }
        }
    }
    (g, b)
}

/// The whitened normal equations of a set of columns, summed over channel axes.
fn system(gs: &[Gram], set: &[usize]) -> (DMatrix<f64>, DVector<f64>, f64, usize) {
    let k = set.len();
    let mut g = DMatrix::zeros(k, k);
    let mut b = DVector::zeros(k);
    let (mut yy, mut n) = (0.0, 0);
    for gr in gs {
        yy += gr.yy_w;
        n += gr.n_w;
        let pos: Vec<Option<usize>> = set.iter().map(|j| gr.cols.iter().position(|c| c == j)).collect();
        for (p, ip) in pos.iter().enumerate() {
            let Some(ip) = ip else { continue };
            b[p] += gr.b_w[*ip];
            for (q, iq) in pos.iter().enumerate() {
                if let Some(iq) = iq {
                    g[(p, q)] += gr.g_w[(*ip, *iq)];
                }
            }
        }
    }
    (g, b, yy, n)
}

/// A fit of a set of columns: the parameters by ordinary least squares (they minimise the
/// error the report measures), the tests on the prewhitened problem (GLS), and the covariance
/// (prewhitened until [`refine`] replaces it by the Newey–West one).
struct Fit {
    set: Vec<usize>,
    /// OLS parameters, full length N_COLUMNS.
    theta: Vec<f64>,
    /// GLS (prewhitened) parameters, full length.
    theta_w: Vec<f64>,
    /// Prewhitened residual sum of squares and sample count (for ΔBIC and the F-test).
    rss: f64,
    n: usize,
    cov: DMatrix<f64>,
}

fn full(set: &[usize], x: &DVector<f64>) -> Vec<f64> {
    let mut theta = vec![0.0; N_COLUMNS];
    for (p, j) in set.iter().enumerate() {
        theta[*j] = x[p];
    }
    theta
}

fn fit(gs: &[Gram], set: &[usize]) -> Fit {
    let (g, b, yy, n) = system(gs, set);
    let x = solve_spd(&g, &b).unwrap_or_else(|| DVector::zeros(set.len()));
    let rss = (yy - x.dot(&b)).max(1e-300);
    let s2 = rss / (n.saturating_sub(set.len()).max(1)) as f64;
    let cov = inverse_spd(&g) * s2;
    let (gr, br) = system_raw(gs, set);
    let xo = solve_spd(&gr, &br).unwrap_or_else(|| DVector::zeros(set.len()));
    Fit { set: set.to_vec(), theta: full(set, &xo), theta_w: full(set, &x), rss, n, cov }
}

/// Newey–West (Bartlett, `lags`) covariance of the OLS parameters: (XᵀX)⁻¹·S·(XᵀX)⁻¹ with
/// S = Σ_l w_l Σ_t (u_t u_{t−l}ᵀ + u_{t−l} u_tᵀ) (l = 0 counted once), w_l = 1 − l/(lags+1), and
/// u_t = Σ_{channel axes} x_t·e_t the score of time sample t summed over every channel axis.
/// Summing per time sample (not per channel axis) lets the channels' noises be correlated:
/// `accel_kin` and `force` share the accelerometer's noise, and their rows are not independent
/// information about, say, an accelerometer bias.
fn hac(d: &Design, train: &[bool], gs: &[Gram], set: &[usize], theta: &[f64], lags: usize) -> DMatrix<f64> {
    let k = set.len();
    let mut u: Vec<Option<DVector<f64>>> = (0..d.n).map(|t| train[t].then(|| DVector::zeros(k))).collect();
    for ((c, a), gr) in active(d).into_iter().zip(gs) {
        let e = residual_of(d, c, a, theta);
        let cols: Vec<Option<&Vec<f64>>> = set.iter().map(|j| d.columns[c][a].iter().find(|x| x.0 == *j).map(|x| &x.1)).collect();
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
        let w = 1.0 - l as f64 / (lags as f64 + 1.0);
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

/// The covariance a systematic relative error ε ~ N(0, σ_T²) of the nominal thrust adds to the
/// weighted least-squares parameters. Such an error adds ε·(−T/m) to the force channel's z
/// residual, which is ε times the thrust-scale column c, so the parameters move by
/// ε·(XᵀWX)⁻¹XᵀWc (W the channel-axis weights): onto the thrust
/// scale alone when it is in the model, otherwise onto whatever explains a vertical force (an
/// accelerometer bias z, a constant force D). The same ε holds for the whole flight, so no
/// amount of data averages it away: it is added to the statistical covariance, not divided
/// by n. σ_T is the model's own resolution ([`NominalModel::thrust_rel_sd`]).
fn thrust_systematic(d: &Design, train: &[bool], gs: &[Gram], set: &[usize], rel_sd: f64) -> DMatrix<f64> {
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

/// Held-out residual energy per channel axis for parameters θ.
fn heldout_rss(gs: &[Gram], theta: &[f64]) -> Vec<f64> {
    gs.iter()
        .map(|g| {
            let th = DVector::from_iterator(g.cols.len(), g.cols.iter().map(|j| theta[*j]));
            (g.yy_t - 2.0 * th.dot(&g.b_t) + (th.transpose() * &g.g_t * &th)[(0, 0)]).max(0.0)
        })
        .collect()
}

fn cols_of(e: Effect) -> std::ops::Range<usize> {
    let o = column_offsets();
    o[e as usize]..o[e as usize + 1]
}

fn set_of(effects: &[Effect]) -> Vec<usize> {
    effects.iter().flat_map(|e| cols_of(*e)).collect()
}

/// Largest canonical correlation between the column blocks A and B with S projected out.
fn canonical_corr(gs: &[Gram], s: &[usize], a: &[usize], b: &[usize]) -> f64 {
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

/// The AR models of the current residual (one per active channel axis).
fn ar_models(d: &Design, train: &[bool], theta: &[f64], max_order: usize) -> Vec<Ar> {
    active(d).into_iter().map(|(c, a)| Ar::fit(&residual_of(d, c, a, theta), train, max_order)).collect()
}

/// Folds the linear increments of the correction effects into the corrections; zeroes them.
fn fold(corr: &mut Corrections, theta: &mut [f64], selected: &[Effect]) {
    for e in selected {
        let r = cols_of(*e);
        match e {
            Effect::BodyOffset => {
                let d = Vector3::new(theta[r.start], theta[r.start + 1], theta[r.start + 2]);
                corr.body_offset = UnitQuaternion::from_scaled_axis(d) * corr.body_offset;
            }
            Effect::WorldTilt => {
                let d = Vector3::new(theta[r.start], theta[r.start + 1], 0.0);
                corr.world_tilt *= UnitQuaternion::from_scaled_axis(d);
            }
            Effect::MocapDelay => corr.mocap_delay_s += theta[r.start],
            Effect::GyroDelay => corr.gyro_delay_s += theta[r.start],
            Effect::LeverArm => corr.lever_arm_m += Vector3::new(theta[r.start], theta[r.start + 1], theta[r.start + 2]),
            _ => continue,
        }
        for j in r {
            theta[j] = 0.0;
        }
    }
}

struct State {
    design: Design,
    train: Vec<bool>,
    test: Vec<bool>,
    grams: Vec<Gram>,
    fit: Fit,
}

/// Fits S at the current corrections, folds the exact effects, re-linearises; returns the
/// final state with AR models fitted to the residual of S.
fn refine(s: &Series, o: &Options, corr: &mut Corrections, selected: &[Effect], iterations: usize) -> State {
    let set = set_of(selected);
    let mut theta = vec![0.0; N_COLUMNS];
    let mut last = None;
    for it in 0..=iterations {
        let design = build(s, corr, &o.design);
        let (train, test) = masks(s, &design, o);
        // AR of the nominal residual first, then of the residual of S
        let ars0 = ar_models(&design, &train, &theta, o.max_ar_order);
        let g0 = grams(&design, &train, &test, &ars0);
        let f0 = fit(&g0, &set);
        let ars = ar_models(&design, &train, &f0.theta, o.max_ar_order);
        let grams = grams(&design, &train, &test, &ars);
        let mut f = fit(&grams, &set);
        let has_corrections = selected.iter().any(|e| e.is_correction());
        if it == iterations || !has_corrections {
            f.cov = hac(&design, &train, &grams, &set, &f.theta, o.hac_lags) + thrust_systematic(&design, &train, &grams, &set, s.model.thrust_rel_sd);
            last = Some(State { design, train, test, grams, fit: f });
            break;
        }
        fold(corr, &mut f.theta, selected);
        theta = f.theta;
    }
    last.expect("at least one iteration")
}

fn available(d: &Design, e: Effect) -> bool {
    match e {
        Effect::ThrustVoltage => d.has_force && d.has_vbat,
        _ => e.channels().iter().all(|c| *c != Channel::Force || d.has_force),
    }
}

/// The tilt at rest that the fitted model predicts, per axis (roll, pitch), in rad. The frame
/// part is the body offset δ plus the world tilt τ as the vehicle sees it at its rest yaw ψ,
/// (τ_x·cos ψ + τ_y·sin ψ, −τ_x·sin ψ + τ_y·cos ψ) (the `accel_kin` column Rᵀ(g·e_D × e_j) at a
/// level attitude, read by the ground check's δ = f̂ × r/g²); the accelerometer bias adds
/// (b_y/g, −b_x/g), as [`super::ground`] derives. Returns (frame part, bias, standard deviation
/// of the whole sum from the fit's covariance: offset and bias trade off in a hover, their sum
/// does not).
/// The whole tilt at rest (roll, pitch; rad): the frame part plus the tilt (b_y/g, −b_x/g) an
/// accelerometer bias b implies (see [`rest_tilt`]).
fn total_tilt(frame: [f64; 2], bias: &Vector3<f64>, g: f64) -> [f64; 2] {
    [frame[0] + bias.y / g, frame[1] - bias.x / g]
}

fn rest_tilt(selected: &[Effect], fit: &Fit, corr: &Corrections, g: f64, yaw: f64) -> ([f64; 2], nalgebra::Vector3<f64>, [f64; 2]) {
    let has = |e: Effect| selected.contains(&e);
    let (c, s) = (yaw.cos(), yaw.sin());
    let mut frame = [0.0, 0.0];
    if has(Effect::BodyOffset) {
        let (r, p, _) = corr.body_offset.euler_angles();
        frame = [r, p];
    }
    if has(Effect::WorldTilt) {
        let (tx, ty, _) = corr.world_tilt.euler_angles();
        frame[0] += tx * c + ty * s;
        frame[1] += -tx * s + ty * c;
    }
    let b = cols_of(Effect::AccelBias);
    let bias = if has(Effect::AccelBias) { nalgebra::Vector3::new(fit.theta[b.start], fit.theta[b.start + 1], fit.theta[b.start + 2]) } else { nalgebra::Vector3::zeros() };
    let o = cols_of(Effect::BodyOffset);
    let w = cols_of(Effect::WorldTilt);
    // gradients of the two sums with respect to the columns
    let grads = [[(o.start, 1.0), (w.start, c), (w.start + 1, s), (b.start + 1, 1.0 / g)], [(o.start + 1, 1.0), (w.start, -s), (w.start + 1, c), (b.start, -1.0 / g)]];
    let sd = grads.map(|grad| {
        let pos: Vec<(usize, f64)> = grad.iter().filter_map(|(j, c)| fit.set.iter().position(|x| x == j).map(|p| (p, *c))).collect();
        let mut v = 0.0;
        for (p, cp) in &pos {
            for (q, cq) in &pos {
                v += cp * cq * fit.cov[(*p, *q)];
            }
        }
        v.max(0.0).sqrt()
    });
    (frame, bias, sd)
}

fn params_of(e: Effect, theta: &[f64], cov: &DMatrix<f64>, set: &[usize], corr: &Corrections) -> Vec<Param> {
    let r = cols_of(e);
    let sd = |j: usize| set.iter().position(|c| *c == j).map_or(0.0, |p| cov[(p, p)].max(0.0).sqrt());
    let value = |k: usize| -> f64 {
        match e {
            Effect::BodyOffset => {
                let (r, p, y) = corr.body_offset.euler_angles();
                [r, p, y][k]
            }
            Effect::WorldTilt => {
                let (r, p, _) = corr.world_tilt.euler_angles();
                [r, p][k]
            }
            Effect::MocapDelay => corr.mocap_delay_s,
            Effect::GyroDelay => corr.gyro_delay_s,
            Effect::LeverArm => corr.lever_arm_m[k],
            _ => theta[r.start + k],
        }
    };
    // The thrust scale and the effects that multiply the thrust (ground effect, thrust against
    // voltage) enter the design additively, T·(1 + a + b·x); the simulation and the fed-back
    // fragment multiply them, T·(1 + a)·(1 + c·x). The same model with c = b/(1 + a), and by
    // the delta method var c = (var b − 2c·cov(a, b) + c²·var a)/(1 + a)².
    let scale = cols_of(Effect::ThrustScale).start;
    if matches!(e, Effect::GroundEffect | Effect::ThrustVoltage)
        && let (Some(pa), Some(pb)) = (set.iter().position(|c| *c == scale), set.iter().position(|c| *c == r.start))
    {
        let (a, b) = (theta[scale], theta[r.start]);
        let c = b / (1.0 + a);
        let var = (cov[(pb, pb)] - 2.0 * c * cov[(pa, pb)] + c * c * cov[(pa, pa)]) / ((1.0 + a) * (1.0 + a));
        let (name, unit, f) = e.params()[0];
        return vec![Param { name: name.to_string(), value: c * f, ci95: Z_975 * var.max(0.0).sqrt() * f, unit: unit.to_string(), identifiable: true }];
    }
    e.params()
        .iter()
        .enumerate()
        .map(|(k, (name, unit, f))| Param { name: name.to_string(), value: value(k) * f, ci95: Z_975 * sd(r.start + k) * f, unit: unit.to_string(), identifiable: true })
        .collect()
}

/// The three gates a candidate must all pass to join the model, among `candidates` candidates:
/// the prewhitened F-test at the Bonferroni level α/candidates, ΔBIC < 0, and a held-out error
/// cut of at least `min_heldout_gain`.
fn passes_gates(p_value: f64, delta_bic: f64, heldout_gain: f64, o: &Options, candidates: usize) -> bool {
    p_value < o.alpha / candidates as f64 && delta_bic < 0.0 && heldout_gain >= o.min_heldout_gain
}

/// Runs the method on one flight: the data-quality gate, then the selection.
///
/// # Errors
/// [`IdentifyError::TooLittleClean`] when the gate cut samples that no flight can produce and
/// too few usable samples remain: no parameter comes out of corrupted data.
pub fn identify(s: &Series, o: &Options) -> Result<Report, IdentifyError> {
    let (clean, quality) = super::quality::gate(s, &o.quality, o.design.smoothing_s, o.design.min_height_m);
    let mut report = select(&clean, o);
    if report.train_samples < MIN_TRAIN_SAMPLES && quality.corrupted().next().is_some() {
        return Err(IdentifyError::TooLittleClean { log: s.source.clone(), usable: report.train_samples, needed: MIN_TRAIN_SAMPLES, cuts: quality.describe() });
    }
    if !quality.cuts.is_empty() {
        report.notes.insert(
            0,
            format!(
                "the data-quality gate cut {} of {} rows before the fit (samples no flight can produce, with a {} s margin): {}",
                quality.rows_cut,
                quality.rows,
                o.quality.margin_s,
                quality.describe().join("; ")
            ),
        );
    }
    report.data_quality = quality;
    Ok(report)
}

/// How strongly one flight excites an effect, decided from the data's information matrix
/// and the effect's size, not from what `identify` found.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct Excitation {
    /// Noncentrality of the effect's block given every other candidate:
    /// λ = θᵀ·(G_CC − G_CO·G_OO⁻¹·G_OC)·θ on the prewhitened training problem (G the whitened
    /// Gram matrix of all candidates, θ the effect's true parameters). The F-test of the block
    /// has power ≈ 95 % at the Bonferroni level 0.001 from λ ≈ 25 (one parameter) to 35 (three).
    pub lambda: f64,
    /// The share of the held-out residual energy on the channel axes the effect acts on that it
    /// makes, E/(E + N): E = θᵀ·(G_t,CC − G_t,CH·G_t,HH⁻¹·G_t,HC)·θ, the held-out energy of the
    /// part of the effect that the flight's *other hidden effects* H do not explain (G_t the raw
    /// held-out Gram over the channel axes the effect acts on; the held-out gate tests the effect on top of
    /// a model that holds them), N the held-out energy of the residual of the model with every
    /// candidate. The held-out gate needs a 10 % RMSE cut, i.e.
    /// a share of at least 19 %.
    pub heldout_share: f64,
}

impl Excitation {
    /// Enough for the selection to find the effect: λ ≥ 40 and a held-out share ≥ 0.3 (margins
    /// over the 95 %-power λ and the 19 % the held-out gate needs).
    pub fn sufficient(&self) -> bool {
        self.lambda >= 40.0 && self.heldout_share >= 0.3
    }
}

/// The excitation of each effect in `truth` (parameters in the reported units) on flight `s`,
/// at the nominal corrections (see [`Excitation`]). Effects the data has no columns for get
/// λ = 0.
pub fn excitation(s: &Series, o: &Options, truth: &[(Effect, Vec<f64>)]) -> Vec<Excitation> {
    let s = &gated(s, o);
    let mut corr = Corrections::default();
    let st = refine(s, o, &mut corr, &[], 0);
    let all: Vec<Effect> = Effect::ALL.iter().copied().filter(|e| (o.candidates.contains(e) || o.forced.contains(e)) && available(&st.design, *e)).collect();
    let white: Vec<Ar> = active(&st.design).iter().map(|_| Ar::white(1.0)).collect();
    let g_ols = grams(&st.design, &st.train, &st.test, &white);
    let f_all = fit(&g_ols, &set_of(&all));
    let ars = ar_models(&st.design, &st.train, &f_all.theta, o.max_ar_order);
    let gs = grams(&st.design, &st.train, &st.test, &ars);
    let rss_full_t = heldout_rss(&gs, &f_all.theta);
    let act = active(&st.design);
    truth
        .iter()
        .map(|(e, values)| {
            if !all.contains(e) {
                return Excitation { lambda: 0.0, heldout_share: 0.0 };
            }
            let block = set_of(&[*e]);
            let others: Vec<usize> = set_of(&all).into_iter().filter(|j| !block.contains(j)).collect();
            let mut order = block.clone();
            order.extend(&others);
            let (g, _, _, _) = system(&gs, &order);
            let k = block.len();
            let gcc = g.view((0, 0), (k, k)).into_owned();
            let gco = g.view((0, k), (k, others.len())).into_owned();
            let goo = g.view((k, k), (others.len(), others.len())).into_owned();
            let schur = gcc - &gco * inverse_spd(&goo) * gco.transpose();
            let theta = DVector::from_iterator(k, values.iter().zip(e.params()).map(|(v, (_, _, f))| v / f));
            let lambda = (theta.transpose() * schur * &theta)[(0, 0)].max(0.0);
            // held-out energy of the part of the effect that the flight's other hidden effects
            // do not explain (the Schur complement of the held-out Gram over the axes the effect
            // acts on: a thrust against voltage whose mean a hidden thrust scale takes is not
            // counted), and of the full model's residual, on those axes
            let mut order = block.clone();
            let partners: Vec<usize> = truth.iter().filter(|(x, _)| x != e && all.contains(x)).flat_map(|(x, _)| set_of(&[*x])).collect();
            order.extend(&partners);
            let pos = |j: usize| order.iter().position(|x| *x == j);
            let mut g_t = DMatrix::<f64>::zeros(order.len(), order.len());
            let mut noise = 0.0;
            for q in 0..act.len() {
                if gs[q].cols.iter().any(|j| block.contains(j)) {
                    let gr = &gs[q];
                    for (u, ju) in gr.cols.iter().enumerate() {
                        for (v, jv) in gr.cols.iter().enumerate() {
                            if let (Some(pu), Some(pv)) = (pos(*ju), pos(*jv)) {
                                g_t[(pu, pv)] += gr.g_t[(u, v)];
                            }
                        }
                    }
                    noise += rss_full_t[q];
                }
            }
            let no = partners.len();
            let schur_t = g_t.view((0, 0), (k, k)).into_owned() - g_t.view((0, k), (k, no)) * inverse_spd(&g_t.view((k, k), (no, no)).into_owned()) * g_t.view((k, 0), (no, k));
            let energy = (theta.transpose() * schur_t * &theta)[(0, 0)].max(0.0);
            let heldout_share = if energy + noise > 0.0 { energy / (energy + noise) } else { 0.0 };
            Excitation { lambda, heldout_share }
        })
        .collect()
}

/// The log with what the data-quality gate cuts taken out of its segments: every error and
/// plot is computed on the samples the fit saw, never on corrupted ones.
fn gated(s: &Series, o: &Options) -> Series {
    super::quality::gate(s, &o.quality, o.design.smoothing_s, o.design.min_height_m).0
}

/// Why [`identify`] gives no report.
#[derive(Debug, thiserror::Error)]
pub enum IdentifyError {
    /// The data-quality gate cut so much that too little remains to fit anything.
    #[error(
        "{log}: only {usable} usable training samples remain after the data-quality gate ({needed} needed), so nothing is identified; what was cut:\n  {}",
        cuts.join("\n  ")
    )]
    TooLittleClean { log: String, usable: usize, needed: usize, cuts: Vec<String> },
}

/// One candidate block (or two together) on top of the fitted set `base`: ΔBIC, F-test,
/// held-out gain on the axes the block acts on, largest correlation with the residual of
/// `base`, and whether it passes the gates among `tests` candidates.
fn score(gs: &[Gram], base: &Fit, effects: &[Effect], tests: usize, o: &Options) -> Candidate {
    let rss_base_t = heldout_rss(gs, &base.theta);
    let mut set = base.set.clone();
    set.extend(set_of(effects));
    let f1 = fit(gs, &set);
    let k = effects.iter().map(|e| e.n_params()).sum::<usize>() as f64;
    let n = f1.n as f64;
    let delta_bic = n * (f1.rss / base.rss).ln() + k * n.ln();
    let f = ((base.rss - f1.rss) / k) / (f1.rss / (n - set.len() as f64));
    let p_value = f_sf(f, k, n - set.len() as f64);
    let rss1_t = heldout_rss(gs, &f1.theta);
    let (mut e0, mut e1) = (0.0, 0.0);
    let block = set_of(effects);
    for q in 0..gs.len() {
        // the axes the block has a regressor on (a thrust scale acts on force z alone:
        // counting force x and y, which it cannot change, would dilute its cut by 3)
        if gs[q].cols.iter().any(|j| block.contains(j)) {
            // each axis relative to the current model's error on it: a cut on an axis
            // that earlier steps already brought down counts as much as on a fresh one
            let w = 1.0 / rss_base_t[q].max(1e-300);
            e0 += w * rss_base_t[q];
            e1 += w * rss1_t[q];
        }
    }
    let heldout_gain = if e0 > 0.0 { 1.0 - (e1 / e0).sqrt() } else { 0.0 };
    // correlation of the residual of S with each whitened column of C
    let mut max_corr: f64 = 0.0;
    let (g, b, yy, _) = system(gs, &set);
    let nb = base.set.len();
    let th_s = DVector::from_iterator(nb, base.set.iter().map(|j| base.theta_w[*j]));
    let rr = (yy - 2.0 * th_s.dot(&b.rows(0, nb)) + (th_s.transpose() * g.view((0, 0), (nb, nb)) * &th_s)[(0, 0)]).max(1e-300);
    for q in nb..set.len() {
        let xr = b[q] - (g.view((q, 0), (1, nb)) * &th_s)[(0, 0)];
        max_corr = max_corr.max((xr / (g[(q, q)] * rr).sqrt()).abs());
    }
    let passed = passes_gates(p_value, delta_bic, heldout_gain, o, tests);
    Candidate { effect: effects[0], delta_bic, f, p_value, heldout_gain, max_corr, passed }
}

/// The candidates a forward step tries: not selected, not removed by the backward check (no
/// re-entry), and with columns in the data.
fn pool_of(o: &Options, d: &Design, selected: &[Effect], removed: &[Removal]) -> Vec<Effect> {
    o.candidates.iter().copied().filter(|e| !selected.contains(e) && !removed.iter().any(|r| r.check.effect == *e) && available(d, *e)).collect()
}

/// The backward check's verdict on the selected set: each `testable` effect is scored on top
/// of every other selected one (`tests` candidates for the Bonferroni level); of those that
/// fail a gate, the one with the largest ΔBIC (the least support) leaves. None when all pass.
fn backward_worst(gs: &[Gram], selected: &[Effect], testable: &[Effect], tests: usize, o: &Options) -> Option<Candidate> {
    let mut worst: Option<Candidate> = None;
    for e in testable {
        let rest: Vec<Effect> = selected.iter().copied().filter(|x| x != e).collect();
        let base = fit(gs, &set_of(&rest));
        let c = score(gs, &base, &[*e], tests, o);
        if !c.passed && worst.as_ref().is_none_or(|w| c.delta_bic > w.delta_bic) {
            worst = Some(c);
        }
    }
    worst
}

/// The selection on a gated flight.
fn select(s: &Series, o: &Options) -> Report {
    let mut corr = Corrections::default();
    let mut selected: Vec<Effect> = Vec::new();
    let mut steps = Vec::new();
    let mut notes = Vec::new();
    let mut final_candidates = Vec::new();
    let nominal = refine(s, o, &mut corr, &[], 0);
    let usable = nominal.train.iter().filter(|x| **x).count();
    let too_few = usable < MIN_TRAIN_SAMPLES;
    if too_few {
        notes.push(format!(
            "only {usable} usable training samples (airborne above {} m, away from gaps and edges; decimated): at least {MIN_TRAIN_SAMPLES} are needed to select effects, so none were tried",
            o.design.min_height_m
        ));
    }
    if nominal.design.outliers > 0 {
        notes.push(format!(
            "{} mocap glitches (a pose more than {} robust σ, and 1 mm or 0.5°, off the midpoint of its neighbours) were left out with ±{} ms around each",
            nominal.design.outliers,
            super::design::GLITCH_SIGMAS,
            (3.0 * o.design.smoothing_s * 1e3).round()
        ));
    }
    let mut state = nominal;
    let mut state_corr = corr;
    let mut removed: Vec<Removal> = Vec::new();
    if !too_few {
        for e in &o.forced {
            if available(&state.design, *e) && !selected.contains(e) {
                selected.push(*e);
            }
        }
        if !selected.is_empty() {
            state = refine(s, o, &mut state_corr, &selected, o.refine_iterations);
            notes.push(format!("fitted without testing (forced): {}", selected.iter().map(|e| e.key()).collect::<Vec<_>>().join(", ")));
        }
    }
    loop {
        if too_few {
            break;
        }
        // backward check, once after every step: an effect that joined early may be explained
        // by the ones that joined after it (a constant force taken first for a force-channel
        // offset that an accelerometer bias and a thrust scale explain once both are in). Each
        // linear effect must still pass the gates that let it in, now on top of all the
        // others; the worst that fails leaves for good (it cannot re-enter, so the selection
        // terminates), and the forward steps go on from the smaller model. Corrections (rotations,
        // delay, lever arm) are folded into the trajectory and are not re-tested; nor is a pair
        // that joined together (each alone fails by construction) or a forced effect.
        // (every pass of the loop after the first follows a step)
        if !steps.is_empty() {
            let in_pair = |e: Effect| steps.iter().any(|st: &Step| st.together_with.is_some() && (st.added == e || st.together_with == Some(e)));
            let testable: Vec<Effect> = selected.iter().copied().filter(|e| !e.is_correction() && !o.forced.contains(e) && !in_pair(*e)).collect();
            let outside = pool_of(o, &state.design, &selected, &removed).len();
            if let Some(w) = backward_worst(&state.grams, &selected, &testable, outside + 1, o) {
                selected.retain(|x| *x != w.effect);
                let mut c2 = state_corr;
                state = refine(s, o, &mut c2, &selected, o.refine_iterations);
                state_corr = c2;
                removed.push(Removal { after_step: steps.len(), check: w });
            }
        }
        if steps.len() >= o.max_steps {
            notes.push(format!("stopped after {} steps (max_steps)", o.max_steps));
            break;
        }
        let pool = pool_of(o, &state.design, &selected, &removed);
        if pool.is_empty() {
            break;
        }
        // the noise model for the tests comes from the residual of the largest model (S and
        // every candidate): an AR fitted to a residual that still holds an effect would model
        // the effect as noise and whiten it away
        let mut full: Vec<Effect> = selected.clone();
        full.extend(&pool);
        let grams_test = {
            let white: Vec<Ar> = active(&state.design).iter().map(|_| Ar::white(1.0)).collect();
            let g_ols = grams(&state.design, &state.train, &state.test, &white);
            let f_ols = fit(&g_ols, &set_of(&full));
            let ars = ar_models(&state.design, &state.train, &f_ols.theta, o.max_ar_order);
            grams(&state.design, &state.train, &state.test, &ars)
        };
        let base = &fit(&grams_test, &state.fit.set);
        let score = |effects: &[Effect], tests: usize| score(&grams_test, base, effects, tests, o);
        let cands: Vec<Candidate> = pool.iter().map(|e| score(&[*e], pool.len())).collect();
        // two effects that only together explain the residual (a body offset and a world tilt,
        // each extrapolating badly to the held-out blocks without the other) are each
        // significant alone but fail the held-out gate: such pairs are tried together, at a
        // Bonferroni level over the singles and these pairs, and win only with a lower ΔBIC
        // than every passing single
        let near: Vec<Effect> = cands.iter().filter(|c| !c.passed && c.p_value < o.alpha / pool.len() as f64 && c.delta_bic < 0.0).map(|c| c.effect).collect();
        let n_pairs = near.len() * near.len().saturating_sub(1) / 2;
        let mut pair: Option<(Effect, Candidate)> = None;
        for (i, a) in near.iter().enumerate() {
            for b in &near[i + 1..] {
                let c = score(&[*a, *b], pool.len() + n_pairs);
                if c.passed && pair.as_ref().is_none_or(|(_, p)| c.delta_bic < p.delta_bic) {
                    pair = Some((*b, c));
                }
            }
        }
        let best_single = cands.iter().filter(|c| c.passed).min_by(|a, b| a.delta_bic.total_cmp(&b.delta_bic)).cloned();
        let (best, partner) = match (best_single, pair) {
            (Some(s1), Some((b, p))) if p.delta_bic < s1.delta_bic => (p, Some(b)),
            (Some(s1), _) => (s1, None),
            (None, Some((b, p))) => (p, Some(b)),
            (None, None) => {
                final_candidates = cands;
                break;
            }
        };
        let mut unident = Vec::new();
        for c in cands.iter().filter(|c| c.effect != best.effect && c.passed) {
            let rho = canonical_corr(&grams_test, &base.set, &set_of(&[best.effect]), &set_of(&[c.effect]));
            if rho > 0.99 {
                unident.push((c.effect, rho));
            }
        }
        selected.push(best.effect);
        selected.extend(partner);
        let mut c2 = state_corr;
        state = refine(s, o, &mut c2, &selected, o.refine_iterations);
        state_corr = c2;
        let params = selected.iter().flat_map(|e| params_of(*e, &state.fit.theta, &state.fit.cov, &state.fit.set, &state_corr)).collect();
        steps.push(Step {
            added: best.effect,
            together_with: partner,
            delta_bic: best.delta_bic,
            p_value: best.p_value,
            heldout_gain: best.heldout_gain,
            candidates: cands,
            not_identifiable_from: unident,
            params,
        });
    }
    let steps_kept = |st: &&Step| !removed.iter().any(|r| r.check.effect == st.added);
    // identifiability of the two frame effects, whatever was selected
    let yaw_spread_deg = state.design.yaw_spread_rad.to_degrees();
    let mut not_identifiable: Vec<(Effect, Effect, f64)> =
        steps.iter().filter(steps_kept).flat_map(|st| st.not_identifiable_from.iter().map(|(e, rho)| (st.added, *e, *rho))).collect();
    let flagged = |a: Effect, b: Effect| {
        steps.iter().any(|st: &Step| (st.added == a && st.not_identifiable_from.iter().any(|x| x.0 == b)) || (st.added == b && st.not_identifiable_from.iter().any(|x| x.0 == a)))
    };
    if (selected.contains(&Effect::BodyOffset) || selected.contains(&Effect::WorldTilt)) && !flagged(Effect::BodyOffset, Effect::WorldTilt) {
        let rho = canonical_corr(&state.grams, &[], &set_of(&[Effect::WorldTilt]), &set_of(&[Effect::BodyOffset]));
        if rho > 0.99 {
            // the one not selected (if both were, the pair is still named)
            let (a, b) = if selected.contains(&Effect::BodyOffset) { (Effect::BodyOffset, Effect::WorldTilt) } else { (Effect::WorldTilt, Effect::BodyOffset) };
            not_identifiable.push((a, b, rho));
            notes.push(format!(
                "mocap world tilt and body offset roll/pitch are not identifiable apart in this flight (canonical correlation {rho:.4}, yaw spread {yaw_spread_deg:.1}°): they differ only through yaw changes, body rates and accelerations other than gravity"
            ));
        }
    }
    for st in steps.iter().filter(steps_kept) {
        for (e, rho) in &st.not_identifiable_from {
            notes.push(format!(
                "{} was chosen over {} by ΔBIC, but this flight cannot tell them apart (canonical correlation {rho:.4}, yaw spread {yaw_spread_deg:.1}°): not identifiable; fly yaw turns, circles and accelerations to separate them",
                st.added.key(),
                e.key()
            ));
        }
    }

    // a mocap that leads the IMU is no latency: a clock offset between the streams, or a delay
    // of the gyro alone (which shares the mocap delay's gyro column and is not searched)
    if selected.contains(&Effect::MocapDelay) && state_corr.mocap_delay_s < 0.0 && !selected.contains(&Effect::GyroDelay) {
        notes.push(format!(
            "the mocap delay came out negative ({:.1} ms: the mocap leads the IMU): a clock offset between the streams, or a delay of the gyro alone against the accelerometer, which `--with gyro_delay` tests",
            state_corr.mocap_delay_s * 1e3
        ));
    }

    // errors before (nominal, no corrections) → after, on the held-out part
    let nominal_design = build(s, &Corrections::default(), &o.design);
    let d = &state.design;
    // the same design with the measured signals, for the leads of what is left
    let with_signals = super::design::build_with_signals(s, &state_corr, &o.design);
    let lead_sigs = lead_signals(&with_signals);
    let mut errors = Vec::new();
    let mut whiteness = Vec::new();
    let mut left = Vec::new();
    for (c, a) in active(d) {
        let before = nominal_design.residual(c, a);
        let after = residual_of(d, c, a, &state.fit.theta);
        let idx: Vec<usize> = (0..d.n).filter(|&i| state.test[i] && nominal_design.ok[i]).collect();
        let ch = Channel::ALL[c];
        errors.push(axis_error(ch, a, &d.measured[c][a], &before, &after, &idx));
        // whiteness of the final residual on the usable samples
        let ok: Vec<bool> = d.ok.clone();
        let raw: Vec<f64> = (0..d.n).map(|i| if ok[i] { after[i] } else { f64::NAN }).collect();
        let (r, n) = autocorrelation(&raw, 50);
        let bound = Z_995 / (n.max(1) as f64).sqrt();
        let outside = r.iter().filter(|x| x.abs() > bound).count() as f64 / r.len() as f64;
        let ar = Ar::fit(&after, &ok, o.max_ar_order);
        let mut w = Vec::new();
        ar.whiten(&after, &ok, &mut w);
        let lb = ljung_box(&w, 20, ar.order());
        let correlates = leads(&lead_sigs, c, a, &after);
        let err = errors.last().expect("pushed above");
        left.push(Left {
            channel: ch,
            axis: AXES[a],
            rmse: err.rmse_after,
            unit: err.unit.clone(),
            ljung_box_p: lb.p_value,
            structured: !correlates.is_empty() || lb.p_value < 0.01,
            correlates,
        });
        whiteness.push(Whiteness { channel: ch, axis: AXES[a], raw_outside_99: outside, ar_order: ar.order(), ljung_box: lb });
    }
    let mut effects: Vec<Found> =
        selected.iter().map(|e| Found { effect: *e, name: e.name().into(), params: params_of(*e, &state.fit.theta, &state.fit.cov, &state.fit.set, &state_corr) }).collect();
    // swaps the final model cannot tell apart: a selected effect E and a candidate C outside the
    // model whose blocks are collinear once every *other* selected effect is projected out (the
    // check at each step conditions only on what was selected before, and misses pairs that a
    // later effect couples, e.g. a constant force and a world tilt through an accelerometer bias
    // that lives in both channels). E's parameters are then one explanation of several; the
    // others' intervals are widened to cover the swapped model's estimates.
    let g = s.model.gravity_m_s2;
    let rest_yaw = super::ground::rest_yaw(s).unwrap_or(0.0);
    let (tilt_offset, tilt_bias, tilt_sd) = rest_tilt(&selected, &state.fit, &state_corr, g, rest_yaw);
    let tilt_total = total_tilt(tilt_offset, &tilt_bias, g);
    let mut tilt_widen = [0.0f64; 2];
    if !too_few {
        let outside: Vec<Effect> = o.candidates.iter().copied().filter(|c| !selected.contains(c) && available(&state.design, *c)).collect();
        for (k, e) in selected.clone().into_iter().enumerate() {
            if o.forced.contains(&e) {
                continue;
            }
            let others: Vec<Effect> = selected.iter().copied().filter(|x| *x != e).collect();
            for c in outside.iter().copied() {
                let rho = canonical_corr(&state.grams, &set_of(&others), &set_of(&[e]), &set_of(&[c]));
                // a pair named at E's step stays one: the step's test found C passing and
                // collinear with E, so E's value may hold C's (a thrust scale holding the mean
                // of a voltage effect), whatever the final model's noise model makes of ρ
                let named_at_step = steps.iter().filter(steps_kept).any(|st| st.added == e && st.not_identifiable_from.iter().any(|x| x.0 == c));
                if rho <= 0.99 && !named_at_step {
                    continue;
                }
                if !not_identifiable.iter().any(|(a, b, _)| (*a == e && *b == c) || (*a == c && *b == e)) {
                    not_identifiable.push((e, c, rho));
                    notes.push(format!(
                        "{} and {} explain this flight's residual alike once the other effects are fitted (canonical correlation {rho:.4}, yaw spread {yaw_spread_deg:.1}°): not identifiable; {}'s parameters are one explanation of two, and the other effects' intervals cover both",
                        e.key(),
                        c.key(),
                        e.key()
                    ));
                }
                for p in &mut effects[k].params {
                    p.identifiable = false;
                }
                if rho <= 0.99 {
                    // named at the step only: E claims no interval, but the final model tells
                    // the two apart well enough that the swapped model is no alternative for
                    // the others (refitting it widened a drag to ± 0.25 where ± 0.003 held)
                    continue;
                }
                let mut alt = others.clone();
                alt.push(c);
                let mut alt_corr = Corrections::default();
                let alt_state = refine(s, o, &mut alt_corr, &alt, o.refine_iterations);
                let (ao, ab, asd) = rest_tilt(&alt, &alt_state.fit, &alt_corr, g, rest_yaw);
                let alt_total = total_tilt(ao, &ab, g);
                for k in 0..2 {
                    tilt_widen[k] = tilt_widen[k].max((alt_total[k] - tilt_total[k]).abs() + Z_975 * asd[k]);
                }
                for f in effects.iter_mut().filter(|f| f.effect != e) {
                    let alt_params = params_of(f.effect, &alt_state.fit.theta, &alt_state.fit.cov, &alt_state.fit.set, &alt_corr);
                    for (p, q) in f.params.iter_mut().zip(alt_params) {
                        p.ci95 = p.ci95.max((q.value - p.value).abs() + q.ci95);
                    }
                }
            }
        }
    }
    // candidates the data half-supports: in the last round they passed the F-test and ΔBIC but
    // not the held-out gate (a 5 ms mocap delay over calibration circles: the rate vector turns
    // at Ω, so the delay looks like a body-offset yaw of Ω·δt, and the flight cannot say which).
    // Left out, such a C may bias the selected effects (omitted variable); so each selected
    // interval is widened to cover the estimate with C in the model too, the shift taken from
    // the linearised fit of S + C at the final corrections.
    if !too_few {
        let near: Vec<&Candidate> = final_candidates.iter().filter(|c| !c.passed && c.delta_bic < 0.0 && c.p_value < o.alpha / final_candidates.len().max(1) as f64).collect();
        let folded = |set: &[usize], effects: &[Effect]| {
            let f = fit(&state.grams, set);
            let mut theta = f.theta.clone();
            let mut corr = state_corr;
            fold(&mut corr, &mut theta, effects);
            (f, theta, corr)
        };
        let (bf, bt, bc) = folded(&state.fit.set, &selected);
        // the tilt at rest the ground check compares with moves too
        let (base_offset, base_bias, _) = rest_tilt(&selected, &bf, &bc, g, rest_yaw);
        let base_total = total_tilt(base_offset, &base_bias, g);
        for c in near {
            let mut with_c = selected.clone();
            with_c.push(c.effect);
            let (af, at, ac) = folded(&set_of(&with_c), &with_c);
            let (alt_offset, alt_bias, _) = rest_tilt(&with_c, &af, &ac, g, rest_yaw);
            let alt_total = total_tilt(alt_offset, &alt_bias, g);
            for k in 0..2 {
                tilt_widen[k] = tilt_widen[k].max((alt_total[k] - base_total[k]).abs() + Z_975 * tilt_sd[k]);
            }
            let mut moved = Vec::new();
            for f in effects.iter_mut() {
                let base = params_of(f.effect, &bt, &bf.cov, &bf.set, &bc);
                let alt = params_of(f.effect, &at, &af.cov, &af.set, &ac);
                for ((p, b), a) in f.params.iter_mut().zip(base).zip(alt) {
                    let shift = (a.value - b.value).abs();
                    if shift > p.ci95 {
                        moved.push(format!("{} {} {:+.3} {}", f.effect.key(), p.name, a.value - b.value, p.unit));
                    }
                    p.ci95 += shift;
                }
            }
            if !moved.is_empty() {
                notes.push(format!(
                    "{} is significant in the fit (ΔBIC {:.0}, F-test p {:.1e}) but does not cut the held-out error enough to join (−{:.1} %); with it in, the estimates would move ({}): their intervals cover both",
                    c.effect.key(),
                    c.delta_bic,
                    c.p_value,
                    100.0 * c.heldout_gain,
                    moved.join(", ")
                ));
            }
        }
    }
    // the widening is an extra half-width beyond the fit's own
    let tilt_widen = [0, 1].map(|k| (tilt_widen[k] - Z_975 * tilt_sd[k]).max(0.0));
    let ground_check = super::ground::ground_check(s);
    let ground_agreement = match (&ground_check, too_few) {
        (Some(raw), false) => super::ground::tilt_at_rest(s, &tilt_bias).map(|corrected| {
            super::ground::agreement(
                raw,
                &corrected,
                tilt_offset,
                tilt_sd,
                tilt_widen,
                selected.contains(&Effect::BodyOffset) || selected.contains(&Effect::WorldTilt),
                selected.contains(&Effect::AccelBias),
            )
        }),
        _ => None,
    };
    if let Some(a) = &ground_agreement {
        for (name, t) in [("roll", &a.roll), ("pitch", &a.pitch)] {
            if t.difference_deg.abs() > 1.0 && t.covers {
                notes.push(format!(
                    "ground check and flight differ by {:.2}° in {name}, within what this flight determines (±{:.2}°): the flight cannot pin its tilt down to 1°",
                    t.difference_deg, t.ci95_deg
                ));
            } else if !t.covers {
                notes.push(format!(
                    "ground check and flight disagree in {name}: the ground reads {:.2}°{}, the flight {:.2}° (difference {:.2} ± {:.2}°): the markers or the IMU board moved between rest and flight, or the flight holds an effect the candidate library lacks",
                    t.ground_deg,
                    if t.bias_tilt_deg != 0.0 { format!(" ({:.2}° once the fitted accelerometer bias is removed)", t.ground_corrected_deg) } else { String::new() },
                    t.flight_deg,
                    t.difference_deg,
                    t.ci95_deg
                ));
            }
        }
    }
    Report {
        source: s.source.clone(),
        samples: s.len(),
        train_samples: state.train.iter().filter(|x| **x).count(),
        heldout_samples: state.test.iter().filter(|x| **x).count(),
        model: s.model.clone(),
        options: o.clone(),
        steps,
        final_candidates,
        removed,
        effects,
        errors,
        whiteness,
        left,
        yaw_spread_deg,
        ground_check,
        ground_agreement,
        notes,
        repairs: s.repairs.clone(),
        data_quality: super::quality::DataQuality::default(),
        not_identifiable,
        corrections: state_corr,
        theta: state.fit.theta.clone(),
    }
}

/// RMSE and NRMSE fit of the residuals `before` and `after` over the samples `idx` of the
/// measured signal `y`.
fn axis_error(ch: Channel, a: usize, y: &[f64], before: &[f64], after: &[f64], idx: &[usize]) -> AxisError {
    let nt = idx.len().max(1) as f64;
    let mean = idx.iter().map(|&i| y[i]).sum::<f64>() / nt;
    let norm_y = idx.iter().map(|&i| (y[i] - mean).powi(2)).sum::<f64>().sqrt();
    let norm_b = idx.iter().map(|&i| before[i].powi(2)).sum::<f64>();
    let norm_a = idx.iter().map(|&i| after[i].powi(2)).sum::<f64>();
    let fit = |norm: f64| (norm_y > 1e-9 * nt.sqrt()).then(|| 100.0 * (1.0 - norm.sqrt() / norm_y));
    AxisError {
        channel: ch,
        axis: AXES[a],
        unit: ch.unit().into(),
        samples: idx.len(),
        rmse_before: (norm_b / nt).sqrt(),
        rmse_after: (norm_a / nt).sqrt(),
        fit_before_pct: fit(norm_b),
        fit_after_pct: fit(norm_a),
    }
}

/// The error of another flight's model on this flight: the nominal model and the nominal model
/// with `r`'s corrections and parameters, on every usable sample of `s` (nothing is refitted).
pub fn evaluate(s: &Series, o: &Options, r: &Report) -> Vec<AxisError> {
    let s = &gated(s, o);
    let before = build(s, &Corrections::default(), &o.design);
    let after = build(s, &r.corrections, &o.design);
    let mut out = Vec::new();
    for (c, a) in active(&after) {
        let rb = before.residual(c, a);
        let ra = residual_of(&after, c, a, &r.theta);
        let idx: Vec<usize> = (0..after.n).filter(|&i| after.ok[i] && before.ok[i]).collect();
        out.push(axis_error(Channel::ALL[c], a, &after.measured[c][a], &rb, &ra, &idx));
    }
    out
}

/// 1 − ‖after‖/‖before‖ over the axes of one channel.
pub fn channel_cut(errors: &[AxisError], c: Channel) -> Option<f64> {
    let (mut b, mut a) = (0.0, 0.0);
    for e in errors.iter().filter(|e| e.channel == c) {
        b += e.rmse_before.powi(2);
        a += e.rmse_after.powi(2);
    }
    (b > 0.0).then(|| 1.0 - (a / b).sqrt())
}

/// The residual of one channel axis over the usable (decimated) samples, before (nominal, no
/// corrections) and after (the report's effects), for plotting.
pub struct ResidualSeries {
    pub channel: Channel,
    pub axis: char,
    /// Seconds from the first sample of the log.
    pub t_s: Vec<f64>,
    pub before: Vec<f64>,
    pub after: Vec<f64>,
}

pub fn residual_series(s: &Series, o: &Options, r: &Report) -> Vec<ResidualSeries> {
    let s = &gated(s, o);
    let before = build(s, &Corrections::default(), &o.design);
    let after = build(s, &r.corrections, &o.design);
    let t0 = s.t_s.first().copied().unwrap_or(0.0);
    active(&after)
        .into_iter()
        .map(|(c, a)| {
            let rb = before.residual(c, a);
            let ra = residual_of(&after, c, a, &r.theta);
            let idx: Vec<usize> = (0..after.n).filter(|&i| after.ok[i] && before.ok[i]).collect();
            ResidualSeries {
                channel: Channel::ALL[c],
                axis: AXES[a],
                t_s: idx.iter().map(|&i| after.t[i] - t0).collect(),
                before: idx.iter().map(|&i| rb[i]).collect(),
                after: idx.iter().map(|&i| ra[i]).collect(),
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each gate alone rejects: a candidate that passes the other two fails when one of them
    /// fails, at its boundary (deleting any one gate makes this test fail).
    #[test]
    fn each_selection_gate_alone_decides() {
        let o = Options::default(); // α = 0.01, min gain 10 %
        let m = 10; // Bonferroni level 0.001
        assert!(passes_gates(0.0009, -1.0, 0.10, &o, m));
        // the F-test alone: p just above α/m (but below α: Bonferroni matters)
        assert!(!passes_gates(0.0011, -1.0, 0.5, &o, m));
        assert!(passes_gates(0.0011, -1.0, 0.5, &o, 1));
        // ΔBIC alone: zero is not a gain
        assert!(!passes_gates(1e-12, 0.0, 0.5, &o, m));
        // the held-out cut alone
        assert!(!passes_gates(1e-12, -100.0, 0.0999, &o, m));
    }

    /// The backward check removes the effect with the least support among those that fail.
    /// One channel axis, pure noise y and three single-column regressors: a thrust scale
    /// that explains nothing, a thrust against voltage that explains a little (0.02·x) and a
    /// ground effect that explains y well (0.5·x). The ground effect passes; of the two that
    /// fail, the one with the larger ΔBIC (the thrust scale, which fits only noise) leaves.
    #[test]
    fn the_backward_check_removes_the_least_supported_failure() {
        let cols = [cols_of(Effect::ThrustScale).start, cols_of(Effect::ThrustVoltage).start, cols_of(Effect::GroundEffect).start];
        let n = 3000;
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut unif = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let xs: Vec<[f64; 3]> = (0..n).map(|_| [unif(), unif(), unif()]).collect();
        let ys: Vec<f64> = xs.iter().map(|x| 0.02 * x[1] + 0.5 * x[2] + 0.1 * unif()).collect();
        let mut g = Gram {
            cols: cols.to_vec(),
            g_w: DMatrix::zeros(3, 3),
            b_w: DVector::zeros(3),
            yy_w: 0.0,
            n_w: 0,
            g_t: DMatrix::zeros(3, 3),
            b_t: DVector::zeros(3),
            yy_t: 0.0,
            n_t: 0,
            g_r: DMatrix::zeros(3, 3),
            b_r: DVector::zeros(3),
            w_r: 1.0,
        };
        for (i, (x, y)) in xs.iter().zip(&ys).enumerate() {
            let xv = DVector::from_row_slice(x);
            let (gm, bv) = (&xv * xv.transpose(), &xv * *y);
            if i % 3 == 2 {
                g.g_t += gm;
                g.b_t += bv;
                g.yy_t += y * y;
                g.n_t += 1;
            } else {
                g.g_w += &gm;
                g.b_w += &bv;
                g.yy_w += y * y;
                g.n_w += 1;
                g.g_r += gm;
                g.b_r += bv;
            }
        }
        let gs = [g];
        let selected = [Effect::ThrustScale, Effect::ThrustVoltage, Effect::GroundEffect];
        let o = Options::default();
        let scores: Vec<Candidate> = selected
            .iter()
            .map(|e| {
                let rest: Vec<Effect> = selected.iter().copied().filter(|x| x != e).collect();
                score(&gs, &fit(&gs, &set_of(&rest)), &[*e], 1, &o)
            })
            .collect();
        assert!(!scores[0].passed && !scores[1].passed && scores[2].passed, "{scores:#?}");
        assert!(scores[0].delta_bic > scores[1].delta_bic, "{scores:#?}");
        let w = backward_worst(&gs, &selected, &selected, 1, &o).expect("two fail");
        assert_eq!(w.effect, Effect::ThrustScale);
        // nothing to remove when every testable effect passes
        assert!(backward_worst(&gs, &selected, &[Effect::GroundEffect], 1, &o).is_none());
    }

    /// The multiplicative reparameterisation by hand: a thrust scale a = −0.2 and an additive
    /// voltage coefficient b = 0.08 give c = b/(1 + a) = 0.1; with var a = 4·10⁻⁶,
    /// var b = 9·10⁻⁶ and cov(a, b) = 3·10⁻⁶, var c = (9 − 2·0.1·3 + 0.01·4)·10⁻⁶/0.64
    /// = 1.31875·10⁻⁵. The ground effect is treated alike; without a thrust scale in the fit,
    /// b is reported as it is.
    #[test]
    fn a_thrust_multiplier_is_reported_over_the_thrust_scale() {
        let (ts, tv, ge) = (cols_of(Effect::ThrustScale).start, cols_of(Effect::ThrustVoltage).start, cols_of(Effect::GroundEffect).start);
        let mut theta = vec![0.0; N_COLUMNS];
        theta[ts] = -0.2;
        theta[tv] = 0.08;
        theta[ge] = 0.08;
        let cov = DMatrix::from_row_slice(2, 2, &[4e-6, 3e-6, 3e-6, 9e-6]);
        let corr = Corrections::default();
        for (e, col) in [(Effect::ThrustVoltage, tv), (Effect::GroundEffect, ge)] {
            let p = params_of(e, &theta, &cov, &[ts, col], &corr);
            assert_eq!(p.len(), 1);
            assert!((p[0].value - 0.1).abs() < 1e-15, "{e:?}: {}", p[0].value);
            assert!((p[0].ci95 - Z_975 * 1.31875e-5f64.sqrt()).abs() < 1e-12, "{e:?}: {}", p[0].ci95);
            // the fit's order does not matter
            let swapped = DMatrix::from_row_slice(2, 2, &[9e-6, 3e-6, 3e-6, 4e-6]);
            let q = params_of(e, &theta, &swapped, &[col, ts], &corr);
            assert!((q[0].value - p[0].value).abs() < 1e-15 && (q[0].ci95 - p[0].ci95).abs() < 1e-15);
            let alone = params_of(e, &theta, &DMatrix::from_row_slice(1, 1, &[9e-6]), &[col], &corr);
            assert!((alone[0].value - 0.08).abs() < 1e-15 && (alone[0].ci95 - Z_975 * 3e-3).abs() < 1e-15);
        }
    }
}

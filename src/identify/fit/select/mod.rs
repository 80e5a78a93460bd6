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
//! The selection's fits use the training part. With `refit_every_sample` (a calibration), once
//! it ends the chosen model is fitted again on every usable sample (at the narrower of the
//! kernel and `refit_smoothing_s`), and its estimates and intervals are that fit's (the
//! held-out errors reported stay those of the training fit, the only out-of-sample figures).
//!
//! Estimates are weighted least squares on the raw samples, each channel axis weighted by
//! 1/(mean square of its residual under the current model): the weights make the estimate
//! independent of units (m/s² against rad/s) and let each channel count by how well it
//! measures. (Unweighted, the accelerometer's noisy ḟ column, three quarters noise on x and y
//! in simulation, outweighed the gyro's clean ω̇ one, and errors in that variable shrank the
//! mocap delay by 2 %; GLS on the prewhitened problem was tried first: with a near-unit-root
//! AR it fits the dynamics and misses the level, and on real flights the held-out errors rose.)
//! A calibration ([`Options::mount_invariant`]) gives the three axes of the accelerometer one
//! noise model and weight, and the gyro's theirs: a weight per axis weighs an axis by its own
//! misfit, and turning the IMU mixes those weights, so that the calibration of one log moved
//! with the mount it was read in (docs/calibration.md, "A real rig: BROAD").
//! The mocap delay and its drift are the exception: they are read off the prewhitened (GLS)
//! fit, and the others fitted by weighted least squares given them (`gram::prewhitened`): in
//! closed loop the vehicle answers the mocap noise, and only the prewhitened residual is free
//! of what it has answered (docs/px4.md, "How far to trust EKF2_EV_DELAY").
//! Their 95 % intervals are ±1.96·σ from the Newey–West covariance (Bartlett, `hac_lags`) of
//! the weighted scores summed over channel axes per time sample, which allows for the
//! residual's colour and for channels that share a sensor's noise (the delays' own share, and
//! on a fit of every usable sample every parameter's, raised where the residuals' auto- and
//! cross-covariances over the whole flight, Parzen over 2 s, give more, or Parzen-weighted
//! scores corrected for the log's finite length: see `covariance` and [`WholeCovariance`]),
//! plus the systematic of the
//! nominal thrust ([`NominalModel::thrust_rel_sd`](crate::identify::input::series::NominalModel), one factor for
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

use super::design::{Design, DesignOptions, N_COLUMNS, build};
use super::ground::Rest;
use super::note::{Note, Unavailable};
use super::stats::{Ar, Z_975, f_sf};
use crate::effects::{Channel, Effect};
use crate::frames::{Body, MocapBody, MocapNav, Nav, Rot, Vec3};
use crate::identify::input::series::{Corrections, Series};
use nalgebra::{DMatrix, DVector, UnitQuaternion, Vector3};

mod covariance;
mod excitation;
mod gram;
mod heldout;
mod left;
pub(crate) mod plausible;
mod result;
mod widen;

use covariance::{hac, thrust_systematic};
pub use excitation::{Excitation, excitation};
use gram::{Fit, Gram, active, ar_models, canonical_corr, cols_of, fit, grams, heldout_rss, masks, set_of, system};
pub use heldout::{ResidualSeries, channel_cut, evaluate, residual_series};
pub use left::{LEAD_MAX, LEAD_MIN_CORR};
use left::{final_residuals, hypothesis_hint, lead_signals};
pub use result::{AxisError, Candidate, Correlate, Found, Left, Param, Removal, Report, StartMoved, Step, Whiteness};

/// How a fit of every usable sample ([`Options::refit_every_sample`]) takes its covariance. A
/// fit with blocks held out always takes Newey–West's.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum WholeCovariance {
    /// The larger, in the positive semidefinite order, of Newey–West and the stationary
    /// estimate (the residuals' auto- and cross-covariances over 2 s): no interval narrower
    /// than either, whether the noise changes size through the log or stays correlated
    /// beyond Newey–West's lags. Conservative where one of them is right.
    #[default]
    Larger,
    /// The stationary estimate alone: right when the residual is noise whose size does not
    /// change through the log (the sensors' and the mocap's, a model that lacks nothing),
    /// too narrow where it does. Newey–West's Bartlett weights, already below one at the
    /// first lags, break the cancellation of a residual whose spectrum has a zero at the
    /// motion's frequencies (the mocap's positions twice differentiated, under a narrow
    /// kernel) and overstate its variance there.
    Stationary,
    /// Newey–West of the per-sample scores with Parzen weights over the stationary estimate's
    /// window (2 s): a noise whose size changes through the log is in it, as in Newey–West's,
    /// and so are correlations as long as the window, with weights near one over the first
    /// lags, so that a residual's short negative correlations cancel. Each parameter's variance
    /// is then raised by what such a sum leaves out on a log of finite length: the share of the
    /// variance that the fitted parameters take out of the scores over a window (they sum to
    /// zero at the estimate), and the sum's own scatter, carried as Student's t with its
    /// Satterthwaite degrees of freedom (about 50 on a hand-held log of 64 s); together
    /// 3.5–4.5 % on the intervals there.
    Parzen,
}

impl WholeCovariance {
    fn is_default(&self) -> bool {
        *self == WholeCovariance::default()
    }
}

/// The method's settings: design, data-quality gate, gates of the selection, held-out split and
/// noise models.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Options {
    /// How the channels are built (smoothing, minimum height).
    pub design: DesignOptions,
    /// The data-quality gate run before anything is fitted.
    pub quality: super::quality::QualityOptions,
    /// Family-wise level of the F-test (Bonferroni over the candidates of a step).
    pub alpha: f64,
    /// A candidate must cut the held-out error on the channel axes it acts on by this fraction.
    pub min_heldout_gain: f64,
    /// Largest AR order of the noise models (chosen by BIC per channel axis).
    pub max_ar_order: usize,
    /// Length of a held-out block (s).
    pub block_s: f64,
    /// Every this-many-th block is held out.
    pub holdout_every: usize,
    /// Whether the chosen model is fitted again on every usable sample once the selection ends
    /// (its estimates and intervals then use the held-out blocks too); false keeps the
    /// training fit's. On for a calibration (`identify --calibrate`,
    /// [`handheld::options`](crate::identify::handheld::options)), where it was measured
    /// (docs/calibration.md); off by default, the fit the closed-loop delay's and the trials'
    /// coverage were measured with (docs/px4.md, docs/trials.md). (Written in a report only when
    /// on.)
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub refit_every_sample: bool,
    /// Whether a sensor's three axes share one noise model (whitening filter and weight; see
    /// `gram::ar_models`), so that the result does not depend on how the IMU is mounted: a
    /// rotation of its readings rotates the calibration and nothing else. On for a calibration
    /// (with [`Options::refit_every_sample`]); off by default, where each axis weighs by its
    /// own residual, the fit the trials' and the closed-loop delay's figures were measured
    /// with. (Written in a report only when on.)
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub mount_invariant: bool,
    /// The kernel of the fit of every usable sample ([`Options::refit_every_sample`]): σ (s),
    /// taken when narrower than the selection's (`design.smoothing_s`). The selection wants a
    /// wide kernel: its held-out gate compares raw errors, and a narrow one leaves in them the
    /// mocap's twice-differentiated noise, beside which a slow effect (a bias's drift) cuts
    /// nothing. The estimates want a narrow one: a wide kernel smooths products (Rᵀ·p̈,
    /// ω × (ω × r)) factor by factor, an error of 0.15 mm and 0.002° at 2 rad/s and σ = 50 ms,
    /// where the noise it would leave out is whitened by the fit anyway. (Written in a report
    /// only when set.)
    #[serde(skip_serializing_if = "Option::is_none")]
    pub refit_smoothing_s: Option<f64>,
    /// The covariance of a fit of every usable sample ([`WholeCovariance`]). (Written in a
    /// report only when not the default.)
    #[serde(skip_serializing_if = "WholeCovariance::is_default")]
    pub whole_covariance: WholeCovariance,
    /// Most forward steps.
    pub max_steps: usize,
    /// Re-linearisations of the corrections (rotations, delays, lever arm) per fit.
    pub refine_iterations: usize,
    /// Bandwidth of the Newey–West covariance (decimated samples).
    pub hac_lags: usize,
    /// The candidates to consider (default: all that the data has columns for).
    pub candidates: Vec<Effect>,
    /// Effects fitted from the start, without passing the tests (the hypothesis under study,
    /// e.g. the body offset of a real flight); the others are selected on top of them.
    pub forced: Vec<Effect>,
    /// Where the global start searches the clock offset between the IMU and the mocap.
    pub clock: crate::identify::fit::start::ClockWindow,
}

impl Options {
    /// What `identify --calibrate` runs: the calibration's effects fitted without testing
    /// ([`Effect::CALIBRATION`]), any other effect selected on top, the chosen model fitted
    /// again on every usable sample with a kernel of 20 ms at most
    /// ([`Options::refit_smoothing_s`]) and Parzen weights on its scores for the covariance
    /// ([`WholeCovariance::Parzen`]), each sensor's axes sharing one noise model, and the
    /// Gaussian cut where it leaks no mocap noise ([`DesignOptions::reach_sigmas`]).
    pub fn calibration() -> Options {
        Options {
            design: DesignOptions { reach_sigmas: super::design::CALIBRATION_REACH_SIGMAS, ..DesignOptions::default() },
            forced: Effect::CALIBRATION.to_vec(),
            refit_every_sample: true,
            refit_smoothing_s: Some(CALIBRATION_REFIT_SMOOTHING_S),
            mount_invariant: true,
            whole_covariance: WholeCovariance::Parzen,
            ..Options::default()
        }
    }
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
            refit_every_sample: false,
            refit_smoothing_s: None,
            mount_invariant: false,
            whole_covariance: WholeCovariance::default(),
            max_steps: 8,
            refine_iterations: 3,
            hac_lags: 12,
            candidates: Effect::ALL.iter().copied().filter(|e| e.searched()).collect(),
            forced: Vec::new(),
            clock: crate::identify::fit::start::ClockWindow::default(),
        }
    }
}

/// The kernel of a calibration's fit of every usable sample ([`Options::refit_smoothing_s`]), σ (s).
pub const CALIBRATION_REFIT_SMOOTHING_S: f64 = 0.02;

const AXES: [char; 3] = ['x', 'y', 'z'];
/// Fewer usable (decimated) training samples than this and no effect is tried.
pub const MIN_TRAIN_SAMPLES: usize = 200;

/// Whether `train_samples` usable (decimated) training samples are enough to select effects:
/// [`MIN_TRAIN_SAMPLES`] or more. The one boundary the selection, the too-little-clean error
/// and the consistency check share.
pub(crate) fn enough_to_select(train_samples: usize) -> bool {
    train_samples >= MIN_TRAIN_SAMPLES
}

/// The tilt-only form of a world tilt R_w: the rotation R_y(θ)·R_x(φ) (Z-Y-X Euler angles with
/// no yaw) that takes gravity's direction e_D where R_w does, u = R_w·e_D, so φ = −asin u_y and
/// θ = atan2(u_x, u_z). A yaw of the world about gravity, R_w·R_z(ε), is seen by no channel
/// (gravity and the body's rates do not change; positions and attitudes turn together), so
/// every R_w with the same u is one tilt; composing increments about x and y gathers such a yaw
/// (of the order of τ_x·τ_y), which would move the reported roll and pitch off the tilt.
pub(crate) fn level_tilt(r_w: &UnitQuaternion<f64>) -> UnitQuaternion<f64> {
    let u = r_w * Vector3::z();
    UnitQuaternion::from_euler_angles(-u.y.clamp(-1.0, 1.0).asin(), u.x.atan2(u.z), 0.0)
}

/// Folds the linear increments of the correction effects into the corrections; zeroes them.
fn fold(corr: &mut Corrections, theta: &mut [f64], selected: &[Effect]) {
    for e in selected {
        let r = cols_of(*e);
        match e {
            Effect::BodyOffset => {
                let d = Vector3::new(theta[r.start], theta[r.start + 1], theta[r.start + 2]);
                // an increment of the body frame: exp(d)·R_off
                corr.body_offset = Rot::<Body, Body>::from_rotation_vector(Vec3::from_raw(d)) * corr.body_offset;
            }
            Effect::WorldTilt => {
                let d = Vector3::new(theta[r.start], theta[r.start + 1], 0.0);
                // an increment of the true world: R_w·exp(d)
                let tilted: Rot<Nav, MocapNav> =
                    corr.world_tilt * Rot::<Nav, Nav>::from_rotation_vector(Vec3::from_raw(d));
                corr.world_tilt = Rot::from_quaternion(level_tilt(tilted.quaternion()));
            }
            Effect::MocapDelay => corr.mocap_delay_s += theta[r.start],
            Effect::GyroDelay => corr.gyro_delay_s += theta[r.start],
            Effect::LeverArm => corr.lever_arm_m += Vec3::new(theta[r.start], theta[r.start + 1], theta[r.start + 2]),
            _ => continue,
        }
        for j in r {
            theta[j] = 0.0;
        }
    }
}

/// A fitted problem at fixed corrections: the design, the train/held-out split, the Gram
/// matrices of the prewhitened columns, the fit and the covariance of its parameters in the
/// order of `fit.set` (Newey–West plus the thrust systematic).
struct Problem {
    design: Design,
    train: Vec<bool>,
    test: Vec<bool>,
    grams: Vec<Gram>,
    fit: Fit,
    cov: DMatrix<f64>,
}

/// Fits S at the current corrections, folds the exact effects, re-linearises; returns the
/// final state with AR models fitted to the residual of S.
fn refine(s: &Series, o: &Options, corr: &mut Corrections, selected: &[Effect], iterations: usize) -> Problem {
    let set = set_of(selected);
    let mut theta = vec![0.0; N_COLUMNS];
    let mut last = None;
    for it in 0..=iterations {
        let design = build(s, corr, &o.design);
        let (train, test) = masks(s, &design, o);
        // AR of the nominal residual first, then of the residual of S
        let ars0 = ar_models(&design, &train, &theta, o);
        let g0 = grams(&design, &train, &test, &ars0);
        let f0 = fit(&g0, &set);
        let ars = ar_models(&design, &train, &f0.theta, o);
        let grams = grams(&design, &train, &test, &ars);
        let mut f = fit(&grams, &set);
        let has_corrections = selected.iter().any(|e| e.is_correction());
        if it == iterations || !has_corrections {
            // a fit on every usable sample (nothing held out) takes the whole stationary
            // covariance too (see `hac`)
            let whole = (!test.iter().any(|x| *x)).then_some(o.whole_covariance);
            let cov = hac(&design, &train, &grams, &ars, &set, &f.theta, o.hac_lags, covariance::GLS_WINDOW_S, whole)
                + thrust_systematic(&design, &train, &grams, &ars, &set, s.model.thrust_rel_sd);
            last = Some(Problem { design, train, test, grams, fit: f, cov });
            break;
        }
        fold(corr, &mut f.theta, selected);
        theta = f.theta;
    }
    last.expect("at least one iteration")
}

/// Whether a log can test effect `e`: the thrust–voltage effect needs the thrust and the battery
/// voltage; any other needs one of its channels, the force channel only where the log has motor
/// commands (an accelerometer bias also acts in the accelerometer-against-mocap channel, so a log
/// without motors still tests it).
fn available(d: &Design, e: Effect) -> bool {
    match e {
        Effect::ThrustVoltage => d.has_force && d.has_vbat,
        Effect::AccelBiasDrift | Effect::GyroBiasDrift => usable_span_s(d) >= crate::effects::DRIFT_MIN_S,
        _ => e.channels().iter().any(|c| *c != Channel::Force || d.has_force),
    }
}

/// The time from the first to the last usable sample of the design (s); 0 without any.
fn usable_span_s(d: &Design) -> f64 {
    let first = d.ok.iter().position(|ok| *ok);
    let last = d.ok.iter().rposition(|ok| *ok);
    match (first, last) {
        (Some(a), Some(b)) => d.t[b] - d.t[a],
        _ => 0.0,
    }
}

/// Why a log cannot test `e` ([`available`]), for the note on an effect asked for with `--with`.
fn unavailable_reason(d: &Design, e: Effect) -> Option<Unavailable> {
    if available(d, e) {
        return None;
    }
    Some(if e == Effect::ThrustVoltage && d.has_force {
        Unavailable::NoVoltage
    } else if matches!(e, Effect::AccelBiasDrift | Effect::GyroBiasDrift) {
        Unavailable::TooShort { span_s: usable_span_s(d), min_s: crate::effects::DRIFT_MIN_S }
    } else {
        Unavailable::NoMotorCommands
    })
}

/// What the fitted model says of the frames at rest: the body offset O and the world tilt W
/// (identity unless selected) and the accelerometer bias b (zero unless selected), from the
/// folded corrections and the OLS parameters `theta`.
fn rest_frames(
    selected: &[Effect],
    theta: &[f64],
    corr: &Corrections,
) -> (Rot<MocapBody, Body>, Rot<Nav, MocapNav>, Vec3<Body>) {
    let has = |e: Effect| selected.contains(&e);
    let offset = if has(Effect::BodyOffset) { corr.body_offset } else { Rot::identity() };
    let world = if has(Effect::WorldTilt) { corr.world_tilt } else { Rot::identity() };
    let b = cols_of(Effect::AccelBias);
    let bias = if has(Effect::AccelBias) {
        Vec3::new(theta[b.start], theta[b.start + 1], theta[b.start + 2])
    } else {
        Vec3::zeros()
    };
    (offset, world, bias)
}

/// The tilt at rest that the fitted model predicts over the ground check's rows, about their
/// level axes (rad; [`super::ground::predicted_tilt`], exact rotations): the frame part (body
/// offset and world tilt) and the whole (with the bias b), and b itself. Zero without a rest.
fn rest_tilt(s: &Series, rest: Option<&Rest>, selected: &[Effect], theta: &[f64], corr: &Corrections) -> RestTilt {
    let (offset, world, bias) = rest_frames(selected, theta, corr);
    let Some(rest) = rest else {
        return RestTilt { frame: [0.0; 2], total: [0.0; 2], bias };
    };
    let frame = super::ground::predicted_tilt(s, rest, &offset, &world, Vec3::zeros());
    let total = super::ground::predicted_tilt(s, rest, &offset, &world, bias);
    RestTilt { frame, total, bias }
}

/// The model's tilt at rest ([`rest_tilt`]).
struct RestTilt {
    /// Body offset and world tilt (rad).
    frame: [f64; 2],
    /// With the accelerometer bias too (rad): what the ground check reads if the model holds.
    total: [f64; 2],
    /// The accelerometer bias (m/s², IMU body).
    bias: Vec3<Body>,
}

/// The standard deviation (rad) of the whole rest tilt (frame part plus bias, per level axis) by
/// the delta method over the columns of `set` with covariance `cov` (in `set`'s order): the
/// gradient of [`rest_tilt`]'s total with respect to the columns of the body offset (an increment
/// d turns O into exp(d)·O), the world tilt (W·exp(d)) and the bias (b + d), by central
/// differences. Offset and bias trade off in a hover, their sum does not. Zero without a rest.
fn rest_tilt_sd(
    s: &Series,
    rest: Option<&Rest>,
    selected: &[Effect],
    theta: &[f64],
    corr: &Corrections,
    set: &[usize],
    cov: &DMatrix<f64>,
) -> [f64; 2] {
    let Some(rest) = rest else {
        return [0.0; 2];
    };
    let (offset, world, bias) = rest_frames(selected, theta, corr);
    let (o, w, b) = (cols_of(Effect::BodyOffset), cols_of(Effect::WorldTilt), cols_of(Effect::AccelBias));
    const H: f64 = 1e-6;
    let total_at = |j: usize, h: f64| {
        let (mut oq, mut wq, mut bv) = (*offset.quaternion(), *world.quaternion(), *bias.raw());
        let mut d = Vector3::zeros();
        if o.contains(&j) {
            d[j - o.start] = h;
            oq = UnitQuaternion::from_scaled_axis(d) * oq;
        } else if w.contains(&j) {
            d[j - w.start] = h;
            wq *= UnitQuaternion::from_scaled_axis(d);
        } else {
            bv[j - b.start] += h;
        }
        super::ground::predicted_tilt(s, rest, &Rot::from_quaternion(oq), &Rot::from_quaternion(wq), Vec3::from_raw(bv))
    };
    let grads: Vec<(usize, [f64; 2])> = set
        .iter()
        .enumerate()
        .filter(|(_, j)| o.contains(*j) || w.contains(*j) || b.contains(*j))
        .map(|(p, j)| {
            let (plus, minus) = (total_at(*j, H), total_at(*j, -H));
            (p, [0, 1].map(|k| (plus[k] - minus[k]) / (2.0 * H)))
        })
        .collect();
    [0, 1].map(|k| {
        let mut v = 0.0;
        for (p, gp) in &grads {
            for (q, gq) in &grads {
                v += gp[k] * gq[k] * cov[(*p, *q)];
            }
        }
        v.max(0.0).sqrt()
    })
}

/// The values of `e`'s parameters in their report units, from the OLS parameters `theta`
/// (columns of `set`) and the folded corrections.
///
/// The thrust scale and the effects that multiply the thrust (ground effect, thrust against
/// voltage) enter the design additively, T·(1 + a + b·x); the simulation and the fed-back
/// fragment multiply them, T·(1 + a)·(1 + c·x). The same model with c = b/(1 + a) when the
/// thrust scale a is in the fit.
fn values_of(e: Effect, theta: &[f64], set: &[usize], corr: &Corrections) -> Vec<f64> {
    let r = cols_of(e);
    if let Some([(a, _), (b, _)]) = thrust_multiplier(e, set) {
        return vec![multiplier(theta, a, b) * e.params()[0].2];
    }
    let value = |k: usize| -> f64 {
        match e {
            Effect::BodyOffset => {
                let (r, p, y) = corr.body_offset.quaternion().euler_angles();
                [r, p, y][k]
            }
            Effect::WorldTilt => {
                let (r, p, _) = corr.world_tilt.quaternion().euler_angles();
                [r, p][k]
            }
            Effect::MocapDelay => corr.mocap_delay_s + corr.pose_shift_s,
            Effect::GyroDelay => corr.gyro_delay_s,
            Effect::LeverArm => corr.lever_arm_m.to_array()[k],
            _ => theta[r.start + k],
        }
    };
    e.params().iter().enumerate().map(|(k, (_, _, f))| value(k) * f).collect()
}

/// The columns and their positions in `set`, [(thrust scale a), (coefficient b)], when `e`
/// multiplies the thrust and both are in `set`: its value is then reported as c = b/(1 + a)
/// (see [`values_of`]).
fn thrust_multiplier(e: Effect, set: &[usize]) -> Option<[(usize, usize); 2]> {
    if !matches!(e, Effect::GroundEffect | Effect::ThrustVoltage) {
        return None;
    }
    let (scale, col) = (cols_of(Effect::ThrustScale).start, cols_of(e).start);
    let at = |j: usize| set.iter().position(|c| *c == j).map(|p| (j, p));
    Some([at(scale)?, at(col)?])
}

/// The thrust multiplier's coefficient c = b/(1 + a) from the additive design's thrust scale
/// `theta[a]` and coefficient `theta[b]` (see [`values_of`]).
fn multiplier(theta: &[f64], a: usize, b: usize) -> f64 {
    theta[b] / (1.0 + theta[a])
}

/// `e`'s parameters with their 95 % half-widths ±1.96·σ, σ from `cov` (the covariance of the
/// columns of `set`, in its order); for a thrust multiplier c = b/(1 + a) by the delta method,
/// var c = (var b − 2c·cov(a, b) + c²·var a)/(1 + a)².
fn params_of(e: Effect, theta: &[f64], cov: &DMatrix<f64>, set: &[usize], corr: &Corrections) -> Vec<Param> {
    let sd: Vec<f64> = match thrust_multiplier(e, set) {
        Some([(a, pa), (b, pb)]) => {
            let c = multiplier(theta, a, b);
            let var = (cov[(pb, pb)] - 2.0 * c * cov[(pa, pb)] + c * c * cov[(pa, pa)])
                / ((1.0 + theta[a]) * (1.0 + theta[a]));
            vec![var.max(0.0).sqrt()]
        }
        None => cols_of(e)
            .take(e.params().len())
            .map(|j| set.iter().position(|c| *c == j).map_or(0.0, |p| cov[(p, p)].max(0.0).sqrt()))
            .collect(),
    };
    values_of(e, theta, set, corr)
        .into_iter()
        .zip(sd)
        .zip(e.params())
        .map(|((value, sd), (name, unit, f))| Param {
            name: name.to_string(),
            value,
            ci95: Z_975 * sd * f,
            unit: unit.to_string(),
            identifiable: true,
        })
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
    let start = crate::identify::fit::start::start(s, &o.clock, o.design.smoothing_s);
    let from = Corrections { pose_shift_s: s.clocks.pose_shift_s, ..start.corrections() };
    // what the start applied is fitted, untested, from there
    let mut o = o.clone();
    for e in start.forced() {
        if !o.forced.contains(&e) {
            o.forced.push(e);
        }
    }
    let o = &o;
    let (clean, quality) = super::quality::gate(s, &o.quality, o.design.smoothing_s, o.design.min_height_m, &from);
    let mut report = select(&clean, o, from);
    report.moved = result::StartMoved::between(&start, &report);
    report.start = start;
    report.misaligned = plausible::check(&report);
    if !report.misaligned.is_empty() {
        report.unclaimed = std::mem::take(&mut report.effects);
    }
    if !enough_to_select(report.train_samples) && quality.corrupted().next().is_some() {
        return Err(IdentifyError::TooLittleClean {
            log: s.source.clone(),
            usable: report.train_samples,
            needed: MIN_TRAIN_SAMPLES,
            cuts: quality.describe(),
        });
    }
    if !quality.cuts.is_empty() {
        report.notes.insert(
            0,
            Note::DataQualityCut {
                rows_cut: quality.rows_cut,
                rows: quality.rows,
                margin_s: o.quality.margin_s,
                cuts: quality.cuts.clone(),
            },
        );
    }
    report.data_quality = quality;
    Ok(report)
}

/// The log with what the data-quality gate cuts taken out of its segments: every error and
/// plot is computed on the samples the fit saw, never on corrupted ones. `from` is the start the
/// gate compares the IMU and the mocap through.
fn gated(s: &Series, o: &Options, from: &Corrections) -> Series {
    super::quality::gate(s, &o.quality, o.design.smoothing_s, o.design.min_height_m, from).0
}

/// Why [`identify`] gives no report.
#[derive(Debug, thiserror::Error)]
pub enum IdentifyError {
    /// The data-quality gate cut so much that too little remains to fit anything.
    #[error(
        "{log}: only {usable} usable training samples remain after the data-quality gate ({needed} needed), so nothing is identified; what was cut:\n  {}",
        cuts.join("\n  ")
    )]
    TooLittleClean {
        /// The log's source name.
        log: String,
        /// Usable training samples left.
        usable: usize,
        /// Usable training samples needed ([`MIN_TRAIN_SAMPLES`]).
        needed: usize,
        /// What the gate cut, one line per stretch.
        cuts: Vec<String>,
    },
}

/// The change of the Bayesian information criterion n·ln(RSS/n) + k·ln n when k parameters
/// take the residual sum of squares from `rss_base` to `rss` over n samples (negative: better).
fn bic_change(n: f64, rss_base: f64, rss: f64, k: f64) -> f64 {
    n * (rss / rss_base).ln() + k * n.ln()
}

/// The nested-model F-test of k added parameters: F = ((RSS₀ − RSS₁)/k) / (RSS₁/(n − p)) with p
/// the parameters of the larger model, and its p-value P(F(k, n − p) > F).
fn f_test(rss_base: f64, rss: f64, k: f64, n: f64, p: f64) -> (f64, f64) {
    let f = ((rss_base - rss) / k) / (rss / (n - p));
    (f, f_sf(f, k, n - p))
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
    let delta_bic = bic_change(n, base.rss, f1.rss, k);
    let (f, p_value) = f_test(base.rss, f1.rss, k, n, set.len() as f64);
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
    let rr = (yy - 2.0 * th_s.dot(&b.rows(0, nb)) + (th_s.transpose() * g.view((0, 0), (nb, nb)) * &th_s)[(0, 0)])
        .max(1e-300);
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
    o.candidates
        .iter()
        .copied()
        .filter(|e| !selected.contains(e) && !removed.iter().any(|r| r.check.effect == *e) && available(d, *e))
        .collect()
}

/// The backward check's verdict on the selected set: each `testable` effect is scored on top
/// of every other selected one, as one of `outside + 1` candidates for the Bonferroni level
/// (the `outside` ones a forward step would try now, and itself); of those that fail a gate,
/// the one with the largest ΔBIC (the least support) leaves. None when all pass.
fn backward_worst(
    gs: &[Gram],
    selected: &[Effect],
    testable: &[Effect],
    outside: usize,
    o: &Options,
) -> Option<Candidate> {
    let tests = outside + 1;
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

/// Whether `e` joined the model as one of a pair: each alone fails the held-out gate by
/// construction, so neither is re-tested by the backward check.
fn joined_as_pair(steps: &[Step], e: Effect) -> bool {
    steps.iter().any(|st| st.together_with.is_some() && (st.added == e || st.together_with == Some(e)))
}

/// The search's state: the selected set, fitted at its folded corrections, and what the steps
/// and backward checks did so far.
struct Search {
    selected: Vec<Effect>,
    state: Problem,
    corr: Corrections,
    steps: Vec<Step>,
    removed: Vec<Removal>,
    /// The candidates of the step that found none passing (the last forward step).
    final_candidates: Vec<Candidate>,
}

impl Search {
    /// Fits the forced effects (those with columns in the data) without testing them.
    fn force(&mut self, s: &Series, o: &Options, notes: &mut Vec<Note>) {
        for e in &o.forced {
            if let Some(why) = unavailable_reason(&self.state.design, *e) {
                notes.push(Note::LeftOut { effect: *e, why });
            } else if !self.selected.contains(e) {
                self.selected.push(*e);
            }
        }
        if !self.selected.is_empty() {
            self.refit(s, o);
            notes.push(Note::Forced { effects: self.selected.clone() });
        }
    }

    /// Refits the selected set from the current corrections.
    fn refit(&mut self, s: &Series, o: &Options) {
        let mut c2 = self.corr;
        self.state = refine(s, o, &mut c2, &self.selected, o.refine_iterations);
        self.corr = c2;
    }

    /// Forward steps, each followed by the backward check, until no candidate passes, none is
    /// left or `max_steps` is reached.
    fn run(&mut self, s: &Series, o: &Options, notes: &mut Vec<Note>) {
        // every pass but the last adds a step, so max_steps + 1 passes are all there can be: the
        // bound makes termination hold by construction, not only by the steps' count (a pass
        // that added nothing and went on would otherwise spin for ever)
        for _ in 0..=o.max_steps {
            // (every pass of the loop after the first follows a step)
            if !self.steps.is_empty() {
                self.backward(s, o);
            }
            if self.steps.len() >= o.max_steps {
                notes.push(Note::MaxSteps { steps: o.max_steps });
                break;
            }
            if !self.forward(s, o) {
                break;
            }
        }
    }

    /// The backward check, once after every step: an effect that joined early may be explained
    /// by the ones that joined after it (a constant force taken first for a force-channel
    /// offset that an accelerometer bias and a thrust scale explain once both are in). Each
    /// linear effect must still pass the gates that let it in, now on top of all the others;
    /// the worst that fails leaves for good (it cannot re-enter, so the selection terminates),
    /// and the forward steps go on from the smaller model. Corrections (rotations, delay, lever
    /// arm) are folded into the trajectory and are not re-tested; nor is a pair that joined
    /// together (each alone fails by construction) or a forced effect.
    fn backward(&mut self, s: &Series, o: &Options) {
        let testable: Vec<Effect> = self
            .selected
            .iter()
            .copied()
            .filter(|e| !e.is_correction() && !o.forced.contains(e) && !joined_as_pair(&self.steps, *e))
            .collect();
        let outside = pool_of(o, &self.state.design, &self.selected, &self.removed).len();
        if let Some(w) = backward_worst(&self.state.grams, &self.selected, &testable, outside, o) {
            self.selected.retain(|x| *x != w.effect);
            self.refit(s, o);
            self.removed.push(Removal { after_step: self.steps.len(), check: w });
        }
    }

    /// One forward step: the candidate (or pair) that passes the gates with the lowest ΔBIC
    /// joins. False when none is left or none passes (its candidates are then kept as the
    /// final ones).
    fn forward(&mut self, s: &Series, o: &Options) -> bool {
        let pool = pool_of(o, &self.state.design, &self.selected, &self.removed);
        if pool.is_empty() {
            return false;
        }
        let state = &self.state;
        // the noise model for the tests comes from the residual of the largest model (S and
        // every candidate): an AR fitted to a residual that still holds an effect would model
        // the effect as noise and whiten it away
        let mut full: Vec<Effect> = self.selected.clone();
        full.extend(&pool);
        let grams_test = {
            let white: Vec<Ar> = active(&state.design).iter().map(|_| Ar::white(1.0)).collect();
            let g_ols = grams(&state.design, &state.train, &state.test, &white);
            let f_ols = fit(&g_ols, &set_of(&full));
            let ars = ar_models(&state.design, &state.train, &f_ols.theta, o);
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
        let near = pair_candidates(&cands, o.alpha);
        let tests = tests_with_pairs(pool.len(), near.len());
        let pair = best_pair(&near, |a, b| score(&[a, b], tests));
        let Some((best, partner)) = round_winner(&cands, pair) else {
            self.final_candidates = cands;
            return false;
        };
        let mut unident = Vec::new();
        for c in cands.iter().filter(|c| c.effect != best.effect && c.passed) {
            let rho = canonical_corr(&grams_test, &base.set, &set_of(&[best.effect]), &set_of(&[c.effect]));
            if rho > 0.99 {
                unident.push((c.effect, rho));
            }
        }
        self.selected.push(best.effect);
        self.selected.extend(partner);
        self.refit(s, o);
        let (fit, cov, corr) = (&self.state.fit, &self.state.cov, &self.corr);
        let params = self.selected.iter().flat_map(|e| params_of(*e, &fit.theta, cov, &fit.set, corr)).collect();
        self.steps.push(Step {
            added: best.effect,
            together_with: partner,
            delta_bic: best.delta_bic,
            p_value: best.p_value,
            heldout_gain: best.heldout_gain,
            candidates: cands,
            not_identifiable_from: unident,
            params,
        });
        true
    }

    /// The pairs the data cannot tell apart, with a note for each: those the kept steps named,
    /// and the two frame effects whatever was selected.
    fn identifiability(&self, yaw_spread_deg: f64, notes: &mut Vec<Note>) -> Vec<(Effect, Effect, f64)> {
        let (steps, selected, state) = (&self.steps, &self.selected, &self.state);
        let mut not_identifiable: Vec<(Effect, Effect, f64)> = kept_steps(steps, &self.removed)
            .flat_map(|st| st.not_identifiable_from.iter().map(|(e, rho)| (st.added, *e, *rho)))
            .collect();
        // the frame pair, unless a kept step named it already (in either order)
        let frames = [Effect::BodyOffset, Effect::WorldTilt];
        let named = not_identifiable.iter().any(|(a, b, _)| frames.contains(a) && frames.contains(b));
        if (selected.contains(&Effect::BodyOffset) || selected.contains(&Effect::WorldTilt)) && !named {
            let rho = canonical_corr(&state.grams, &[], &set_of(&[Effect::WorldTilt]), &set_of(&[Effect::BodyOffset]));
            if rho > 0.99 {
                // the one not selected (if both were, the pair is still named)
                let (a, b) = if selected.contains(&Effect::BodyOffset) {
                    (Effect::BodyOffset, Effect::WorldTilt)
                } else {
                    (Effect::WorldTilt, Effect::BodyOffset)
                };
                not_identifiable.push((a, b, rho));
                notes.push(Note::FramesNotApart { correlation: rho, yaw_spread_deg });
            }
        }
        for st in kept_steps(steps, &self.removed) {
            for (e, rho) in &st.not_identifiable_from {
                notes.push(Note::ChosenOver { chosen: st.added, rival: *e, correlation: *rho, yaw_spread_deg });
            }
        }
        // a mocap that leads the IMU is no latency: a clock offset between the streams, or a
        // delay of the gyro alone (which shares the mocap delay's gyro column and is not searched)
        if selected.contains(&Effect::MocapDelay)
            && self.corr.mocap_delay_s + self.corr.pose_shift_s < 0.0
            && !selected.contains(&Effect::GyroDelay)
        {
            notes.push(Note::MocapLeadsImu { delay_s: self.corr.mocap_delay_s + self.corr.pose_shift_s });
        }
        not_identifiable
    }
}

/// The steps whose added effect the backward check did not remove later: only their rivals
/// are reported as not identifiable (a removed effect is not in the model, so "chosen over"
/// would be false).
fn kept_steps<'a>(steps: &'a [Step], removed: &'a [Removal]) -> impl Iterator<Item = &'a Step> + 'a {
    steps.iter().filter(move |st| !removed.iter().any(|r| r.check.effect == st.added))
}

/// The step that added `e` (and was kept) named `c` as not identifiable from it.
fn named_at_step(steps: &[Step], removed: &[Removal], e: Effect, c: Effect) -> bool {
    kept_steps(steps, removed).any(|st| st.added == e && st.not_identifiable_from.iter().any(|x| x.0 == c))
}

/// The candidates of a round that are tried in pairs: each failed its gates, yet alone is
/// significant at the Bonferroni level α/m over the round's m candidates and pays for its
/// parameters (ΔBIC < 0).
fn pair_candidates(cands: &[Candidate], alpha: f64) -> Vec<Effect> {
    let level = alpha / cands.len() as f64;
    cands.iter().filter(|c| !c.passed && c.p_value < level && c.delta_bic < 0.0).map(|c| c.effect).collect()
}

/// The passing pair of `near` (each unordered pair once, scored by `score`) with the lowest
/// ΔBIC, the first in order on a tie: its scoreboard and the partner that joins with its first
/// effect. None when no pair passes.
fn best_pair(near: &[Effect], mut score: impl FnMut(Effect, Effect) -> Candidate) -> Option<(Effect, Candidate)> {
    let mut pair: Option<(Effect, Candidate)> = None;
    for (i, a) in near.iter().enumerate() {
        for b in &near[i + 1..] {
            let c = score(*a, *b);
            if c.passed && pair.as_ref().is_none_or(|(_, p)| c.delta_bic < p.delta_bic) {
                pair = Some((*b, c));
            }
        }
    }
    pair
}

/// A round's winner: the passing pair (its scoreboard and the partner that joins with its first
/// effect) when its ΔBIC is strictly lower than every passing single's, else the passing single
/// with the lowest ΔBIC; None when nothing passed.
fn round_winner(cands: &[Candidate], pair: Option<(Effect, Candidate)>) -> Option<(Candidate, Option<Effect>)> {
    let best_single = cands.iter().filter(|c| c.passed).min_by(|a, b| a.delta_bic.total_cmp(&b.delta_bic)).cloned();
    match (best_single, pair) {
        (Some(s1), Some((b, p))) if p.delta_bic < s1.delta_bic => Some((p, Some(b))),
        (Some(s1), _) => Some((s1, None)),
        (None, Some((b, p))) => Some((p, Some(b))),
        (None, None) => None,
    }
}

/// The number of tests a pair is judged among (its Bonferroni count): the round's m singles and
/// the r(r − 1)/2 pairs of its r pair candidates.
fn tests_with_pairs(singles: usize, near: usize) -> usize {
    singles + near * near.saturating_sub(1) / 2
}

/// Notes on the nominal fit's data (too few usable samples, glitches left out); true when
/// there are too few samples to select anything.
fn gate_notes(s: &Series, nominal: &Problem, o: &Options, notes: &mut Vec<Note>) -> bool {
    let usable = nominal.train.iter().filter(|x| **x).count();
    let too_few = !enough_to_select(usable);
    if s.model.rigid_body || !nominal.design.has_force {
        notes.push(Note::NoForceModel { rigid_body: s.model.rigid_body });
    }
    if too_few {
        notes.push(Note::TooFewSamples { usable, needed: MIN_TRAIN_SAMPLES, min_height_m: o.design.min_height_m });
    }
    if nominal.design.outliers > 0 {
        notes.push(Note::Glitches {
            count: nominal.design.outliers,
            sigmas: super::design::GLITCH_SIGMAS,
            window_ms: (3.0 * o.design.smoothing_s * 1e3).round(),
        });
    }
    too_few
}

/// The options of the final fit: `o` with nothing held out, at the narrower of its kernel and
/// [`Options::refit_smoothing_s`]. The held-out blocks choose the effects and score the chosen
/// model out of sample; once chosen, the model's estimates and intervals use every usable
/// sample (docs/calibration.md, "What each choice bought").
fn every_sample(o: &Options) -> Options {
    let mut design = o.design;
    if let Some(sigma) = o.refit_smoothing_s {
        design.smoothing_s = design.smoothing_s.min(sigma);
    }
    Options { holdout_every: usize::MAX, design, ..o.clone() }
}

/// The selection on a gated flight, its corrections starting at `from` (the global start's).
fn select(s: &Series, o: &Options, from: Corrections) -> Report {
    let mut notes = Vec::new();
    let mut corr = from;
    let nominal = refine(s, o, &mut corr, &[], 0);
    let too_few = gate_notes(s, &nominal, o, &mut notes);
    let mut search = Search {
        selected: Vec::new(),
        state: nominal,
        corr,
        steps: Vec::new(),
        removed: Vec::new(),
        final_candidates: Vec::new(),
    };
    if !too_few {
        search.force(s, o, &mut notes);
        search.run(s, o, &mut notes);
    }
    let yaw_spread_deg = search.state.design.yaw_spread_rad.to_degrees();

    // errors before (nominal, no corrections) → after, on the held-out part, of the model
    // fitted on the training part: the only figures that score it out of sample
    let nominal_design = build(s, &Corrections::default(), &o.design);
    let (trained, trained_corr) = (&search.state, search.corr);
    // the same design with the measured signals, for the leads of what is left
    let with_signals = super::design::build_with_signals(s, &trained_corr, &o.design);
    let lead_sigs = lead_signals(&with_signals);
    let (errors, whiteness, left) = final_residuals(
        &trained.design,
        &trained.fit.theta,
        &trained.test,
        &nominal_design,
        &lead_sigs,
        o.max_ar_order,
    );
    let split = (trained.train.iter().filter(|x| **x).count(), trained.test.iter().filter(|x| **x).count());

    // the chosen model's estimates and intervals from every usable sample, when asked
    let last = if o.refit_every_sample { every_sample(o) } else { o.clone() };
    if !too_few && o.refit_every_sample {
        search.refit(s, &last);
    }
    let mut not_identifiable = search.identifiability(yaw_spread_deg, &mut notes);
    notes.extend(hypothesis_hint(&left, &search.selected));
    let (state, corr, selected) = (&search.state, search.corr, &search.selected);
    let mut effects: Vec<Found> = selected
        .iter()
        .map(|e| Found {
            effect: *e,
            name: e.name().into(),
            params: params_of(*e, &state.fit.theta, &state.cov, &state.fit.set, &corr),
        })
        .collect();
    let (ground_check, ground_agreement) = if too_few {
        (super::ground::ground_check(s), None)
    } else {
        ground(s, &last, &search, yaw_spread_deg, &mut not_identifiable, &mut effects, &mut notes)
    };
    Report {
        source: s.source.clone(),
        samples: s.len(),
        train_samples: split.0,
        heldout_samples: split.1,
        channels: Channel::ALL.into_iter().filter(|c| *c != Channel::Force || state.design.has_force).collect(),
        model: s.model.clone(),
        options: o.clone(),
        final_candidates: search.final_candidates,
        removed: search.removed,
        steps: search.steps,
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
        corrections: corr,
        theta: search.state.fit.theta.clone(),
        start: crate::identify::fit::start::Start::default(),
        moved: result::StartMoved::default(),
        misaligned: Vec::new(),
        unclaimed: Vec::new(),
    }
}

/// The tilt at rest the selected model predicts, widened where the flight cannot tell two
/// models apart, against the ground check (before take-off, during the spin-up, after landing).
fn ground(
    s: &Series,
    o: &Options,
    search: &Search,
    yaw_spread_deg: f64,
    not_identifiable: &mut Vec<(Effect, Effect, f64)>,
    effects: &mut [Found],
    notes: &mut Vec<Note>,
) -> (Option<super::ground::GroundCheck>, Option<super::ground::GroundAgreement>) {
    let (state, selected) = (&search.state, &search.selected);
    let rest = super::ground::rest_before_takeoff(s);
    let tilt = rest_tilt(s, rest.as_ref(), selected, &state.fit.theta, &search.corr);
    let tilt_sd = rest_tilt_sd(s, rest.as_ref(), selected, &state.fit.theta, &search.corr, &state.fit.set, &state.cov);
    let mut tilt_widen = [0.0f64; 2];
    let fin = widen::Final { s, o, state, corr: search.corr, selected, rest };
    widen::swaps(
        &fin,
        |e, c| named_at_step(&search.steps, &search.removed, e, c),
        tilt.total,
        yaw_spread_deg,
        not_identifiable,
        effects,
        &mut tilt_widen,
        notes,
    );
    widen::half_supported(&fin, &search.final_candidates, tilt_sd, effects, &mut tilt_widen, notes);
    // the widening is an extra half-width beyond the fit's own
    let tilt_widen = [0, 1].map(|k| widen::beyond_own(tilt_widen[k], Z_975 * tilt_sd[k]));
    let ground_check = super::ground::ground_check(s);
    let ground_agreement = ground_check.as_ref().and_then(|raw| {
        super::ground::tilt_at_rest(s, tilt.bias).map(|corrected| {
            let flight = super::ground::FlightTilt {
                offset_rad: tilt.frame,
                sd_rad: tilt_sd,
                widen_rad: tilt_widen,
                frame_fitted: selected.contains(&Effect::BodyOffset) || selected.contains(&Effect::WorldTilt),
                accel_bias_fitted: selected.contains(&Effect::AccelBias),
            };
            super::ground::agreement(
                raw,
                &corrected,
                &flight,
                super::ground::spin_up(s, tilt.bias).as_ref(),
                super::ground::tilt_after_landing(s, tilt.bias).as_ref(),
            )
        })
    });
    if let Some(a) = &ground_agreement {
        notes.extend(super::note::of_ground_agreement(a));
    }
    if let Some(off) = super::ground::rest_off_axis_deg(s)
        .filter(|off| ground_check.is_none() && *off > super::ground::MAX_REST_OFF_AXIS_DEG)
    {
        notes.push(Note::RestOffAxis { off_axis_deg: off });
    }
    (ground_check, ground_agreement)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::identify::input::series::NominalModel;

    /// The level form of a world tilt keeps gravity's direction in the mocap world and has no
    /// yaw: R_w·R_z(ε) (the same tilt under a yaw no sensor sees) levels to R_y(θ)·R_x(φ) itself,
    /// for tilts of 6° and 40°. Composing increments about x and y (the fold) gathers such a yaw:
    /// 6° of roll then 2° of pitch, as increments, carry a yaw of about τ_x·τ_y/2 = 0.1°, and
    /// leave roll and pitch off the tilt's by 0.005–0.01° unless levelled.
    #[test]
    fn a_world_tilt_levels_to_its_gravity_direction_without_yaw() {
        for (phi, theta) in [(6f64.to_radians(), -2f64.to_radians()), (0.7, 0.3)] {
            let level = UnitQuaternion::from_euler_angles(phi, theta, 0.0);
            for eps in [0.0, 0.3, -1.2] {
                let got = level_tilt(&(level * UnitQuaternion::from_euler_angles(0.0, 0.0, eps)));
                assert!(got.angle_to(&level) < 1e-12, "φ {phi} θ {theta} ε {eps}: {:?}", got.euler_angles());
            }
        }
        let composed = UnitQuaternion::from_scaled_axis(Vector3::new(6f64.to_radians(), 0.0, 0.0))
            * UnitQuaternion::from_scaled_axis(Vector3::new(0.0, 2f64.to_radians(), 0.0));
        let (r, p, y) = composed.euler_angles();
        let (lr, lp, ly) = level_tilt(&composed).euler_angles();
        let u = composed * Vector3::z();
        assert!(ly.abs() < 1e-15 && (level_tilt(&composed) * Vector3::z() - u).norm() < 1e-15, "{lr} {lp} {ly}");
        assert!(
            y.abs() > 1e-3 && ((r - lr).abs() + (p - lp).abs()).to_degrees() > 1e-3,
            "{r} {p} {y} against {lr} {lp}"
        );
    }

    /// `refine` folds a correction over its iterations. The swing of [`Series::swing_for_tests`] (a
    /// ±0.01 m/s² alternation on the IMU) is seen through markers turned by R_off = (0.6°, −0.4°,
    /// 1.0°); with the body offset selected, three iterations bring corr.body_offset to R_off (to
    /// 4·10⁻⁶°; the tolerance is 0.01°). A bug it catches: the loop's stop `it == iterations ||
    /// !has_corrections` as `&&` (it never keeps a pass: `expect` panics) and `==` as `!=` (it
    /// returns before folding).
    #[test]
    fn refine_folds_a_marker_offset_into_the_body_offset() {
        let r_off = UnitQuaternion::from_euler_angles(0.6f64.to_radians(), -0.4f64.to_radians(), 1.0f64.to_radians());
        let s = Series::swing_for_tests(r_off, 0.01);
        let mut corr = Corrections::default();
        refine(&s, &Options::default(), &mut corr, &[Effect::BodyOffset], 3);
        let err = (corr.body_offset.quaternion().inverse() * r_off).angle().to_degrees();
        assert!(
            err < 0.01,
            "body offset {:?} against R_off {:?}: {err}°",
            corr.body_offset.quaternion().euler_angles(),
            r_off.euler_angles()
        );
    }

    /// The final fit's covariance is the statistical (Newey–West) one plus the thrust systematic,
    /// added (see `covariance::thrust_systematic`): with the thrust scale in the model, a nominal
    /// thrust known to σ_T = 5 % adds σ_T² = 0.0025 to its variance, and no data averages it away.
    /// On [`Series::swing_for_tests`] the statistical part is at most ~3·10⁻¹⁰ (a ±0.01 m/s²
    /// alternation over 4000 samples of a 9.81 m/s² column, 10⁻⁴/(4000·9.81²), before the
    /// Newey–West weights, which cancel an alternation further: 0 to rounding here), so the
    /// variance is σ_T² to 10⁻⁶ of itself. A bug it catches: the sum as a difference (a negative
    /// variance) and as a product.
    #[test]
    fn the_thrust_scales_variance_adds_the_thrust_systematic_to_the_statistical() {
        let mut s = Series::swing_for_tests(UnitQuaternion::identity(), 0.01);
        s.model.thrust_rel_sd = 0.05;
        let p = refine(&s, &Options::default(), &mut Corrections::default(), &[Effect::ThrustScale], 3);
        assert_eq!(p.cov.shape(), (1, 1));
        let var = p.cov[(0, 0)];
        assert!(
            (0.0025..0.0025 * (1.0 + 1e-6)).contains(&var),
            "thrust-scale variance {var}, want 0.0025 plus a statistical part under 3e-10"
        );
    }

    /// A still rest of 100 rows at yaw `yaw` (rad), markers level: the mocap reports R_z(yaw).
    fn rest_at_yaw(yaw: f64) -> (Series, Rest) {
        let n = 100;
        let s = Series {
            source: "rest".into(),
            t_s: (0..n).map(|i| i as f64 * 0.01).collect(),
            pos_mocap_nav: vec![Vec3::zeros(); n],
            att_mocap: vec![Rot::from_quaternion(UnitQuaternion::from_euler_angles(0.0, 0.0, yaw)); n],
            mocap_ok: vec![true; n],
            gyro_body: vec![Vec3::zeros(); n],
            accel_body: vec![Vec3::new(0.0, 0.0, -9.81); n],
            thrust_n: None,
            vbat_v: None,
            segments: vec![(0, n)],
            model: NominalModel::for_tests(9.81),
            repairs: vec![],
            clocks: Default::default(),
        };
        (s, Rest { start: 0, end: n, up: super::super::ground::UpAxis::Z })
    }

    /// The model's tilt at rest composes rotations exactly, by hand for rotations about level
    /// axes (a rotation by α about a horizontal n turns gravity by exactly α·n):
    /// - a world tilt exp(α·n) (6°) seen at rest yaw ψ is α·R_z(−ψ)·n in the body;
    /// - a body offset's yaw ψ_o turns it further, α·R_z(ψ_o − ψ)·n: a mocap body defined 60°
    ///   off the IMU in yaw turns the tilt by 60°, which the offset's Euler roll and pitch leave
    ///   out (3° of yaw on a 6° tilt already moves it by 0.3°);
    /// - a body offset exp(α·m) alone is α·m, where its Euler roll and pitch are off by ~α²/4;
    /// - a level bias b reads as atan(|b|/g) about (b_y, −b_x, 0)/|b| (f = −g·e_z + b), and as
    ///   b_y/g in roll only to first order;
    /// - effects not selected add nothing, whatever the corrections hold.
    #[test]
    fn the_rest_tilt_composes_the_frames_exactly() {
        let (g, yaw, alpha, beta) = (9.81, 0.3_f64, 6f64.to_radians(), 0.7_f64);
        let (s, rest) = rest_at_yaw(yaw);
        let n = Vector3::new(beta.cos(), beta.sin(), 0.0);
        let tilt = UnitQuaternion::from_scaled_axis(n * alpha);
        let theta = vec![0.0; N_COLUMNS];
        let near =
            |got: [f64; 2], want: Vector3<f64>| (got[0] - want.x).abs() < 1e-12 && (got[1] - want.y).abs() < 1e-12;
        let corr = Corrections { world_tilt: Rot::from_quaternion(tilt), ..Corrections::default() };
        let t = rest_tilt(&s, Some(&rest), &[Effect::WorldTilt], &theta, &corr);
        let want = UnitQuaternion::from_euler_angles(0.0, 0.0, -yaw) * n * alpha;
        assert!(near(t.frame, want) && near(t.total, want), "{:?} against {want:?}", t.frame);
        let psi_o = 60f64.to_radians();
        let corr = Corrections {
            world_tilt: Rot::from_quaternion(tilt),
            body_offset: Rot::from_quaternion(UnitQuaternion::from_euler_angles(0.0, 0.0, psi_o)),
            ..Corrections::default()
        };
        let t = rest_tilt(&s, Some(&rest), &[Effect::BodyOffset, Effect::WorldTilt], &theta, &corr);
        let want = UnitQuaternion::from_euler_angles(0.0, 0.0, psi_o - yaw) * n * alpha;
        assert!(near(t.frame, want), "{:?} against {want:?}", t.frame);
        let corr = Corrections { body_offset: Rot::from_quaternion(tilt), ..Corrections::default() };
        let t = rest_tilt(&s, Some(&rest), &[Effect::BodyOffset], &theta, &corr);
        assert!(near(t.frame, n * alpha), "{:?}", t.frame);
        let (r, p, _) = tilt.euler_angles();
        assert!((r - alpha * n.x).abs() > 1e-5 || (p - alpha * n.y).abs() > 1e-5, "the Euler angles would have done");
        let b = cols_of(Effect::AccelBias);
        let mut theta_b = theta.clone();
        let bias = Vector3::new(-1.5, 2.5, 0.0);
        theta_b[b.start..b.end].copy_from_slice(bias.as_slice());
        let t = rest_tilt(&s, Some(&rest), &[Effect::AccelBias], &theta_b, &Corrections::default());
        let want = Vector3::new(bias.y, -bias.x, 0.0).normalize() * (bias.norm() / g).atan();
        assert!(near(t.total, want) && t.frame == [0.0; 2] && *t.bias.raw() == bias, "{:?} against {want:?}", t.total);
        assert!((t.total[0] - bias.y / g).abs() > 1e-3, "first order would have done");
        // nothing selected: nothing, and no rest: nothing
        let corr = Corrections {
            world_tilt: Rot::from_quaternion(tilt),
            body_offset: Rot::from_quaternion(tilt),
            ..Corrections::default()
        };
        let t = rest_tilt(&s, Some(&rest), &[], &theta_b, &corr);
        assert_eq!((t.frame, t.total, *t.bias.raw()), ([0.0; 2], [0.0; 2], Vector3::zeros()));
        let t = rest_tilt(&s, None, &[Effect::BodyOffset, Effect::WorldTilt], &theta_b, &corr);
        assert_eq!((t.frame, t.total), ([0.0; 2], [0.0; 2]));
    }

    /// The spread of the whole rest tilt by the delta method, at a level rest at yaw ψ with no
    /// offset, tilt or bias yet, where the gradients are by hand: roll over (o_x, w_x·c, w_y·s,
    /// b_y/g), pitch over (o_y, −w_x·s, w_y·c, −b_x/g), the offset's yaw none; with the
    /// covariances' cross terms. Every column has its own variance, so a gradient that picks the
    /// wrong column (b_x for roll's b_y) or drops one changes the result; the covariances of
    /// pitch's w_x and of roll's w_y with the offset give each world-tilt gradient's sign a cross
    /// term (a bug it catches: −s as s, which the variances alone square away).
    #[test]
    fn the_rest_tilt_spread_is_the_delta_method_over_the_frames() {
        let (g, yaw) = (9.81, 0.3_f64);
        let (c, s) = (yaw.cos(), yaw.sin());
        let (series, rest) = rest_at_yaw(yaw);
        let selected = [Effect::BodyOffset, Effect::WorldTilt, Effect::AccelBias];
        let set = set_of(&selected);
        let (o, w, b) = (cols_of(Effect::BodyOffset), cols_of(Effect::WorldTilt), cols_of(Effect::AccelBias));
        let at = |j: usize| set.iter().position(|x| *x == j).unwrap();
        let var = |j: usize| 1e-4 * (1.0 + at(j) as f64);
        let mut cov = DMatrix::from_fn(set.len(), set.len(), |p, q| if p == q { 1e-4 * (1.0 + p as f64) } else { 0.0 });
        let mut put = |i: usize, j: usize, k: f64| {
            cov[(at(i), at(j))] = k;
            cov[(at(j), at(i))] = k;
        };
        let (k1, k2, k3, k4, k5) = (3e-5, -2e-5, 1.5e-5, -2.5e-5, 4e-5);
        put(o.start, b.start + 1, k1);
        put(o.start + 1, b.start, k2);
        put(o.start + 1, w.start, k3);
        put(o.start, w.start + 1, k4);
        // the offset's yaw with the roll: no gradient, so no term
        put(o.start + 2, o.start, k5);
        let theta = vec![0.0; N_COLUMNS];
        let sd = rest_tilt_sd(&series, Some(&rest), &selected, &theta, &Corrections::default(), &set, &cov);
        let roll = var(o.start)
            + c * c * var(w.start)
            + s * s * var(w.start + 1)
            + var(b.start + 1) / (g * g)
            + 2.0 * k1 / g
            + 2.0 * k4 * s;
        let pitch = var(o.start + 1) + s * s * var(w.start) + c * c * var(w.start + 1) + var(b.start) / (g * g)
            - 2.0 * k2 / g
            - 2.0 * k3 * s;
        assert!(
            (sd[0] - roll.sqrt()).abs() < 1e-9 && (sd[1] - pitch.sqrt()).abs() < 1e-9,
            "{sd:?} against {} {}",
            roll.sqrt(),
            pitch.sqrt()
        );
        assert_eq!(rest_tilt_sd(&series, None, &selected, &theta, &Corrections::default(), &set, &cov), [0.0; 2]);
    }

    /// The F-test by hand: RSS 120 → 100 with k = 2 added of p = 4, n = 54: F = (20/2)/(100/50) =
    /// 5, and F(2, d₂)'s survival function is (1 + 2x/d₂)^(−d₂/2), so p = 1.2^−25 = 0.01048 (a bug
    /// it catches: the denominator's n − p as n + p gave F = 5.8).
    #[test]
    fn the_f_test_is_the_nested_models_by_hand() {
        let (f, p) = f_test(120.0, 100.0, 2.0, 54.0, 4.0);
        assert!((f - 5.0).abs() < 1e-12, "{f}");
        assert!((p - 1.2f64.powi(-25)).abs() < 1e-9, "{p} against {}", 1.2f64.powi(-25));
    }

    /// ΔBIC by hand: 1000 samples, 3 parameters, RSS 200 → 180: 1000·ln 0.9 + 3·ln 1000
    /// = −105.36 + 20.72 = −84.63; the penalty grows with k·ln n, not k + ln n.
    #[test]
    fn bic_change_is_the_likelihood_gain_plus_k_ln_n() {
        let d = bic_change(1000.0, 200.0, 180.0, 3.0);
        assert!((d - (-105.360_515_657_826_3 + 20.723_265_836_946_41)).abs() < 1e-9, "{d}");
        assert!((bic_change(1000.0, 1.0, 1.0, 2.0) - 2.0 * 1000f64.ln()).abs() < 1e-12);
    }

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
    /// A step that added a body offset together with a world tilt, then a single ground
    /// effect: the pair's two effects are spared the backward check, the single is not, and an
    /// effect that never joined is not a pair's.
    #[test]
    fn only_the_effects_of_a_pair_step_count_as_joined_in_a_pair() {
        let step = |added, together_with| Step {
            added,
            together_with,
            delta_bic: 0.0,
            p_value: 0.0,
            heldout_gain: 0.0,
            candidates: vec![],
            not_identifiable_from: vec![],
            params: vec![],
        };
        let steps = [step(Effect::BodyOffset, Some(Effect::WorldTilt)), step(Effect::GroundEffect, None)];
        let joined: Vec<bool> = [Effect::BodyOffset, Effect::WorldTilt, Effect::GroundEffect, Effect::ThrustScale]
            .iter()
            .map(|e| joined_as_pair(&steps, *e))
            .collect();
        assert_eq!(joined, [true, true, false, false]);
        assert!(!joined_as_pair(&steps[1..], Effect::GroundEffect), "a single step is no pair");
    }

    /// A uniform draw on [−0.5, 0.5) from a xorshift state (the tests' own, reproducible).
    fn uniform(state: &mut u64) -> f64 {
        *state ^= *state << 13;
        *state ^= *state >> 7;
        *state ^= *state << 17;
        (*state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    }

    /// The normal equations of y = Σ β_j·x_j + 0.1·u over 3000 rows of the three columns
    /// `cols` (x_j and u uniform on [−0.5, 0.5)); every third row is held out, the rest are the
    /// whitened and the raw training part alike (white noise needs no prewhitening).
    fn synthetic_gram(cols: [usize; 3], beta: [f64; 3]) -> Gram {
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut g = Gram::zeros(cols.to_vec(), 1.0);
        for i in 0..3000 {
            let x = [uniform(&mut state), uniform(&mut state), uniform(&mut state)];
            let y = beta[0] * x[0] + beta[1] * x[1] + beta[2] * x[2] + 0.1 * uniform(&mut state);
            let xv = DVector::from_row_slice(&x);
            let (gm, bv) = (&xv * xv.transpose(), &xv * y);
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
        g
    }

    /// The boundary by hand: 199 usable training samples are too few, 200 enough.
    #[test]
    fn two_hundred_training_samples_are_enough_to_select() {
        assert!(!enough_to_select(199) && enough_to_select(200) && enough_to_select(201));
        assert!(!enough_to_select(0));
    }

    #[test]
    fn the_backward_check_removes_the_least_supported_failure() {
        let cols = [
            cols_of(Effect::ThrustScale).start,
            cols_of(Effect::ThrustVoltage).start,
            cols_of(Effect::GroundEffect).start,
        ];
        let gs = [synthetic_gram(cols, [0.0, 0.02, 0.5])];
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
        let w = backward_worst(&gs, &selected, &selected, 0, &o).expect("two fail");
        assert_eq!(w.effect, Effect::ThrustScale);
        // the least supported leaves whatever the order they are tested in (a bug it catches:
        // `c.delta_bic > w.delta_bic` as `==` kept the first failure)
        let reordered = [Effect::ThrustVoltage, Effect::GroundEffect, Effect::ThrustScale];
        assert_eq!(backward_worst(&gs, &selected, &reordered, 0, &o).map(|w| w.effect), Some(Effect::ThrustScale));
        // nothing to remove when every testable effect passes
        assert!(backward_worst(&gs, &selected, &[Effect::GroundEffect], 0, &o).is_none());
    }

    /// Pairs are tried among the round's failures that alone are significant at α/m and have ΔBIC <
    /// 0: with α = 0.01 and m = 5 candidates the level is 0.002, so p = 0.0015 is in and p = 0.0025
    /// is out (a bug it catches: α/m as α % m, which is α, took it in); a passed candidate and a
    /// failure with ΔBIC ≥ 0 are out at any p.
    #[test]
    fn pairs_are_tried_among_failures_significant_at_alpha_over_the_candidates() {
        let c = |effect: Effect, passed: bool, p_value: f64, delta_bic: f64| Candidate {
            effect,
            delta_bic,
            f: 10.0,
            p_value,
            heldout_gain: -0.01,
            max_corr: 0.3,
            passed,
        };
        let cands = [
            c(Effect::BodyOffset, false, 0.0015, -3.0),
            c(Effect::WorldTilt, false, 0.0025, -3.0),
            c(Effect::RotorDrag, true, 1e-9, -50.0),
            c(Effect::GyroDelay, false, 1e-9, 0.0),
            c(Effect::AccelBias, false, 1e-9, -0.5),
        ];
        assert_eq!(pair_candidates(&cands, 0.01), [Effect::BodyOffset, Effect::AccelBias]);
        assert_eq!(
            pair_candidates(&cands[..2], 0.01),
            [Effect::BodyOffset, Effect::WorldTilt],
            "m = 2: the level is 0.005"
        );
        // a pair is judged among the m singles and the r(r − 1)/2 pairs of r candidates (a bug it
        // catches: the count's `/ 2` as `% 2`, always 0, judged pairs among the singles alone)
        let counts: Vec<usize> = (0..5).map(|r| tests_with_pairs(10, r)).collect();
        assert_eq!(counts, [10, 10, 11, 13, 16]);
    }

    /// Only the steps whose effect stayed name rivals: of a gyro-delay step (naming the mocap
    /// delay) that the backward check removed after step 2, and a body-offset step (naming the
    /// world tilt) that stayed, the report keeps the second alone, and the swaps check
    /// (`named_at_step`) knows only its pair, in its order. A bug it catches: `kept` as `true` let
    /// the removed step's pair into the report ("gyro_delay was chosen over mocap_delay …" for an
    /// effect not in the model), and the whole suite passed.
    #[test]
    fn only_the_steps_the_backward_check_kept_name_rivals() {
        let steps = [step(Effect::GyroDelay, Effect::MocapDelay), step(Effect::BodyOffset, Effect::WorldTilt)];
        let removed = [Removal { after_step: 2, check: scoreboard(Effect::GyroDelay, false, 4.0) }];
        let kept: Vec<Effect> = kept_steps(&steps, &removed).map(|st| st.added).collect();
        assert_eq!(kept, [Effect::BodyOffset]);
        let all: Vec<Effect> = kept_steps(&steps, &[]).map(|st| st.added).collect();
        assert_eq!(all, [Effect::GyroDelay, Effect::BodyOffset], "with nothing removed every step is kept");
        // a pair is named by the kept step that added its first effect, in that order only
        assert!(named_at_step(&steps, &removed, Effect::BodyOffset, Effect::WorldTilt));
        assert!(!named_at_step(&steps, &removed, Effect::GyroDelay, Effect::MocapDelay), "its step was removed");
        assert!(named_at_step(&steps, &[], Effect::GyroDelay, Effect::MocapDelay));
        assert!(
            !named_at_step(&steps, &removed, Effect::WorldTilt, Effect::BodyOffset),
            "the step added the body offset"
        );
        assert!(!named_at_step(&steps, &removed, Effect::BodyOffset, Effect::MocapDelay), "another step's rival");
    }

    /// The pairs and notes of a search by hand (no frame effect selected, so no Gram matrix is
    /// read): the kept step that added the mocap delay over the gyro delay (ρ 0.995) gives the pair
    /// and its note, the step the backward check removed gives neither, and a negative mocap delay
    /// (−3 ms) with no gyro delay selected gets its note. A bug it catches: `identifiability` → no
    /// pairs (and no notes).
    #[test]
    fn the_search_names_its_kept_rivals_and_a_negative_mocap_delay() {
        let search = |mocap_delay_s: f64, selected: Vec<Effect>| {
            let steps = vec![step(Effect::MocapDelay, Effect::GyroDelay), step(Effect::GyroBias, Effect::AccelBias)];
            let removed = vec![Removal { after_step: 2, check: scoreboard(Effect::GyroBias, false, 4.0) }];
            finished_search(selected, steps, removed, Vec::new(), mocap_delay_s)
        };
        let mut notes = Vec::new();
        let pairs = search(-0.003, vec![Effect::MocapDelay]).identifiability(12.0, &mut notes);
        assert_eq!(pairs, [(Effect::MocapDelay, Effect::GyroDelay, 0.995)]);
        assert_eq!(
            notes.iter().map(ToString::to_string).collect::<Vec<_>>(),
            [
                "mocap_delay was chosen over gyro_delay by ΔBIC, but this flight cannot tell them apart (canonical correlation 0.9950, yaw spread 12.0°): not identifiable; fly yaw turns, circles and accelerations to separate them",
                "the mocap delay came out negative (-3.0 ms: the mocap leads the IMU): a clock offset between the streams, or a delay of the gyro alone against the accelerometer, which `--with gyro_delay` tests",
            ]
        );
        // a positive delay, or one with the gyro delay selected beside it, gets no such note
        for (delay, selected) in
            [(0.003, vec![Effect::MocapDelay]), (-0.003, vec![Effect::MocapDelay, Effect::GyroDelay])]
        {
            let mut notes = Vec::new();
            search(delay, selected).identifiability(12.0, &mut notes);
            assert_eq!(notes.len(), 1, "{notes:?}");
        }
    }

    /// The mocap world tilt and the body offset's roll/pitch differ only through yaw changes, body
    /// rates and accelerations other than gravity. With either selected and no kept step naming the
    /// pair, the search names it (the selected one first) when the flight's canonical correlation
    /// between their columns exceeds 0.99. By hand, five samples: world tilt column 0 = e1 and
    /// column 1 = e3; body offset column 0 = c·e1 + s·e2 (c² + s² = 1), columns 1 and 2 = e4, e5;
    /// so ρ = c. A bug it catches: this branch's conditions as `&&`/`||`/`!=`.
    #[test]
    fn the_frame_pair_is_named_when_their_columns_correlate_above_the_cut() {
        let (wt, bo) = (set_of(&[Effect::WorldTilt]), set_of(&[Effect::BodyOffset]));
        assert_eq!((wt.len(), bo.len()), (2, 3));
        let grams = |c: f64| {
            let s = (1.0 - c * c).sqrt();
            let cols: Vec<usize> = wt.iter().chain(&bo).copied().collect();
            // columns: wt0 wt1 bo0 bo1 bo2
            let rows: [&[f64]; 5] = [
                &[1.0, 0.0, c, 0.0, 0.0],
                &[0.0, 0.0, s, 0.0, 0.0],
                &[0.0, 1.0, 0.0, 0.0, 0.0],
                &[0.0, 0.0, 0.0, 1.0, 0.0],
                &[0.0, 0.0, 0.0, 0.0, 1.0],
            ];
            vec![Gram::of_samples(&cols, &rows)]
        };
        let pairs = |c: f64, selected: Vec<Effect>, steps: Vec<Step>, removed: Vec<Removal>| {
            let mut notes = Vec::new();
            let pairs = finished_search(selected, steps, removed, grams(c), 0.0).identifiability(12.0, &mut notes);
            let notes: Vec<String> = notes.iter().map(ToString::to_string).collect();
            (pairs.into_iter().map(|(a, b, rho)| (a, b, (rho * 1e4).round() / 1e4)).collect::<Vec<_>>(), notes)
        };
        let (bo_e, wt_e) = (Effect::BodyOffset, Effect::WorldTilt);
        let (got, notes) = pairs(0.995, vec![bo_e], Vec::new(), Vec::new());
        assert_eq!(got, [(bo_e, wt_e, 0.995)]);
        assert_eq!(
            notes,
            [
                "mocap world tilt and body offset roll/pitch are not identifiable apart in this flight (canonical correlation 0.9950, yaw spread 12.0°): they differ only through yaw changes, body rates and accelerations other than gravity"
            ]
        );
        assert_eq!(
            pairs(0.995, vec![wt_e], Vec::new(), Vec::new()).0,
            [(wt_e, bo_e, 0.995)],
            "the world tilt selected"
        );
        assert_eq!(
            pairs(0.995, vec![Effect::GyroBias, wt_e, bo_e], Vec::new(), Vec::new()).0,
            [(bo_e, wt_e, 0.995)],
            "both selected"
        );
        assert_eq!(pairs(1.0, vec![bo_e], Vec::new(), Vec::new()).0, [(bo_e, wt_e, 1.0)]);
        // under the cut, or with neither selected: nothing
        assert_eq!(pairs(0.985, vec![bo_e], Vec::new(), Vec::new()), (Vec::new(), Vec::new()));
        assert_eq!(pairs(0.995, vec![Effect::GyroBias], Vec::new(), Vec::new()), (Vec::new(), Vec::new()));
        // a kept step that named the pair (either way round) names it once, with its own note
        for (added, rival) in [(bo_e, wt_e), (wt_e, bo_e)] {
            let (got, notes) = pairs(0.995, vec![added], vec![step(added, rival)], Vec::new());
            assert_eq!(got, [(added, rival, 0.995)]);
            assert_eq!(notes.len(), 1, "{notes:?}");
            assert!(notes[0].contains("was chosen over"), "{notes:?}");
        }
        // a kept step naming another pair, even one with a frame effect in it (a body offset
        // over an accelerometer bias, which tilt gravity alike at hover), does not stand for it
        let (got, notes) = pairs(0.995, vec![bo_e], vec![step(bo_e, Effect::AccelBias)], Vec::new());
        assert_eq!(got, [(bo_e, Effect::AccelBias, 0.995), (bo_e, wt_e, 0.995)]);
        assert_eq!(notes.len(), 2, "{notes:?}");
        // a step the backward check removed names nothing: the frame check still does
        let removed = vec![Removal { after_step: 2, check: scoreboard(wt_e, false, 4.0) }];
        assert_eq!(pairs(0.995, vec![bo_e], vec![step(wt_e, bo_e)], removed).0, [(bo_e, wt_e, 0.995)]);
    }

    /// A finished search by hand for the `identifiability` tests: the selected effects, the
    /// forward steps, the backward check's removals, the Grams the frame-pair check reads and
    /// the mocap delay (s).
    fn finished_search(
        selected: Vec<Effect>,
        steps: Vec<Step>,
        removed: Vec<Removal>,
        grams: Vec<Gram>,
        mocap_delay_s: f64,
    ) -> Search {
        Search {
            selected,
            state: Problem {
                design: Design::default(),
                train: Vec::new(),
                test: Vec::new(),
                grams,
                fit: Fit {
                    set: Vec::new(),
                    theta: vec![0.0; N_COLUMNS],
                    theta_w: vec![0.0; N_COLUMNS],
                    rss: 0.0,
                    n: 0,
                },
                cov: DMatrix::zeros(0, 0),
            },
            corr: Corrections { mocap_delay_s, ..Corrections::default() },
            steps,
            removed,
            final_candidates: Vec::new(),
        }
    }

    /// A kept forward step that added `added` and named `rival` as not identifiable from it
    /// (ρ 0.995).
    fn step(added: Effect, rival: Effect) -> Step {
        Step {
            added,
            together_with: None,
            delta_bic: -20.0,
            p_value: 1e-6,
            heldout_gain: 0.1,
            candidates: Vec::new(),
            not_identifiable_from: vec![(rival, 0.995)],
            params: Vec::new(),
        }
    }

    /// A round's scoreboard entry for the winner tests: only the effect, whether it passed and
    /// its ΔBIC matter there.
    fn scoreboard(effect: Effect, passed: bool, delta_bic: f64) -> Candidate {
        Candidate { effect, delta_bic, f: 10.0, p_value: 1e-6, heldout_gain: 0.1, max_corr: 0.3, passed }
    }

    /// A round's winner by hand: of the passing singles (ΔBIC −10 and −20; a failure at −30 does
    /// not count) the one at −20, unless a passing pair is strictly lower (a bug it catches: the
    /// pair's `<` as `==` let a pair win only when it tied); with no single passing, the pair; with
    /// nothing passing, none.
    #[test]
    fn a_pair_wins_a_round_only_strictly_below_every_passing_single() {
        let c = scoreboard;
        let singles =
            [c(Effect::RotorDrag, true, -10.0), c(Effect::GyroDelay, true, -20.0), c(Effect::AccelBias, false, -30.0)];
        let pair = |delta_bic: f64| Some((Effect::WorldTilt, c(Effect::BodyOffset, true, delta_bic)));
        let winner =
            |cands: &[Candidate], pair| round_winner(cands, pair).map(|(w, partner)| (w.effect, w.delta_bic, partner));
        assert_eq!(winner(&singles, None), Some((Effect::GyroDelay, -20.0, None)));
        assert_eq!(winner(&singles, pair(-25.0)), Some((Effect::BodyOffset, -25.0, Some(Effect::WorldTilt))));
        assert_eq!(winner(&singles, pair(-20.0)), Some((Effect::GyroDelay, -20.0, None)), "a tie goes to the single");
        assert_eq!(winner(&singles, pair(-15.0)), Some((Effect::GyroDelay, -20.0, None)));
        assert_eq!(winner(&singles[2..], pair(-5.0)), Some((Effect::BodyOffset, -5.0, Some(Effect::WorldTilt))));
        assert_eq!(winner(&singles[2..], None), None);
    }

    /// A round's pair is the passing one with the lowest ΔBIC, whatever its place in the order: of
    /// the pairs of (RotorDrag, GyroDelay, AccelBias, WorldTilt), the failing one with ΔBIC −30 is
    /// skipped, −9 beats the −5 before it and the −7 after it, and the later ties at −9 keep the
    /// first. A bug it catches: `<` as `==` (the first passing pair) survived the whole suite: in
    /// none of its flights does a round's first passing pair differ from its best.
    #[test]
    fn the_round_pair_is_the_passing_one_with_the_lowest_delta_bic() {
        use Effect::*;
        let c = scoreboard;
        let near = [RotorDrag, GyroDelay, AccelBias, WorldTilt];
        let board = |a: Effect, b: Effect| match (a, b) {
            (RotorDrag, GyroDelay) => c(a, true, -5.0),
            (RotorDrag, AccelBias) => c(a, true, -9.0),
            (RotorDrag, WorldTilt) => c(a, false, -30.0),
            (GyroDelay, AccelBias) => c(a, true, -7.0),
            (_, _) => c(a, true, -9.0),
        };
        let got = best_pair(&near, board).map(|(partner, p)| (p.effect, partner, p.delta_bic));
        assert_eq!(got, Some((RotorDrag, AccelBias, -9.0)));
        assert_eq!(best_pair(&near[..1], board).map(|(b, _)| b), None, "one candidate has no pair");
        assert_eq!(best_pair(&[RotorDrag, WorldTilt], board).map(|(b, _)| b), None, "only a failing pair");
    }

    /// The backward check's Bonferroni level: an effect re-tested on top of the others competes
    /// with the `outside` candidates a forward step would try now and with itself, so it must
    /// reach p < α/(outside + 1). A weak voltage term (β = 0.008 against a noise of 0.029 over
    /// 2000 training rows: p = 6.1·10⁻⁴, so k = 16 at α = 0.01) with the held-out gate off: for
    /// the k with α/(k + 1) < p < α/k, it stays when k − 1 candidates are outside and leaves
    /// when k are.
    #[test]
    fn the_backward_check_tests_at_alpha_over_the_outside_candidates_and_itself() {
        let cols = [
            cols_of(Effect::ThrustScale).start,
            cols_of(Effect::ThrustVoltage).start,
            cols_of(Effect::GroundEffect).start,
        ];
        let gs = [synthetic_gram(cols, [0.0, 0.008, 0.5])];
        let selected = [Effect::ThrustVoltage, Effect::GroundEffect];
        let o = Options { min_heldout_gain: f64::NEG_INFINITY, ..Options::default() };
        let c = score(&gs, &fit(&gs, &set_of(&[Effect::GroundEffect])), &[Effect::ThrustVoltage], 1, &o);
        let k = (o.alpha / c.p_value).floor() as usize;
        assert!(c.delta_bic < 0.0 && (2..50).contains(&k) && c.p_value < o.alpha / k as f64, "{c:?}, k = {k}");
        let leaves =
            |outside: usize| backward_worst(&gs, &selected, &[Effect::ThrustVoltage], outside, &o).map(|w| w.effect);
        assert_eq!(leaves(k - 1), None, "p = {} < α/{k}", c.p_value);
        assert_eq!(leaves(k), Some(Effect::ThrustVoltage), "p = {} > α/{}", c.p_value, k + 1);
    }

    /// Which effects a log can test: the thrust–voltage effect needs the thrust and the battery
    /// voltage, a force-channel effect the thrust, a rate or acceleration effect neither. A bug it
    /// catches: without the voltage arm a log with thrust and no battery voltage offered it.
    #[test]
    fn an_effect_is_available_only_with_the_columns_it_needs() {
        let design = |has_force: bool, has_vbat: bool| Design { has_force, has_vbat, ..Design::default() };
        let offers = |has_force, has_vbat, e| available(&design(has_force, has_vbat), e);
        assert!(offers(true, true, Effect::ThrustVoltage));
        assert!(!offers(true, false, Effect::ThrustVoltage) && !offers(false, true, Effect::ThrustVoltage));
        assert!(offers(true, false, Effect::ThrustScale) && !offers(false, false, Effect::ThrustScale));
        assert!(offers(false, false, Effect::GyroDelay));
        // an accelerometer bias acts in accel_kin too: a log without motors tests it
        assert!(offers(false, false, Effect::AccelBias) && offers(false, false, Effect::AccelScale));
        assert!(!offers(false, false, Effect::ImuOffset) && !offers(false, false, Effect::ConstantForce));
        let no_force = design(false, false);
        assert_eq!(unavailable_reason(&no_force, Effect::AccelBias), None);
        assert_eq!(unavailable_reason(&no_force, Effect::ThrustScale), Some(Unavailable::NoMotorCommands));
        assert_eq!(unavailable_reason(&design(true, false), Effect::ThrustVoltage), Some(Unavailable::NoVoltage));
        // a drift with too short a log is that, with or without motors (no usable row: 0 s)
        let short = Some(Unavailable::TooShort { span_s: 0.0, min_s: crate::effects::DRIFT_MIN_S });
        assert_eq!(unavailable_reason(&design(true, false), Effect::AccelBiasDrift), short);
        assert_eq!(unavailable_reason(&no_force, Effect::GyroBiasDrift), short);
    }

    /// A candidate's correlation with the residual, from the Gram sums by hand: on the base set
    /// {ground effect} alone (column 2, θ = b₂/g₂₂) the residual's square is yy − b₂²/g₂₂ and its
    /// product with the voltage column (1) is b₁ − g₁₂·b₂/g₂₂; `max_corr` is |that| over √(g₁₁·rr).
    /// A bug it catches: `b − G·θ` as `b + G·θ`.
    #[test]
    fn a_candidates_correlation_with_the_residual_by_hand() {
        let cols = [
            cols_of(Effect::ThrustScale).start,
            cols_of(Effect::ThrustVoltage).start,
            cols_of(Effect::GroundEffect).start,
        ];
        let gs = [synthetic_gram(cols, [0.0, 0.02, 0.5])];
        let (g, b, yy) = (&gs[0].g_w, &gs[0].b_w, gs[0].yy_w);
        let theta = b[2] / g[(2, 2)];
        let (rr, xr) = (yy - b[2] * theta, b[1] - g[(1, 2)] * theta);
        let by_hand = xr.abs() / (g[(1, 1)] * rr).sqrt();
        let c =
            score(&gs, &fit(&gs, &set_of(&[Effect::GroundEffect])), &[Effect::ThrustVoltage], 1, &Options::default());
        assert!(
            by_hand > 0.05 && (c.max_corr - by_hand).abs() < 1e-12 * by_hand,
            "{} against {by_hand} by hand",
            c.max_corr
        );
    }

    /// The held-out gate weighs each channel axis the candidate acts on by the current model's
    /// held-out error there: gain = 1 − √(mean_q rss₁,q/rss₀,q). Two axes share the columns; the
    /// voltage column explains y on the first (β 0.2) and nothing on the second, whose held-out
    /// rows are 100× larger in x and y (the same β, 10⁴× the error): the fit's compromise cuts the
    /// first axis's error and raises the second's, and the mean of the ratios differs from the
    /// pooled 1 − √(Σrss₁/Σrss₀), which the big axis would rule. A bug it catches: the weight 1 %
    /// rss₀ (1 for an error above one).
    #[test]
    fn the_heldout_gain_weighs_each_axis_by_its_current_error() {
        let cols = [
            cols_of(Effect::ThrustScale).start,
            cols_of(Effect::ThrustVoltage).start,
            cols_of(Effect::GroundEffect).start,
        ];
        let acted_on = synthetic_gram(cols, [0.0, 0.2, 0.5]);
        let mut big = synthetic_gram(cols, [0.0, 0.0, 0.5]);
        big.g_t *= 1e4;
        big.b_t *= 1e4;
        big.yy_t *= 1e4;
        let gs = [acted_on, big];
        let base = fit(&gs, &set_of(&[Effect::GroundEffect]));
        let with = fit(&gs, &set_of(&[Effect::GroundEffect, Effect::ThrustVoltage]));
        let (r0, r1) = (heldout_rss(&gs, &base.theta), heldout_rss(&gs, &with.theta));
        assert!(r0[1] > 100.0 * r0[0] && r1[0] < r0[0] && r1[1] > r0[1], "held-out errors {r0:?} → {r1:?}");
        let by_hand = 1.0 - ((r1[0] / r0[0] + r1[1] / r0[1]) / 2.0).sqrt();
        let pooled = 1.0 - ((r1[0] + r1[1]) / (r0[0] + r0[1])).sqrt();
        assert!((by_hand - pooled).abs() > 0.05, "the weighting must matter: {by_hand} against {pooled} pooled");
        let c = score(&gs, &base, &[Effect::ThrustVoltage], 1, &Options::default());
        assert!((c.heldout_gain - by_hand).abs() < 1e-12, "{} against {by_hand} by hand", c.heldout_gain);
    }

    /// With no held-out rows (no sample in the held-out mask) both held-out errors are 0: the gain
    /// is 0, not 0/0 = NaN, and the held-out gate fails. A bug it catches: the guard `e0 > 0` as
    /// `>=`.
    #[test]
    fn without_heldout_rows_the_heldout_gain_is_zero_not_nan() {
        let cols = [
            cols_of(Effect::ThrustScale).start,
            cols_of(Effect::ThrustVoltage).start,
            cols_of(Effect::GroundEffect).start,
        ];
        let mut g = synthetic_gram(cols, [0.0, 0.2, 0.5]);
        (g.g_t, g.b_t, g.yy_t, g.n_t) = (DMatrix::zeros(3, 3), DVector::zeros(3), 0.0, 0);
        let gs = [g];
        let c =
            score(&gs, &fit(&gs, &set_of(&[Effect::GroundEffect])), &[Effect::ThrustVoltage], 1, &Options::default());
        assert_eq!(c.heldout_gain.to_bits(), 0.0f64.to_bits(), "gain {}", c.heldout_gain);
        assert!(!c.passed && c.p_value < 1e-6, "significant in training, yet no held-out support: {c:?}");
    }

    /// The corrections' fold by hand: the body offset's increment d composes on the left, R_off ←
    /// exp(d)·R_off; the world tilt's (d_x, d_y, 0) on the right and levelled, R_w ← level(R_w·exp(d))
    /// ([`level_tilt`]); the two delays
    /// and the lever arm add. Each folded column is zeroed; an effect that is no correction (the
    /// thrust scale) or is not selected (the accelerometer bias) keeps its θ. A bug it catches:
    /// `fold` doing nothing, each of its arms deleted and an index r.start + 1 as r.start − 1
    /// (whole flights caught them).
    #[test]
    fn the_corrections_fold_into_their_rotations_delays_and_lever_arm() {
        let col = |e: Effect| cols_of(e).start;
        let mut theta = vec![0.0; N_COLUMNS];
        let d_off = Vector3::new(0.01, -0.02, 0.03);
        let d_w = Vector3::new(0.004, -0.003, 0.0);
        let lever = Vector3::new(0.01, 0.02, -0.03);
        for k in 0..3 {
            theta[col(Effect::BodyOffset) + k] = d_off[k];
            theta[col(Effect::LeverArm) + k] = lever[k];
        }
        theta[col(Effect::WorldTilt)] = d_w.x;
        theta[col(Effect::WorldTilt) + 1] = d_w.y;
        theta[col(Effect::MocapDelay)] = 0.005;
        theta[col(Effect::GyroDelay)] = 0.002;
        theta[col(Effect::ThrustScale)] = 0.1;
        theta[col(Effect::AccelBias)] = 0.2;
        let (off0, w0) = (
            UnitQuaternion::from_euler_angles(0.02, 0.01, -0.05),
            UnitQuaternion::from_euler_angles(0.003, 0.001, 0.0),
        );
        let mut corr = Corrections {
            body_offset: Rot::from_quaternion(off0),
            world_tilt: Rot::from_quaternion(w0),
            mocap_delay_s: 0.010,
            gyro_delay_s: -0.001,
            lever_arm_m: Vec3::new(0.1, 0.0, 0.0),
            pose_shift_s: 0.0,
        };
        let selected = [
            Effect::BodyOffset,
            Effect::WorldTilt,
            Effect::MocapDelay,
            Effect::GyroDelay,
            Effect::LeverArm,
            Effect::ThrustScale,
        ];
        fold(&mut corr, &mut theta, &selected);
        let (off, w) =
            (UnitQuaternion::from_scaled_axis(d_off) * off0, level_tilt(&(w0 * UnitQuaternion::from_scaled_axis(d_w))));
        assert!(
            corr.body_offset.quaternion().angle_to(&off) < 1e-15 && corr.world_tilt.quaternion().angle_to(&w) < 1e-15,
            "{corr:?}"
        );
        // the order of composition, and the levelling, are visible at these sizes
        assert!((off0 * UnitQuaternion::from_scaled_axis(d_off)).angle_to(&off) > 1e-5);
        assert!((w0 * UnitQuaternion::from_scaled_axis(d_w)).angle_to(&w) > 1e-7);
        assert!((corr.mocap_delay_s - 0.015).abs() < 1e-15 && (corr.gyro_delay_s - 0.001).abs() < 1e-15, "{corr:?}");
        assert!((corr.lever_arm_m.raw() - Vector3::new(0.11, 0.02, -0.03)).amax() < 1e-15, "{corr:?}");
        for e in [Effect::BodyOffset, Effect::WorldTilt, Effect::MocapDelay, Effect::GyroDelay, Effect::LeverArm] {
            assert!(cols_of(e).all(|j| theta[j] == 0.0), "{e:?} not zeroed");
        }
        assert_eq!((theta[col(Effect::ThrustScale)], theta[col(Effect::AccelBias)]), (0.1, 0.2));
    }

    /// The corrections reported in their units, read from the folded corrections and not from θ
    /// (whose correction columns hold 0.5 here): R_off's ZYX angles and R_w's roll and pitch in
    /// degrees, the delays in ms (the mocap delay the rows' 12 ms plus the 250 ms the join of two
    /// streams took out), the lever arm in mm. A bug it catches: each of the five arms deleted
    /// (θ reported instead), the join's share left out.
    #[test]
    fn the_corrections_are_reported_in_degrees_milliseconds_and_millimetres() {
        let deg = 180.0 / std::f64::consts::PI;
        let theta = vec![0.5; N_COLUMNS];
        let corr = Corrections {
            body_offset: Rot::from_quaternion(UnitQuaternion::from_euler_angles(0.01, -0.02, 0.03)),
            world_tilt: Rot::from_quaternion(UnitQuaternion::from_euler_angles(0.004, -0.003, 0.0)),
            mocap_delay_s: 0.012,
            gyro_delay_s: 0.002,
            lever_arm_m: Vec3::new(0.01, 0.02, -0.03),
            pose_shift_s: 0.25,
        };
        let all: Vec<usize> = (0..N_COLUMNS).collect();
        let cases: [(Effect, &[f64]); 5] = [
            (Effect::BodyOffset, &[0.01 * deg, -0.02 * deg, 0.03 * deg]),
            (Effect::WorldTilt, &[0.004 * deg, -0.003 * deg]),
            (Effect::MocapDelay, &[262.0]),
            (Effect::GyroDelay, &[2.0]),
            (Effect::LeverArm, &[10.0, 20.0, -30.0]),
        ];
        for (e, want) in cases {
            let got = values_of(e, &theta, &all, &corr);
            assert_eq!(got.len(), want.len(), "{e:?}");
            for (g, w) in got.iter().zip(want) {
                assert!((g - w).abs() < 1e-12 * w.abs().max(1.0), "{e:?}: {got:?} against {want:?}");
            }
        }
        // an effect without a correction reads its own columns, k-th parameter from column start +
        // k, times its unit factor (a bug it catches: theta[start − k], since the cases above read
        // equal columns)
        let theta: Vec<f64> = (0..N_COLUMNS).map(|j| j as f64 + 1.0).collect();
        for (e, unit) in [(Effect::AccelBias, 1.0), (Effect::GyroBias, deg), (Effect::ConstantForce, 1.0)] {
            let s = cols_of(e).start as f64 + 1.0;
            let want = [s * unit, (s + 1.0) * unit, (s + 2.0) * unit];
            assert_eq!(values_of(e, &theta, &all, &corr), want, "{e:?}");
        }
    }

    /// The multiplicative reparameterisation by hand: a thrust scale a = −0.2 and an additive
    /// voltage coefficient b = 0.08 give c = b/(1 + a) = 0.1; with var a = 4·10⁻⁶,
    /// var b = 9·10⁻⁶ and cov(a, b) = 3·10⁻⁶, var c = (9 − 2·0.1·3 + 0.01·4)·10⁻⁶/0.64
    /// = 1.31875·10⁻⁵. The ground effect is treated alike; without a thrust scale in the fit,
    /// b is reported as it is.
    #[test]
    fn a_thrust_multiplier_is_reported_over_the_thrust_scale() {
        let (ts, tv, ge) = (
            cols_of(Effect::ThrustScale).start,
            cols_of(Effect::ThrustVoltage).start,
            cols_of(Effect::GroundEffect).start,
        );
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

//! What the selection reports: the estimates with their intervals, each step's scoreboard,
//! the held-out errors, the whiteness and what is left of the residual.

use super::Options;
use crate::effects::{Channel, Effect};
use crate::identify::fit::stats::LjungBox;
use crate::identify::input::series::{Corrections, NominalModel};

/// One parameter, in the reported unit.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Param {
    /// The parameter's name (`roll`, `k_x`, `north`, ...; see [`Effect::params`]).
    pub name: String,
    /// The estimate, in `unit`.
    pub value: f64,
    /// Half-width of the 95 % interval. Where the flight cannot tell an effect of the model from
    /// one outside it, the interval is widened to cover the estimate of the swapped model too.
    pub ci95: f64,
    /// The reported unit (degrees, ms, mm, ...: the edge's units, not the internal SI).
    pub unit: String,
    /// False when this effect cannot be told apart from one outside the model by this flight
    /// (see [`Report::not_identifiable`]): the value is one of several explanations, and no
    /// interval is claimed for it.
    pub identifiable: bool,
}

/// One candidate's gates at one step: what adding it to the model would do.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Candidate {
    /// The candidate.
    pub effect: Effect,
    /// BIC with it minus BIC without (negative: it pays for its parameters).
    pub delta_bic: f64,
    /// The F statistic of its block on the prewhitened training data.
    pub f: f64,
    /// The F-test's p-value.
    pub p_value: f64,
    /// Relative drop of the held-out error on the candidate's channels.
    pub heldout_gain: f64,
    /// Largest |correlation| of a prewhitened regressor column with the prewhitened residual.
    pub max_corr: f64,
    /// Whether it passed all three gates (F-test, ΔBIC, held-out).
    pub passed: bool,
}

/// One forward step of the selection: the effect that joined and the scoreboard it won.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Step {
    /// The effect that joined.
    pub added: Effect,
    /// A second effect added in the same step: the two explain the residual only together
    /// (each alone is significant but fails the held-out gate); the step's figures are the pair's.
    pub together_with: Option<Effect>,
    /// The added effect's ΔBIC.
    pub delta_bic: f64,
    /// Its F-test p-value.
    pub p_value: f64,
    /// Its relative drop of the held-out error.
    pub heldout_gain: f64,
    /// Every candidate of the round, with its gates.
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

/// An effect in the final model, with its parameters.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Found {
    /// The effect.
    pub effect: Effect,
    /// Its name for people.
    pub name: String,
    /// Its parameters with their 95 % intervals.
    pub params: Vec<Param>,
}

/// The held-out error of one channel axis before and after the effects.
#[derive(Clone, Debug, serde::Serialize)]
pub struct AxisError {
    /// The channel.
    pub channel: Channel,
    /// Its axis, `x`, `y` or `z` (body frame).
    pub axis: char,
    /// The channel's unit.
    pub unit: String,
    /// Held-out samples compared.
    pub samples: usize,
    /// RMSE of the nominal model.
    pub rmse_before: f64,
    /// RMSE with the selected effects.
    pub rmse_after: f64,
    /// NRMSE fit, 100·(1 − ‖y − ŷ‖/‖y − ȳ‖) (%); None when the measured signal is constant
    /// (an ideal accelerometer's x axis without drag reads exactly zero).
    pub fit_before_pct: Option<f64>,
    /// The same fit with the effects.
    pub fit_after_pct: Option<f64>,
}

/// Whether the final residual of one channel axis is white.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Whiteness {
    /// The channel.
    pub channel: Channel,
    /// Its axis.
    pub axis: char,
    /// Fraction of the lags 1..=50 of the raw residual outside the 99 % bounds ±2.58/√n.
    pub raw_outside_99: f64,
    /// The order of the AR model that prewhitens it.
    pub ar_order: usize,
    /// Ljung–Box on the residual prewhitened by its AR(p), 20 lags.
    pub ljung_box: LjungBox,
}

/// A measured signal that the residual left at the end follows.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Correlate {
    /// The signal's name and unit.
    pub signal: String,
    /// Pearson correlation with the final residual over the usable samples.
    pub r: f64,
    /// Bartlett's effective sample size (both series are autocorrelated).
    pub n_eff: f64,
    /// The signal is a measurement's own error (the mocap attitude against the gyro's integral, say): following it is no lead for an effect.
    pub floor: bool,
}

/// What is left on one channel axis once the effects are fitted: is the residual still
/// structured, and what does it follow? A lead for the next effect, not a verdict.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Left {
    /// The channel.
    pub channel: Channel,
    /// Its axis.
    pub axis: char,
    /// Held-out RMSE after the effects.
    pub rmse: f64,
    /// The channel's unit.
    pub unit: String,
    /// Ljung–Box p-value of the prewhitened final residual (from [`Whiteness`]).
    pub ljung_box_p: f64,
    /// The signals the residual follows: |r| ≥ [`LEAD_MIN_CORR`](super::LEAD_MIN_CORR) and r ≠ 0 at the 1 % level
    /// Bonferroni-corrected over the signals (r·√n_eff against N(0, 1)), strongest first, at
    /// most [`LEAD_MAX`](super::LEAD_MAX).
    pub correlates: Vec<Correlate>,
    /// The residual is not noise: it follows a measured signal of the flight (not only a
    /// measurement's own error), or fails Ljung–Box at 1 %.
    pub structured: bool,
}

/// What `identify` found in one flight, and how sure it is.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Report {
    /// The flight's name (file, or scenario and seed).
    pub source: String,
    /// Usable samples after decimation.
    pub samples: usize,
    /// Of which the selection fitted on.
    pub train_samples: usize,
    /// And held out to judge it.
    pub heldout_samples: usize,
    /// The residual channels the fit compared, in report order: the accelerometer against the
    /// mocap (accel_kin) and the gyro always, the force model only where the log has motor
    /// commands and the vehicle is not declared a rigid body.
    pub channels: Vec<Channel>,
    /// The declared model the effects are added to.
    pub model: NominalModel,
    /// The options it ran with.
    pub options: Options,
    /// The forward steps, in order.
    pub steps: Vec<Step>,
    /// The scoreboard of the last round, in which no candidate passed.
    pub final_candidates: Vec<Candidate>,
    /// Effects that joined in a step but failed the backward check (their gates re-run on top
    /// of every other selected effect), in the order they left.
    pub removed: Vec<Removal>,
    /// The final model's effects.
    pub effects: Vec<Found>,
    /// Held-out errors per channel axis.
    pub errors: Vec<AxisError>,
    /// Whiteness of the final residual per channel axis.
    pub whiteness: Vec<Whiteness>,
    /// Per channel axis: what the effects leave unexplained and what it follows.
    pub left: Vec<Left>,
    /// Yaw spread of the flight (circular standard deviation, deg): world tilt and body offset
    /// differ only when the vehicle yaws.
    pub yaw_spread_deg: f64,
    /// Roll/pitch misalignment from the vehicle at rest before take-off (independent check).
    pub ground_check: Option<crate::identify::fit::ground::GroundCheck>,
    /// The ground check against the flight's offset plus the tilt of its accelerometer bias.
    pub ground_agreement: Option<crate::identify::fit::ground::GroundAgreement>,
    /// What a reader should know (a negative delay, a half-supported candidate, ...), one
    /// [`Note`](crate::identify::Note) each: data to match on; `Display` gives the sentence.
    pub notes: Vec<crate::identify::fit::note::Note>,
    /// What the readers did to the log: repairs (dropped duplicate rows, gaps, messages left out)
    /// and, for PX4 logs, which stamps it read; one [`ReadNote`](crate::identify::ReadNote) each,
    /// whose `Display` is the sentence.
    pub repairs: Vec<crate::identify::ReadNote>,
    /// What the data-quality gate cut out before the fit.
    pub data_quality: crate::identify::fit::quality::DataQuality,
    /// Pairs of effects this flight cannot tell apart (canonical correlation > 0.99): the first
    /// was selected, the second would have explained the same residual.
    pub not_identifiable: Vec<(Effect, Effect, f64)>,
    /// The final corrections (rotations, delays, lever arm) in internal units.
    #[serde(skip)]
    pub corrections: Corrections,
    /// The final linear parameters (internal units), by column.
    #[serde(skip)]
    pub theta: Vec<f64>,
    /// The global start: the clocks and frames in closed form, and what of it the fine fit
    /// started from.
    pub start: crate::identify::fit::start::Start,
    /// How far the fine fit moved from the start, for each calibration effect it fitted.
    pub moved: StartMoved,
    /// What makes the fit physically impossible (empty: nothing): then the frames or the clocks
    /// are not aligned, and no effect is claimed.
    pub misaligned: Vec<super::plausible::Implausible>,
    /// The effects the fit gave when [`Report::misaligned`] is not empty, claimed as nothing
    /// (kept for the diagnosis; [`Report::effects`] is then empty).
    pub unclaimed: Vec<Found>,
}

/// How far the fine fit moved from the global start ([`Report::moved`]), for the effects it
/// fitted (`None`: not fitted, or no start of it).
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct StartMoved {
    /// The angle between the start's and the fit's rotation mocap body → IMU (deg).
    pub rotation_deg: Option<f64>,
    /// The angle between the start's and the fit's gravity directions in the mocap world (deg).
    pub tilt_deg: Option<f64>,
    /// The fit's mocap delay less the start's clock offset (ms).
    pub clock_ms: Option<f64>,
    /// ‖r_fit − r_start‖ of the lever arm (mm).
    pub lever_arm_mm: Option<f64>,
}

impl StartMoved {
    /// The distances between `start` and the fit of `r` (whose delay is its correction's plus
    /// the share the join of two streams took out, [`Corrections::pose_shift_s`]).
    pub(crate) fn between(start: &crate::identify::fit::start::Start, r: &Report) -> StartMoved {
        let has = |e: Effect| r.effect(e).is_some();
        let c = &r.corrections;
        let f = start.frames.as_ref();
        let down = nalgebra::Vector3::z();
        StartMoved {
            rotation_deg: f
                .filter(|_| has(Effect::BodyOffset))
                .map(|f| f.body_offset.quaternion().angle_to(c.body_offset.quaternion()).to_degrees()),
            tilt_deg: f
                .filter(|_| has(Effect::WorldTilt))
                .map(|f| (f.world_tilt.quaternion() * down).angle(&(c.world_tilt.quaternion() * down)).to_degrees()),
            clock_ms: start
                .clock
                .filter(|_| has(Effect::MocapDelay))
                .map(|k| (c.pose_shift_s + c.mocap_delay_s - k.best.offset_s) * 1e3),
            lever_arm_mm: f
                .filter(|_| has(Effect::LeverArm))
                .map(|f| (c.lever_arm_m.raw() - f.lever_arm_m.raw()).norm() * 1e3),
        }
    }
}

impl Report {
    /// The effect `e` of the final model, if selected.
    pub fn effect(&self, e: Effect) -> Option<&Found> {
        self.effects.iter().find(|f| f.effect == e)
    }
    /// A parameter value in its reported unit.
    pub fn param(&self, e: Effect, name: &str) -> Option<f64> {
        self.effect(e)?.params.iter().find(|p| p.name == name).map(|p| p.value)
    }
}

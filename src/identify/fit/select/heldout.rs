//! The held-out errors of a report on a flight (the report's own or another's: cross-validation)
//! and the residual series for plotting.

use super::gram::{active, residual_of};
use super::result::{AxisError, Report};
use super::{AXES, Options, gated};
use crate::effects::Channel;
use crate::identify::fit::design::{Design, build};
use crate::identify::input::series::{Corrections, Series};

/// RMSE and NRMSE fit of the residuals `before` and `after` over the samples `idx` of the
/// measured signal `y`.
pub(super) fn axis_error(ch: Channel, a: usize, y: &[f64], before: &[f64], after: &[f64], idx: &[usize]) -> AxisError {
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
    let (after, rows, paired) = paired_residuals(&gated(s, o, &r.start.corrections()), o, r);
    paired
        .iter()
        .map(|p| axis_error(Channel::ALL[p.c], p.a, &after.measured[p.c][p.a], &p.before, &p.after, &rows))
        .collect()
}

/// One channel axis's residuals before (the nominal model) and after (`r`'s corrections and
/// parameters).
struct Paired {
    c: usize,
    a: usize,
    before: Vec<f64>,
    after: Vec<f64>,
}

/// The design of the (gated) flight `s` with `r`'s corrections, the rows usable before and
/// after, and the paired residuals of every channel axis it has.
fn paired_residuals(s: &Series, o: &Options, r: &Report) -> (Design, Vec<usize>, Vec<Paired>) {
    let before = build(s, &Corrections::default(), &o.design);
    let after = build(s, &r.corrections, &o.design);
    let rows = usable_in_both(&before.ok, &after.ok);
    let paired = active(&after)
        .into_iter()
        .map(|(c, a)| Paired { c, a, before: before.residual(c, a), after: residual_of(&after, c, a, &r.theta) })
        .collect();
    (after, rows, paired)
}

/// The rows usable in both designs: a correction moves the usable window (a delay reaches past a
/// segment's end, a glitch moves with the delay), and a row only one model can use compares
/// nothing.
fn usable_in_both(before_ok: &[bool], after_ok: &[bool]) -> Vec<usize> {
    (0..after_ok.len().min(before_ok.len())).filter(|&i| after_ok[i] && before_ok[i]).collect()
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
    /// The channel.
    pub channel: Channel,
    /// The axis: 'x', 'y' or 'z'.
    pub axis: char,
    /// Seconds from the first sample of the log.
    pub t_s: Vec<f64>,
    /// The residual of the nominal model.
    pub before: Vec<f64>,
    /// The residual with the report's effects.
    pub after: Vec<f64>,
}

/// The residuals of every channel axis before and after the report's effects, on the gated flight.
pub fn residual_series(s: &Series, o: &Options, r: &Report) -> Vec<ResidualSeries> {
    let s = &gated(s, o, &r.start.corrections());
    let t0 = s.t_s.first().copied().unwrap_or(0.0);
    let (after, rows, paired) = paired_residuals(s, o, r);
    paired
        .iter()
        .map(|p| ResidualSeries {
            channel: Channel::ALL[p.c],
            axis: AXES[p.a],
            t_s: rows.iter().map(|&i| after.t[i] - t0).collect(),
            before: rows.iter().map(|&i| p.before[i]).collect(),
            after: rows.iter().map(|&i| p.after[i]).collect(),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A row counts only where both models can use it: one usable in one design only is left
    /// out, whichever of the two it is.
    #[test]
    fn only_rows_usable_before_and_after_are_compared() {
        let before = [true, true, false, true, false];
        let after = [true, false, true, true, false];
        assert_eq!(usable_in_both(&before, &after), [0, 3]);
        assert_eq!(usable_in_both(&after, &before), [0, 3]);
        assert!(usable_in_both(&[false; 3], &[true; 3]).is_empty());
    }

    /// RMSE and the NRMSE fit by hand: y = (1, 2, 3, 4) has mean 2.5 and ‖y − ȳ‖ = √5; a
    /// residual (1, 1, 1, 1) is RMSE 1 and fit 100·(1 − 2/√5) = 10.56 %, one of (0.5, 0, 0, 0.5)
    /// RMSE √(0.5/4) = 0.354 and fit 100·(1 − √0.5/√5) = 68.38 %. Only the samples `idx` count.
    #[test]
    fn the_errors_are_the_rmse_and_the_nrmse_fit_by_hand() {
        let y = [1.0, 2.0, 3.0, 4.0, 100.0];
        let (before, after) = ([1.0, 1.0, 1.0, 1.0, 50.0], [0.5, 0.0, 0.0, 0.5, 50.0]);
        let e = axis_error(Channel::AccelKin, 1, &y, &before, &after, &[0, 1, 2, 3]);
        assert_eq!((e.axis, e.samples), ('y', 4));
        assert!((e.rmse_before - 1.0).abs() < 1e-15 && (e.rmse_after - 0.125f64.sqrt()).abs() < 1e-15, "{e:?}");
        let want = |r2: f64| 100.0 * (1.0 - (r2 / 5.0f64).sqrt());
        assert!(
            (e.fit_before_pct.unwrap() - want(4.0)).abs() < 1e-12
                && (e.fit_after_pct.unwrap() - want(0.5)).abs() < 1e-12,
            "{e:?}"
        );
        // a flat signal has no fit to speak of
        let flat = axis_error(Channel::AccelKin, 0, &[2.0; 4], &before, &after, &[0, 1, 2, 3]);
        assert!(flat.fit_before_pct.is_none() && flat.fit_after_pct.is_none());
        // y = (1, −1, 1, −1): a spread of ‖y − ȳ‖ = 2 = √n, far above the 1e-9·√n threshold, has
        // its fit, 100·(1 − 1/2) = 50 % for a residual of 0.5 (a bug it catches: `1e-9 + √n` gave none)
        let e = axis_error(Channel::Gyro, 2, &[1.0, -1.0, 1.0, -1.0], &before, &[0.5; 4], &[0, 1, 2, 3]);
        assert!((e.fit_after_pct.unwrap() - 50.0).abs() < 1e-12 && (e.rmse_after - 0.5).abs() < 1e-15, "{e:?}");
        // the threshold grows with √n: over n = 4 it is 2e-9, so a spread of 1e-9 (y = ±5e-10) has
        // no fit and one of 3e-9 (y = ±1.5e-9) has one (a bug it catches: `1e-9 / √n`, 5e-10, gave the first a fit)
        let alt = |h: f64| [h, -h, h, -h];
        let thin = axis_error(Channel::Gyro, 0, &alt(5e-10), &before, &[0.5; 4], &[0, 1, 2, 3]);
        let thick = axis_error(Channel::Gyro, 0, &alt(1.5e-9), &before, &[0.5; 4], &[0, 1, 2, 3]);
        assert!(thin.fit_after_pct.is_none() && thick.fit_after_pct.is_some(), "{thin:?} {thick:?}");
        // and the bound is strict: a spread of exactly 2e-9 (y = ±1e-9: √(4·(1e-9)²) is 2e-9 to the
        // bit, as is 1e-9·√4) has none (a bug it catches: `>` as `>=` gave it one)
        let edge = axis_error(Channel::Gyro, 0, &alt(1e-9), &before, &[0.5; 4], &[0, 1, 2, 3]);
        assert!(edge.fit_after_pct.is_none(), "{edge:?}");
    }
}

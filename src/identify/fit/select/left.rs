//! "What is left": the final residual per channel axis (held-out error, whiteness) and the
//! measured signals it follows (the leads), with the effective sample size of two
//! autocorrelated series (Bartlett) for the significance.

use super::AXES;
use super::gram::{active, residual_of};
use super::heldout::axis_error;
use super::result::{AxisError, Correlate, Left, Whiteness};
use crate::effects::{Channel, Effect};
use crate::identify::fit::design::Design;
use crate::identify::fit::note::{ForceLead, Note};
use crate::identify::fit::stats::{Ar, Z_995, autocorrelation, ljung_box};

/// Weaker correlations than this are not named as leads (significant but explaining < 1 % of
/// the residual's variance is no lead).
pub const LEAD_MIN_CORR: f64 = 0.1;
/// At most this many leads per channel axis.
pub const LEAD_MAX: usize = 3;

/// The measured signals of a design built with signals, masked to its usable samples, with
/// their autocorrelations (lags 1..=50), computed once for every channel axis.
pub(super) struct LeadSignals<'a> {
    pub(super) design: &'a Design,
    pub(super) masked: Vec<Vec<f64>>,
    pub(super) acf: Vec<Vec<f64>>,
}

pub(super) fn lead_signals(d: &Design) -> LeadSignals<'_> {
    let masked: Vec<Vec<f64>> =
        d.signals.iter().map(|sg| (0..d.n).map(|i| if d.ok[i] { sg.samples[i] } else { f64::NAN }).collect()).collect();
    let acf = masked.iter().map(|x| crate::identify::fit::stats::autocorrelation(x, 50).0).collect();
    LeadSignals { design: d, masked, acf }
}

/// The leads of one residual of channel `c`, axis `a`: the measured signals it follows (see
/// [`Left::correlates`]).
pub(super) fn leads(ls: &LeadSignals, c: usize, a: usize, residual: &[f64]) -> Vec<Correlate> {
    let d = ls.design;
    let r: Vec<f64> = (0..d.n).map(|i| if d.ok[i] { residual[i] } else { f64::NAN }).collect();
    let idx: Vec<usize> = (0..d.n).filter(|&i| r[i].is_finite()).collect();
    if idx.len() < 3 {
        return Vec::new();
    }
    let (r_acf, _) = crate::identify::fit::stats::autocorrelation(&r, 50);
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
        let n_eff = crate::identify::fit::stats::effective_n(idx.len(), &r_acf, &ls.acf[k]);
        // two-sided test of r = 0 (r·√n_eff ~ N(0, 1)), Bonferroni over the signals
        let p = crate::identify::fit::stats::chi2_sf(rho * rho * n_eff, 1.0);
        if rho.abs() >= LEAD_MIN_CORR && p < 0.01 / d.signals.len() as f64 {
            out.push(Correlate { signal: sg.name.to_string(), r: rho, n_eff, floor: sg.floor });
        }
    }
    out.sort_by(|a, b| b.r.abs().total_cmp(&a.r.abs()));
    out.truncate(LEAD_MAX);
    out
}

/// The final model's held-out error per channel axis (against the nominal model's), the
/// whiteness of its residual (raw autocorrelation, then Ljung–Box after AR(p) prewhitening)
/// and what is left of it (structured or not, and the leads it follows).
pub(super) fn final_residuals(
    d: &Design,
    theta: &[f64],
    test: &[bool],
    nominal_design: &Design,
    lead_sigs: &LeadSignals,
    max_ar_order: usize,
) -> (Vec<AxisError>, Vec<Whiteness>, Vec<Left>) {
    let mut errors = Vec::new();
    let mut whiteness = Vec::new();
    let mut left = Vec::new();
    for (c, a) in active(d) {
        let before = nominal_design.residual(c, a);
        let after = residual_of(d, c, a, theta);
        let idx: Vec<usize> = (0..d.n).filter(|&i| test[i] && nominal_design.ok[i]).collect();
        let ch = Channel::ALL[c];
        errors.push(axis_error(ch, a, &d.measured[c][a], &before, &after, &idx));
        // whiteness of the final residual on the usable samples
        let ok: Vec<bool> = d.ok.clone();
        let raw: Vec<f64> = (0..d.n).map(|i| if ok[i] { after[i] } else { f64::NAN }).collect();
        let (r, n) = autocorrelation(&raw, 50);
        let outside = outside_99(&r, n);
        let ar = Ar::fit(&after, &ok, max_ar_order);
        let mut w = Vec::new();
        ar.whiten(&after, &ok, &mut w);
        let lb = ljung_box(&w, 20, ar.order());
        let correlates = leads(lead_sigs, c, a, &after);
        let err = errors.last().expect("pushed above");
        left.push(Left {
            channel: ch,
            axis: AXES[a],
            rmse: err.rmse_after,
            unit: err.unit.clone(),
            ljung_box_p: lb.p_value,
            structured: structured(&correlates, lb.p_value),
            correlates,
        });
        whiteness.push(Whiteness {
            channel: ch,
            axis: AXES[a],
            raw_outside_99: outside,
            ar_order: ar.order(),
            ljung_box: lb,
        });
    }
    (errors, whiteness, left)
}

/// A note naming the hypothesis that a lead is the signature of, when it was not fitted: the
/// force residual's x following the angular acceleration about y, or its y the one about x, is
/// what an IMU off the centre of mass leaves there (ω̇ × r with r along z: (ω̇_y·r_z, −ω̇_x·r_z));
/// `--with imu_offset` tests it. On the held-out NanoBench flights that lead (the commonest one
/// of the force channel: x on 38 of 68 flights, y on 19) is gone on all but 9 and 1 once the
/// offset is fitted.
pub(super) fn hypothesis_hint(left: &[Left], fitted: &[Effect]) -> Option<Note> {
    if fitted.contains(&Effect::ImuOffset) {
        return None;
    }
    let signature = |l: &Left| {
        let about = match l.axis {
            'x' => "angular acceleration y (rad/s²)",
            'y' => "angular acceleration x (rad/s²)",
            _ => return None,
        };
        l.correlates.iter().find(|c| c.signal == about).map(|c| ForceLead {
            axis: l.axis,
            signal: c.signal.clone(),
            r: c.r,
        })
    };
    let leads: Vec<ForceLead> = left.iter().filter(|l| l.channel == Channel::Force).filter_map(signature).collect();
    (!leads.is_empty()).then_some(Note::ImuOffsetSignature { leads })
}

/// The fraction of the autocorrelations `r` (of a series with `n` usable samples) outside the
/// 99 % band of white noise, ±z₀.₉₉₅/√n.
fn outside_99(r: &[f64], n: usize) -> f64 {
    let bound = Z_995 / (n.max(1) as f64).sqrt();
    r.iter().filter(|x| x.abs() > bound).count() as f64 / r.len() as f64
}

/// Is a final residual still structured? It follows a measured signal of the flight (a lead; a
/// signal of the mocap's own error, a floor, is none), or its prewhitened residual fails
/// Ljung–Box at 1 %.
fn structured(correlates: &[Correlate], ljung_box_p: f64) -> bool {
    correlates.iter().any(|x| !x.floor) || ljung_box_p < 0.01
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::identify::fit::design::Signal;

    /// A design of `n` usable samples with the given lead signals and nothing else.
    fn signals_only(n: usize, signals: Vec<Signal>) -> Design {
        Design {
            n,
            t: (0..n).map(|i| i as f64 * 0.01).collect(),
            ok: vec![true; n],
            has_force: true,
            signals,
            ..Design::default()
        }
    }

    /// The held-out error counts the samples that are both held out and usable in the nominal
    /// design: of 100, the even ones held out and the first 80 usable leave 40, each with a nominal
    /// residual of ±3 (RMSE 3); every other sample's residual is 1000. A bug it catches: the `&&`
    /// as `||` (90 samples, RMSE √((40·9 + 50·1000²)/90) ≈ 745).
    #[test]
    fn the_heldout_error_counts_the_usable_heldout_samples_only() {
        let n = 100;
        let test: Vec<bool> = (0..n).map(|i| i % 2 == 0).collect();
        let mut nominal = signals_only(n, Vec::new());
        nominal.ok = (0..n).map(|i| i < 80).collect();
        let y: Vec<f64> =
            (0..n).map(|i| if test[i] && i < 80 { if i % 4 == 0 { 3.0 } else { -3.0 } } else { 1000.0 }).collect();
        nominal.measured[0][0] = y;
        nominal.predicted[0][0] = vec![0.0; n];
        let d = Design {
            measured: nominal.measured.clone(),
            predicted: nominal.predicted.clone(),
            ..signals_only(n, Vec::new())
        };
        let (errors, _, _) = final_residuals(&d, &[], &test, &nominal, &lead_signals(&d), 2);
        assert_eq!(errors.len(), 1);
        let e = &errors[0];
        assert_eq!((e.samples, e.rmse_before, e.rmse_after), (40, 3.0, 3.0));
    }

    /// Pearson's r is invariant to offsets and scale: a residual r = 2x + 3 of a white signal x = 1 +
    /// w (w uniform on ±0.5, so n_eff ≈ n) follows it with r = 1 exactly, and one independent of
    /// x (a second white series) is no lead. Fails if either sum of squares is taken about anything
    /// but the mean (a bug it catches: Σ(r + m̄)² = n·(σ_r² + 4m̄²) gives r = σ_r/√(σ_r² + 4·5²) =
    /// 0.577/10.0 ≈ 0.058 here, below `LEAD_MIN_CORR`: no lead). The cross sum Σ(r − m̄)(x − x̄) is
    /// the same about any centre of one factor (Σ(x − x̄) = 0).
    #[test]
    fn a_residual_that_is_a_signal_plus_an_offset_follows_it_with_r_one() {
        let n = 400;
        let mut rng = crate::rng::Stream::new(5, crate::rng::Component::Sweep, 0);
        let mut white = || rng.uniform() - 0.5;
        let x: Vec<f64> = (0..n).map(|_| 1.0 + white()).collect();
        let other: Vec<f64> = (0..n).map(|_| white()).collect();
        let d = signals_only(n, vec![Signal { name: "x", samples: x.clone(), excludes: vec![], floor: false }]);
        let ls = lead_signals(&d);
        let residual: Vec<f64> = x.iter().map(|x| 2.0 * x + 3.0).collect();
        let got = leads(&ls, 1, 0, &residual);
        assert_eq!(got.len(), 1, "{got:?}");
        assert!((got[0].r - 1.0).abs() < 1e-12, "{got:?}");
        assert!(leads(&ls, 1, 0, &other).is_empty());
        // a signal excluded for this channel axis is no lead even when followed exactly
        let d = signals_only(n, vec![Signal { name: "x", samples: x, excludes: vec![(1, 0)], floor: false }]);
        assert!(leads(&lead_signals(&d), 1, 0, &residual).is_empty());
    }

    /// A lead must be significant as well as strong: ρ²·n_eff against χ²(1) at 1 % (one signal).
    /// Over 200 samples of white series (n_eff ≈ 200; it would have to exceed 460), a residual
    /// built to follow the signal with ρ = 0.12 exactly (the signal's and an orthogonal white
    /// series' centred parts, of equal norm, mixed as ρ and √(1 − ρ²)) clears `LEAD_MIN_CORR` but
    /// not the test (ρ²·n_eff ≈ 2.9 < 6.63), so it is no lead; with ρ = 0.5 (≈ 50) it is one, with
    /// that r. A bug it catches: the statistic ρ² + n_eff (every correlation above 0.1
    /// significant).
    #[test]
    fn a_lead_needs_a_significant_correlation_not_only_one_above_the_floor() {
        let n = 200;
        let mut rng = crate::rng::Stream::new(9, crate::rng::Component::Sweep, 0);
        let mut white = || rng.uniform() - 0.5;
        let x: Vec<f64> = (0..n).map(|_| white()).collect();
        let y: Vec<f64> = (0..n).map(|_| white()).collect();
        let centred = |v: &[f64]| {
            let m = v.iter().sum::<f64>() / v.len() as f64;
            v.iter().map(|v| v - m).collect::<Vec<f64>>()
        };
        let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(a, b)| a * b).sum::<f64>();
        let xc = centred(&x);
        let yc = centred(&y);
        let along = dot(&yc, &xc) / dot(&xc, &xc);
        let y_perp: Vec<f64> = yc.iter().zip(&xc).map(|(y, x)| y - along * x).collect();
        let scale = (dot(&xc, &xc) / dot(&y_perp, &y_perp)).sqrt();
        let follow = |rho: f64| -> Vec<f64> {
            xc.iter().zip(&y_perp).map(|(x, y)| 0.7 + rho * x + (1.0 - rho * rho).sqrt() * scale * y).collect()
        };
        let d = signals_only(n, vec![Signal { name: "x", samples: x.clone(), excludes: vec![], floor: false }]);
        let ls = lead_signals(&d);
        let weak = leads(&ls, 1, 0, &follow(0.12));
        assert!(weak.is_empty(), "{weak:?}");
        let strong = leads(&ls, 1, 0, &follow(0.5));
        assert_eq!(strong.len(), 1, "{strong:?}");
        assert!((strong[0].r - 0.5).abs() < 1e-12 && (100.0..300.0).contains(&strong[0].n_eff), "{strong:?}");
        // the weak one's statistic, with the strong one's n_eff (both residuals are white)
        assert!(0.12f64.powi(2) * strong[0].n_eff < 6.63, "n_eff {}", strong[0].n_eff);
        // Bonferroni over the signals: ρ²·n_eff ≈ 8 (p ≈ 0.005) is a lead of one signal (level
        // 0.01, χ²(1) > 6.63) but not of one among five (level 0.002, χ²(1) > 9.55): four more
        // white signals, independent of the residual, only raise the bar. A bug it catches: the
        // level 0.01·m or 0.01 % m (both 0.01 for one signal).
        let mid = follow((8.0 / strong[0].n_eff).sqrt());
        let one = leads(&ls, 1, 0, &mid);
        assert_eq!(one.len(), 1, "{one:?}");
        let stat = one[0].r.powi(2) * one[0].n_eff;
        assert!((6.63..9.55).contains(&stat), "ρ²·n_eff = {stat}");
        let mut five = vec![Signal { name: "x", samples: x, excludes: vec![], floor: false }];
        for name in ["w1", "w2", "w3", "w4"] {
            five.push(Signal { name, samples: (0..n).map(|_| white()).collect(), excludes: vec![], floor: false });
        }
        let among_five = leads(&lead_signals(&signals_only(n, five)), 1, 0, &mid);
        assert!(among_five.is_empty(), "{among_five:?}");
    }

    /// The hint names `--with imu_offset` for force.x following ω̇_y or force.y following ω̇_x,
    /// not for force.z, not for another signal, and not once the offset is fitted.
    #[test]
    fn the_imu_offset_is_named_for_its_signature_only() {
        let left = |axis: char, signal: &str| Left {
            channel: Channel::Force,
            axis,
            rmse: 0.03,
            unit: "m/s²".into(),
            ljung_box_p: 0.5,
            structured: true,
            correlates: vec![Correlate { signal: signal.into(), r: 0.25, n_eff: 300.0, floor: false }],
        };
        let hit = hypothesis_hint(&[left('x', "angular acceleration y (rad/s²)")], &[]);
        assert_eq!(
            hit,
            Some(Note::ImuOffsetSignature {
                leads: vec![ForceLead { axis: 'x', signal: "angular acceleration y (rad/s²)".into(), r: 0.25 }]
            })
        );
        assert!(hypothesis_hint(&[left('y', "angular acceleration x (rad/s²)")], &[]).is_some());
        assert!(hypothesis_hint(&[left('x', "angular acceleration y (rad/s²)")], &[Effect::ImuOffset]).is_none());
        assert!(
            hypothesis_hint(
                &[left('x', "angular acceleration x (rad/s²)"), left('z', "angular acceleration y (rad/s²)")],
                &[]
            )
            .is_none()
        );
        let mut gyro = left('x', "angular acceleration y (rad/s²)");
        gyro.channel = Channel::Gyro;
        assert!(hypothesis_hint(&[gyro], &[]).is_none());
    }

    /// The verdict by hand: a lead makes a residual structured whatever Ljung–Box says, a
    /// floor does not, and without a lead Ljung–Box decides at 1 %.
    #[test]
    fn a_residual_is_structured_by_a_lead_or_by_ljung_box() {
        let c = |floor: bool| Correlate { signal: "s".into(), r: 0.3, n_eff: 100.0, floor };
        assert!(structured(&[c(false)], 0.9));
        assert!(!structured(&[c(true)], 0.9));
        assert!(!structured(&[], 0.011) && !structured(&[], 0.01));
        assert!(structured(&[], 0.009) && structured(&[c(true)], 0.001));
    }

    /// The 99 % band by hand: with 100 samples it is ±2.5758/10 = ±0.258, so of the lags
    /// (0.5, 0.25, −0.3, 0.01) two lie outside; with 10,000 samples (±0.0258) three do.
    #[test]
    fn the_white_noise_band_narrows_with_the_samples() {
        let r = [0.5, 0.25, -0.3, 0.01];
        assert_eq!(outside_99(&r, 100), 0.5);
        assert_eq!(outside_99(&r, 10_000), 0.75);
    }
}

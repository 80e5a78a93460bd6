//! After the selection: the intervals widened where the final model cannot tell two
//! explanations apart (a swap of a selected effect for one outside), or where a candidate the
//! data half-supports would move the estimates.

use super::gram::{canonical_corr, fit, set_of};
use super::result::{Candidate, Found};
use super::{Options, Problem, available, fold, params_of, refine, rest_tilt, rest_tilt_sd, values_of};
use crate::effects::Effect;
use crate::identify::fit::ground::Rest;
use crate::identify::fit::note::{Moved, Note};
use crate::identify::fit::stats::Z_975;
use crate::identify::input::series::{Corrections, Series};

/// The final model, as the widening checks read it.
pub(super) struct Final<'a> {
    pub(super) s: &'a Series,
    pub(super) o: &'a Options,
    pub(super) state: &'a Problem,
    pub(super) corr: Corrections,
    pub(super) selected: &'a [Effect],
    /// The rest the ground check reads, for the tilt it compares with.
    pub(super) rest: Option<Rest>,
}

/// swaps the final model cannot tell apart: a selected effect E and a candidate C outside the
/// model whose blocks are collinear once every *other* selected effect is projected out (the
/// check at each step conditions only on what was selected before, and misses pairs that a
/// later effect couples, e.g. a constant force and a world tilt through an accelerometer bias
/// that lives in both channels). E's parameters are then one explanation of several; the
/// others' intervals are widened to cover the swapped model's estimates.
///
/// `named_at_step(e, c)`: the step that added E named C not identifiable from it.
#[allow(clippy::too_many_arguments)]
pub(super) fn swaps(
    fin: &Final,
    named_at_step: impl Fn(Effect, Effect) -> bool,
    tilt_total: [f64; 2],
    yaw_spread_deg: f64,
    not_identifiable: &mut Vec<(Effect, Effect, f64)>,
    effects: &mut [Found],
    tilt_widen: &mut [f64; 2],
    notes: &mut Vec<Note>,
) {
    let outside: Vec<Effect> = fin
        .o
        .candidates
        .iter()
        .copied()
        .filter(|c| !fin.selected.contains(c) && available(&fin.state.design, *c))
        .collect();
    for (k, e) in fin.selected.iter().copied().enumerate() {
        if fin.o.forced.contains(&e) {
            continue;
        }
        let others: Vec<Effect> = fin.selected.iter().copied().filter(|x| *x != e).collect();
        for c in outside.iter().copied() {
            let rho = canonical_corr(&fin.state.grams, &set_of(&others), &set_of(&[e]), &set_of(&[c]));
            // a pair named at E's step stays one: the step's test found C passing and
            // collinear with E, so E's value may hold C's (a thrust scale holding the mean
            // of a voltage effect), whatever the final model's noise model makes of ρ
            let named_at_step = named_at_step(e, c);
            if rho <= 0.99 && !named_at_step {
                continue;
            }
            if !lists(not_identifiable, e, c) {
                not_identifiable.push((e, c, rho));
                notes.push(Note::ExplainAlike { effect: e, other: c, correlation: rho, yaw_spread_deg });
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
            let alt_state = refine(fin.s, fin.o, &mut alt_corr, &alt, fin.o.refine_iterations);
            let alt_total = rest_tilt(fin.s, fin.rest.as_ref(), &alt, &alt_state.fit.theta, &alt_corr).total;
            let asd = rest_tilt_sd(
                fin.s,
                fin.rest.as_ref(),
                &alt,
                &alt_state.fit.theta,
                &alt_corr,
                &alt_state.fit.set,
                &alt_state.cov,
            );
            for k in 0..2 {
                tilt_widen[k] = tilt_widen[k].max(covering(tilt_total[k], alt_total[k], Z_975 * asd[k]));
            }
            for f in effects.iter_mut().filter(|f| f.effect != e) {
                let alt_params =
                    params_of(f.effect, &alt_state.fit.theta, &alt_state.cov, &alt_state.fit.set, &alt_corr);
                for (p, q) in f.params.iter_mut().zip(alt_params) {
                    p.ci95 = p.ci95.max(covering(p.value, q.value, q.ci95));
                }
            }
        }
    }
}

/// Whether `pairs` holds the pair {e, c}, in either order.
fn lists(pairs: &[(Effect, Effect, f64)], e: Effect, c: Effect) -> bool {
    pairs.iter().any(|(a, b, _)| (*a == e && *b == c) || (*a == c && *b == e))
}

/// The half-width an interval around `estimate` needs to contain the interval of half-width
/// `half_width` around `alternative`: |alternative − estimate| + half_width, the smallest that
/// covers both the estimate and the alternative's whole interval.
fn covering(estimate: f64, alternative: f64, half_width: f64) -> f64 {
    (alternative - estimate).abs() + half_width
}

/// What a widened half-width `covering` adds beyond the fit's own half-width `own`:
/// covering − own, and nothing when the fit's own interval already covers the alternatives.
pub(super) fn beyond_own(covering: f64, own: f64) -> f64 {
    (covering - own).max(0.0)
}

/// A candidate of a last round of `m` the data half-supports: it failed (the held-out gate), yet
/// it lowers BIC and passes the F-test at the Bonferroni level α/m.
fn is_half_supported(c: &Candidate, alpha: f64, m: usize) -> bool {
    !c.passed && c.delta_bic < 0.0 && c.p_value < alpha / m.max(1) as f64
}

/// candidates the data half-supports: in the last round they passed the F-test and ΔBIC but
/// not the held-out gate (a 5 ms mocap delay over calibration circles: the rate vector turns
/// at Ω, so the delay looks like a body-offset yaw of Ω·δt, and the flight cannot say which).
/// Left out, such a C may bias the selected effects (omitted variable); so each selected
/// interval is widened to cover the estimate with C in the model too, the shift taken from
/// the linearised fit of S + C at the final corrections.
pub(super) fn half_supported(
    fin: &Final,
    final_candidates: &[Candidate],
    tilt_sd: [f64; 2],
    effects: &mut [Found],
    tilt_widen: &mut [f64; 2],
    notes: &mut Vec<Note>,
) {
    let near: Vec<&Candidate> =
        final_candidates.iter().filter(|c| is_half_supported(c, fin.o.alpha, final_candidates.len())).collect();
    let folded = |set: &[usize], effects: &[Effect]| {
        let mut theta = fit(&fin.state.grams, set).theta;
        let mut corr = fin.corr;
        fold(&mut corr, &mut theta, effects);
        (theta, corr)
    };
    let base_set = &fin.state.fit.set;
    let (bt, bc) = folded(base_set, fin.selected);
    // the tilt at rest the ground check compares with moves too
    let base_total = rest_tilt(fin.s, fin.rest.as_ref(), fin.selected, &bt, &bc).total;
    for c in near {
        let mut with_c = fin.selected.to_vec();
        with_c.push(c.effect);
        let alt_set = set_of(&with_c);
        let (at, ac) = folded(&alt_set, &with_c);
        let alt_total = rest_tilt(fin.s, fin.rest.as_ref(), &with_c, &at, &ac).total;
        for k in 0..2 {
            tilt_widen[k] = tilt_widen[k].max(covering(base_total[k], alt_total[k], Z_975 * tilt_sd[k]));
        }
        let mut moved = Vec::new();
        for f in effects.iter_mut() {
            let base = values_of(f.effect, &bt, base_set, &bc);
            let alt = values_of(f.effect, &at, &alt_set, &ac);
            for ((p, b), a) in f.params.iter_mut().zip(base).zip(alt) {
                if (a - b).abs() > p.ci95 {
                    moved.push(Moved { effect: f.effect, param: p.name.clone(), shift: a - b, unit: p.unit.clone() });
                }
                p.ci95 = covering(b, a, p.ci95);
            }
        }
        notes.extend(moved_note(c, moved, fin.o.min_heldout_gain));
    }
}

/// ΔBIC at or below this is very strong evidence (ΔBIC ≈ −2·ln B, the Bayes factor B; Kass and
/// Raftery's scale calls 2·ln B > 10 very strong).
pub(super) const VERY_STRONG_BIC: f64 = -10.0;

/// The note for a half-supported candidate `c`: with very strong evidence (ΔBIC ≤
/// [`VERY_STRONG_BIC`]) it always names the candidate and the option that fits it as a tested
/// hypothesis (a delay that the held-out blocks cannot confirm is still the value a user must
/// set); and it names the estimates `moved` beyond their own intervals with it in. None for a
/// weaker candidate that moves nothing that far.
fn moved_note(c: &Candidate, moved: Vec<Moved>, min_heldout_gain: f64) -> Option<Note> {
    let very_strong = c.delta_bic <= VERY_STRONG_BIC;
    (very_strong || !moved.is_empty()).then_some(Note::HalfSupported {
        effect: c.effect,
        delta_bic: c.delta_bic,
        p_value: c.p_value,
        heldout_gain: c.heldout_gain,
        min_heldout_gain,
        very_strong,
        moved,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The note's sentence for candidate `c` with a 10 % held-out gate.
    fn text(c: &Candidate, moved: Vec<Moved>) -> Option<String> {
        moved_note(c, moved, 0.1).map(|n| n.to_string())
    }

    /// An estimate of `effect` that moved by `shift`.
    fn moved_by(effect: Effect, param: &str, shift: f64, unit: &str) -> Moved {
        Moved { effect, param: param.into(), shift, unit: unit.into() }
    }

    /// A pair is listed in either order and only as itself: with {thrust scale, voltage} listed, a
    /// pair that shares one of its effects is not. A bug it catches: the check as `(a == e || b ==
    /// c) || …` took (thrust scale, ground effect) as listed, and a second pair of one selected
    /// effect went unlisted.
    #[test]
    fn a_pair_is_listed_in_either_order_and_only_as_itself() {
        use Effect::{GroundEffect, MocapDelay, ThrustScale, ThrustVoltage};
        let pairs = [(ThrustScale, ThrustVoltage, 0.995)];
        assert!(lists(&pairs, ThrustScale, ThrustVoltage) && lists(&pairs, ThrustVoltage, ThrustScale));
        for (e, c) in [
            (ThrustScale, GroundEffect),
            (GroundEffect, ThrustVoltage),
            (ThrustVoltage, GroundEffect),
            (GroundEffect, ThrustScale),
            (MocapDelay, GroundEffect),
        ] {
            assert!(!lists(&pairs, e, c), "({e:?}, {c:?}) is not listed");
        }
        assert!(!lists(&[], ThrustScale, ThrustVoltage));
    }

    /// The widened interval b ± w contains the alternative's interval a ± h, for a on either
    /// side of b, and no smaller w does: b = 1.0, a = 1.3 or 0.7, h = 0.2 give w = 0.5.
    /// Beyond the fit's own 0.2 that adds 0.3.
    #[test]
    fn a_widened_interval_covers_the_alternative_interval_and_no_more() {
        let (b, h) = (1.0, 0.2);
        for a in [1.3, 0.7] {
            let w = covering(b, a, h);
            assert!((w - 0.5).abs() < 1e-15, "{w}");
            assert!(b - w <= a - h + 1e-15 && a + h <= b + w + 1e-15, "{a} ± {h} not inside {b} ± {w}");
        }
        assert_eq!(covering(b, b, h), h, "no shift: the interval itself");
        // what it adds to the fit's own 0.2: 0.3; an own interval of 0.6 already covers
        assert!((beyond_own(covering(b, 1.3, h), h) - 0.3).abs() < 1e-15);
        assert_eq!(beyond_own(0.5, 0.6), 0.0);
    }

    /// By hand, α = 0.01 over 10 candidates (Bonferroni 0.001): p = 0.0005 with ΔBIC −3 that
    /// failed the held-out gate is half-supported; p = 0.005 is not (it would be at α·m or α);
    /// nor is one that passed, one with ΔBIC ≥ 0, or p at the level itself.
    #[test]
    fn half_supported_is_failed_bic_lowering_and_bonferroni_significant() {
        let c = |passed: bool, delta_bic: f64, p_value: f64| Candidate {
            effect: Effect::MocapDelay,
            delta_bic,
            f: 10.0,
            p_value,
            heldout_gain: 0.05,
            max_corr: 0.5,
            passed,
        };
        assert!(is_half_supported(&c(false, -3.0, 0.0005), 0.01, 10));
        assert!(!is_half_supported(&c(false, -3.0, 0.005), 0.01, 10));
        assert!(!is_half_supported(&c(true, -3.0, 0.0005), 0.01, 10));
        assert!(!is_half_supported(&c(false, 0.0, 0.0005), 0.01, 10));
        assert!(!is_half_supported(&c(false, -3.0, 0.001), 0.01, 10));
        // one candidate (or none counted): the level is α itself
        assert!(is_half_supported(&c(false, -3.0, 0.005), 0.01, 1));
        assert!(is_half_supported(&c(false, -3.0, 0.005), 0.01, 0));
    }

    /// A weakly supported candidate (ΔBIC −9.6, above the very-strong −10) gets a note only when
    /// an estimate moves beyond its own interval, and the note names each one. A bug it catches:
    /// the `!` deleted (a note for each candidate that moved nothing, none for one that did).
    #[test]
    fn a_note_names_the_estimates_a_half_supported_candidate_would_move() {
        let c = Candidate {
            effect: Effect::MocapDelay,
            delta_bic: -9.6,
            f: 10.0,
            p_value: 2.5e-4,
            heldout_gain: 0.031,
            max_corr: 0.5,
            passed: false,
        };
        assert_eq!(moved_note(&c, Vec::new(), 0.1), None);
        let moved =
            vec![moved_by(Effect::BodyOffset, "yaw", 0.412, "deg"), moved_by(Effect::GyroBias, "z", -0.05, "deg/s")];
        assert_eq!(
            text(&c, moved).as_deref(),
            Some(
                "mocap_delay is significant in the fit (ΔBIC -10, F-test p 2.5e-4) but does not cut the held-out error enough to join (-3.1 %); with it in, the estimates would move (body_offset yaw +0.412 deg, gyro_bias z -0.050 deg/s): their intervals cover both"
            )
        );
    }

    /// A candidate with very strong evidence (ΔBIC ≤ −10 on Kass and Raftery's scale) that fails
    /// only the held-out gate is always named, with the option that tests it, whether or not it
    /// moves an estimate; at ΔBIC −10 exactly it is very strong, at −9.99 not. A bug it catches:
    /// `<=` as `<`, or the strong note dropped when nothing moves.
    #[test]
    fn a_very_strong_candidate_failing_only_the_heldout_gate_is_named_with_its_option() {
        let c = |delta_bic| Candidate {
            effect: Effect::MocapDelay,
            delta_bic,
            f: 300.0,
            p_value: 1.0e-60,
            heldout_gain: 0.042,
            max_corr: 0.5,
            passed: false,
        };
        assert_eq!(
            text(&c(-358.2), Vec::new()).as_deref(),
            Some(
                "mocap_delay has very strong evidence in the fit (ΔBIC -358, F-test p 1.0e-60) and fails only the held-out gate (held-out error -4.2 %, the gate needs −10 %): not added; `--with mocap_delay` fits it as a hypothesis, with its interval"
            )
        );
        assert!(text(&c(-10.0), Vec::new()).is_some_and(|n| n.contains("very strong")));
        assert_eq!(moved_note(&c(-9.99), Vec::new(), 0.1), None);
        // a candidate that makes the held-out error grow says so with its sign
        let grows = Candidate { heldout_gain: -0.002, ..c(-67.0) };
        assert!(
            text(&grows, Vec::new()).is_some_and(|n| n.contains("(held-out error +0.2 %,")),
            "{:?}",
            text(&grows, Vec::new())
        );
        let moved = vec![moved_by(Effect::RotorDrag, "x", -0.01, "1/s")];
        assert!(text(&c(-50.0), moved).is_some_and(|n| n.contains("--with mocap_delay")
            && n.ends_with("(rotor_drag x -0.010 1/s): their intervals cover both")));
    }
}

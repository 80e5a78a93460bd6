//! R5: did `identify` find what the scenario hid? Rows in the same table as R1–R4.

use crate::effects::{Channel, Effect};
use crate::identify::fit::select::Report;
use crate::requirements::{self, Row};
use crate::scenario::IdentifyReq;

/// 1 − ‖after‖/‖before‖ over the three axes of a channel, held out.
pub fn heldout_cut(r: &Report, c: Channel) -> Option<f64> {
    crate::identify::fit::select::channel_cut(&r.errors, c)
}

/// The best held-out cut among the channels an effect lives in.
pub fn effect_cut(r: &Report, e: Effect) -> Option<f64> {
    e.channels().iter().filter_map(|c| heldout_cut(r, *c)).max_by(f64::total_cmp)
}

/// R5 for one vehicle: the rows of its `identify` requirement (effects found, parameters within
/// their limits, the held-out cut, nothing invented) checked against a report. An effect fitted
/// because the user asked for it (`--with`, or the delay `--px4` always fits) was not found by the
/// selection: it neither counts as found first nor as invented, but its parameters are checked
/// when it is expected.
pub fn check(r: &Report, req: &IdentifyReq, vehicle: &str) -> requirements::Report {
    let row = |what: String, measured: String, limit: String, pass: bool| Row {
        vehicle: vehicle.to_string(),
        id: "R5",
        what,
        measured,
        limit,
        pass,
        asserted: true,
    };
    let mut rows = Vec::new();
    let found: Vec<Effect> = r.effects.iter().map(|f| f.effect).filter(|e| !r.options.forced.contains(e)).collect();
    let names = |v: &[Effect]| {
        if v.is_empty() { "nothing".to_string() } else { v.iter().map(|e| e.key()).collect::<Vec<_>>().join(", ") }
    };
    let expected: Vec<Effect> = req.expect().map(|e| e.effect).collect();
    if let Some(first) = expected.first() {
        if r.options.forced.contains(first) {
            rows.push(row(
                "effect found first".into(),
                "fitted as asked (--with)".into(),
                first.key().into(),
                r.effect(*first).is_some(),
            ));
        } else {
            rows.push(row(
                "effect found first".into(),
                found.first().map_or("nothing".into(), |e| e.key().to_string()),
                first.key().into(),
                found.first() == Some(first),
            ));
        }
    }
    for e in req.expect() {
        let Some(f) = r.effect(e.effect) else {
            rows.push(row(format!("{} found", e.effect.key()), "not found".into(), "found".into(), false));
            continue;
        };
        for ((p, v), tol) in f.params.iter().zip(&e.values).zip(&e.tolerance) {
            let err = (p.value - v).abs();
            rows.push(row(
                format!("{} {} (truth {v} {})", e.effect.key(), p.name, p.unit).replace(" )", ")"),
                format!("{} {}", crate::identify::precision::with_interval(p.value, p.ci95), p.unit)
                    .trim_end()
                    .to_string(),
                format!("|err| ≤ {tol}"),
                err <= *tol,
            ));
        }
        let cut = effect_cut(r, e.effect);
        rows.push(row(
            format!("{} held-out RMSE cut (best channel)", e.effect.key()),
            cut.map_or("—".into(), |c| format!("{:.1} %", 100.0 * c)),
            format!("≥ {:.0} %", 100.0 * req.min_heldout_cut),
            cut.is_some_and(|c| c >= req.min_heldout_cut),
        ));
    }
    let extra: Vec<Effect> = found.iter().copied().filter(|e| !expected.contains(e)).collect();
    rows.push(row("no effect that is not there".into(), names(&extra), "nothing".into(), extra.is_empty()));
    requirements::Report { rows }
}

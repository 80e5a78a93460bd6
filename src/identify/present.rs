//! The presentation layer of `identify`'s front: the text the command line prints and the JSON
//! it writes, rendered from what [`run`](super::run) and [`run_many`](super::run_many) return
//! ([`Identified`], [`CrossValidated`], which hold data). It composes the renderers of the
//! report ([`render`](super::output::report::render)), the consistency across flights
//! ([`render`](super::output::consistency::render)) and the ground summaries
//! (`output/summary.rs`). A report's notes are data ([`Note`](super::Note)); their sentences are
//! `output/note.rs`'s `Display`. What is still text below this layer: the scenario fragment,
//! YAML by nature.

use super::Report;
use super::output::{report, summary};
use super::precision::{signed_with_interval as pm, with_interval};
use super::workflow::{CrossValidated, Exclusion, Identified};
use serde_json::{Value, json};

/// The report as `flyarena identify` prints it: the report's table, then, for a flight flown
/// from a scenario, the closed loop's error before and after.
pub fn identified_text(done: &Identified) -> String {
    let mut text = report::render(&done.report);
    if let Some((before, after)) = &done.closed_loop {
        text += &format!(
            "\n  closed loop (simulation vs data, same seed): position RMSE {:.1} mm → {:.1} mm, attitude RMSE {:.3}° → {:.3}°\n",
            before.position_rmse_m * 1e3,
            after.position_rmse_m * 1e3,
            before.attitude_rmse_deg,
            after.attitude_rmse_deg
        );
    }
    text
}

/// The report as `flyarena identify` writes it (`<input>.identify.json`): the report, the closed
/// loop (`null` for a log read through a mapping) and, for a flight flown from a scenario, R5.
pub fn identified_json(done: &Identified) -> Value {
    match &done.closed_loop {
        None => json!({ "report": done.report, "closed_loop": null }),
        Some((before, after)) => json!({
            "report": done.report,
            "closed_loop": { "nominal": before, "with_effects": after },
            "requirements": done.requirements
        }),
    }
}

/// A cross-validation as `flyarena identify LOG…` prints it: per flight, the two tables, the
/// consistency per mounting and the summaries over the flights.
pub fn cross_validated_text(m: &CrossValidated) -> String {
    let mut text = per_flight_text(&m.reports, &m.excluded);
    text += &cross_tables(&m.reports, &m.cross);
    text += &super::output::consistency::render(&m.consistency);
    text += &m.spin_up.as_ref().map_or(String::new(), summary::spin_up);
    text += &m.after_landing.as_ref().map_or(String::new(), summary::landed);
    text += &m.rest_pose.as_ref().map_or(String::new(), summary::rest_pose);
    text
}

/// A cross-validation as `flyarena identify LOG…` writes it (`cross-validation.identify.json`).
pub fn cross_validated_json(m: &CrossValidated) -> Value {
    let (reports, cross) = (&m.reports, &m.cross);
    json!({
        "reports": reports.iter().map(|(n, r)| json!({"flight": n, "report": r})).collect::<Vec<_>>(),
        "consistency": m.consistency,
        "spin_up": m.spin_up,
        "after_landing": m.after_landing,
        "rest_pose": m.rest_pose,
        "excluded": m.excluded.iter().map(|(n, e)| json!({"flight": n, "reason": e.to_string()})).collect::<Vec<_>>(),
        "cross_validation": {
            "flights": reports.iter().map(|(n, _)| n.clone()).collect::<Vec<_>>(),
            "accel_kin_cut": cross.iter().map(|row| row.iter().map(|c| c.0).collect::<Vec<_>>()).collect::<Vec<_>>(),
            "force_cut": cross.iter().map(|row| row.iter().map(|c| c.1).collect::<Vec<_>>()).collect::<Vec<_>>(),
        }
    })
}

/// The per-flight block of a cross-validation: each flight's held-out cuts, effects, ground
/// checks, leads and notes, then the flights left out and why.
fn per_flight_text(reports: &[(String, Report)], excluded: &[(String, Exclusion)]) -> String {
    use super::fit::select::channel_cut;
    use crate::effects::Channel;
    let mut text = String::from("per flight (held-out error cut per channel; effects with 95 % intervals):\n");
    for (name, r) in reports {
        let cuts: Vec<String> =
            Channel::ALL.iter().map(|c| format!("{} {}", c.name(), pct(channel_cut(&r.errors, *c)))).collect();
        text += &format!("\n  {name}: {}\n", cuts.join(", "));
        for f in &r.effects {
            let ps: Vec<String> =
                f.params.iter().map(|p| super::precision::param_text(p, |x| format!("{x:.3}"))).collect();
            text += &format!("    {:<34} {}\n", f.name, ps.join(", "));
        }
        if let Some(g) = &r.ground_check {
            let [r, p] = g.up_axis.tilt_names();
            let (rv, pv) = (with_interval(g.roll_deg, g.roll_se_deg), with_interval(g.pitch_deg, g.pitch_se_deg));
            text +=
                &format!("    ground check (at rest, {} samples; ± standard error): {r} {rv}°, {p} {pv}°\n", g.samples);
        }
        if let Some(a) = &r.ground_agreement {
            let [r, p] = a.up_axis.tilt_names();
            text += &format!(
                "    ground − bias tilt vs flight offset: {r} {}°, {p} {}°{}\n",
                pm(a.roll.difference_deg, a.roll.ci95_deg),
                pm(a.pitch.difference_deg, a.pitch.ci95_deg),
                if a.roll.covers && a.pitch.covers { "" } else { " (disagree)" }
            );
            if let Some(sp) = &a.spin_up {
                text += &format!(
                    "    spin-up ({:.0} % of the weight, {:.2} s) − rest: roll {}°, pitch {}°; spin-up − bias tilt vs flight offset: roll {}°, pitch {}°\n",
                    100.0 * sp.thrust_fraction,
                    sp.duration_s,
                    pm(sp.roll.change_deg, sp.roll.change_ci95_deg),
                    pm(sp.pitch.change_deg, sp.pitch.change_ci95_deg),
                    pm(sp.roll.difference_deg, sp.roll.ci95_deg),
                    pm(sp.pitch.difference_deg, sp.pitch.ci95_deg)
                );
            }
        }
        for l in r.left.iter().filter(|l| !l.correlates.is_empty()) {
            let leads: Vec<String> = l
                .correlates
                .iter()
                .map(|c| {
                    format!(
                        "{} r = {:+.2}{}",
                        c.signal,
                        c.r,
                        if c.floor { " (the mocap pose's own error)" } else { "" }
                    )
                })
                .collect();
            text += &format!(
                "    left on {}.{} ({:.3} {}): follows {}\n",
                l.channel.name(),
                l.axis,
                l.rmse,
                l.unit,
                leads.join(", ")
            );
        }
        for n in &r.notes {
            text += &format!("    note: {n}\n");
        }
    }
    for (name, e) in excluded {
        text += &format!("\n  {name}: left out, {e}\n");
    }
    text
}

/// Percent of a cut, or a dash where the channel is missing.
fn pct(x: Option<f64>) -> String {
    x.map_or("—".to_string(), |v| format!("{:.0}%", 100.0 * v))
}

/// The two cross-validation tables (accel_kin, force): the cut when the model fitted on the
/// row's flight is used on the column's flight.
fn cross_tables(reports: &[(String, Report)], cross: &[Vec<(Option<f64>, Option<f64>)>]) -> String {
    let mut text = String::new();
    for (k, title) in [
        (0, "accel_kin (mocap vs IMU: marker offset, tilt, delay)"),
        (1, "force (IMU vs force model: thrust, drag, wind)"),
    ] {
        text += &format!(
            "\ncross-validation, {title}: error cut when the model fitted on the row's flight is used on the column's flight\n"
        );
        // flight names cut to 12 characters (not bytes: a name may be any UTF-8)
        let short = |n: &str| n.chars().take(12).collect::<String>();
        let w = reports.iter().map(|(n, _)| short(n).chars().count()).max().unwrap_or(8).max(14);
        text += &format!("  {:<w$}", "fitted on \\ on");
        for (n, _) in reports {
            text += &format!(" {:>12}", short(n));
        }
        text.push('\n');
        for (i, (n, _)) in reports.iter().enumerate() {
            text += &format!("  {:<w$}", short(n));
            for cell in &cross[i] {
                text += &format!(" {:>12}", pct(if k == 0 { cell.0 } else { cell.1 }));
            }
            text.push('\n');
        }
    }
    text
}

impl std::fmt::Display for Exclusion {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Exclusion::CopyOf(first) => write!(f, "the same samples as {first} (a copy of that log): counted once"),
            Exclusion::Rejected(e) => write!(f, "{e}"),
        }
    }
}

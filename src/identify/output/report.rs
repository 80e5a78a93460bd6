//! The human table of an identification [`Report`].

use crate::identify::fit::select::Report;
use crate::identify::precision::param_text;
use std::fmt::Write as _;

fn sig(x: f64) -> String {
    if x == 0.0 || !x.is_finite() {
        return format!("{x}");
    }
    let mag = x.abs().log10().floor() as i32;
    let decimals = (2 - mag).clamp(0, 9) as usize;
    format!("{x:.decimals$}")
}

fn pct(x: Option<f64>) -> String {
    x.map_or("—".into(), |v| format!("{v:.1}%"))
}

/// A rotation past which Z-Y-X angles stop reading as three small turns about the axes (deg):
/// beyond it a rotation is printed as its angle and axis too, and its intervals as what they are,
/// small rotations about the axes.
const LARGE_ROTATION_DEG: f64 = crate::identify::fit::start::ROTATION_REACH_DEG;

/// An effect's parameters as printed. A body offset or a world tilt beyond
/// [`LARGE_ROTATION_DEG`] is printed as its angle about its axis, its Z-Y-X angles, and its 95 %
/// half-widths as a small rotation about the axes they belong to (the IMU's for the body offset,
/// the world's for the tilt): near a pitch of ±90° a roll or a yaw alone means nothing, and their
/// intervals are not the angles' own.
fn effect_text(f: &crate::identify::fit::select::Found, r: &Report) -> String {
    let (rot, about) = match f.effect {
        crate::effects::Effect::BodyOffset => (*r.corrections.body_offset.quaternion(), "the IMU's x, y, z"),
        crate::effects::Effect::WorldTilt => (*r.corrections.world_tilt.quaternion(), "the world's x, y"),
        _ => (nalgebra::UnitQuaternion::identity(), ""),
    };
    let angle = rot.angle().to_degrees();
    if about.is_empty() || angle <= LARGE_ROTATION_DEG || f.params.iter().any(|p| !p.identifiable) {
        let ps: Vec<String> = f.params.iter().map(|p| param_text(p, sig)).collect();
        return ps.join(", ");
    }
    let axis = rot.axis().map_or([0.0; 3], |a| [a.x, a.y, a.z]);
    let d = f.params.iter().map(|p| crate::identify::precision::decimals_for(p.ci95)).max().unwrap_or(2);
    let names: Vec<String> = f.params.iter().map(|p| format!("{} {:.d$}", p.name, p.value)).collect();
    let cis: Vec<String> = f.params.iter().map(|p| format!("±{:.d$}", p.ci95)).collect();
    format!(
        "{angle:.d$}° about ({:.3}, {:.3}, {:.3}): {} deg (Z-Y-X); 95 % {} deg about {about}",
        axis[0],
        axis[1],
        axis[2],
        names.join(", "),
        cis.join(", ")
    )
}

/// The report as the terminal shows it: steps, effects with their intervals, errors before and
/// after, what is left, the ground check and the notes.
pub fn render(r: &Report) -> String {
    let mut s = String::new();
    render_steps(&mut s, r);
    render_fit(&mut s, r);
    render_left(&mut s, r);
    render_ground(&mut s, r);
    for n in &r.notes {
        let _ = writeln!(s, "\n  note: {n}");
    }
    s
}

/// The report in one line, what `identify --quiet` prints: the effects fitted (selected or
/// named by `--with`), or that none passed the tests, or that the flight had too few usable
/// samples to try any, or that the fit is not physically possible (the frames or the clocks
/// are not aligned).
pub fn verdict(r: &Report) -> String {
    if let Some(m) = r.misaligned.first() {
        return format!("not aligned: {m}; no effect claimed");
    }
    if !crate::identify::fit::select::enough_to_select(r.train_samples) {
        return format!(
            "nothing identified: {} usable training samples, {} needed",
            r.train_samples,
            crate::identify::fit::select::MIN_TRAIN_SAMPLES
        );
    }
    if r.effects.is_empty() {
        return "no effect found: the nominal model explains the data".to_string();
    }
    let names: Vec<&str> = r.effects.iter().map(|f| f.name.as_str()).collect();
    format!("{} effect{} found: {}", names.len(), if names.len() == 1 { "" } else { "s" }, names.join("; "))
}

/// The header (samples, split, nominal model, repairs) and the selection, step by step.
fn render_steps(s: &mut String, r: &Report) {
    let _ = writeln!(s, "identify: {}", r.source);
    let mass = if r.model.rigid_body { String::new() } else { format!(", m = {} kg", r.model.mass_kg) };
    let _ = writeln!(
        s,
        "  {} samples; after smoothing and decimation {} for training and {} held out (the last of every {} blocks of {} s); nominal model: {}{mass}",
        r.samples, r.train_samples, r.heldout_samples, r.options.holdout_every, r.options.block_s, r.model.vehicle
    );
    for rep in &r.repairs {
        let _ = writeln!(s, "  read: {rep}");
    }
    super::start::render_start(s, r);
    if !crate::identify::fit::select::enough_to_select(r.train_samples) {
        let _ = writeln!(
            s,
            "\n  too few usable samples to select effects ({} for training, {} needed): none were tried, and what follows is the nominal model's",
            r.train_samples,
            crate::identify::fit::select::MIN_TRAIN_SAMPLES
        );
    } else if r.steps.is_empty() && r.options.forced.is_empty() {
        let _ = writeln!(s, "\n  no effect passes the tests: the nominal model explains the data");
    } else if r.steps.is_empty() {
        let _ = writeln!(s, "\n  no effect besides those fitted untested passes the tests");
    }
    for (k, st) in r.steps.iter().enumerate() {
        let _ = writeln!(
            s,
            "\n  step {}: + {}   ΔBIC {:.0}, F-test p {:.1e}, held-out error −{:.1} %",
            k + 1,
            match st.together_with {
                Some(b) => format!("{} together with {}", st.added.name(), b.name()),
                None => st.added.name().to_string(),
            },
            st.delta_bic,
            st.p_value,
            100.0 * st.heldout_gain
        );
        for (e, rho) in &st.not_identifiable_from {
            let _ = writeln!(
                s,
                "          not identifiable from {} by this data (canonical correlation {rho:.4})",
                e.name()
            );
        }
        let runners: Vec<String> = st
            .candidates
            .iter()
            .filter(|c| c.effect != st.added && Some(c.effect) != st.together_with)
            .map(|c| format!("{} {:.0}{}", c.effect.key(), c.delta_bic, if c.passed { "" } else { "✗" }))
            .collect();
        let _ = writeln!(s, "          other candidates (ΔBIC, ✗ = fails a test): {}", runners.join(", "));
        for w in r.removed.iter().filter(|w| w.after_step == k + 1) {
            let _ = writeln!(
                s,
                "\n  backward check: − {}   on top of every other selected effect: ΔBIC {:.0}, F-test p {:.1e}, held-out error {:+.1} % (fails a test: it leaves)",
                w.check.effect.name(),
                w.check.delta_bic,
                w.check.p_value,
                -100.0 * w.check.heldout_gain
            );
        }
    }
}

/// How the intervals were computed: Newey–West for a fit with blocks held out; a fit of every
/// usable sample takes its [`WholeCovariance`](crate::identify::WholeCovariance).
fn intervals_name(r: &Report) -> &'static str {
    use crate::identify::WholeCovariance::*;
    if !r.options.refit_every_sample {
        return "95 % Newey–West intervals";
    }
    match r.options.whole_covariance {
        Larger => "95 % intervals: the larger of Newey–West and the stationary covariance",
        Stationary => "95 % intervals: the stationary covariance",
        Parzen => "95 % intervals: Parzen-weighted scores over 2 s, Student's t",
    }
}

/// The effects found with their intervals, the held-out errors and the final whiteness.
fn render_fit(s: &mut String, r: &Report) {
    super::start::render_misaligned(s, r);
    if !r.effects.is_empty() {
        let _ = writeln!(s, "\n  effects found (least squares, {}):", intervals_name(r));
        for f in &r.effects {
            let _ = writeln!(s, "    {:<34} {}", f.name, effect_text(f, r));
        }
    }
    if r.train_samples + r.heldout_samples == 0 {
        // every figure below would be of no sample at all
        let _ = writeln!(
            s,
            "\n  no usable sample (airborne, away from gaps and edges): no error, whiteness or residual to show"
        );
        return;
    }
    let _ = writeln!(s, "\n  held-out error, nominal → with the effects:");
    let _ = writeln!(
        s,
        "    {:<11} {:>4} {:>12} {:>12} {:>8} {:>10} {:>10}",
        "channel", "axis", "RMSE before", "RMSE after", "unit", "fit before", "fit after"
    );
    for e in &r.errors {
        let _ = writeln!(
            s,
            "    {:<11} {:>4} {:>12} {:>12} {:>8} {:>10} {:>10}",
            e.channel.name(),
            e.axis,
            if e.samples == 0 { "—".to_string() } else { sig(e.rmse_before) },
            if e.samples == 0 { "—".to_string() } else { sig(e.rmse_after) },
            e.unit,
            pct(e.fit_before_pct),
            pct(e.fit_after_pct)
        );
    }
    let _ = writeln!(s, "\n  final residual whiteness (Ljung–Box, 20 lags, after AR(p) prewhitening):");
    let cells: Vec<String> = r
        .whiteness
        .iter()
        .map(|w| {
            format!(
                "{}.{} p={} (AR{}, raw {:.0}% of lags outside 99%)",
                w.channel.name(),
                w.axis,
                sig(w.ljung_box.p_value),
                w.ar_order,
                100.0 * w.raw_outside_99
            )
        })
        .collect();
    for c in cells {
        let _ = writeln!(s, "    {c}");
    }
}

/// What is left: per channel axis, structure, leads and the floor.
fn render_left(s: &mut String, r: &Report) {
    if !r.left.is_empty() && r.train_samples + r.heldout_samples > 0 {
        let _ = writeln!(
            s,
            "\n  what is left (final residual; leads: measured signals it follows, |r| ≥ 0.1 and significant at 1 % over all signals):"
        );
        for l in &r.left {
            let leads: Vec<String> =
                l.correlates.iter().filter(|c| !c.floor).map(|c| format!("{} r = {:+.2}", c.signal, c.r)).collect();
            let floor: Vec<String> =
                l.correlates.iter().filter(|c| c.floor).map(|c| format!("{} r = {:+.2}", c.signal, c.r)).collect();
            let mut verdict = match (l.structured, leads.is_empty()) {
                (false, _) => "no structure left (white, follows no measured signal of the flight)".to_string(),
                (true, true) => format!(
                    "structured (Ljung–Box p = {}), follows no measured signal of the flight",
                    sig(l.ljung_box_p)
                ),
                (true, false) => format!("structured, follows {}", leads.join(", ")),
            };
            if !floor.is_empty() {
                verdict += &format!("; part of it is the mocap pose's own error (follows {})", floor.join(", "));
            }
            let _ = writeln!(s, "    {}.{}: {} {} left; {verdict}", l.channel.name(), l.axis, sig(l.rmse), l.unit);
        }
    }
}

/// The ground check against the flight: at rest, at spin-up and after landing; each difference
/// at the precision of its interval.
fn render_ground(s: &mut String, r: &Report) {
    let pm = crate::identify::precision::signed_with_interval;
    if let Some(a) = &r.ground_agreement {
        let _ = writeln!(
            s,
            "\n  ground check against the flight (°; ground − fitted accelerometer-bias tilt vs the frame tilt, body offset + world tilt):"
        );
        if let Some(g) = &r.ground_check {
            let [r, p] = g.up_axis.tilt_names();
            let _ = writeln!(
                s,
                "    the still vehicle's mocap tilt scatters {:.3}° {r}, {:.3}° {p} per sample at rest",
                g.mocap_sd_deg[0], g.mocap_sd_deg[1]
            );
        }
        let names = a.up_axis.tilt_names();
        for (name, t) in names.into_iter().zip([&a.roll, &a.pitch]) {
            let _ = writeln!(
                s,
                "    {name:<5} ground {:+.2}, bias tilt {:+.2}, corrected {:+.2}; flight {:+.2}{}; difference {} {}",
                t.ground_deg,
                t.bias_tilt_deg,
                t.ground_corrected_deg,
                t.flight_deg,
                if a.frame_fitted { "" } else { " (no body offset or world tilt selected)" },
                pm(t.difference_deg, t.ci95_deg),
                if t.covers { "(agree)" } else { "(DISAGREE)" }
            );
        }
        if let Some(sp) = &a.spin_up {
            let _ = writeln!(
                s,
                "  spin-up (motors on at {:.0} % of the weight, still on the floor, {:.2} s) as the ground check:",
                100.0 * sp.thrust_fraction,
                sp.duration_s
            );
            for (name, t) in names.into_iter().zip([&sp.roll, &sp.pitch]) {
                let _ = writeln!(
                    s,
                    "    {name:<5} spin-up {:+.2} (spin-up − rest {}); difference to the flight {} {}",
                    t.ground_corrected_deg,
                    pm(t.change_deg, t.change_ci95_deg),
                    pm(t.difference_deg, t.ci95_deg),
                    if t.covers { "(agree)" } else { "(DISAGREE)" }
                );
            }
        }
    }
    if let Some((a, l)) = r.ground_agreement.as_ref().and_then(|a| a.after_landing.as_ref().map(|l| (a, l))) {
        let _ =
            writeln!(s, "  rest after landing ({} samples) as the ground check, and the two rests' mean:", l.samples);
        for (name, t) in a.up_axis.tilt_names().into_iter().zip([&l.roll, &l.pitch]) {
            let _ = writeln!(
                s,
                "    {name:<5} after {:+.2} (after − before {}); difference to the flight {} {}; mean of the rests {} {}",
                t.check.ground_corrected_deg,
                pm(t.check.change_deg, t.check.change_ci95_deg),
                pm(t.check.difference_deg, t.check.ci95_deg),
                if t.check.covers { "(agree)" } else { "(DISAGREE)" },
                pm(t.bracket_difference_deg, t.bracket_ci95_deg),
                if t.bracket_covers { "(agree)" } else { "(DISAGREE)" }
            );
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::identify::fit::select::Param;

    fn param(value: f64, ci95: f64, identifiable: bool) -> Param {
        Param { name: "x".into(), value, ci95, unit: "mm".into(), identifiable }
    }

    /// A parameter keeps the precision of its interval: the half-width to two significant
    /// digits, the value to the same decimals (a −3.02 ms delay ± 0.035 is not "−3.0 ± 0.04"
    /// nor "−3.0213 ± 0.0354"). Without an interval (not identifiable) the caller's format holds.
    #[test]
    fn a_parameter_is_printed_to_the_precision_of_its_interval() {
        let sig3 = |x: f64| format!("{x:.3}");
        assert_eq!(param_text(&param(-115.97, 1.82, true), sig3), "x -116.0 ± 1.8 mm");
        assert_eq!(param_text(&param(-3.0213, 0.0354, true), sig3), "x -3.021 ± 0.035 mm");
        assert_eq!(param_text(&param(0.34937, 0.00176, true), sig3), "x 0.3494 ± 0.0018 mm");
        assert_eq!(param_text(&param(161.98, 12.4, true), sig3), "x 162 ± 12 mm");
        assert_eq!(param_text(&param(0.0358, 0.0, false), sig3), "x 0.036 mm (not identifiable)");
        // not identifiable claims no interval, even where the fit computed one
        assert_eq!(param_text(&param(0.0358, 0.3, false), sig3), "x 0.036 mm (not identifiable)");
    }
}

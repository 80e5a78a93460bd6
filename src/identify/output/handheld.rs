//! The table of a batch of hand-held rigs (`trials --handheld`): per calibration parameter the
//! error's distribution, its 95 % coverage and the Cramér–Rao floor's, then what was selected.

use crate::effects::Effect;
use crate::identify::checks::handheld::{BOUND_DRAWS, Bound, Estimate, Outcome, Setting};
use std::fmt::Write as _;

/// The q-quantile of `x` (linear between order statistics); NaN for an empty slice.
pub(crate) fn quantile(x: &[f64], q: f64) -> f64 {
    let mut v = x.to_vec();
    v.sort_by(f64::total_cmp);
    if v.is_empty() {
        return f64::NAN;
    }
    let h = q * (v.len() - 1) as f64;
    let (lo, hi) = (h.floor() as usize, h.ceil() as usize);
    v[lo] + (v[hi] - v[lo]) * (h - lo as f64)
}

/// "95.5 % (191/200)", or a dash when there is nothing to cover.
fn coverage(covered: usize, of: usize) -> String {
    if of == 0 { "—".to_string() } else { format!("{:.1} % ({covered}/{of})", 100.0 * covered as f64 / of as f64) }
}

/// One outcome's error in a parameter, if it was found.
type ErrorOf = fn(&Outcome) -> Option<f64>;

/// The batch's table: per calibration parameter the error's median, 90th percentile and
/// largest value, and the 95 % coverage; then what was selected.
pub fn render(outcomes: &[Outcome], set: &Setting) -> String {
    let mut s = String::new();
    let ok: Vec<&Outcome> = outcomes.iter().filter(|o| o.error.is_none()).collect();
    let _ = writeln!(
        s,
        "{} hand-held flight{} of {} s (mocap {} Hz, IMU {} Hz), {} identified\n",
        outcomes.len(),
        if outcomes.len() == 1 { "" } else { "s" },
        set.duration_s,
        set.mocap_hz,
        set.imu_hz,
        ok.len()
    );
    let _ = writeln!(
        s,
        "| parameter | found | median error | p90 error | largest error | 95 % coverage | Cramér–Rao median, perfect mocap | Cramér–Rao median, as recorded |\n|---|---|---|---|---|---|---|---|"
    );
    let efficient = |b: fn(&Outcome) -> Option<&Bound>| -> Vec<[f64; 4]> {
        ok.iter().filter_map(|o| b(o)?.draws(o.trial.index, BOUND_DRAWS)).flatten().collect()
    };
    let (perfect, recorded) = (efficient(|o| o.bound.as_ref()), efficient(|o| o.bound_as_recorded.as_ref()));
    let rows: [(&str, &str, ErrorOf, &str); 4] = [
        ("rotation (angle)", "°", |o| o.rotation_err_deg, "body_offset."),
        ("world tilt (angle)", "°", |o| o.tilt_err_deg, "world_tilt."),
        ("lever arm (norm)", "mm", |o| o.lever_err_mm, "lever_arm."),
        ("time offset", "µs", |o| o.delay_err_us, "mocap_delay."),
    ];
    for (i, (name, unit, err, prefix)) in rows.into_iter().enumerate() {
        let e: Vec<f64> = ok.iter().filter_map(|o| err(o)).collect();
        let est: Vec<&Estimate> = ok.iter().flat_map(|o| &o.estimates).filter(|x| x.name.starts_with(prefix)).collect();
        let covered = est.iter().filter(|x| x.covered()).count();
        let column = |e: &[[f64; 4]]| e.iter().map(|d| d[i]).collect::<Vec<f64>>();
        // a parameter no rig gave has no distribution: a dash, not NaN
        let at =
            |v: &[f64], q: f64| if v.is_empty() { "—".to_string() } else { format!("{:.4} {unit}", quantile(v, q)) };
        let _ = writeln!(
            s,
            "| {name} | {}/{} | {} | {} | {} | {} | {} | {} |",
            e.len(),
            ok.len(),
            at(&e, 0.5),
            at(&e, 0.9),
            at(&e, 1.0),
            coverage(covered, est.len()),
            at(&column(&perfect), 0.5),
            at(&column(&recorded), 0.5),
        );
    }
    for prefix in ["accel_bias.", "gyro_bias.", "accel_bias_drift.", "gyro_bias_drift."] {
        let est: Vec<&Estimate> = ok.iter().flat_map(|o| &o.estimates).filter(|x| x.name.starts_with(prefix)).collect();
        if est.is_empty() && prefix.contains("drift") {
            continue;
        }
        let covered = est.iter().filter(|x| x.covered()).count();
        let _ = writeln!(
            s,
            "| {} ({}) | {}/{} | | | | {} | | |",
            &prefix[..prefix.len() - 1],
            if prefix.contains("drift") { "slope" } else { "mean" },
            est.len() / 3,
            ok.len(),
            coverage(covered, est.len())
        );
    }
    let mut extra: Vec<(Effect, usize)> = Vec::new();
    for o in &ok {
        for e in o.selected.iter().filter(|e| !Effect::CALIBRATION.contains(e)) {
            match extra.iter_mut().find(|x| x.0 == *e) {
                Some(x) => x.1 += 1,
                None => extra.push((*e, 1)),
            }
        }
    }
    let extra = if extra.is_empty() {
        "none".to_string()
    } else {
        extra.iter().map(|(e, n)| format!("{} in {n}", e.key())).collect::<Vec<_>>().join(", ")
    };
    let _ = writeln!(s, "\nCramér–Rao median: {}", floor_note(&ok, set));
    // the rigs carry nothing but the calibration: anything else selected is invented
    let _ = writeln!(s, "effects selected besides the calibration (the rigs have none): {extra}");
    s
}

/// What the Cramér–Rao columns are, and how many rigs each leaves out.
fn floor_note(ok: &[&Outcome], set: &Setting) -> String {
    if !set.imu_has_white_noise() {
        return "none, the IMU of this setting has no white noise (with a perfect mocap the floor is zero)".to_string();
    }
    let unseen = ok.iter().filter(|o| o.bound.is_none()).count();
    let unseen_recorded = ok.iter().filter(|o| o.bound_as_recorded.is_none()).count();
    format!(
        "the errors of an efficient estimator, {BOUND_DRAWS} draws per rig from its bound, with a perfect mocap and constant biases, then on the log as recorded (the mocap's noise and the biases' walks in it){}",
        match (unseen, unseen_recorded) {
            (0, 0) => String::new(),
            (u, r) => format!(
                "; rigs whose motion leaves a parameter unseen are left out ({u} with a perfect mocap, {r} as recorded)"
            ),
        }
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::identify::checks::handheld::{draw, options, run};

    /// A rig whose log is too short to calibrate gives a table of dashes, not NaN: at 1 Hz for
    /// 10 s identify fits nothing, and every error, quantile and coverage has no sample.
    #[test]
    fn a_rig_too_short_to_calibrate_prints_dashes_not_nan() {
        let set = Setting { imu_hz: 1.0, mocap_hz: 1.0, duration_s: 10.0, ..Setting::default() };
        let out = run(&draw(1, 0), &set, &options());
        assert!(out.rotation_err_deg.is_none(), "{out:?}");
        let table = render(&[out], &set);
        assert!(!table.contains("NaN") && table.contains("| rotation (angle) | 0/1 | — | — | — | — |"), "{table}");
    }

    /// Each floor's column leaves out the rigs without that floor, and the table says how
    /// many: of two calibrated rigs, one without a floor as recorded gives "(0 with a perfect
    /// mocap, 1 as recorded)", and the as-recorded column is the other rig's alone.
    #[test]
    fn a_rig_without_a_floor_is_counted_out_of_its_column() {
        let set = Setting { duration_s: 12.0, ..Setting::default() };
        let out = run(&draw(1, 0), &set, &options());
        assert!(out.error.is_none() && out.bound.is_some() && out.bound_as_recorded.is_some(), "{out:?}");
        let full = render(&[out.clone(), out.clone()], &set);
        assert!(!full.contains("left out"), "{full}");
        let missing = Outcome { bound_as_recorded: None, ..out.clone() };
        let table = render(&[out, missing], &set);
        assert!(table.contains("(0 with a perfect mocap, 1 as recorded)"), "{table}");
        let row = |t: &str| t.lines().find(|l| l.starts_with("| rotation")).unwrap().to_string();
        assert_eq!(row(&table), row(&full), "one rig's draws have the median of two copies of it");
    }

    /// The table's quantiles interpolate between order statistics: of 0, 1, …, 10 the median is
    /// 5 and the 90th percentile 9; of 1, 2, 3, 4 the median is 2.5 and the 90th 3.7.
    #[test]
    fn quantiles_interpolate_between_order_statistics() {
        let ten: Vec<f64> = (0..=10).rev().map(f64::from).collect();
        assert_eq!((quantile(&ten, 0.5), quantile(&ten, 0.9), quantile(&ten, 1.0)), (5.0, 9.0, 10.0));
        let four = [4.0, 1.0, 3.0, 2.0];
        assert!((quantile(&four, 0.5) - 2.5).abs() < 1e-12 && (quantile(&four, 0.9) - 3.7).abs() < 1e-12);
        assert!(quantile(&[], 0.5).is_nan());
    }
}

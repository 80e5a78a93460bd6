//! The `identify` workflow behind `flyarena identify`, usable from Rust: load the input (a scenario
//! to run, a flyarena log with its scenario, or another tool's log through a mapping), identify,
//! compare the closed loop, and return the report, its text, its JSON and the fragment.

use super::input::error::InputError;
use super::input::flyarena_log;
use super::output::feedback::{TrajectoryError, fragment, nominal_and_fed_back, trajectory_error};
use super::output::report;
use super::precision::{signed_with_interval as pm, with_interval};
use super::{Options, identify};
use crate::frames::{Body, MocapBody, Rot};
use crate::scenario::Scenario;
use serde_json::{Value, json};
use std::path::Path;

/// One identification, with everything the CLI writes.
pub struct Identified {
    /// The report.
    pub report: super::Report,
    /// R5, when the scenario declares it.
    pub requirements: Option<crate::requirements::Report>,
    /// The report as text.
    pub text: String,
    /// The report as JSON.
    pub json: Value,
    /// The scenario fragment that adds the found effects (`--feedback`).
    pub fragment: String,
    /// Closed-loop error of the nominal and of the corrected simulation against the flight, when it
    /// was flown from a scenario.
    pub closed_loop: Option<(TrajectoryError, TrajectoryError)>,
    /// Residuals before and after, for the recording.
    pub residuals: Vec<super::fit::select::ResidualSeries>,
}

fn vehicle_index(s: &Scenario, file: &Path, name: Option<&str>) -> Result<usize, InputError> {
    match name {
        None => Ok(0),
        Some(n) => s.vehicle_cfgs().position(|v| v.name == n).ok_or_else(|| {
            InputError::invalid(
                file.display(),
                format!(
                    "no vehicle `{n}` in the scenario; it has {}",
                    s.vehicle_cfgs().map(|v| format!("`{}`", v.name)).collect::<Vec<_>>().join(", ")
                ),
            )
        }),
    }
}

/// The options of a request: the forced effects, and the smoothing from the request, else from
/// the mapping, else the default.
fn options(
    forced: &[super::Effect],
    smoothing_ms: Option<f64>,
    map: Option<&super::input::mapping::Mapping>,
) -> Options {
    let mut opts = Options { forced: forced.to_vec(), ..Options::default() };
    if let Some(sm) = smoothing_ms.or(map.and_then(|m| m.smoothing_ms)) {
        opts.design.smoothing_s = sm * 1e-3;
    }
    opts
}

/// What `identify` reads.
#[derive(Clone, Copy, Debug)]
pub enum Source<'a> {
    /// A scenario, flown here; its undeclared effects are the hidden truth.
    Scenario(&'a Path),
    /// A flyarena flight log (`run --log`) with the scenario it was flown from.
    FlyarenaLog {
        /// The log.
        log: &'a Path,
        /// The scenario it was flown from.
        scenario: &'a Path,
    },
    /// Another tool's log (CSV, or a ROS 2 bag) through a mapping.
    Mapped {
        /// The log.
        log: &'a Path,
        /// The mapping that reads it.
        mapping: &'a Path,
    },
}

/// One identification: the source and its options (what `flyarena identify` takes).
#[derive(Clone, Debug)]
pub struct Request<'a> {
    /// What to read.
    pub source: Source<'a>,
    /// The scenario's vehicle by name (the first when `None`; not used for a mapped log).
    pub vehicle: Option<&'a str>,
    /// Another seed for the scenario and its closed-loop reruns.
    pub seed: Option<u64>,
    /// The smoothing of the kinematics (ms); else the mapping's, else the default.
    pub smoothing_ms: Option<f64>,
    /// Effects fitted whatever the selection says (`--with`).
    pub forced: Vec<super::Effect>,
}

impl<'a> Request<'a> {
    /// A request with default options.
    pub fn new(source: Source<'a>) -> Self {
        Request { source, vehicle: None, seed: None, smoothing_ms: None, forced: Vec::new() }
    }
}

/// Identifies from a scenario (flown here), a flyarena log with its scenario, or a mapped log;
/// for a scenario or a flyarena log, also flies the nominal and the fed-back model against
/// the data (closed loop) and checks R5 when the scenario declares it.
pub fn run(req: &Request) -> crate::Result<Identified> {
    let (forced, smoothing_ms, vehicle, seed) = (&req.forced[..], req.smoothing_ms, req.vehicle, req.seed);
    let opts = options(forced, smoothing_ms, None);
    let (input, scenario) = match req.source {
        Source::Scenario(p) => (p, None),
        Source::FlyarenaLog { log, scenario } => (log, Some(scenario)),
        Source::Mapped { log: input, mapping: m } => {
            let map = super::input::mapping::Mapping::load(m)?;
            let opts = options(forced, smoothing_ms, Some(&map));
            let series = map.read(input)?;
            let report = identify(&series, &opts)?;
            let text = report::render(&report);
            // the log's own frame rate, for rounding a delay to whole frames
            // (and four markers, the common pattern, for a lever arm: the log names no template)
            let fragment = fragment(&report, 0, (1.0 / series.dt()).round().max(1.0) as u32, 4);
            let json = json!({ "report": report, "closed_loop": null });
            let residuals = super::fit::select::residual_series(&series, &opts, &report);
            return Ok(Identified { report, requirements: None, text, json, fragment, closed_loop: None, residuals });
        }
    };
    let scen_path = scenario.unwrap_or(input);
    let src = std::fs::read_to_string(scen_path).map_err(|e| InputError::io(scen_path.display(), e))?;
    let mut s = Scenario::parse(&src, scen_path)?;
    let mut tree: Value = serde_saphyr::from_str(&src).map_err(|e| InputError::invalid(scen_path.display(), e))?;
    if let Some(seed) = seed {
        s = s.with_seed(seed);
        tree["seed"] = json!(seed);
    }
    let i = vehicle_index(&s, scen_path, vehicle)?;
    let data = if scenario.is_some() {
        let text = std::fs::read_to_string(input).map_err(|e| InputError::io(input.display(), e))?;
        let log = crate::log::read_csv(&text, &input.display().to_string())?;
        flyarena_log::series(&log, &s, i, &input.display().to_string())?
    } else {
        flyarena_log::run_and_log(
            &s,
            i,
            &format!("{} (seed {}, vehicle `{}`)", scen_path.display(), s.seed, s.vehicle(i).name),
        )?
        .1
    };
    let report = identify(&data, &opts)?;
    let frag = fragment(&report, i, s.mocap.rate_hz(), s.spec().vehicles[i].template.len());
    // closed loop: the nominal scenario and the nominal scenario with the effects, same seed
    let (nominal, fed) = nominal_and_fed_back(&tree, i, &frag, &scen_path.display().to_string())?;
    let before = trajectory_error(&data, &flyarena_log::run_and_log(&nominal, i, "nominal")?.1);
    let after = trajectory_error(&data, &flyarena_log::run_and_log(&fed, i, "fed back")?.1);
    let mut text = report::render(&report);
    text += &format!(
        "\n  closed loop (simulation vs data, same seed): position RMSE {:.1} mm → {:.1} mm, attitude RMSE {:.3}° → {:.3}°\n",
        before.position_rmse_m * 1e3,
        after.position_rmse_m * 1e3,
        before.attitude_rmse_deg,
        after.attitude_rmse_deg
    );
    let requirements =
        s.requirements.identify.as_ref().map(|req| super::checks::check::check(&report, req, &s.vehicle(i).name));
    let json = json!({ "report": report, "closed_loop": { "nominal": before, "with_effects": after }, "requirements": requirements });
    let residuals = super::fit::select::residual_series(&data, &opts, &report);
    Ok(Identified { report, requirements, text, json, fragment: frag, closed_loop: Some((before, after)), residuals })
}

/// Several logs through one mapping: each identified, then every flight's model evaluated on
/// every other flight (cross-validation), per channel.
pub struct CrossValidated {
    /// Each flight's report, by flight name.
    pub reports: Vec<(String, super::Report)>,
    /// [fitted on][evaluated on] → cut of the accel_kin and force errors (None: channel missing)
    pub cross: Vec<Vec<(Option<f64>, Option<f64>)>>,
    /// Mountings from the ground check, the body offsets' agreement inside each, and transfer.
    pub consistency: super::checks::consistency::Consistency,
    /// The cross-validation as text.
    pub text: String,
    /// The cross-validation as JSON.
    pub json: Value,
}

/// Identifies every log through one mapping, then evaluates each flight's model on every other
/// flight and checks the offsets' consistency per mounting.
pub fn run_many(
    inputs: &[&Path],
    mapping: &Path,
    smoothing_ms: Option<f64>,
    forced: &[super::Effect],
) -> crate::Result<CrossValidated> {
    use super::fit::design::Channel;
    use super::fit::select::{channel_cut, evaluate};
    let map = super::input::mapping::Mapping::load(mapping)?;
    let opts = options(forced, smoothing_ms, Some(&map));
    let Each { reports, series, excluded } = identify_each(inputs, &map, &opts)?;
    let cross: Vec<Vec<(Option<f64>, Option<f64>)>> = reports
        .iter()
        .map(|(_, r)| {
            series
                .iter()
                .map(|s| {
                    let e = evaluate(s, &opts, r);
                    (channel_cut(&e, Channel::AccelKin), channel_cut(&e, Channel::Force))
                })
                .collect()
        })
        .collect();
    let mut text = per_flight_text(&reports, &excluded);
    text += &cross_tables(&reports, &cross);
    let accel_cross: Vec<Vec<Option<f64>>> = cross.iter().map(|row| row.iter().map(|c| c.0).collect()).collect();
    // i's accel_kin cut on flight j minus the cut with i's body offset replaced by `offset(j)`
    let gain = |offset: &dyn Fn(usize) -> Option<Rot<MocapBody, Body>>| -> Vec<Vec<Option<f64>>> {
        reports
            .iter()
            .zip(&accel_cross)
            .map(|((_, r), row)| {
                let mut alt = super::checks::consistency::without_body_offset(r);
                (0..series.len())
                    .map(|j| {
                        let alt = alt.as_mut()?;
                        alt.corrections.body_offset = offset(j)?;
                        Some(row[j]? - channel_cut(&evaluate(&series[j], &opts, alt), Channel::AccelKin)?)
                    })
                    .collect()
            })
            .collect()
    };
    // the body offset's own share: each model again without its offset
    let offset_gain = gain(&|_| Some(Rot::identity()));
    // the mounting's own part: each model again with the fleet's mean offset (j left out)
    let fleet: Vec<_> =
        (0..series.len()).map(|j| super::checks::consistency::fleet_offset_without(&reports, j)).collect();
    let mounting_gain = gain(&|j| fleet[j]);
    let transfer = super::checks::consistency::Transfer {
        cut: &accel_cross,
        offset_gain: &offset_gain,
        mounting_gain: &mounting_gain,
    };
    let consistency =
        super::checks::consistency::consistency(&reports, &transfer, super::checks::consistency::LINK_DEG);
    text += &super::checks::consistency::render(&consistency);
    let agreements = || reports.iter().filter_map(|(_, r)| r.ground_agreement.as_ref());
    let spin_up = super::fit::ground::spin_up_summary(agreements());
    let landed = super::fit::ground::landed_summary(agreements());
    let rest_pose = super::fit::ground::rest_pose_summary(agreements());
    text += &spin_up.as_ref().map_or(String::new(), super::fit::ground::render_spin_up_summary);
    text += &landed.as_ref().map_or(String::new(), super::fit::ground::render_landed_summary);
    text += &rest_pose.as_ref().map_or(String::new(), super::fit::ground::render_rest_pose_summary);
    let json = json!({
        "reports": reports.iter().map(|(n, r)| json!({"flight": n, "report": r})).collect::<Vec<_>>(),
        "consistency": consistency,
        "spin_up": spin_up,
        "after_landing": landed,
        "rest_pose": rest_pose,
        "excluded": excluded.iter().map(|(n, e)| json!({"flight": n, "reason": e})).collect::<Vec<_>>(),
        "cross_validation": {
            "flights": reports.iter().map(|(n, _)| n.clone()).collect::<Vec<_>>(),
            "accel_kin_cut": cross.iter().map(|row| row.iter().map(|c| c.0).collect::<Vec<_>>()).collect::<Vec<_>>(),
            "force_cut": cross.iter().map(|row| row.iter().map(|c| c.1).collect::<Vec<_>>()).collect::<Vec<_>>(),
        }
    });
    Ok(CrossValidated { reports, cross, consistency, text, json })
}

/// The logs of a multi-flight run, identified: reports and series of the flights kept (in input
/// order), and the flights left out with the reason.
struct Each {
    reports: Vec<(String, super::Report)>,
    series: Vec<super::Series>,
    excluded: Vec<(String, String)>,
}

/// Reads and identifies every log: the reports and series of the flights identified (in input
/// order), and the flights left out with the reason — a copy of an earlier log (the same
/// samples under another name: published datasets hold such copies, which would agree with
/// themselves and count twice) or one the data-quality gate rejects. An error only when no
/// flight is left.
fn identify_each(
    inputs: &[&Path],
    map: &super::input::mapping::Mapping,
    opts: &super::Options,
) -> Result<Each, InputError> {
    let mut read: Vec<(String, super::Series)> = Vec::new();
    let mut excluded: Vec<(String, String)> = Vec::new();
    for p in inputs {
        let s = map.read(p)?;
        let name = p.file_stem().map_or_else(|| p.display().to_string(), |x| x.to_string_lossy().into_owned());
        if let Some((first, _)) = read.iter().find(|(_, r)| r.same_samples(&s)) {
            excluded.push((name, format!("the same samples as {first} (a copy of that log): counted once")));
            continue;
        }
        read.push((name, s));
    }
    let (mut reports, mut kept) = (Vec::new(), Vec::new());
    for (name, s) in read {
        match identify(&s, opts) {
            Ok(r) => {
                reports.push((name, r));
                kept.push(s);
            }
            Err(e) => excluded.push((name, e.to_string())),
        }
    }
    if reports.is_empty() {
        return Err(InputError::NoFlightPasses(excluded.into_iter().map(|(_, e)| e).collect()));
    }
    Ok(Each { reports, series: kept, excluded })
}

/// The per-flight block of a cross-validation: each flight's held-out cuts, effects, ground
/// checks, leads and notes, then the flights left out and why.
fn per_flight_text(reports: &[(String, super::Report)], excluded: &[(String, String)]) -> String {
    use super::fit::design::Channel;
    use super::fit::select::channel_cut;
    let mut text = String::from("per flight (held-out error cut per channel; effects with 95 % intervals):\n");
    for (name, r) in reports {
        let cuts: Vec<String> =
            Channel::ALL.iter().map(|c| format!("{} {}", c.name(), pct(channel_cut(&r.errors, *c)))).collect();
        text += &format!("\n  {name}: {}\n", cuts.join(", "));
        for f in &r.effects {
            let ps: Vec<String> = f.params.iter().map(|p| report::param_text(p, |x| format!("{x:.3}"))).collect();
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
fn cross_tables(reports: &[(String, super::Report)], cross: &[Vec<(Option<f64>, Option<f64>)>]) -> String {
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

//! `flyarena identify`: inputs, the closed-loop comparison, and the outputs.

use super::feedback::{TrajectoryError, fragment, nominal_and_fed_back, trajectory_error};
use super::{Options, flyarena_log, identify, report};
use crate::scenario::Scenario;
use serde_json::{Value, json};
use std::path::Path;

pub struct Done {
    pub report: super::Report,
    /// R5, when the scenario declares it.
    pub requirements: Option<crate::requirements::Report>,
    pub text: String,
    pub json: Value,
    pub fragment: String,
    pub closed_loop: Option<(TrajectoryError, TrajectoryError)>,
}

fn vehicle_index(s: &Scenario, name: Option<&str>) -> Result<usize, String> {
    match name {
        None => Ok(0),
        Some(n) => s.vehicles.value.iter().position(|v| v.value.name == n).ok_or_else(|| {
            format!("no vehicle `{n}` in the scenario; it has {}", s.vehicles.value.iter().map(|v| format!("`{}`", v.value.name)).collect::<Vec<_>>().join(", "))
        }),
    }
}

/// Identifies from a scenario (run here), a flyarena log with its scenario, or a mapped log.
pub fn run(input: &Path, scenario: Option<&Path>, mapping: Option<&Path>, vehicle: Option<&str>, seed: Option<u64>) -> Result<Done, String> {
    let opts = Options::default();
    if let Some(m) = mapping {
        let map = super::mapping::Mapping::load(m)?;
        let series = map.read(input)?;
        let report = identify(&series, &opts);
        let text = report::render(&report);
        let fragment = fragment(&report, 0, 100);
        let json = json!({ "report": report, "closed_loop": null });
        return Ok(Done { report, requirements: None, text, json, fragment, closed_loop: None });
    }
    let scen_path = scenario.unwrap_or(input);
    let src = std::fs::read_to_string(scen_path).map_err(|e| format!("{}: {e}", scen_path.display()))?;
    let mut s = Scenario::parse(&src, scen_path).map_err(|e| e.to_string())?;
    let mut tree: Value = serde_saphyr::from_str(&src).map_err(|e| format!("{}: {e}", scen_path.display()))?;
    if let Some(seed) = seed {
        s.seed = seed;
        tree["seed"] = json!(seed);
    }
    let i = vehicle_index(&s, vehicle)?;
    let data = if scenario.is_some() {
        let text = std::fs::read_to_string(input).map_err(|e| format!("{}: {e}", input.display()))?;
        let log = crate::log::read_csv(&text, &input.display().to_string()).map_err(|e| e.to_string())?;
        flyarena_log::series(&log, &s, i, &input.display().to_string())?
    } else {
        flyarena_log::run_and_log(&s, i, &format!("{} (seed {}, vehicle `{}`)", scen_path.display(), s.seed, s.vehicles.value[i].value.name))?.1
    };
    let report = identify(&data, &opts);
    let frag = fragment(&report, i, s.mocap.rate_hz.value);
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
    let requirements = s.requirements.identify.as_ref().map(|req| super::check::check(&report, req, &s.vehicles.value[i].value.name));
    let json = json!({ "report": report, "closed_loop": { "nominal": before, "with_effects": after }, "requirements": requirements });
    Ok(Done { report, requirements, text, json, fragment: frag, closed_loop: Some((before, after)) })
}

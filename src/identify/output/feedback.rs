//! Feeding identified effects back into the simulation.
//!
//! A *fragment* is a small YAML file that sets scenario fields by path (the same paths as
//! `sweep.vary.field`):
//!
//! ```yaml
//! effects:
//!   vehicles[0].markers.rotation_deg: [1.02, -0.49, 3.98]
//!   vehicles[0].undeclared.rotor_drag_per_s: [0.31, 0.29]
//! ```
//!
//! `flyarena run SCENARIO --effects FRAGMENT` applies it before the scenario is validated, so
//! every value meets the same range checks as a hand-written one. For flyarena's own runs,
//! `identify` simulates the *nominal* scenario (the undeclared effects removed) and the nominal
//! scenario plus the fragment with the data's seed, and reports how far each closed-loop
//! trajectory is from the data.

use crate::effects::Effect;
use crate::identify::fit::select::Report;
use crate::identify::input::error::InputError;
use crate::identify::input::series::Series;
use crate::identify::precision::{decimals_for, with_interval};
use crate::scenario::Scenario;
use crate::scenario::patch::set_in;
use serde_json::{Value, json};
use std::collections::BTreeMap;
use std::path::Path;

#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct Fragment {
    effects: BTreeMap<String, Value>,
}

fn remove(tree: &mut Value, path: &[&str]) {
    let mut cur = tree;
    for (k, key) in path.iter().enumerate() {
        if k == path.len() - 1 {
            if let Some(o) = cur.as_object_mut() {
                o.remove(*key);
            }
            return;
        }
        match cur.get_mut(*key) {
            Some(c) => cur = c,
            None => return,
        }
    }
}

/// The scenario as the declared model sees it: marker offsets, camera error, disturbance, IMU
/// biases and `undeclared` of vehicle `i` removed.
fn nominal_tree(tree: &Value, i: usize) -> Value {
    let mut t = tree.clone();
    remove(&mut t, &["mocap", "camera_error"]);
    if let Some(v) = t.get_mut("vehicles").and_then(|v| v.get_mut(i)) {
        for path in [
            &["markers", "rotation_deg"][..],
            &["markers", "displacement_mm"],
            &["disturbance"],
            &["undeclared"],
            &["imu", "gyro_bias_deg_s"],
            &["imu", "accel_bias_m_s2"],
            &["imu", "position_mm"],
        ] {
            remove(v, path);
        }
    }
    t
}

/// `x` rounded to the precision of its interval, and to at least 4 decimals.
fn round_to(x: f64, ci: f64) -> f64 {
    let scale = 10f64.powi(decimals_for(ci).max(4) as i32);
    (x * scale).round() / scale
}

/// The fragment of a report for vehicle `i` (with `n_markers` markers): one scenario field per
/// effect found, and a comment where a value had to be rounded to what the scenario can express.
pub fn fragment(r: &Report, i: usize, mocap_rate_hz: u32, n_markers: usize) -> String {
    fragment_of(&r.source, &r.effects, i, mocap_rate_hz, n_markers)
}

/// [`fragment`] from the effects found: every value keeps the precision of its interval (at
/// least 4 decimals), and a value the scenario cannot express (a negative delay: poses stamped
/// before their capture) is said with its interval and left out, not set to the nearest it can.
fn fragment_of(
    source: &str,
    effects: &[crate::identify::fit::select::Found],
    i: usize,
    mocap_rate_hz: u32,
    n_markers: usize,
) -> String {
    let mut lines = vec![
        format!("# flyarena identify: the effects found in {source}"),
        "# apply with: flyarena run SCENARIO.yaml --effects THIS_FILE".to_string(),
    ];
    let mut set = Vec::new();
    let imu_offset = effects.iter().find(|f| f.effect == Effect::ImuOffset);
    for f in effects {
        let v: Vec<f64> = f.params.iter().map(|p| round_to(p.value, p.ci95)).collect();
        let vi = format!("vehicles[{i}]");
        match f.effect {
            Effect::BodyOffset => set.push((format!("{vi}.markers.rotation_deg"), json!(v))),
            Effect::WorldTilt => set.push(("mocap.camera_error.rotation_deg".into(), json!([v[0], v[1], 0.0]))),
            Effect::MocapDelay | Effect::GyroDelay => {
                // the scenario takes whole frames of the mocap period (≥ 0)
                let period = 1000.0 / mocap_rate_hz as f64;
                let (what, field) = if f.effect == Effect::MocapDelay {
                    ("mocap delay", "mocap_delay_ms")
                } else {
                    ("gyro delay", "gyro_delay_ms")
                };
                let shown = with_interval(f.params[0].value, f.params[0].ci95);
                if v[0] < 0.0 {
                    lines.push(format!("# {what} {shown} ms is negative (stamped before the capture: a clock offset), which no scenario field expresses: left out"));
                    continue;
                }
                let frames = (v[0] / period).round();
                if (frames * period - v[0]).abs() > 1e-6 {
                    lines.push(format!("# {what} {shown} ms rounded to {frames} whole frames of {period} ms"));
                }
                set.push((format!("{vi}.undeclared.{field}"), json!(frames * period)));
            }
            Effect::AccelBias => set.push((format!("{vi}.imu.accel_bias_m_s2"), json!(v))),
            Effect::GyroBias => set.push((format!("{vi}.imu.gyro_bias_deg_s"), json!(v))),
            Effect::RotorDrag => set.push((
                format!("{vi}.undeclared.rotor_drag_per_s"),
                json!(v.iter().map(|x| x.max(0.0)).collect::<Vec<_>>()),
            )),
            Effect::ConstantForce => set.push((format!("{vi}.disturbance.force_n"), json!(v))),
            Effect::ThrustScale => set.push((
                format!("{vi}.undeclared.thrust_scale"),
                json!(round_to(1.0 + f.params[0].value, f.params[0].ci95)),
            )),
            Effect::GroundEffect => set.push((format!("{vi}.undeclared.ground_effect"), json!(v[0].max(0.0)))),
            Effect::LeverArm => {
                // markers displaced by d from the centre of mass make the mocap track the point
                // d, and the IMU sits at r_c from it: r = r_c − d, so d = r_c − r for each marker
                let r_c =
                    imu_offset.map_or(vec![0.0; 3], |c| c.params.iter().map(|p| round_to(p.value, p.ci95)).collect());
                let d: Vec<f64> =
                    v.iter().zip(&r_c).zip(&f.params).map(|((x, c), p)| round_to(c - x, p.ci95)).collect();
                set.push((format!("{vi}.markers.displacement_mm"), json!(vec![d; n_markers])));
            }
            Effect::ImuOffset => set.push((format!("{vi}.imu.position_mm"), json!(v))),
            Effect::ThrustVoltage => set.push((format!("{vi}.undeclared.thrust_voltage_per_v"), json!(v[0].max(0.0)))),
            // hypotheses the simulator has no counterpart for: said, not set
            Effect::AccelMisalignment
            | Effect::AccelScale
            | Effect::ThrustTilt
            | Effect::ClockDrift
            | Effect::AccelBiasDrift
            | Effect::GyroBiasDrift => {
                lines.push(format!("# {} {:?} is not simulated: left out", f.effect.key(), v));
            }
        }
    }
    lines.push(if set.is_empty() { "effects: {}".into() } else { "effects:".into() });
    for (k, v) in set {
        lines.push(format!("  {k}: {v}"));
    }
    lines.join("\n") + "\n"
}

/// Reads a scenario and applies a fragment to it.
pub fn load_with_effects(scenario: &Path, fragment: &Path) -> Result<Scenario, InputError> {
    let src = std::fs::read_to_string(scenario).map_err(|e| InputError::io(scenario.display(), e))?;
    let fsrc = std::fs::read_to_string(fragment).map_err(|e| InputError::io(fragment.display(), e))?;
    let frag: Fragment = serde_saphyr::from_str(&fsrc).map_err(|e| InputError::invalid(fragment.display(), e))?;
    // the scenario is checked as a whole, with its positions, before the fragment touches it
    Scenario::parse(&src, scenario)?;
    let base: Value = serde_saphyr::from_str(&src).map_err(|e| InputError::invalid(scenario.display(), e))?;
    let mut tree = base.clone();
    for (path, v) in &frag.effects {
        set_in(&mut tree, path, v.clone(), true).map_err(|e| InputError::invalid(fragment.display(), e))?;
    }
    let merged = |t: &Value| {
        Scenario::parse(
            &serde_json::to_string(t).expect("a JSON tree serialises"),
            Path::new(&format!("{} + {}", scenario.display(), fragment.display())),
        )
    };
    merged(&tree).or_else(|whole| {
        // the merged tree's positions are in no file the user has: name the fragment's entry
        // (and its line) after which the scenario stops being valid
        let mut t = base;
        for (path, v) in &frag.effects {
            set_in(&mut t, path, v.clone(), true).map_err(|e| InputError::invalid(fragment.display(), e))?;
            if let Err(e) = merged(&t) {
                let message = e.what();
                let line = fsrc
                    .lines()
                    .position(|l| l.trim_start().starts_with(path.as_str()))
                    .map_or(String::new(), |k| format!(":{}", k + 1));
                return Err(InputError::invalid(
                    format!("{}{line}", fragment.display()),
                    format!("`{path}`: {message}"),
                ));
            }
        }
        Err(whole.into())
    })
}

/// Closed-loop distance between two flights of the same plan: RMS of the mocap position
/// difference (m) and of the attitude difference angle (deg), over the rows both saw.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct TrajectoryError {
    /// RMS of the mocap position difference (m).
    pub position_rmse_m: f64,
    /// RMS of the attitude difference angle (deg).
    pub attitude_rmse_deg: f64,
    /// Rows both flights saw.
    pub samples: usize,
}

/// The [`TrajectoryError`] between a measured flight and its simulated twin, row by row over the
/// rows both have.
pub(crate) fn trajectory_error(data: &Series, sim: &Series) -> TrajectoryError {
    let n = data.len().min(sim.len());
    let (mut sp, mut sa, mut k) = (0.0, 0.0, 0usize);
    for i in 0..n {
        if data.mocap_ok[i] && sim.mocap_ok[i] {
            sp += (data.pos_mocap_nav[i] - sim.pos_mocap_nav[i]).raw().norm_squared();
            sa += data.att_mocap[i].quaternion().angle_to(sim.att_mocap[i].quaternion()).powi(2);
            k += 1;
        }
    }
    let kf = k.max(1) as f64;
    TrajectoryError { position_rmse_m: (sp / kf).sqrt(), attitude_rmse_deg: (sa / kf).sqrt().to_degrees(), samples: k }
}

/// The scenario with its undeclared effects removed, and with the fragment applied to that.
pub(crate) fn nominal_and_fed_back(
    scenario_src: &Value,
    i: usize,
    fragment_text: &str,
    name: &str,
) -> Result<(Scenario, Scenario), InputError> {
    let nominal = nominal_tree(scenario_src, i);
    let frag: Fragment = serde_saphyr::from_str(fragment_text).map_err(|e| InputError::invalid("fragment", e))?;
    let mut fed = nominal.clone();
    for (path, v) in frag.effects {
        set_in(&mut fed, &path, v, true).map_err(|e| InputError::invalid("fragment", e))?;
    }
    let parse = |t: &Value, what: &str| {
        Scenario::parse(&serde_json::to_string(t).expect("JSON"), Path::new(&format!("{name} ({what})")))
    };
    Ok((parse(&nominal, "nominal")?, parse(&fed, "with the identified effects")?))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::identify::fit::select::{Found, Param};

    fn found(effect: Effect, values: &[(f64, f64)]) -> Found {
        let params = values
            .iter()
            .map(|&(value, ci95)| Param { name: "p".into(), value, ci95, unit: "u".into(), identifiable: true })
            .collect();
        Found { effect, name: effect.key().into(), params }
    }

    /// Two significant digits of the half-width: 0.05 → 3 decimals, 0.0086 → 4, 0.5 → 2, 12 → 0.
    #[test]
    fn decimals_give_the_interval_two_significant_digits() {
        assert_eq!(
            [decimals_for(0.05), decimals_for(0.0086), decimals_for(0.5), decimals_for(12.0), decimals_for(0.0)],
            [3, 4, 2, 0, 6]
        );
        assert_eq!(with_interval(-3.0213, 0.05), "-3.021 ± 0.050");
        // at least 4 decimals in the values set, more where the interval is finer
        assert_eq!((round_to(1.234_567, 0.5), round_to(1.234_567, 0.000_12)), (1.2346, 1.23457));
    }

    /// A delay of −3.02 ± 0.05 ms (poses stamped before their capture) is no scenario's: the
    /// fragment says so with its interval and sets nothing, instead of rounding it to 0 frames;
    /// 7.32 ± 0.41 ms is set as the nearest whole frame of 5 ms (5 ms), and the comment keeps its
    /// precision. A bug it catches: the old `.max(0.0)`, which set the negative delay to 0.
    #[test]
    fn a_negative_delay_is_said_and_left_out_and_a_positive_one_rounded_to_frames() {
        let frag = fragment_of("f.csv", &[found(Effect::MocapDelay, &[(-3.0213, 0.05)])], 0, 200, 4);
        assert!(!frag.contains("mocap_delay_ms"), "{frag}");
        assert!(frag.contains("# mocap delay -3.021 ± 0.050 ms is negative"), "{frag}");
        let frag = fragment_of("f.csv", &[found(Effect::MocapDelay, &[(7.3213, 0.41)])], 0, 200, 4);
        assert!(
            frag.contains("# mocap delay 7.32 ± 0.41 ms rounded to 1 whole frames of 5 ms")
                && frag.contains("vehicles[0].undeclared.mocap_delay_ms: 5.0"),
            "{frag}"
        );
    }
}

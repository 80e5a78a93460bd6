//! The checks a scenario passes after each value's own range (`schema`): rates that divide the
//! physics clock, vehicles that can fly and that the mocap can tell apart, requirements that fit
//! their effects. Each error names the file, line, column and field. What passes becomes an
//! [`ArenaSpec`] (`spec`), so that nothing downstream checks again.

use super::assemble::{self, Checked, Rates};
use super::error::{self, ScenarioError, Span};
use super::ranges;
use super::schema::{Preset, Scenario};
use super::spec::{ArenaSpec, PHYSICS, PHYSICS_HZ};
use crate::clock::Rate;
use crate::frames::{Body, Euler, MocapBody, Vec3};
use crate::mocap::markers::{BUILTIN_PATTERNS, builtin_pattern, patterns_confusable};
use crate::mocap::{MarkerSet, TrueOffset, rigid_fit};
use crate::vehicle::VehicleParams;
use serde_saphyr::Spanned;
use std::path::Path;

/// Parses and validates YAML text; `file` is only used in messages.
pub(super) fn parse(src: &str, file: &Path) -> Result<Scenario, ScenarioError> {
    let mut s: Scenario =
        serde_saphyr::from_str(src).map_err(|e| error::from_yaml(src, file, &e, error::with_suggestion))?;
    s.spec = s.validate(src, file)?;
    Ok(s)
}

impl Scenario {
    fn invalid(src: &str, file: &Path, loc: serde_saphyr::Location, message: String) -> ScenarioError {
        let span = (loc.line() > 0).then(|| Span { line: loc.line() as u32, column: loc.column() as u32 });
        let path = span.as_ref().map(|s| error::yaml_path_at(src, s.line, s.column)).unwrap_or_default();
        ScenarioError::Invalid { file: file.to_path_buf(), span, path, message, snippet: String::new() }
    }

    /// The checks that involve more than one value (ranges of single values are checked while
    /// parsing), and what they leave: the scenario as the engine runs it.
    pub(super) fn validate(&self, src: &str, file: &Path) -> Result<ArenaSpec, ScenarioError> {
        let err = |loc: serde_saphyr::Location, msg: String| Err(Self::invalid(src, file, loc, msg));
        let ticks = |what: &str, r: &Spanned<u32>| {
            Rate::from_hz(r.value).and_then(|x| Some((x, x.ticks_of(PHYSICS)?))).ok_or_else(|| {
                Self::invalid(src, file, r.referenced, format!("{what} {} Hz must divide the {PHYSICS_HZ} Hz physics clock (e.g. 50, 100, 200, 250, 500, 1000)", r.value))
            })
        };
        let rates = Rates {
            mocap: ticks("mocap rate", &self.mocap.rate_hz)?,
            radio: ticks("radio rate", &self.radio.rate_hz)?,
            telemetry: ticks("telemetry rate", &self.telemetry.rate_hz)?,
        };
        if !(4..=crate::radio::MAX_CHANNELS as u32).contains(&self.radio.channels.value) {
            return err(
                self.radio.channels.referenced,
                format!(
                    "{} channels is outside the allowed range [4, {}] (p, q, r and thrust need 4)",
                    self.radio.channels.value,
                    crate::radio::MAX_CHANNELS
                ),
            );
        }
        for o in &self.link.outages {
            if o.value.to_s.is_some_and(|t| t <= o.value.from_s) {
                return err(
                    o.referenced,
                    format!("outage ends ({} s) before it starts ({} s)", o.value.to_s.unwrap_or(0.0), o.value.from_s),
                );
            }
        }
        if let Some(r) = &self.requirements.identify {
            for e in &r.expect {
                let n = e.value.effect.n_params();
                if e.value.values.len() != n || e.value.tolerance.len() != n {
                    let names: Vec<&str> = e.value.effect.params().iter().map(|p| p.0).collect();
                    return err(
                        e.referenced,
                        format!(
                            "{} has {n} parameters ({}): give {n} values and {n} tolerances",
                            e.value.effect.key(),
                            names.join(", ")
                        ),
                    );
                }
                if let Some(t) = e.value.tolerance.iter().find(|t| !(**t > 0.0 && t.is_finite())) {
                    return err(e.referenced, format!("tolerance {t} must be positive"));
                }
            }
        }
        let vehicles = &self.vehicles.value;
        if vehicles.is_empty() || vehicles.len() > 16 {
            return err(
                self.vehicles.referenced,
                format!("{} vehicles is outside the allowed range [1, 16]", vehicles.len()),
            );
        }
        if self.plan.value.is_empty() {
            return err(
                self.plan.referenced,
                "the plan is empty: give at least one phase (e.g. `- takeoff: {altitude_m: 1, duration_s: 3}`)".into(),
            );
        }
        let mut templates: Vec<(usize, Vec<Vec3<MocapBody>>)> = Vec::new();
        let mut checked = Vec::with_capacity(vehicles.len());
        for i in 0..vehicles.len() {
            checked.push(self.validate_vehicle(i, &mut templates, src, file)?);
        }
        Ok(assemble::arena(self, rates, checked))
    }

    /// The checks of vehicle `i` against itself and the vehicles before it (`templates`: their
    /// marker templates, to which its own is added): a unique name, a marker pattern the mocap
    /// can tell apart, one displacement per marker, occlusions of markers that exist, undeclared
    /// delays in whole mocap frames, markers that still define an attitude as mounted, and
    /// thrust to spare over its weight.
    fn validate_vehicle(
        &self,
        i: usize,
        templates: &mut Vec<(usize, Vec<Vec3<MocapBody>>)>,
        src: &str,
        file: &Path,
    ) -> Result<Checked, ScenarioError> {
        let err = |loc: serde_saphyr::Location, msg: String| Err(Self::invalid(src, file, loc, msg));
        let vehicles = &self.vehicles.value;
        let v = &vehicles[i];
        if vehicles[..i].iter().any(|o| o.value.name == v.value.name) {
            return err(v.referenced, format!("vehicle name `{}` is used twice; names must be unique", v.value.name));
        }
        let t = self.checked_template(i).map_err(|(loc, m)| Self::invalid(src, file, loc, m))?;
        if let Some((j, _)) = templates.iter().find(|(_, o)| patterns_confusable(o, &t, 0.005)) {
            return err(
                v.referenced,
                format!(
                    "vehicle `{}` has the same marker pattern as vehicle `{}` (pairwise distances within 5 mm): the mocap could not tell them apart; give each a different `markers.pattern` (0–{}) or `template_m`",
                    v.value.name,
                    vehicles[*j].value.name,
                    BUILTIN_PATTERNS - 1
                ),
            );
        }
        templates.push((i, t.clone()));
        let (markers, truth) = self.checked_markers(i, &t).map_err(|(loc, m)| Self::invalid(src, file, loc, m))?;
        let u = &v.value.undeclared;
        let period_ms = 1000.0 / self.mocap.rate_hz.value as f64;
        for (field, delay) in [("mocap_delay_ms", u.mocap_delay_ms), ("gyro_delay_ms", u.gyro_delay_ms)] {
            let frames = delay / period_ms;
            if (frames - frames.round()).abs() > 1e-9 {
                return err(
                    v.referenced,
                    format!(
                        "vehicle `{}`: undeclared.{field} {delay} is not a multiple of the mocap period {period_ms} ms",
                        v.value.name
                    ),
                );
            }
        }
        let p = self.checked_vehicle_params(i).map_err(|(loc, m)| Self::invalid(src, file, loc, m))?;
        let t_max = self.radio.thrust_max_n.unwrap_or(p.thrust_max()).min(p.thrust_max());
        if t_max <= p.hover_thrust() * 1.1 {
            return err(
                v.referenced,
                format!(
                    "vehicle `{}`: maximum thrust {:.2} N is not above its hover thrust m·g = {:.2} N with a 10 % margin; it cannot fly (raise rotor_speed_max_rad_s, k_thrust or radio.thrust_max_n, or lower mass_kg)",
                    v.value.name,
                    t_max,
                    p.hover_thrust()
                ),
            );
        }
        Ok(Checked { params: p, template: t, markers, truth })
    }

    /// The markers of vehicle `i` as mounted on template `t` (displacements, occlusions, the
    /// rotation), checked, and the true offset they give: displacements one per marker and in
    /// range, occlusions of existing markers that end after they start, and markers as mounted
    /// that are not collinear.
    fn checked_markers(
        &self,
        i: usize,
        t: &[Vec3<MocapBody>],
    ) -> Result<(MarkerSet, TrueOffset), (serde_saphyr::Location, String)> {
        let v = &self.vehicles.value[i];
        let m = &v.value.markers;
        if let Some(d) = &m.displacement_mm
            && d.value.len() != t.len()
        {
            return Err((
                d.referenced,
                format!("{} displacements for {} markers: give one [x, y, z] (mm) per marker", d.value.len(), t.len()),
            ));
        }
        if let Some(d) = &m.displacement_mm {
            for x in d.value.iter().flatten() {
                ranges::displacement_mm::check(*x).map_err(|e| (d.referenced, e.to_string()))?;
            }
        }
        for o in &m.occlusions {
            if o.value.marker as usize >= t.len() {
                return Err((
                    o.referenced,
                    format!("marker {} does not exist: markers are numbered 0–{}", o.value.marker, t.len() - 1),
                ));
            }
            if o.value.to_s <= o.value.from_s {
                return Err((
                    o.referenced,
                    format!("occlusion ends ({} s) before it starts ({} s)", o.value.to_s, o.value.from_s),
                ));
            }
        }
        let disp: Vec<Vec3<Body>> = match &m.displacement_mm {
            Some(d) => d.value.iter().map(|a| Vec3::from_array(a.map(|x| x * 1e-3))).collect(),
            None => vec![Vec3::zeros(); t.len()],
        };
        let markers = MarkerSet::displaced(
            t.to_vec(),
            Euler::from_degrees(m.rotation_deg[0], m.rotation_deg[1], m.rotation_deg[2]),
            &disp,
        );
        // the cameras see the markers as mounted: collinear there, the attitude about their line
        // is unobservable however good the template
        let all = vec![true; t.len()];
        let (Some(truth), Some(_)) = (markers.true_offset(), rigid_fit(&markers.mounted, &markers.template, &all))
        else {
            let loc = m.displacement_mm.as_ref().map_or(v.referenced, |d| d.referenced);
            return Err((
                loc,
                format!(
                    "vehicle `{}`: the markers as mounted (displaced) are collinear: the mocap cannot determine an attitude from them",
                    v.value.name
                ),
            ));
        };
        Ok((markers, truth))
    }

    /// The marker template of vehicle `i` (m, the markers' frame), checked: its size and
    /// coordinates, and that a mocap can fit an attitude to it.
    fn checked_template(&self, i: usize) -> Result<Vec<Vec3<MocapBody>>, (serde_saphyr::Location, String)> {
        let m = &self.vehicles.value[i].value.markers;
        let t: Vec<Vec3<MocapBody>> = match (&m.template_m, &m.pattern) {
            (Some(_), Some(p)) => return Err((p.referenced, "give either `pattern` or `template_m`, not both".into())),
            (Some(t), None) => {
                if !(3..=8).contains(&t.value.len()) {
                    return Err((
                        t.referenced,
                        format!("{} markers is outside the allowed range [3, 8]", t.value.len()),
                    ));
                }
                for x in t.value.iter().flatten() {
                    ranges::template_m::check(*x).map_err(|e| (t.referenced, e.to_string()))?;
                }
                t.value.iter().map(|a| Vec3::from_array(*a)).collect()
            }
            (None, Some(p)) => {
                if p.value as usize >= BUILTIN_PATTERNS {
                    return Err((
                        p.referenced,
                        format!("pattern {} is outside the allowed range [0, {}]", p.value, BUILTIN_PATTERNS - 1),
                    ));
                }
                builtin_pattern(p.value as usize).to_vec()
            }
            (None, None) => builtin_pattern(i % BUILTIN_PATTERNS).to_vec(),
        };
        let loc = m.template_m.as_ref().map_or(self.vehicles.value[i].referenced, |t| t.referenced);
        let ms = crate::mocap::MarkerSet::displaced(t.clone(), Euler::ZERO, &vec![Vec3::zeros(); t.len()]);
        if ms.true_offset().is_none() {
            return Err((loc, "the marker template is degenerate (collinear or coincident markers): the mocap cannot determine an attitude from it".into()));
        }
        for a in 0..t.len() {
            for b in a + 1..t.len() {
                if (t[a] - t[b]).norm() < 0.01 {
                    return Err((
                        loc,
                        format!(
                            "markers {a} and {b} are {:.1} mm apart; cameras need at least 10 mm to separate them",
                            (t[a] - t[b]).norm() * 1e3
                        ),
                    ));
                }
            }
        }
        Ok(t)
    }

    /// The physical parameters of vehicle `i` (preset with overrides), with the ranges of the
    /// overrides that are lists.
    fn checked_vehicle_params(&self, i: usize) -> Result<VehicleParams, (serde_saphyr::Location, String)> {
        let m = &self.vehicles.value[i].value.model;
        let mut p = match m.preset {
            Preset::X3d => VehicleParams::x3d(),
            Preset::Crazyflie21 => VehicleParams::crazyflie21(),
        };
        if let Some(x) = m.mass_kg {
            p.mass_kg = x;
        }
        if let Some(x) = &m.inertia_kg_m2 {
            p.inertia_kg_m2 = each_in_range(x, ranges::inertia::check)?;
        }
        if let Some(x) = m.arm_m {
            p.arm_m = x;
        }
        if let Some(x) = m.k_thrust {
            p.k_thrust = x;
        }
        if let Some(x) = m.k_torque_m {
            p.k_torque_m = x;
        }
        if let Some(x) = m.motor_tau_s {
            p.motor_tau_s = x;
        }
        if let Some(x) = m.rotor_speed_max_rad_s {
            p.rotor_speed_max = x;
        }
        if let Some(x) = &m.rotor_drag_per_s {
            p.rotor_drag_per_s = each_in_range(x, ranges::drag_per_s::check)?;
        }
        if let Some(x) = &m.rate_loop_gain_per_s {
            p.rate_loop_gain_per_s = each_in_range(x, ranges::gain_per_s::check)?;
        }
        if let Some(x) = &m.rate_loop_integral_per_s2 {
            p.rate_loop_integral_per_s2 = each_in_range(x, ranges::integral_per_s2::check)?;
        }
        if let Some(x) = m.onboard_mode {
            p.onboard_mode = x;
        }
        if let Some(x) = &m.attitude_loop_gain_per_s {
            p.attitude_loop_gain_per_s = each_in_range(x, ranges::gain_per_s::check)?;
        }
        let b = &self.vehicles.value[i].value.battery;
        if let Some(x) = &b.cells {
            ranges::cells::check(x.value as f64).map_err(|e| (x.referenced, e.to_string()))?;
            p.battery.cells = x.value;
            p.battery.v_ref = 3.7 * x.value as f64;
        }
        if let Some(x) = b.capacity_mah {
            p.battery.capacity_ah = x * 1e-3;
        }
        if let Some(x) = b.resistance_ohm {
            p.battery.resistance_ohm = x;
        }
        if let Some(x) = b.charge_start {
            p.battery.charge_start = x;
        }
        Ok(p)
    }
}

/// The values of a written list override, each checked by its field's range (`check`); an error
/// points at the list.
fn each_in_range<const N: usize>(
    x: &Spanned<[f64; N]>,
    check: fn(f64) -> Result<f64, ranges::OutOfRange>,
) -> Result<[f64; N], (serde_saphyr::Location, String)> {
    for v in x.value {
        check(v).map_err(|e| (x.referenced, e.to_string()))?;
    }
    Ok(x.value)
}

#[cfg(test)]
mod tests {
    use crate::Scenario;

    /// A list override with one value outside its field's range is refused, located at the list
    /// and naming the range: an inertia of 0 (the range excludes it) and a negative integral gain.
    #[test]
    fn each_value_of_a_list_override_is_range_checked() {
        let with = |model: &str| {
            Scenario::parse(
                &format!(
                    "name: m\nvehicles: [{{name: a, model: {{{model}}}}}]\nplan: [{{hover: {{duration_s: 1}}}}]\n"
                ),
                "m.yaml".as_ref(),
            )
        };
        assert!(with("inertia_kg_m2: [0.007, 0.007, 0.012]").is_ok());
        let e = with("inertia_kg_m2: [0.007, 0, 0.012]").unwrap_err().to_string();
        assert!(e.contains("m.yaml:2:") && e.contains("0 kg·m² is outside the allowed range (0, 10]"), "{e}");
        let e = with("rate_loop_integral_per_s2: [1, -1, 0]").unwrap_err().to_string();
        assert!(e.contains("-1 1/s² is outside the allowed range [0, 1000]"), "{e}");
    }
}

//! Does `identify` hold on flights it was not tuned to? Random hidden-effect mixes on random
//! plans, both presets, random seeds, each flown by the engine and identified; the outcomes
//! scored against the truth.
//!
//! **The generator.** Trial `i` of master seed `S` is a pure function of (S, i): its own
//! scenario seed, a preset (`x3d` or `crazyflie21`), a plan and 0–3 hidden effects, drawn from
//! [`crate::rng::Stream`] (component `Sweep`, index i). Plans are built from a family of pieces
//! after take-off and a short hover: waypoint tours (2–4 points within ±3 m, 0.8–2 m/s),
//! figure-8s (eight waypoints on a lemniscate of half-width 1–2 m), circles on the spot
//! (`calibrate_gyro`, radius 0.2–0.5 m, period 2–3.5 s), yaw turns (90–360°), and hovers with a
//! short excursion (0.5 m out and back); three to five pieces, then landing.
//!
//! **Hidden effects and their ranges** (uniform magnitude, random sign, per axis):
//!
//! | effect | scenario field | range |
//! |---|---|---|
//! | body offset | `vehicles[0].markers.rotation_deg` | 0.5–3° |
//! | world tilt | `mocap.camera_error.rotation_deg` (roll, pitch) | 0.3–1.5° |
//! | mocap delay | `vehicles[0].undeclared.mocap_delay_ms` | 1–4 frames of 5 ms |
//! | accelerometer bias | `vehicles[0].imu.accel_bias_m_s2` | 0.05–0.3 m/s² |
//! | gyro bias | `vehicles[0].imu.gyro_bias_deg_s` | 0.3–1.5 °/s |
//! | rotor drag | `vehicles[0].undeclared.rotor_drag_per_s` | 0.1–0.5 1/s (positive) |
//! | constant force | `vehicles[0].disturbance.force_n` | 2–10 % of the weight (N, E), 0–3 % (D) |
//! | thrust scale | `vehicles[0].undeclared.thrust_scale` | 3–15 % off 1 |
//! | ground effect | `vehicles[0].undeclared.ground_effect` | c_g 0.5–1.5, in half the flights with a low hover |
//! | lever arm, mocap origin → IMU | `vehicles[0].markers.displacement_mm` (−r for every marker) | 10–40 mm |
//! | thrust vs battery voltage | `vehicles[0].undeclared.thrust_voltage_per_v` | 0.05–0.2 /V (`crazyflie21`, 1 cell), 0.015–0.07 /V (`x3d`, 3 cells) |
//!
//! A quarter of the flights end with a low hover (1.2–3 rotor radii over the floor, at least
//! 0.1 m, for 4 s).
//! The battery is each preset's pack at 90 % charge (see [`crate::vehicle::battery`]): the voltage
//! sags with the load and falls as the charge is drawn, and the log carries it.
//!
//! **Scoring.** A hidden effect is *found* when it is selected, *flagged* when the report names
//! it not identifiable from a selected effect (then neither a miss nor, for the selected
//! partner, an invention), *missed* otherwise. A selected effect that was not hidden and is not
//! flagged is an *invention*. Each found parameter is *covered* when its 95 % interval contains
//! the truth, and *confidently wrong* when the truth lies more than 3 half-widths from the
//! estimate. Whether a flight excites a hidden effect enough is decided before the outcome, from
//! the data's information matrix ([`crate::identify::fit::select::Excitation`]).

use crate::effects::Effect;
use crate::identify::fit::select::{Excitation, Options, excitation, identify};
use crate::identify::input::flyarena_log::run_and_log;
use crate::rng::{Component, Stream};
use crate::scenario::Scenario;
use serde_saphyr::FlowMap;
use std::fmt::Write as _;

/// The effects drawn as 0–3 of a flight's hidden effects, in [`Effect::ALL`] order: every
/// searched candidate but the ground effect (drawn on its own, only for flights with a low
/// hover) and the bias drifts (the simulated IMU holds its biases still, and a trial flight is
/// shorter than a drift is offered on).
pub fn simulated() -> Vec<Effect> {
    Effect::ALL
        .iter()
        .copied()
        .filter(|e| e.searched() && !matches!(e, Effect::GroundEffect | Effect::AccelBiasDrift | Effect::GyroBiasDrift))
        .collect()
}

/// One drawn trial.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct Trial {
    /// Trial number within the batch.
    pub index: u64,
    /// Seed of the flight's scenario (drawn from the batch seed and the index).
    pub seed: u64,
    /// Vehicle preset flown.
    pub preset: String,
    /// The plan pieces, in words.
    pub plan: Vec<String>,
    /// Hidden effects with their true parameters in the reported units.
    pub hidden: Vec<(Effect, Vec<f64>)>,
    /// The scenario text that is flown (save it and `flyarena identify` it to look closer).
    pub yaml: String,
}

struct Draw(Stream);

impl Draw {
    fn u(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.0.uniform()
    }
    fn sign(&mut self) -> f64 {
        if self.0.uniform() < 0.5 { -1.0 } else { 1.0 }
    }
    fn signed(&mut self, lo: f64, hi: f64) -> f64 {
        self.sign() * self.u(lo, hi)
    }
    fn pick(&mut self, n: usize) -> usize {
        ((self.0.uniform() * n as f64) as usize).min(n - 1)
    }
}

fn r(x: f64, digits: i32) -> f64 {
    let k = 10f64.powi(digits);
    (x * k).round() / k
}

/// Draws trial `index` of master seed `seed`.
pub fn draw(seed: u64, index: u64) -> Trial {
    let mut d = Draw(Stream::new(seed, Component::Sweep, index as usize));
    let run_seed = d.0.next_u64() % 1_000_000;
    let cf = d.0.uniform() < 0.5;
    let preset = if cf { "crazyflie21" } else { "x3d" };
    let mut hidden = draw_hidden(&mut d, cf);
    let (plan, words) = draw_plan(&mut d, cf, &mut hidden);
    let yaml = trial_yaml(index, run_seed, preset, &plan, &hidden);
    Trial { index, seed: run_seed, preset: preset.to_string(), plan: words, hidden, yaml }
}

/// The hidden effects of a trial: 0–3 distinct simulated ones, with values drawn in ranges a
/// flight of that vehicle can show (`cf`: the Crazyflie, else the X3D), sorted by effect.
fn draw_hidden(d: &mut Draw, cf: bool) -> Vec<(Effect, Vec<f64>)> {
    let weight = if cf { 0.034 * 9.81 } else { 0.68 * 9.81 };
    // hidden effects: 0–3 distinct ones
    let count = d.pick(4);
    let mut pool: Vec<Effect> = simulated();
    let mut hidden = Vec::new();
    for _ in 0..count {
        let e = pool.remove(d.pick(pool.len()));
        let v = match e {
            Effect::BodyOffset => (0..3).map(|_| r(d.signed(0.5, 3.0), 3)).collect(),
            Effect::WorldTilt => (0..2).map(|_| r(d.signed(0.3, 1.5), 3)).collect(),
            Effect::MocapDelay => vec![5.0 * (1 + d.pick(4)) as f64],
            Effect::AccelBias => (0..3).map(|_| r(d.signed(0.05, 0.3), 4)).collect(),
            Effect::GyroBias => (0..3).map(|_| r(d.signed(0.3, 1.5), 3)).collect(),
            Effect::RotorDrag => (0..2).map(|_| r(d.u(0.1, 0.5), 3)).collect(),
            Effect::ConstantForce => vec![
                r(d.signed(0.02, 0.1) * weight, 4),
                r(d.signed(0.02, 0.1) * weight, 4),
                r(d.signed(0.0, 0.03) * weight, 4),
            ],
            Effect::ThrustScale => vec![r(d.signed(0.03, 0.15), 4)],
            Effect::LeverArm => (0..3).map(|_| r(d.signed(10.0, 40.0), 1)).collect(),
            Effect::ThrustVoltage => vec![r(if cf { d.u(0.05, 0.2) } else { d.u(0.015, 0.07) }, 4)],
            Effect::GyroDelay => vec![5.0 * (1 + d.pick(3)) as f64],
            _ => unreachable!("only simulated effects are hidden"),
        };
        hidden.push((e, v));
    }
    hidden.sort_by_key(|h| h.0);
    hidden
}

/// The flight plan of a trial (the scenario's plan steps) and its description in words: take-off, 3–5
/// pieces (a tour, a figure-8, gyro circles, a yaw turn, a short excursion), in a quarter of the
/// flights a low hover (and, when fewer than three effects are hidden, in half of those a ground
/// effect added to `hidden`), landing.
fn draw_plan(d: &mut Draw, cf: bool, hidden: &mut Vec<(Effect, Vec<f64>)>) -> (Vec<Step>, Vec<String>) {
    let alt = r(d.u(0.8, 1.5), 2);
    let mut plan = vec![
        Step::Idle { duration_s: 1.0 },
        Step::Takeoff { altitude_m: alt, duration_s: 3.0 },
        Step::Hover { duration_s: 2.0 },
    ];
    let mut words = Vec::new();
    let pieces = 3 + d.pick(3);
    let wp = |n: f64, e: f64, speed: f64, hold: f64| waypoint(n, e, alt, speed, hold);
    for _ in 0..pieces {
        match d.pick(5) {
            0 => {
                let n = 2 + d.pick(3);
                let speed = r(d.u(0.8, 2.0), 2);
                for _ in 0..n {
                    let (pn, pe) = (d.u(-3.0, 3.0), d.u(-3.0, 3.0));
                    plan.push(wp(pn, pe, speed, 0.5));
                }
                plan.push(wp(0.0, 0.0, speed, 0.5));
                words.push(format!("tour of {n} at {speed} m/s"));
            }
            1 => {
                let a = d.u(1.0, 2.0);
                let speed = r(d.u(0.8, 1.5), 2);
                for k in 1..=8 {
                    let t = k as f64 * std::f64::consts::TAU / 8.0;
                    plan.push(wp(a * t.sin(), a * t.sin() * t.cos(), speed, 0.0));
                }
                words.push(format!("figure-8 of {:.1} m at {speed} m/s", a));
            }
            2 => {
                let (rad, period, turns) = (r(d.u(0.2, 0.5), 2), r(d.u(2.0, 3.5), 2), (2 + d.pick(3)) as f64);
                plan.push(Step::CalibrateGyro { settle_s: 1.0, radius_m: rad, period_s: period, turns });
                words.push(format!("{turns} circles of {rad} m"));
            }
            3 => {
                let angle = r(d.u(90.0, 360.0), 0) * d.sign();
                let dur = r(angle.abs() / 45.0 + 1.0, 1);
                plan.push(Step::YawSpin { settle_s: 1.0, angle_deg: angle, duration_s: dur });
                words.push(format!("yaw turn of {angle}°"));
            }
            _ => {
                let heading = d.u(0.0, std::f64::consts::TAU);
                plan.push(Step::Hover { duration_s: 2.0 });
                plan.push(wp(0.5 * heading.cos(), 0.5 * heading.sin(), 0.5, 0.5));
                plan.push(wp(0.0, 0.0, 0.5, 0.5));
                words.push("hover and a 0.5 m excursion".to_string());
            }
        }
    }
    // drawn last, so that the draws above are the same with or without it: in a quarter of the
    // flights a low hover (1.2–3 rotor radii over the floor), and in half of those (when fewer
    // than three effects are hidden) a ground effect
    if d.0.uniform() < 0.25 {
        let r_rotor: f64 = if cf {
            crate::vehicle::params::CRAZYFLIE21_ROTOR_RADIUS_M
        } else {
            crate::vehicle::params::X3D_ROTOR_RADIUS_M
        };
        // not below 0.1 m: identify leaves out what is within 8 cm of the floor
        let low = r((d.u(1.2, 3.0) * r_rotor).max(0.1), 3);
        plan.push(waypoint(0.0, 0.0, low, 0.5, 4.0));
        plan.push(wp(0.0, 0.0, 0.5, 1.0));
        words.push(format!("low hover at {low} m"));
        if hidden.len() < 3 && d.0.uniform() < 0.5 {
            hidden.push((Effect::GroundEffect, vec![r(d.u(0.5, 1.5), 3)]));
        }
    }
    plan.push(Step::Land { duration_s: 3.0 });
    (plan, words)
}

/// A plan step to (north, east) m at `height` m above the floor, at `speed` m/s, held `hold` s.
fn waypoint(n: f64, e: f64, height: f64, speed: f64, hold: f64) -> Step {
    Step::Waypoint { pos_m: [r(n, 2), r(e, 2), -height], speed_m_s: speed, accel_m_s2: 1.5, hold_s: hold }
}

/// A step of a trial's plan, as the scenario's `plan:` writes it (docs/scenarios.md).
#[derive(serde::Serialize)]
#[serde(rename_all = "snake_case")]
enum Step {
    Idle { duration_s: f64 },
    Takeoff { altitude_m: f64, duration_s: f64 },
    Hover { duration_s: f64 },
    Waypoint { pos_m: [f64; 3], speed_m_s: f64, accel_m_s2: f64, hold_s: f64 },
    CalibrateGyro { settle_s: f64, radius_m: f64, period_s: f64, turns: f64 },
    YawSpin { settle_s: f64, angle_deg: f64, duration_s: f64 },
    Land { duration_s: f64 },
}

/// A trial's scenario, as its YAML file writes it: the fields a trial sets, the rest at the
/// scenario's defaults; each vehicle and plan step on one line.
#[derive(serde::Serialize)]
struct TrialScenario<'a> {
    name: String,
    seed: u64,
    mocap: FlowMap<TrialMocap>,
    calibration: FlowMap<Apply>,
    vehicles: [FlowMap<TrialVehicle<'a>>; 1],
    plan: Vec<FlowMap<PlanItem<'a>>>,
}

/// A plan step as a one-key mapping (`waypoint: {...}`), which a flow style can take.
#[derive(serde::Serialize)]
struct PlanItem<'a> {
    #[serde(flatten)]
    step: &'a Step,
}

#[derive(serde::Serialize)]
struct TrialMocap {
    noise_mm: f64,
    #[serde(skip_serializing_if = "Option::is_none")]
    camera_error: Option<RotationDeg>,
}

#[derive(serde::Serialize)]
struct RotationDeg {
    rotation_deg: [f64; 3],
}

#[derive(serde::Serialize)]
struct Apply {
    apply: bool,
}

#[derive(serde::Serialize)]
struct Preset<'a> {
    preset: &'a str,
}

#[derive(serde::Serialize)]
struct Force {
    force_n: Vec<f64>,
}

#[derive(serde::Serialize)]
struct TrialVehicle<'a> {
    name: &'a str,
    model: Preset<'a>,
    #[serde(skip_serializing_if = "Option::is_none")]
    disturbance: Option<Force>,
    #[serde(skip_serializing_if = "Markers::is_empty")]
    markers: Markers,
    imu: Imu,
    #[serde(skip_serializing_if = "Undeclared::is_empty")]
    undeclared: Undeclared,
}

#[derive(serde::Serialize, Default, PartialEq)]
struct Markers {
    #[serde(skip_serializing_if = "Option::is_none")]
    rotation_deg: Option<Vec<f64>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    displacement_mm: Option<[Vec<f64>; 4]>,
}

impl Markers {
    fn is_empty(&self) -> bool {
        *self == Markers::default()
    }
}

#[derive(serde::Serialize)]
struct Imu {
    gyro_noise_deg_s: f64,
    accel_noise_m_s2: f64,
    #[serde(skip_serializing_if = "Option::is_none")]
    accel_bias_m_s2: Option<Vec<f64>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    gyro_bias_deg_s: Option<Vec<f64>>,
}

/// The effects the simulation applies and the model does not declare (`undeclared:`).
#[derive(serde::Serialize, Default, PartialEq)]
struct Undeclared {
    #[serde(skip_serializing_if = "Option::is_none")]
    mocap_delay_ms: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    rotor_drag_per_s: Option<Vec<f64>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    thrust_scale: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    ground_effect: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    thrust_voltage_per_v: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    gyro_delay_ms: Option<f64>,
}

impl Undeclared {
    fn is_empty(&self) -> bool {
        *self == Undeclared::default()
    }
}

/// The trial's scenario: the preset, the hidden effects written where the simulation applies
/// them (markers, camera, IMU, undeclared, disturbance), the plan; YAML written by serde.
fn trial_yaml(index: u64, run_seed: u64, preset: &str, plan: &[Step], hidden: &[(Effect, Vec<f64>)]) -> String {
    let mut vehicle = TrialVehicle {
        name: "v",
        model: Preset { preset },
        disturbance: None,
        markers: Markers::default(),
        imu: Imu { gyro_noise_deg_s: 0.3, accel_noise_m_s2: 0.05, accel_bias_m_s2: None, gyro_bias_deg_s: None },
        undeclared: Undeclared::default(),
    };
    let mut mocap = TrialMocap { noise_mm: 0.1, camera_error: None };
    let u = &mut vehicle.undeclared;
    for (e, v) in hidden {
        match e {
            Effect::BodyOffset => vehicle.markers.rotation_deg = Some(v.clone()),
            // the mocap tracks the markers' origin, displaced by d = −r from the IMU (at the
            // centre of mass); the built-in patterns have four markers
            Effect::LeverArm => {
                let d: Vec<f64> = v.iter().map(|x| -x).collect();
                vehicle.markers.displacement_mm = Some([d.clone(), d.clone(), d.clone(), d]);
            }
            Effect::WorldTilt => mocap.camera_error = Some(RotationDeg { rotation_deg: [v[0], v[1], 0.0] }),
            Effect::MocapDelay => u.mocap_delay_ms = Some(v[0]),
            Effect::AccelBias => vehicle.imu.accel_bias_m_s2 = Some(v.clone()),
            Effect::GyroBias => vehicle.imu.gyro_bias_deg_s = Some(v.clone()),
            Effect::RotorDrag => u.rotor_drag_per_s = Some(v.clone()),
            Effect::ConstantForce => vehicle.disturbance = Some(Force { force_n: v.clone() }),
            Effect::ThrustScale => u.thrust_scale = Some(1.0 + v[0]),
            Effect::GroundEffect => u.ground_effect = Some(v[0]),
            Effect::ThrustVoltage => u.thrust_voltage_per_v = Some(v[0]),
            Effect::GyroDelay => u.gyro_delay_ms = Some(v[0]),
            Effect::AccelMisalignment
            | Effect::AccelScale
            | Effect::ThrustTilt
            | Effect::ClockDrift
            | Effect::ImuOffset
            | Effect::AccelBiasDrift
            | Effect::GyroBiasDrift => {
                unreachable!("only simulated effects are hidden")
            }
        }
    }
    let scenario = TrialScenario {
        name: format!("trial-{index}"),
        seed: run_seed,
        mocap: FlowMap(mocap),
        calibration: FlowMap(Apply { apply: false }),
        vehicles: [FlowMap(vehicle)],
        plan: plan.iter().map(|step| FlowMap(PlanItem { step })).collect(),
    };
    serde_saphyr::to_string(&scenario).expect("a trial's scenario is plain data")
}

/// What happened to one hidden effect.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct HiddenOutcome {
    /// The effect hidden.
    pub effect: Effect,
    /// Its true parameters, in the report's units.
    pub truth: Vec<f64>,
    /// How well the flight excites it.
    pub excitation: Excitation,
    /// Selected by `identify`.
    pub found: bool,
    /// Named not identifiable from a selected effect.
    pub flagged: bool,
    /// (estimate, 95 % half-width) per parameter, when found.
    pub estimates: Vec<(f64, f64)>,
    /// Found, but reported not identifiable from an effect outside the model.
    pub identifiable: bool,
}

/// One trial, identified and scored.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct Outcome {
    /// The trial as drawn.
    pub trial: Trial,
    /// Each hidden effect's outcome.
    pub hidden: Vec<HiddenOutcome>,
    /// Selected effects that were not hidden, and whether each is flagged.
    pub extra: Vec<(Effect, bool)>,
    /// Why the trial could not be identified (the flight or the gate failed), if it could not.
    pub error: Option<String>,
}

/// Flies and identifies one trial.
pub fn run(trial: &Trial, o: &Options) -> Outcome {
    let fail = |e: String| Outcome { trial: trial.clone(), hidden: Vec::new(), extra: Vec::new(), error: Some(e) };
    let s = match Scenario::parse(&trial.yaml, std::path::Path::new(&format!("trial-{}.yaml", trial.index))) {
        Ok(s) => s,
        Err(e) => return fail(e.to_string()),
    };
    let series = match run_and_log(&s, 0, &format!("trial {}", trial.index)) {
        Ok((_, series)) => series,
        Err(e) => return fail(e.to_string()),
    };
    let report = match identify(&series, o) {
        Ok(r) => r,
        Err(e) => return fail(e.to_string()),
    };
    let exc = excitation(&series, o, &trial.hidden);
    let hidden_effects: Vec<Effect> = trial.hidden.iter().map(|h| h.0).collect();
    let pair = |a: Effect, b: Effect| {
        report.not_identifiable.iter().any(|(x, y, _)| (*x == a && *y == b) || (*x == b && *y == a))
    };
    let selected: Vec<Effect> = report.effects.iter().map(|f| f.effect).collect();
    let hidden = trial
        .hidden
        .iter()
        .zip(exc)
        .map(|((e, truth), excitation)| {
            let found = report.effect(*e);
            HiddenOutcome {
                effect: *e,
                truth: truth.clone(),
                excitation,
                found: found.is_some(),
                flagged: found.is_none() && selected.iter().any(|s| pair(*s, *e)),
                estimates: found.map_or_else(Vec::new, |f| f.params.iter().map(|p| (p.value, p.ci95)).collect()),
                identifiable: found.is_none_or(|f| f.params.iter().all(|p| p.identifiable)),
            }
        })
        .collect();
    let extra = selected
        .iter()
        .filter(|e| !hidden_effects.contains(e))
        .map(|e| (*e, hidden_effects.iter().any(|h| pair(*e, *h))))
        .collect();
    Outcome { trial: trial.clone(), hidden, extra, error: None }
}

/// Flies `count` trials of master seed `seed` on all cores; outcomes in index order, the same
/// whatever the thread count.
pub fn run_many(seed: u64, count: u64, o: &Options) -> Vec<Outcome> {
    run_shard(seed, count, None, o)
}

/// The trials of shard `(k, n)` (0-based k: the indices i with i mod n = k) of `count`, or all
/// of them with `None`; outcomes in index order. Trial i is a pure function of (seed, i), so the
/// shards of a split hold, between them, exactly the outcomes of the unsharded batch.
pub fn run_shard(seed: u64, count: u64, shard: Option<(u64, u64)>, o: &Options) -> Vec<Outcome> {
    use rayon::prelude::*;
    let mine: Vec<u64> = (0..count).filter(|i| shard.is_none_or(|(k, n)| i % n == k)).collect();
    mine.into_par_iter().map(|i| run(&draw(seed, i), o)).collect()
}

/// One shard of a batch of trials, as `trials --shard K/N` writes it.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct TrialsShard {
    /// The batch's master seed.
    pub seed: u64,
    /// The batch's number of flights.
    pub flights: u64,
    /// This shard, 1-based, and the number of shards: [K, N].
    pub shard: [u64; 2],
    /// Its outcomes, in index order.
    pub outcomes: Vec<Outcome>,
}

/// The outcomes of a whole batch from its shards, in index order, with the batch's seed and
/// size; an error names a shard that does not belong (another seed, size or split), is given
/// twice or is missing, or one whose outcomes are not its trials.
pub fn merge(parts: Vec<TrialsShard>) -> Result<(u64, u64, Vec<Outcome>), String> {
    let first = parts.first().ok_or("no shard files given")?;
    let (seed, flights, split) = (first.seed, first.flights, first.shard[1]);
    let mut seen = std::collections::BTreeSet::new();
    for p in &parts {
        let [k, n] = p.shard;
        let why = if p.seed != seed {
            Some(format!("seed {}, not {seed}", p.seed))
        } else if p.flights != flights {
            Some(format!("{} flights, not {flights}", p.flights))
        } else if n != split {
            Some(format!("a split into {n} shards, not {split}"))
        } else {
            None
        };
        if let Some(why) = why {
            return Err(format!(
                "shard {k} of {n} does not belong with shard {} of {split} of trials seed {seed}: {why}",
                first.shard[0]
            ));
        }
        if !(1..=n).contains(&k) || !seen.insert(k) {
            return Err(format!("shard {k} of {n} is given twice or is no shard of {n}"));
        }
        let want: Vec<u64> = (0..flights).filter(|i| i % n == k - 1).collect();
        let got: Vec<u64> = p.outcomes.iter().map(|o| o.trial.index).collect();
        if got != want {
            return Err(format!(
                "shard {k} of {n} does not hold its trials (every {n}th from {}): a shard file cut short or edited",
                k - 1
            ));
        }
    }
    if let Some(missing) = (1..=split).find(|k| !seen.contains(k)) {
        return Err(format!("shard {missing} of {split} is missing"));
    }
    let mut outcomes: Vec<Outcome> = parts.into_iter().flat_map(|p| p.outcomes).collect();
    outcomes.sort_by_key(|o| o.trial.index);
    Ok((seed, flights, outcomes))
}

/// Per-effect scores over a set of outcomes.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct EffectScore {
    /// Trials that hid the effect.
    pub hidden: usize,
    /// Hidden where the excitation suffices (decided before the outcome).
    pub excited: usize,
    /// Found where excited.
    pub found_excited: usize,
    /// Missed where excited.
    pub missed_excited: usize,
    /// Hidden and named not identifiable from a selected effect.
    pub flagged: usize,
    /// Found, excited or not.
    pub found_all: usize,
    /// Selected without being hidden (and not flagged).
    pub invented: usize,
    /// Parameters of found effects with an interval.
    pub params: usize,
    /// Parameters of found effects the report calls not identifiable (no interval claimed).
    pub unidentifiable_params: usize,
    /// Intervals that contain the truth.
    pub covered: usize,
    /// Intervals that miss the truth by more than three half-widths (confidently wrong).
    pub confidently_wrong: usize,
}

impl EffectScore {
    /// found_excited / (found_excited + missed_excited).
    pub fn recall_excited(&self) -> Option<f64> {
        let d = self.found_excited + self.missed_excited;
        (d > 0).then(|| self.found_excited as f64 / d as f64)
    }
    /// found_all / (found_all + invented).
    pub fn precision(&self) -> Option<f64> {
        let d = self.found_all + self.invented;
        (d > 0).then(|| self.found_all as f64 / d as f64)
    }
    /// covered / params: the 95 % intervals' measured coverage.
    pub fn coverage(&self) -> Option<f64> {
        (self.params > 0).then(|| self.covered as f64 / self.params as f64)
    }
}

/// The scores per effect (in [`Effect::ALL`] order) and the total.
pub fn score(outcomes: &[Outcome]) -> (Vec<(Effect, EffectScore)>, EffectScore) {
    let mut by: Vec<(Effect, EffectScore)> = Effect::ALL.iter().map(|e| (*e, EffectScore::default())).collect();
    for o in outcomes.iter().filter(|o| o.error.is_none()) {
        for h in &o.hidden {
            let sc = &mut by.iter_mut().find(|x| x.0 == h.effect).expect("every effect").1;
            sc.hidden += 1;
            if h.flagged {
                sc.flagged += 1;
                continue;
            }
            if h.found {
                sc.found_all += 1;
            }
            if h.excitation.sufficient() {
                sc.excited += 1;
                if h.found {
                    sc.found_excited += 1;
                } else {
                    sc.missed_excited += 1;
                }
            }
            if !h.identifiable {
                // the report says this flight cannot tell it from another effect: no interval is claimed
                sc.unidentifiable_params += h.truth.len();
                continue;
            }
            for ((est, hw), t) in h.estimates.iter().zip(&h.truth) {
                sc.params += 1;
                let err = (est - t).abs();
                if err <= *hw {
                    sc.covered += 1;
                }
                if err > 3.0 * hw {
                    sc.confidently_wrong += 1;
                }
            }
        }
        for (e, flagged) in &o.extra {
            if !flagged {
                by.iter_mut().find(|x| x.0 == *e).expect("every effect").1.invented += 1;
            }
        }
    }
    let mut total = EffectScore::default();
    for (_, s) in &by {
        total.hidden += s.hidden;
        total.excited += s.excited;
        total.found_excited += s.found_excited;
        total.missed_excited += s.missed_excited;
        total.flagged += s.flagged;
        total.found_all += s.found_all;
        total.invented += s.invented;
        total.params += s.params;
        total.unidentifiable_params += s.unidentifiable_params;
        total.covered += s.covered;
        total.confidently_wrong += s.confidently_wrong;
    }
    (by, total)
}

/// The table of [`score`], as docs/trials.md shows it.
pub fn render(outcomes: &[Outcome]) -> String {
    let (by, total) = score(outcomes);
    let pct = |x: Option<f64>| x.map_or("—".to_string(), |v| format!("{:.1} %", 100.0 * v));
    let failed = outcomes.iter().filter(|o| o.error.is_some()).count();
    let mut s = String::new();
    let _ =
        writeln!(s, "{} flights ({} could not be identified), {} hidden effects", outcomes.len(), failed, total.hidden);
    let _ = writeln!(
        s,
        "| effect | hidden | excited | recall (excited) | found (all) | flagged | invented | precision | 95 % coverage | not identifiable | confidently wrong |"
    );
    let _ = writeln!(s, "|---|---|---|---|---|---|---|---|---|---|---|");
    let row = |s: &mut String, name: &str, x: &EffectScore| {
        let _ = writeln!(
            s,
            "| {name} | {} | {} | {} ({}/{}) | {} | {} | {} | {} | {} ({}/{}) | {} | {} |",
            x.hidden,
            x.excited,
            pct(x.recall_excited()),
            x.found_excited,
            x.found_excited + x.missed_excited,
            x.found_all,
            x.flagged,
            x.invented,
            pct(x.precision()),
            pct(x.coverage()),
            x.covered,
            x.params,
            x.unidentifiable_params,
            x.confidently_wrong
        );
    };
    for (e, x) in &by {
        row(&mut s, e.key(), x);
    }
    row(&mut s, "**all**", &total);
    for o in outcomes.iter().filter(|o| o.error.is_some()) {
        let _ = writeln!(s, "trial {}: {}", o.trial.index, o.error.as_deref().unwrap_or(""));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each hidden effect is written where the module doc's table says the simulation applies
    /// it, with its value: the scenario parsed back holds the value at that path and nothing
    /// else besides the trial's fixed noise (a field dropped, misnamed or signed wrong fails).
    /// The thrust scale is written as 1 + the reported share, the lever arm r as the markers'
    /// displacement −r (four markers), the tilt with a zero yaw.
    #[test]
    fn each_hidden_effect_is_written_where_the_table_says() {
        let plan = [Step::Idle { duration_s: 1.0 }, Step::Takeoff { altitude_m: 1.0, duration_s: 3.0 }];
        let cases: [(Effect, Vec<f64>, &str, serde_json::Value); 11] = [
            (
                Effect::BodyOffset,
                vec![1.5, -0.5, 2.0],
                "/vehicles/0/markers/rotation_deg",
                serde_json::json!([1.5, -0.5, 2.0]),
            ),
            (
                Effect::WorldTilt,
                vec![0.4, -1.2],
                "/mocap/camera_error/rotation_deg",
                serde_json::json!([0.4, -1.2, 0.0]),
            ),
            (Effect::MocapDelay, vec![15.0], "/vehicles/0/undeclared/mocap_delay_ms", serde_json::json!(15.0)),
            (
                Effect::AccelBias,
                vec![0.1, -0.2, 0.3],
                "/vehicles/0/imu/accel_bias_m_s2",
                serde_json::json!([0.1, -0.2, 0.3]),
            ),
            (
                Effect::GyroBias,
                vec![0.5, 1.0, -1.5],
                "/vehicles/0/imu/gyro_bias_deg_s",
                serde_json::json!([0.5, 1.0, -1.5]),
            ),
            (
                Effect::RotorDrag,
                vec![0.2, 0.3],
                "/vehicles/0/undeclared/rotor_drag_per_s",
                serde_json::json!([0.2, 0.3]),
            ),
            (
                Effect::ConstantForce,
                vec![0.5, -0.4, 0.1],
                "/vehicles/0/disturbance/force_n",
                serde_json::json!([0.5, -0.4, 0.1]),
            ),
            (Effect::ThrustScale, vec![-0.1], "/vehicles/0/undeclared/thrust_scale", serde_json::json!(0.9)),
            (Effect::GroundEffect, vec![1.2], "/vehicles/0/undeclared/ground_effect", serde_json::json!(1.2)),
            (Effect::ThrustVoltage, vec![0.05], "/vehicles/0/undeclared/thrust_voltage_per_v", serde_json::json!(0.05)),
            (Effect::GyroDelay, vec![10.0], "/vehicles/0/undeclared/gyro_delay_ms", serde_json::json!(10.0)),
        ];
        let bare =
            serde_json::to_value(Scenario::parse(&trial_yaml(0, 7, "x3d", &plan, &[]), "t.yaml".as_ref()).unwrap())
                .unwrap();
        for (e, v, path, want) in cases {
            let yaml = trial_yaml(0, 7, "x3d", &plan, &[(e, v)]);
            let s =
                Scenario::parse(&yaml, "t.yaml".as_ref()).unwrap_or_else(|err| panic!("{}: {err}\n{yaml}", e.key()));
            let got = serde_json::to_value(&s).unwrap();
            assert_eq!(got.pointer(path), Some(&want), "{}: {yaml}", e.key());
            assert_ne!(bare.pointer(path), Some(&want), "{}: the bare trial has it too", e.key());
        }
        let yaml = trial_yaml(0, 7, "x3d", &plan, &[(Effect::LeverArm, vec![10.0, -20.0, 30.0])]);
        let got = serde_json::to_value(Scenario::parse(&yaml, "t.yaml".as_ref()).unwrap()).unwrap();
        assert_eq!(
            got.pointer("/vehicles/0/markers/displacement_mm"),
            Some(&serde_json::json!([
                [-10.0, 20.0, -30.0],
                [-10.0, 20.0, -30.0],
                [-10.0, 20.0, -30.0],
                [-10.0, 20.0, -30.0]
            ]))
        );
        // the trial's own settings, and the plan as drawn
        assert_eq!(bare.pointer("/seed"), Some(&serde_json::json!(7)));
        assert_eq!(bare.pointer("/name"), Some(&serde_json::json!("trial-0")));
        assert_eq!(bare.pointer("/calibration/apply"), Some(&serde_json::json!(false)));
        assert_eq!(bare.pointer("/plan/1/takeoff/altitude_m"), Some(&serde_json::json!(1.0)));
    }
}

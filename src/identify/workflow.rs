//! The `identify` workflow behind `flyarena identify`, usable from Rust: load the input (a scenario
//! to run, a flyarena log with its scenario, or another tool's log through a mapping), identify,
//! compare the closed loop, and return the report, R5, the fragment and the residuals as data
//! (`present` renders them as text and JSON).

use super::fit::start::ClockWindow;
use super::input::error::InputError;
use super::input::flyarena_log;
use super::output::calibration::{LogAxes, imu_trajectory_tum, t_bs_yaml};
use super::output::feedback::{TrajectoryError, fragment, nominal_and_fed_back, trajectory_error};
use super::{Options, identify};
use crate::frames::{Body, MocapBody, Rot};
use crate::scenario::Scenario;
use serde_json::{Value, json};
use std::path::Path;

/// Why an identification ([`run`], [`run_many`]) stopped before a result: an input that cannot
/// be used (a mapping, a log, a scenario, a fragment), or data that does not pass the
/// data-quality gate. [`crate::Error`] gathers it with the other stages' errors.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// An input that cannot be used.
    #[error(transparent)]
    Input(#[from] InputError),
    /// Data that does not pass the data-quality gate, or too little of it.
    #[error(transparent)]
    Data(#[from] super::IdentifyError),
}

impl From<crate::scenario::ScenarioError> for Error {
    fn from(e: crate::scenario::ScenarioError) -> Self {
        Error::Input(e.into())
    }
}

impl From<crate::log::LogError> for Error {
    fn from(e: crate::log::LogError) -> Self {
        Error::Input(e.into())
    }
}

/// One identification, with everything the CLI writes.
pub struct Identified {
    /// The report.
    pub report: super::Report,
    /// R5, when the scenario declares it.
    pub requirements: Option<crate::requirements::Report>,
    /// The scenario fragment that adds the found effects (`--feedback`).
    pub fragment: String,
    /// Closed-loop error of the nominal and of the corrected simulation against the flight, when it
    /// was flown from a scenario.
    pub closed_loop: Option<(TrajectoryError, TrajectoryError)>,
    /// Residuals before and after, for the recording.
    pub residuals: Vec<super::fit::select::ResidualSeries>,
    /// The calibration as T_BS (ASL/Kalibr YAML), when the report holds one
    /// ([`super::calibration::t_bs_yaml`]).
    pub t_bs_yaml: Option<String>,
    /// The IMU frame's trajectory (TUM), when the report holds a calibration
    /// ([`super::calibration::imu_trajectory_tum`]).
    pub imu_trajectory: Option<String>,
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

/// The options of a request: the forced effects, the clock's search window, whether it is a
/// calibration ([`Request::calibrate`]), and the smoothing from the request, else from the
/// mapping, else the default.
fn options(
    forced: &[super::Effect],
    smoothing_ms: Option<f64>,
    calibrate: bool,
    clock: Option<ClockWindow>,
    map: Option<&super::input::mapping::Mapping>,
) -> Options {
    // a calibration's fit is `Options::calibration`'s; its forced effects are the request's
    let base = if calibrate { Options::calibration() } else { Options::default() };
    let mut opts = Options { forced: forced.to_vec(), ..base };
    if let Some(c) = clock {
        opts.clock = c;
    }
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
    /// Another tool's log (CSV, a ROS 2 bag, a PX4 log, an ASL folder, or an IMU log beside a
    /// pose file) through a mapping.
    Mapped {
        /// The log (the IMU's, where the poses are a file of their own; an ASL folder).
        log: &'a Path,
        /// The mapping that reads it.
        mapping: &'a Path,
        /// The pose file beside an IMU log (a mapping with a `poses:` block), or another pose
        /// stream of an ASL folder.
        poses: Option<&'a Path>,
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
    /// A calibration (`--calibrate`): the chosen model fitted again on every usable sample
    /// ([`Options::refit_every_sample`]), each sensor's axes sharing one noise model
    /// ([`Options::mount_invariant`]).
    pub calibrate: bool,
    /// Effects fitted whatever the selection says (`--with`).
    pub forced: Vec<super::Effect>,
    /// Where the clock offset between the IMU and the mocap is searched (`--clock-offset`;
    /// `None`: ±5 s around 0).
    pub clock: Option<ClockWindow>,
}

impl<'a> Request<'a> {
    /// A request with default options.
    pub fn new(source: Source<'a>) -> Self {
        Request {
            source,
            vehicle: None,
            seed: None,
            smoothing_ms: None,
            calibrate: false,
            forced: Vec::new(),
            clock: None,
        }
    }
}

/// A log through its mapping: one file as it is read, or two streams joined once the clock
/// search has found how they stand ([`super::fit::start`]).
fn read_log(
    map: &super::input::mapping::Mapping,
    log: &Path,
    poses: Option<&Path>,
    clock: &ClockWindow,
) -> Result<super::Series, InputError> {
    if map.two_streams() {
        let streams = map.read_streams(log, poses)?;
        // a report names both files: one IMU log with two pose files is two calibrations
        let source = match poses {
            Some(p) => format!("{} with the poses of {}", log.display(), p.display()),
            None => log.display().to_string(),
        };
        return super::fit::start::joined(map, &streams, clock, &source);
    }
    if let Some(p) = poses {
        return Err(InputError::invalid(
            p.display(),
            "--poses names a pose file of its own, and the mapping reads the poses from the log: give it a `poses:` block",
        ));
    }
    map.read(log)
}

/// Identifies from a scenario (flown here), a flyarena log with its scenario, or a mapped log;
/// for a scenario or a flyarena log, also flies the nominal and the fed-back model against
/// the data (closed loop) and checks R5 when the scenario declares it.
pub fn run(req: &Request) -> Result<Identified, Error> {
    let (forced, smoothing_ms, vehicle, seed) = (&req.forced[..], req.smoothing_ms, req.vehicle, req.seed);
    let opts = options(forced, smoothing_ms, req.calibrate, req.clock, None);
    let (input, scenario) = match req.source {
        Source::Scenario(p) => (p, None),
        Source::FlyarenaLog { log, scenario } => (log, Some(scenario)),
        Source::Mapped { log: input, mapping: m, poses } => {
            let map = super::input::mapping::Mapping::load(m)?;
            let opts = options(forced, smoothing_ms, req.calibrate, req.clock, Some(&map));
            let series = read_log(&map, input, poses, &opts.clock)?;
            let report = identify(&series, &opts)?;
            // the log's own frame rate, for rounding a delay to whole frames
            // (and four markers, the common pattern, for a lever arm: the log names no template)
            let fragment = fragment(&report, 0, (1.0 / series.dt()).round().max(1.0) as u32, 4);
            let residuals = super::fit::select::residual_series(&series, &opts, &report);
            let axes = LogAxes { world: map.world, body: map.body };
            let source = report.source.clone();
            return Ok(Identified {
                t_bs_yaml: t_bs_yaml(&report, axes, &source),
                imu_trajectory: imu_trajectory_tum(&series, &report, axes),
                report,
                requirements: None,
                fragment,
                closed_loop: None,
                residuals,
            });
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
    let requirements =
        s.requirements.identify.as_ref().map(|req| super::checks::check::check(&report, req, &s.vehicle(i).name));
    let residuals = super::fit::select::residual_series(&data, &opts, &report);
    let source = input.display().to_string();
    Ok(Identified {
        t_bs_yaml: t_bs_yaml(&report, LogAxes::flyarena(), &source),
        imu_trajectory: imu_trajectory_tum(&data, &report, LogAxes::flyarena()),
        report,
        requirements,
        fragment: frag,
        closed_loop: Some((before, after)),
        residuals,
    })
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
    /// The spin-ups against the rests over the flights that have one (`None`: fewer than 3).
    pub spin_up: Option<super::fit::ground::SpinUpSummary>,
    /// The rests after landing against the rests before and the flights (`None`: fewer than 3).
    pub after_landing: Option<super::fit::ground::LandedSummary>,
    /// The still pose's scatter at rest over the flights (`None`: fewer than 3).
    pub rest_pose: Option<super::fit::ground::RestPoseSummary>,
    /// The flights left out, each with the reason.
    pub excluded: Vec<(String, Exclusion)>,
}

/// Identifies every log through one mapping, then evaluates each flight's model on every other
/// flight and checks the offsets' consistency per mounting. `calibrate` as in
/// [`Request::calibrate`] (on with `--calibrate`).
pub fn run_many(
    inputs: &[&Path],
    mapping: &Path,
    smoothing_ms: Option<f64>,
    calibrate: bool,
    forced: &[super::Effect],
) -> Result<CrossValidated, Error> {
    use super::fit::select::{channel_cut, evaluate};
    use crate::effects::Channel;
    let map = super::input::mapping::Mapping::load(mapping)?;
    let opts = options(forced, smoothing_ms, calibrate, None, Some(&map));
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
    let agreements = || reports.iter().filter_map(|(_, r)| r.ground_agreement.as_ref());
    let spin_up = super::fit::ground::spin_up_summary(agreements());
    let landed = super::fit::ground::landed_summary(agreements());
    let rest_pose = super::fit::ground::rest_pose_summary(agreements());
    Ok(CrossValidated { reports, cross, consistency, spin_up, after_landing: landed, rest_pose, excluded })
}

/// The logs of a multi-flight run, identified: reports and series of the flights kept (in input
/// order), and the flights left out with the reason.
struct Each {
    reports: Vec<(String, super::Report)>,
    series: Vec<super::Series>,
    excluded: Vec<(String, Exclusion)>,
}

/// Why a flight of a cross-validation was left out (its sentence is its `Display`).
#[derive(Debug)]
#[non_exhaustive]
pub enum Exclusion {
    /// The same samples as the named earlier flight under another name (published datasets hold
    /// such copies, which would agree with themselves and count twice): counted once.
    CopyOf(String),
    /// [`identify`] gave no report (the data-quality gate left too little clean data).
    Rejected(super::IdentifyError),
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
    let mut excluded: Vec<(String, Exclusion)> = Vec::new();
    for p in inputs {
        let s = read_log(map, p, None, &opts.clock)?;
        let name = p.file_stem().map_or_else(|| p.display().to_string(), |x| x.to_string_lossy().into_owned());
        if let Some((first, _)) = read.iter().find(|(_, r)| r.same_samples(&s)) {
            excluded.push((name, Exclusion::CopyOf(first.clone())));
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
            Err(e) => excluded.push((name, Exclusion::Rejected(e))),
        }
    }
    if reports.is_empty() {
        return Err(InputError::NoFlightPasses(excluded.iter().map(|(_, e)| e.to_string()).collect()));
    }
    Ok(Each { reports, series: kept, excluded })
}

//! Rerun recording of a run (`.rrd`, rerun 0.36.3): what a person needs to see why a vehicle
//! circled, how the calibration converged and where packets were lost.
//!
//! The recording is built after the run from the engine's trace, column by column
//! (`send_columns`), into memory, and written by the CLI atomically (temporary file + rename).
//! Columns give one chunk per entity and stream, so identical runs produce identical recordings
//! (`rerun rrd compare`), and logging costs a few milliseconds instead of slowing the loop.
//!
//! Timelines: `sim_time` (s, from the integer clock) and `tick` (physics ticks, 1 kHz). There is
//! no wall-clock timeline (`log_time` is disabled). The recording id is
//! `flyarena/<scenario>/seed-<seed>`: the same run always has the same id.
//!
//! Decimation: the 200 Hz trace is recorded every `every`-th Vicon frame (default 4, i.e. 50 Hz,
//! the PPM frame rate, so every radio frame appears); the RLS estimate is recorded sample by sample.
//!
//! Entities (`<v>` = vehicle name; frames: `world` is the mocap's NED frame, x North, y East,
//! z Down, which the viewer is told with `ViewCoordinates::FRD`):
//!
//! | entity | what |
//! |---|---|
//! | `world/arena` | the Flying Machine Arena, 10 m × 10 m × 10 m above the floor |
//! | `world/<v>/true_body` | true pose (Transform3D); `axes`: x_b, y_b, z_b (red, green, blue, 0.3 m) |
//! | `world/<v>/true_body/markers` | the markers where they are really mounted (body frame) |
//! | `world/<v>/mocap_body` | the pose the Vicon reports (Transform3D); `axes`: x_m, y_m, z_m (orange, 0.45 m) |
//! | `world/<v>/mocap_body/template` | the stored template, placed by the mocap's fit |
//! | `world/<v>/reference_path`, `flown_path`, `uncompensated_path` | reference, flown track, and the same flight without compensation (the circle of Fig. 6) |
//! | `plots/<v>/attitude/{roll,pitch,yaw}/{true,measured,compensated}` | degrees |
//! | `plots/<v>/position/{deviation_m,uncompensated_deviation_m}` | horizontal distance from the reference |
//! | `plots/<v>/ppm/{p,q,r,thrust}` | the channels as sent, 0..255 (attitude mode: `ppm/{roll,pitch,yaw_rate,thrust}`, φ_com, θ_com, ψ̇_com) |
//! | `plots/<v>/link/{missing_frames,longest_gap_ms}`, `plots/<v>/telemetry/missing_frames` | link monitoring |
//! | `plots/<v>/calibration/{roll,pitch}_hover_deg`, `{roll,pitch,yaw}_truth_deg`, `yaw_rls_deg`, `yaw_ls_deg`, `yaw_gyro_deg` | the running hover average, the RLS yaw sample by sample, the batch LS and gyro results, and the truth |
//! | `events` | phase changes, calibration results, link gaps, requirement results (TextLog) |

use crate::clock::Nanos;
use crate::engine::{RunOutput, TraceSample, VehicleRun};
use crate::frames::{Frame, Vec3};
use crate::requirements::Report;
use rerun::blueprint::{Blueprint, Horizontal, Spatial3DView, Tabs, TextLogView, TimeSeriesView, Vertical};
use rerun::log::TimeColumn;

/// Recording options.
#[derive(Clone, Copy, Debug)]
pub struct RecordOptions {
    /// Record every `every`-th Vicon frame (≥ 1).
    pub every: usize,
}

impl Default for RecordOptions {
    fn default() -> Self {
        RecordOptions { every: 4 }
    }
}

/// Why a recording could not be written.
#[derive(Debug, thiserror::Error)]
pub enum RecordError {
    /// The Rerun SDK failed.
    #[error("rerun: {0}")]
    Rerun(String),
}

fn err(e: impl std::fmt::Display) -> RecordError {
    RecordError::Rerun(e.to_string())
}

/// The recording id of a run: a pure function of scenario name and seed.
pub fn recording_id(scenario: &str, seed: u64) -> String {
    format!("flyarena/{scenario}/seed-{seed}")
}

const PHYSICS_TICK_NS: i64 = 1_000_000;

struct Columns {
    secs: Vec<f64>,
    ticks: Vec<i64>,
}

impl Columns {
    fn of(times: impl Iterator<Item = Nanos>) -> Self {
        let (mut secs, mut ticks) = (Vec::new(), Vec::new());
        for t in times {
            secs.push(t.as_secs_f64());
            ticks.push(t.0 / PHYSICS_TICK_NS);
        }
        Columns { secs, ticks }
    }
    fn time(&self) -> [TimeColumn; 2] {
        [
            TimeColumn::new_duration_secs("sim_time", self.secs.iter().copied()),
            TimeColumn::new_sequence("tick", self.ticks.iter().copied()),
        ]
    }
}

fn f32x3<F: Frame>(v: Vec3<F>) -> [f32; 3] {
    v.to_array().map(|x| x as f32)
}

fn quat(q: &nalgebra::UnitQuaternion<f64>) -> rerun::Quaternion {
    rerun::Quaternion::from_xyzw([q.i as f32, q.j as f32, q.k as f32, q.w as f32])
}

struct Rec<'a> {
    rec: &'a rerun::RecordingStream,
}

impl Rec<'_> {
    fn series(
        &self,
        path: &str,
        name: &str,
        color: [u8; 3],
        cols: &Columns,
        values: Vec<f64>,
    ) -> Result<(), RecordError> {
        self.rec
            .log_static(
                path,
                &rerun::SeriesLines::new()
                    .with_names([name])
                    .with_colors([rerun::Color::from_rgb(color[0], color[1], color[2])]),
            )
            .map_err(err)?;
        self.rec
            .send_columns(path, cols.time(), rerun::Scalars::new(values).columns_of_unit_batches().map_err(err)?)
            .map_err(err)
    }

    /// A series with gaps (samples where `values[i]` is `None` are left out).
    fn sparse_series(
        &self,
        path: &str,
        name: &str,
        color: [u8; 3],
        samples: &[&TraceSample],
        values: impl Fn(&TraceSample) -> Option<f64>,
    ) -> Result<(), RecordError> {
        let kept: Vec<(Nanos, f64)> = samples.iter().filter_map(|s| values(s).map(|v| (s.t, v))).collect();
        let cols = Columns::of(kept.iter().map(|x| x.0));
        self.series(path, name, color, &cols, kept.into_iter().map(|x| x.1).collect())
    }

    fn event(&self, t: Nanos, level: &str, text: String) -> Result<(), RecordError> {
        let cols = Columns::of(std::iter::once(t));
        self.rec
            .send_columns(
                "events",
                cols.time(),
                rerun::TextLog::update_fields()
                    .with_many_text([text])
                    .with_many_level([level])
                    .columns_of_unit_batches()
                    .map_err(err)?,
            )
            .map_err(err)
    }
}

const TRUE_COLOR: [u8; 3] = [80, 200, 120];
const MEASURED_COLOR: [u8; 3] = [255, 150, 40];
const COMPENSATED_COLOR: [u8; 3] = [90, 160, 255];
const REFERENCE_COLOR: [u8; 3] = [170, 170, 170];
const UNCOMPENSATED_COLOR: [u8; 3] = [230, 60, 60];

fn rgb(c: [u8; 3]) -> rerun::Color {
    rerun::Color::from_rgb(c[0], c[1], c[2])
}

/// Encodes the recording of a run into `.rrd` bytes.
pub fn encode(
    main: &RunOutput,
    uncompensated: Option<&RunOutput>,
    report: &Report,
    opts: RecordOptions,
) -> Result<Vec<u8>, RecordError> {
    let (rec, storage) = rerun::RecordingStreamBuilder::new("flyarena")
        .recording_id(recording_id(&main.scenario, main.seed))
        // no RecordingInfo: its default start time is the wall clock, which would make identical
        // runs differ; the name alone is sent below
        .send_properties(false)
        .memory()
        .map_err(err)?;
    rec.set_log_time_enabled(false);
    let mut plot_paths = Vec::new();
    let bp = blueprint(&main.vehicles.iter().map(|v| v.name.as_str()).collect::<Vec<_>>(), &mut plot_paths);
    send_blueprint(&rec, bp, &plot_paths, main.duration)?;
    rec.send_recording_name(format!("{} (seed {})", main.scenario, main.seed)).map_err(err)?;
    let r = Rec { rec: &rec };
    rec.log_static("world", &rerun::ViewCoordinates::FRD()).map_err(err)?;
    rec.log_static(
        "world/arena",
        &rerun::Boxes3D::from_centers_and_half_sizes([(0.0, 0.0, -5.0)], [(5.0, 5.0, 5.0)])
            .with_colors([rerun::Color::from_unmultiplied_rgba(120, 120, 120, 60)]),
    )
    .map_err(err)?;
    for (i, v) in main.vehicles.iter().enumerate() {
        let unc = uncompensated.and_then(|u| u.vehicles.get(i));
        vehicle(&r, v, unc, opts)?;
    }
    // requirement results at the end of the run
    for row in &report.rows {
        let level = if row.pass { "INFO" } else { "ERROR" };
        r.event(
            main.duration,
            level,
            format!(
                "{} {} {}: {} (limit {}) {}",
                row.vehicle,
                row.id,
                row.what,
                row.measured,
                row.limit,
                if row.pass { "pass" } else { "FAIL" }
            ),
        )?;
    }
    rec.flush_blocking().map_err(err)?;
    let bytes = storage.drain_as_bytes().map_err(err)?;
    drop(rec);
    Ok(bytes)
}

/// Sends the layout. The Rust blueprint API of 0.36 has no setter for a plot's time range, and
/// the viewer's default shows ±30 s around the time cursor; so the blueprint is rendered into
/// messages here, and each plot gets a `TimeAxis` property (the whole run) in the same
/// blueprint store, before the activation command.
fn send_blueprint(
    rec: &rerun::RecordingStream,
    bp: Blueprint,
    plot_paths: &[String],
    end: Nanos,
) -> Result<(), RecordError> {
    use rerun::blueprint::components::TimeRange;
    use rerun::external::re_log_types::LogMsg;
    let (tmp, tmp_storage) = rerun::RecordingStreamBuilder::new("flyarena").memory().map_err(err)?;
    bp.send(&tmp, rerun::blueprint::BlueprintActivation::default()).map_err(err)?;
    tmp.flush_blocking().map_err(err)?;
    let mut msgs = tmp_storage.take();
    let at = msgs
        .iter()
        .position(|m| matches!(m, LogMsg::BlueprintActivationCommand(_)))
        .ok_or_else(|| err("blueprint without activation"))?;
    let LogMsg::BlueprintActivationCommand(cmd) = msgs.remove(at) else { unreachable!("matched above") };
    msgs.retain(|m| *m.store_id() == cmd.blueprint_id);
    let (extra, extra_storage) = rerun::RecordingStreamBuilder::new("flyarena")
        .recording_id(cmd.blueprint_id.recording_id().clone())
        .blueprint()
        .memory()
        .map_err(err)?;
    extra.set_time_sequence("blueprint", 0);
    use rerun::datatypes::TimeRangeBoundary::Absolute;
    let whole = TimeRange(rerun::datatypes::TimeRange { start: Absolute(0.into()), end: Absolute(end.0.into()) });
    for path in plot_paths {
        let axis = rerun::external::re_sdk_types::blueprint::archetypes::TimeAxis::new().with_view_range(whole);
        extra.log(format!("{path}/TimeAxis"), &axis).map_err(err)?;
    }
    extra.flush_blocking().map_err(err)?;
    msgs.extend(extra_storage.take().into_iter().filter(|m| matches!(m, LogMsg::ArrowMsg(..))));
    rec.send_blueprint(msgs, cmd);
    Ok(())
}

/// The layout: 3D (flight, arena, per-vehicle close-up) and events on the left, plots on the right.
fn blueprint(vehicles: &[&str], plot_paths: &mut Vec<String>) -> Blueprint {
    use rerun::blueprint::{BlueprintPanel, ContainerLike, SelectionPanel, TimePanel};
    let mut plots = |name: &str, what: &[&str]| {
        let queries: Vec<String> =
            vehicles.iter().flat_map(|v| what.iter().map(move |w| format!("+ /plots/{v}/{w}/**"))).collect();
        let view = ContainerLike::from(TimeSeriesView::new(name).with_origin("/plots").with_contents(queries));
        if let ContainerLike::View(v) = &view {
            plot_paths.push(v.blueprint_path().to_string());
        }
        view
    };
    // the close-up sits in the true body frame: the mocap's axes and template show the offset
    let closeups: Vec<ContainerLike> = vehicles
        .iter()
        .map(|v| {
            Spatial3DView::new(format!("{v}: true body (short axes) vs mocap body (long axes)"))
                .with_origin(format!("/world/{v}/true_body"))
                .with_contents([format!("+ /world/{v}/true_body/**"), format!("+ /world/{v}/mocap_body/**")])
                .into()
        })
        .collect();
    Blueprint::new(Horizontal::new([
        Vertical::new([
            Horizontal::new([
                Tabs::new([
                    Spatial3DView::new("flight (NED: x North, y East, z Down)")
                        .with_origin("/world")
                        .with_contents(["+ /world/**", "- /world/arena"])
                        .into(),
                    Spatial3DView::new("arena 10 × 10 × 10 m").with_origin("/world").into(),
                ])
                .into(),
                Tabs::new(closeups).into(),
            ])
            .into(),
            TextLogView::new("events").with_origin("/events").into(),
        ])
        .with_row_shares([0.68, 0.32])
        .into(),
        Vertical::new([
            plots("roll and pitch (°): true · measured (mocap) · compensated", &["attitude/roll", "attitude/pitch"]),
            plots("horizontal distance from the reference (m): compensated · uncompensated", &["position"]),
            Tabs::new([
                plots("calibration estimates as they converge, and the truth (°)", &["calibration"]),
                plots("yaw (°)", &["attitude/yaw"]),
                plots("PPM commands as sent (0..255)", &["ppm"]),
                plots("link: missing frames, longest gap (ms)", &["link"]),
            ])
            .into(),
        ])
        .into(),
    ]))
    .with_time_panel(TimePanel::new().with_timeline("sim_time"))
    .with_blueprint_panel(BlueprintPanel::new().with_state(rerun::blueprint::components::PanelState::Collapsed))
    .with_selection_panel(SelectionPanel::new().with_state(rerun::blueprint::components::PanelState::Collapsed))
}

/// One vehicle's recording: the 3D scene, the time plots, the calibration and the events, in
/// that order (the order the stream is written in).
fn vehicle(r: &Rec, v: &VehicleRun, unc: Option<&VehicleRun>, opts: RecordOptions) -> Result<(), RecordError> {
    let samples: Vec<&TraceSample> = v.trace.iter().step_by(opts.every.max(1)).collect();
    let cols = Columns::of(samples.iter().map(|s| s.t));
    scene(r, v, unc, &samples, &cols)?;
    time_plots(r, v, unc, opts, &samples, &cols)?;
    calibration(r, v)?;
    events(r, v)
}

/// The 3D scene: the true and the measured body frames side by side, the markers, the paths.
fn scene(
    r: &Rec,
    v: &VehicleRun,
    unc: Option<&VehicleRun>,
    samples: &[&TraceSample],
    cols: &Columns,
) -> Result<(), RecordError> {
    let rec = r.rec;
    let n = &v.name;

    // 3D: true and measured body frames side by side
    axes(rec, &format!("world/{n}/true_body/axes"), 0.3, [[230, 50, 50], [50, 200, 50], [60, 90, 240]], "b")?;
    rec.send_columns(
        format!("world/{n}/true_body"),
        cols.time(),
        rerun::Transform3D::update_fields()
            .with_many_translation(samples.iter().map(|s| f32x3(s.pos)))
            .with_many_quaternion(samples.iter().map(|s| quat(s.att_true_rot.quaternion())))
            .columns_of_unit_batches()
            .map_err(err)?,
    )
    .map_err(err)?;
    let labels: Vec<String> = (0..v.markers.mounted.len()).map(|k| format!("m{k}")).collect();
    rec.log_static(
        format!("world/{n}/true_body/markers"),
        &rerun::Points3D::new(v.markers.mounted.iter().map(|m| f32x3(*m)))
            .with_radii([0.006])
            .with_colors([rgb(TRUE_COLOR)])
            .with_labels(labels),
    )
    .map_err(err)?;
    let measured: Vec<&&TraceSample> =
        samples.iter().filter(|s| s.pos_measured.is_some() && s.att_measured.is_some()).collect();
    let mcols = Columns::of(measured.iter().map(|s| s.t));
    axes(rec, &format!("world/{n}/mocap_body/axes"), 0.45, [[255, 150, 40]; 3], "m")?;
    rec.send_columns(
        format!("world/{n}/mocap_body"),
        mcols.time(),
        rerun::Transform3D::update_fields()
            .with_many_translation(measured.iter().filter_map(|s| s.pos_measured.map(f32x3)))
            .with_many_quaternion(measured.iter().filter_map(|s| s.att_measured.map(|a| quat(a.quaternion()))))
            .columns_of_unit_batches()
            .map_err(err)?,
    )
    .map_err(err)?;
    rec.log_static(
        format!("world/{n}/mocap_body/template"),
        &rerun::Points3D::new(v.markers.template.iter().map(|m| f32x3(*m)))
            .with_radii([0.012])
            .with_colors([rerun::Color::from_unmultiplied_rgba(255, 150, 40, 110)]),
    )
    .map_err(err)?;
    let path = |name: &str, pts: Vec<[f32; 3]>, color: [u8; 3]| {
        rec.log_static(
            format!("world/{n}/{name}"),
            &rerun::LineStrips3D::new([pts]).with_colors([rgb(color)]).with_radii([0.008]),
        )
        .map_err(err)
    };
    path("reference_path", v.trace.iter().map(|s| f32x3(s.reference)).collect(), REFERENCE_COLOR)?;
    path("flown_path", v.trace.iter().map(|s| f32x3(s.pos)).collect(), TRUE_COLOR)?;
    if let Some(u) = unc.filter(|u| !u.trace.is_empty()) {
        path("uncompensated_path", u.trace.iter().map(|s| f32x3(s.pos)).collect(), UNCOMPENSATED_COLOR)?;
    }
    Ok(())
}

/// Attitude (true, measured, compensated), the distance from the reference, the PPM channels and
/// the link's health over time.
fn time_plots(
    r: &Rec,
    v: &VehicleRun,
    unc: Option<&VehicleRun>,
    opts: RecordOptions,
    samples: &[&TraceSample],
    cols: &Columns,
) -> Result<(), RecordError> {
    let n = &v.name;
    // attitude: true, measured (raw mocap), compensated (what the controller used)
    for (axis, get) in [("roll", 0usize), ("pitch", 1), ("yaw", 2)] {
        let pick = |e: crate::frames::Euler| [e.roll, e.pitch, e.yaw][get].to_degrees();
        // pitch in darker shades of the same three colours
        let shade = |c: [u8; 3]| if get == 1 { c.map(|x| (x as f32 * 0.6) as u8) } else { c };
        let base = format!("plots/{n}/attitude/{axis}");
        r.series(
            &format!("{base}/true"),
            &format!("{n} {axis} true"),
            shade(TRUE_COLOR),
            cols,
            samples.iter().map(|s| pick(s.att_true)).collect(),
        )?;
        r.sparse_series(
            &format!("{base}/measured"),
            &format!("{n} {axis} measured"),
            shade(MEASURED_COLOR),
            samples,
            |s| s.att_measured.map(|a| pick(a.euler())),
        )?;
        r.sparse_series(
            &format!("{base}/compensated"),
            &format!("{n} {axis} compensated"),
            shade(COMPENSATED_COLOR),
            samples,
            |s| s.att_compensated.map(pick),
        )?;
    }

    // distance from the reference (the circling of Fig. 6), with and without compensation
    let dev = |s: &TraceSample| (s.pos - s.reference.assume_same_as::<crate::frames::Nav>()).horizontal_norm();
    r.series(
        &format!("plots/{n}/position/deviation_m"),
        &format!("{n} compensated"),
        TRUE_COLOR,
        cols,
        samples.iter().map(|s| dev(s)).collect(),
    )?;
    if let Some(u) = unc.filter(|u| !u.trace.is_empty()) {
        let us: Vec<&TraceSample> = u.trace.iter().step_by(opts.every.max(1)).collect();
        let ucols = Columns::of(us.iter().map(|s| s.t));
        r.series(
            &format!("plots/{n}/position/uncompensated_deviation_m"),
            &format!("{n} uncompensated"),
            UNCOMPENSATED_COLOR,
            &ucols,
            us.iter().map(|s| dev(s)).collect(),
        )?;
    }

    // PPM channels as sent, named by what they carry in the vehicle's onboard mode
    let names = match v.params.onboard_mode {
        crate::vehicle::OnboardMode::Rate => ["p", "q", "r", "thrust"],
        crate::vehicle::OnboardMode::Attitude => ["roll", "pitch", "yaw_rate", "thrust"],
    };
    for (k, ch) in names.iter().enumerate() {
        let color = [[230, 90, 90], [90, 200, 90], [90, 120, 230], [200, 200, 200]][k];
        r.sparse_series(&format!("plots/{n}/ppm/{ch}"), &format!("{n} {ch}"), color, samples, |s| {
            s.ppm.map(|f| f.channels[k] as f64)
        })?;
    }

    // link monitoring
    r.series(
        &format!("plots/{n}/link/missing_frames"),
        &format!("{n} mocap frames missing"),
        MEASURED_COLOR,
        cols,
        samples.iter().map(|s| s.link.missing_frames as f64).collect(),
    )?;
    r.series(
        &format!("plots/{n}/link/longest_gap_ms"),
        &format!("{n} longest gap (ms)"),
        UNCOMPENSATED_COLOR,
        cols,
        samples.iter().map(|s| s.link.longest_gap_ns as f64 * 1e-6).collect(),
    )?;
    Ok(())
}

/// The calibration: RLS sample by sample, the batch LS result, the hover average, the gyro
/// estimate and the truth.
fn calibration(r: &Rec, v: &VehicleRun) -> Result<(), RecordError> {
    let n = &v.name;
    let cal = &v.calibration;
    if !v.rls_trace.is_empty() {
        let rc = Columns::of(v.rls_trace.iter().map(|s| s.t));
        // the same quantity as the report's yaw offset: previous estimate + held yaw + fit
        let shift = cal.yaw_offset.zip(cal.yaw_ls).map_or(0.0, |(y, ls)| y - ls.psi_offset);
        r.series(
            &format!("plots/{n}/calibration/yaw_rls_deg"),
            &format!("{n} yaw RLS"),
            COMPENSATED_COLOR,
            &rc,
            v.rls_trace.iter().map(|s| (s.psi_offset + shift).to_degrees()).collect(),
        )?;
        if let Some(y) = cal.yaw_offset {
            let ends = [v.rls_trace[0].t, v.rls_trace[v.rls_trace.len() - 1].t];
            r.series(
                &format!("plots/{n}/calibration/yaw_ls_deg"),
                &format!("{n} yaw batch LS"),
                MEASURED_COLOR,
                &Columns::of(ends.into_iter()),
                vec![y.to_degrees(); 2],
            )?;
        }
    }
    let end = v.trace.last().map_or(Nanos::ZERO, |s| s.t);
    let whole = Columns::of([Nanos::ZERO, end].into_iter());
    if !v.hover_trace.is_empty() {
        // the hover average converging onto the roll and pitch offsets
        let hc = Columns::of(v.hover_trace.iter().map(|s| s.t));
        r.series(
            &format!("plots/{n}/calibration/roll_hover_deg"),
            &format!("{n} roll hover average"),
            [230, 120, 60],
            &hc,
            v.hover_trace.iter().map(|s| s.roll.to_degrees()).collect(),
        )?;
        r.series(
            &format!("plots/{n}/calibration/pitch_hover_deg"),
            &format!("{n} pitch hover average"),
            [150, 80, 40],
            &hc,
            v.hover_trace.iter().map(|s| s.pitch.to_degrees()).collect(),
        )?;
        r.series(
            &format!("plots/{n}/calibration/roll_truth_deg"),
            &format!("{n} roll truth"),
            [60, 170, 90],
            &whole,
            vec![v.truth.euler.roll.to_degrees(); 2],
        )?;
        r.series(
            &format!("plots/{n}/calibration/pitch_truth_deg"),
            &format!("{n} pitch truth"),
            [40, 110, 60],
            &whole,
            vec![v.truth.euler.pitch.to_degrees(); 2],
        )?;
    }
    r.series(
        &format!("plots/{n}/calibration/yaw_truth_deg"),
        &format!("{n} yaw truth"),
        TRUE_COLOR,
        &whole,
        vec![v.truth.euler.yaw.to_degrees(); 2],
    )?;
    if let Some(g) = cal.gyro {
        let at = phase_end(v, "calibrate_gyro").unwrap_or(end);
        r.series(
            &format!("plots/{n}/calibration/yaw_gyro_deg"),
            &format!("{n} yaw gyro"),
            [200, 90, 220],
            &Columns::of([at, end].into_iter()),
            vec![g.euler.yaw.to_degrees(); 2],
        )?;
    }
    Ok(())
}

/// The events: phases, calibration results, link gaps.
fn events(r: &Rec, v: &VehicleRun) -> Result<(), RecordError> {
    let n = &v.name;
    let cal = &v.calibration;
    for (t, name) in &v.phases {
        r.event(*t, "INFO", format!("{n}: phase {name}"))?;
    }
    if let (Some((roll, pitch, k)), Some(t)) = (cal.roll_pitch, phase_end(v, "calibrate_roll_pitch")) {
        r.event(
            t,
            "INFO",
            format!(
                "{n}: hover average over {k} frames: roll offset {:.4}°, pitch offset {:.4}° (truth {:.4}°, {:.4}°)",
                roll.to_degrees(),
                pitch.to_degrees(),
                v.truth.euler.roll.to_degrees(),
                v.truth.euler.pitch.to_degrees()
            ),
        )?;
    }
    if let Some(t) = phase_end(v, "calibrate_yaw") {
        if let Some(val) = cal.validity {
            let level = if val.accepted { "INFO" } else { "WARN" };
            r.event(
                t,
                level,
                format!(
                    "{n}: validity (7) {}: mean yaw {:.3}°, mean roll {:.3}°",
                    if val.accepted { "accepted" } else { "rejected" },
                    val.mean_yaw.to_degrees(),
                    val.mean_roll.to_degrees()
                ),
            )?;
        }
        if let Some(y) = cal.yaw_offset {
            r.event(
                t,
                "INFO",
                format!(
                    "{n}: straight-flight yaw offset {:.3}° (truth {:.3}°)",
                    y.to_degrees(),
                    v.truth.euler.yaw.to_degrees()
                ),
            )?;
        }
    }
    if let (Some(g), Some(t)) = (cal.gyro, phase_end(v, "calibrate_gyro")) {
        let e = g.euler.to_degrees();
        r.event(
            t,
            "INFO",
            format!(
                "{n}: gyro alignment over {} windows: roll {:.3}°, pitch {:.3}°, yaw {}° (1σ; truth yaw {:.3}°)",
                g.windows,
                e[0],
                e[1],
                crate::identify::precision::with_interval(e[2], g.sigma[2].to_degrees()),
                v.truth.euler.yaw.to_degrees()
            ),
        )?;
    }
    let mut longest = 0;
    for s in &v.trace {
        if s.link.longest_missing_run > longest {
            longest = s.link.longest_missing_run;
            if longest >= 3 {
                r.event(
                    s.t,
                    "WARN",
                    format!(
                        "{n}: link gap, {longest} consecutive mocap frames missing ({} missing so far)",
                        s.link.missing_frames
                    ),
                )?;
            }
        }
    }
    Ok(())
}

/// Three labelled axis arrows (x, y, z of a frame) of length `len` (m).
fn axes(
    rec: &rerun::RecordingStream,
    path: &str,
    len: f32,
    colors: [[u8; 3]; 3],
    suffix: &str,
) -> Result<(), RecordError> {
    let arrows = rerun::Arrows3D::from_vectors([[len, 0.0, 0.0], [0.0, len, 0.0], [0.0, 0.0, len]])
        .with_colors(colors.map(rgb))
        .with_radii([0.004])
        .with_labels([format!("x_{suffix}"), format!("y_{suffix}"), format!("z_{suffix}")]);
    rec.log_static(path, &arrows).map_err(err)
}

/// When the named phase ended (the start of the next one, or the end of the trace).
fn phase_end(v: &VehicleRun, name: &str) -> Option<Nanos> {
    let i = v.phases.iter().position(|(_, p)| *p == name)?;
    v.phases.get(i + 1).map(|x| x.0).or(v.trace.last().map(|s| s.t))
}

/// The data recording of an `.rrd` file, decoded (for tests and tools).
pub struct Decoded {
    /// The recording's id, if it has one.
    pub recording_id: Option<String>,
    /// Its chunks.
    pub chunks: Vec<rerun::log::Chunk>,
}

impl Decoded {
    /// Every chunk of one entity path (e.g. `/plots/x3d/attitude/roll/true`).
    pub fn entity(&self, path: &str) -> Vec<&rerun::log::Chunk> {
        self.chunks.iter().filter(|c| c.entity_path().to_string() == path).collect()
    }

    /// The (sim_time ns, value) pairs of a Scalars entity, in time order.
    pub fn scalars(&self, path: &str) -> Vec<(i64, f64)> {
        let id = rerun::Scalars::descriptor_scalars().component;
        let mut out = Vec::new();
        for c in self.entity(path) {
            let Some(times) = c.timelines().get(&rerun::TimelineName::from("sim_time")) else { continue };
            for (t, v) in times.times_raw().iter().zip(c.iter_slices::<f64>(id)) {
                out.extend(v.iter().map(|x| (*t, *x)));
            }
        }
        out.sort_by_key(|x| x.0);
        out
    }
}

/// Decodes `.rrd` bytes: the recording id and the chunks of the data recording.
pub fn decode(bytes: &[u8]) -> Result<Decoded, RecordError> {
    use rerun::external::re_log_encoding::DecoderApp;
    let mut out = Decoded { recording_id: None, chunks: Vec::new() };
    for msg in DecoderApp::decode_lazy(std::io::BufReader::new(bytes)) {
        let msg = msg.map_err(err)?;
        if let rerun::log::LogMsg::ArrowMsg(store, arrow) = &msg
            && store.kind() == rerun::StoreKind::Recording
        {
            out.recording_id.get_or_insert_with(|| store.recording_id().to_string());
            out.chunks.push(rerun::log::Chunk::from_arrow_msg(arrow).map_err(err)?);
        }
    }
    Ok(out)
}

/// Encodes the residuals of an identification into `.rrd` bytes: per channel axis the residual
/// of the nominal model and of the model with the effects found, on the timeline `sim_time`
/// (seconds from the log's first sample, also for a real flight's log), and the steps and
/// effects as text events.
///
/// | entity | what |
/// |---|---|
/// | `identify/<channel>/<axis>/nominal`, `…/with_effects` | residual (m/s² or rad/s) |
/// | `events` | one line per step and per effect found |
pub fn encode_identify(
    name: &str,
    report: &crate::identify::Report,
    residuals: &[crate::identify::residual::ResidualSeries],
) -> Result<Vec<u8>, RecordError> {
    use rerun::blueprint::{BlueprintPanel, ContainerLike, SelectionPanel, TimePanel};
    let (rec, storage) = rerun::RecordingStreamBuilder::new("flyarena")
        .recording_id(format!("flyarena/identify/{name}"))
        .send_properties(false)
        .memory()
        .map_err(err)?;
    rec.set_log_time_enabled(false);
    let end = residuals.iter().filter_map(|r| r.t_s.last()).fold(0.0f64, |a, b| a.max(*b));
    let mut plot_paths = Vec::new();
    let mut views: Vec<ContainerLike> = Vec::new();
    for ch in crate::effects::Channel::ALL {
        if residuals.iter().any(|r| r.channel == ch) {
            let view = ContainerLike::from(
                TimeSeriesView::new(format!("{} residual ({}): nominal · with the effects", ch.name(), ch.unit()))
                    .with_origin(format!("/identify/{}", ch.name())),
            );
            if let ContainerLike::View(v) = &view {
                plot_paths.push(v.blueprint_path().to_string());
            }
            views.push(view);
        }
    }
    let bp = Blueprint::new(
        Horizontal::new([
            Vertical::new(views).into(),
            TextLogView::new("steps and effects").with_origin("/events").into(),
        ])
        .with_column_shares([0.72, 0.28]),
    )
    .with_time_panel(TimePanel::new().with_timeline("sim_time"))
    .with_blueprint_panel(BlueprintPanel::new().with_state(rerun::blueprint::components::PanelState::Collapsed))
    .with_selection_panel(SelectionPanel::new().with_state(rerun::blueprint::components::PanelState::Collapsed));
    send_blueprint(&rec, bp, &plot_paths, Nanos::from_secs_f64(end))?;
    rec.send_recording_name(format!("identify: {name}")).map_err(err)?;
    let r = Rec { rec: &rec };
    let axis_color = |a: char| match a {
        'x' => [230, 80, 80],
        'y' => [80, 190, 90],
        _ => [80, 130, 240],
    };
    let faded = |c: [u8; 3]| c.map(|x| (x as u16 * 2 / 5 + 150) as u8);
    for rs in residuals {
        let cols = Columns::of(rs.t_s.iter().map(|t| Nanos::from_secs_f64(*t)));
        let base = format!("identify/{}/{}", rs.channel.name(), rs.axis);
        r.series(
            &format!("{base}/nominal"),
            &format!("{} nominal", rs.axis),
            faded(axis_color(rs.axis)),
            &cols,
            rs.before.clone(),
        )?;
        r.series(
            &format!("{base}/with_effects"),
            &format!("{} with effects", rs.axis),
            axis_color(rs.axis),
            &cols,
            rs.after.clone(),
        )?;
    }
    let at = Nanos::from_secs_f64(end);
    for (k, st) in report.steps.iter().enumerate() {
        r.event(
            at,
            "INFO",
            format!(
                "step {}: + {} (ΔBIC {:.0}, p {:.1e}, held-out −{:.1} %)",
                k + 1,
                st.added.name(),
                st.delta_bic,
                st.p_value,
                100.0 * st.heldout_gain
            ),
        )?;
    }
    for f in &report.effects {
        let ps: Vec<String> = f
            .params
            .iter()
            .map(|p| format!("{} {} {}", p.name, crate::identify::precision::with_interval(p.value, p.ci95), p.unit))
            .collect();
        r.event(at, "INFO", format!("{}: {}", f.name, ps.join(", ")))?;
    }
    if report.effects.is_empty() {
        r.event(at, "INFO", "no effect passes the tests".into())?;
    }
    rec.flush_blocking().map_err(err)?;
    let bytes = storage.drain_as_bytes().map_err(err)?;
    drop(rec);
    Ok(bytes)
}

//! Column mappings: how to read another tool's flight log as identification data.
//!
//! A mapping is a small YAML file naming which column holds which quantity, in which unit and
//! frame. The reader converts everything to flyarena's conventions: SI units, radians, a z-down
//! world and an FRD body. A z-up world or an FLU body is turned by π about its x axis
//! (x kept, y and z negated): ENU becomes East-South-Down, which is as good as NED here because
//! nothing in `identify` depends on where North is.
//!
//! ```yaml
//! vehicle: crazyflie21            # preset: mass, rotor radius, thrust map of the motor commands
//! time: { column: t, unit: s }    # s | ms | us | ns
//! position: { columns: [px, py, pz], unit: m }            # m | mm
//! attitude: { columns: [qx, qy, qz, qw], order: xyzw }    # quaternion body → world; xyzw | wxyz
//!   # or: attitude: { euler: [roll, pitch, yaw], unit: deg }  # Z-Y-X Euler angles; rad | deg
//! world: z_up                     # the world's up axis: z_up | z_down | y_up | y_down | x_up | x_down
//! body: flu                       # flu | frd
//! gyro: { columns: [gx, gy, gz], unit: rad/s }           # rad/s | deg/s
//! accel: { columns: [ax, ay, az], unit: g }              # g | m/s2
//! motors: { columns: [m1, m2, m3, m4] }                  # optional: PWM 0..65535 → thrust map
//! battery: { column: vbat }                              # optional, volts
//! mass_kg: 0.034                                          # optional: overrides the preset
//! smoothing_ms: 50                                        # optional: σ of the smoothing (default 20)
//! ```
//!
//! Two streams on clocks of their own are read by two more forms, and joined onto the IMU's
//! clock once the global start has found how the clocks stand ([`crate::identify::fit::start`]):
//!
//! ```yaml
//! # an ASL (EuRoC, TUM-VI) folder: `identify SEQUENCE/ --mapping …` (SEQUENCE/mav0/imu0/data.csv …)
//! vehicle: rigid_body
//! asl: { imu: imu0, poses: vicon0 }   # the stream folders under mav0/ (poses: mocap0 for TUM-VI)
//! world: z_up                         # default z_up; body: as the IMU's axes are (default frd)
//!
//! # an IMU CSV beside a pose file: `identify IMU.csv --poses POSES.txt --mapping …`
//! vehicle: rigid_body
//! time: { column: t, unit: s }
//! gyro: { columns: [gx, gy, gz], unit: rad/s }
//! accel: { columns: [ax, ay, az], unit: m/s2 }
//! poses: { format: tum }              # tum (t x y z qx qy qz qw) | asl; order: xyzw | wxyz; unit: m | mm
//! world: z_up
//! body: flu
//! ```
//!
//! Rows whose pose cells are empty or NaN count as frames in which the vehicle was not seen;
//! any other empty or non-numeric cell is an error naming its line and column. Timestamps must
//! increase; a repeated timestamp is dropped and a gap longer than 3 × the median interval
//! splits the log into segments, both reported.

use super::error::InputError;
use super::joined::Stream;
use super::read_note::ReadNote;
use super::series::{NominalModel, Series};
use super::streams::{WXYZ, XYZW};
use crate::frames::{Rot, Vec3};
use crate::log::Repair;
use crate::vehicle::params::{CRAZYFLIE21_ROTOR_RADIUS_M, GRAVITY, PwmThrustMap, VehicleParams};
use nalgebra::{Quaternion, UnitQuaternion, Vector3};
use std::path::Path;

/// How another tool's log maps onto identify's data: which column holds what, in which unit
/// and frames (the YAML format of `mappings/*.yaml`, see the module doc).
#[derive(Debug, Clone, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Mapping {
    /// The nominal model the effects are added to.
    pub vehicle: VehiclePreset,
    /// The time column (unit `s`, `ms`, `us` or `ns`; seconds by default).
    pub time: Column,
    /// The mocap position (`m` or `mm`).
    pub position: Columns3,
    /// The mocap attitude.
    pub attitude: AttitudeCols,
    /// The log's world frame.
    pub world: WorldUp,
    /// The log's body axes.
    pub body: BodyAxes,
    /// The gyro (`rad/s` or `deg/s`).
    pub gyro: Columns3,
    /// The accelerometer (`m/s2` or `g`).
    pub accel: Columns3,
    /// The motor commands (PWM), for the force channel (`crazyflie21` only).
    #[serde(default)]
    pub motors: Option<Motors>,
    /// The battery voltage (V).
    #[serde(default)]
    pub battery: Option<Column>,
    /// The mass, when not the preset's (kg).
    #[serde(default)]
    pub mass_kg: Option<f64>,
    /// σ of the smoothing kernel for this data (ms; default 20). Small vehicles with close
    /// markers have noisy mocap attitudes and need more.
    #[serde(default)]
    pub smoothing_ms: Option<f64>,
    /// The topics of a ROS 2 bag (MCAP); `None` for a CSV log.
    #[serde(skip)]
    pub ros2: Option<super::ros2::Topics>,
    /// The topics of a PX4 log (ULog); `None` for a CSV log.
    #[serde(skip)]
    pub px4: Option<super::ulog::Topics>,
    /// The stream folders of an ASL (EuRoC) folder; `None` otherwise.
    #[serde(skip)]
    pub asl: Option<Asl>,
    /// The IMU columns and the pose file of an IMU log beside a pose file; `None` otherwise.
    #[serde(skip)]
    pub split: Option<Split>,
    /// The file the mapping was read from, for errors that name it (`""` when built in code).
    #[serde(skip)]
    pub file: String,
}

/// The streams of an ASL (EuRoC, TUM-VI) folder: `mav0/<imu>/data.csv` and `mav0/<poses>/data.csv`.
#[derive(Debug, Clone, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Asl {
    /// The IMU's folder under `mav0/` (default `imu0`).
    #[serde(default = "imu0")]
    pub imu: String,
    /// The pose stream's folder under `mav0/` (default `vicon0`; `mocap0` in TUM-VI, or
    /// `state_groundtruth_estimate0`).
    #[serde(default = "vicon0")]
    pub poses: String,
    /// The pose quaternion's order (the format's is w, x, y, z).
    #[serde(default)]
    pub order: Option<QuatOrder>,
}

fn imu0() -> String {
    "imu0".into()
}

fn vicon0() -> String {
    "vicon0".into()
}

/// A pose file's format.
#[derive(Debug, serde::Deserialize, Clone, Copy, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum PoseFormat {
    /// `t x y z qx qy qz qw`, whitespace-separated, t in seconds (TUM RGB-D, `evo`).
    Tum,
    /// `timestamp [ns], p_x, p_y, p_z, q_w, q_x, q_y, q_z`, comma-separated (ASL, EuRoC).
    Asl,
}

/// The pose file beside an IMU log (`identify IMU.csv --poses FILE`).
#[derive(Debug, Clone, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PoseFile {
    /// Its format.
    pub format: PoseFormat,
    /// The quaternion's order, when not the format's (TUM: x, y, z, w; ASL: w, x, y, z).
    #[serde(default)]
    pub order: Option<QuatOrder>,
    /// The position's unit (`m` or `mm`; default m).
    #[serde(default)]
    pub unit: Option<String>,
}

/// An IMU log beside a pose file: the IMU CSV's own columns, and the pose file's format.
#[derive(Debug, Clone)]
pub struct Split {
    /// The IMU CSV's time column.
    pub time: Column,
    /// Its gyro columns.
    pub gyro: Columns3,
    /// Its accelerometer columns.
    pub accel: Columns3,
    /// The pose file's format.
    pub poses: PoseFile,
}

/// A mapping for an ASL folder (see [`Asl`]).
#[derive(Debug, Clone, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct AslFile {
    vehicle: VehiclePreset,
    asl: Asl,
    #[serde(default = "z_up")]
    world: WorldUp,
    #[serde(default = "frd")]
    body: BodyAxes,
    #[serde(default)]
    mass_kg: Option<f64>,
    #[serde(default)]
    smoothing_ms: Option<f64>,
}

/// A mapping for an IMU CSV beside a pose file (see [`Split`]).
#[derive(Debug, Clone, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct SplitFile {
    vehicle: VehiclePreset,
    time: Column,
    gyro: Columns3,
    accel: Columns3,
    poses: PoseFile,
    world: WorldUp,
    body: BodyAxes,
    #[serde(default)]
    mass_kg: Option<f64>,
    #[serde(default)]
    smoothing_ms: Option<f64>,
}

impl AslFile {
    /// The CSV mapping of the rows the two streams are joined into.
    fn into_mapping(self) -> Mapping {
        Mapping {
            asl: Some(self.asl),
            ..joined_mapping(self.vehicle, self.world, self.body, false, false, self.mass_kg, self.smoothing_ms)
        }
    }
}

impl SplitFile {
    /// The CSV mapping of the rows the two streams are joined into, with the IMU CSV's own
    /// columns kept to read it.
    fn into_mapping(self) -> Mapping {
        Mapping {
            split: Some(Split { time: self.time, gyro: self.gyro, accel: self.accel, poses: self.poses }),
            ..joined_mapping(self.vehicle, self.world, self.body, false, false, self.mass_kg, self.smoothing_ms)
        }
    }
}

/// A mapping for ROS 2 bags: topics instead of columns (see [`super::ros2`]).
#[derive(Debug, Clone, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct Ros2File {
    vehicle: VehiclePreset,
    ros2: super::ros2::Topics,
    #[serde(default = "z_up")]
    world: WorldUp,
    #[serde(default = "flu")]
    body: BodyAxes,
    #[serde(default)]
    mass_kg: Option<f64>,
    #[serde(default)]
    smoothing_ms: Option<f64>,
}

/// A mapping for PX4 logs: topics instead of columns, PX4's frames (see [`super::ulog`]).
#[derive(Debug, Clone, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct Px4File {
    vehicle: VehiclePreset,
    px4: super::ulog::Topics,
    #[serde(default)]
    mass_kg: Option<f64>,
    #[serde(default)]
    smoothing_ms: Option<f64>,
}

impl Px4File {
    /// The CSV mapping of the rows [`super::ulog::to_csv`] writes: a z-down world, an FRD body.
    fn into_mapping(self) -> Mapping {
        let (motors, battery) = (self.px4.motors.is_some(), self.px4.battery.is_some());
        Mapping {
            px4: Some(self.px4),
            ..joined_mapping(
                self.vehicle,
                WorldUp::ZDown,
                BodyAxes::Frd,
                motors,
                battery,
                self.mass_kg,
                self.smoothing_ms,
            )
        }
    }
}

/// The CSV mapping of the rows a bag or a PX4 log is joined into (`identify/input/joined.rs`):
/// SI units, an x, y, z, w quaternion, the given frames. The motor columns are named when the
/// log is read (their count is the messages').
fn joined_mapping(
    vehicle: VehiclePreset,
    world: WorldUp,
    body: BodyAxes,
    motors: bool,
    battery: bool,
    mass_kg: Option<f64>,
    smoothing_ms: Option<f64>,
) -> Mapping {
    let s = |x: &str| x.to_string();
    let three = |a: &str, b: &str, c: &str, unit: &str| Columns3 { columns: [s(a), s(b), s(c)], unit: s(unit) };
    Mapping {
        vehicle,
        time: Column { column: s("t"), unit: Some(s("s")) },
        position: three("px", "py", "pz", "m"),
        attitude: AttitudeCols {
            columns: Some([s("qx"), s("qy"), s("qz"), s("qw")]),
            order: Some(QuatOrder::Xyzw),
            euler: None,
            unit: None,
        },
        world,
        body,
        gyro: three("gx", "gy", "gz", "rad/s"),
        accel: three("ax", "ay", "az", "m/s2"),
        motors: motors.then(|| Motors { columns: Vec::new() }),
        battery: battery.then(|| Column { column: s("vbat"), unit: None }),
        file: String::new(),
        mass_kg,
        smoothing_ms,
        ros2: None,
        px4: None,
        asl: None,
        split: None,
    }
}

fn z_up() -> WorldUp {
    WorldUp::ZUp
}

fn frd() -> BodyAxes {
    BodyAxes::Frd
}

fn flu() -> BodyAxes {
    BodyAxes::Flu
}

impl Ros2File {
    /// The CSV mapping of the rows [`super::ros2::to_csv`] writes.
    fn into_mapping(self) -> Mapping {
        let (motors, battery) = (self.ros2.motors.is_some(), self.ros2.battery.is_some());
        Mapping {
            ros2: Some(self.ros2),
            ..joined_mapping(self.vehicle, self.world, self.body, motors, battery, self.mass_kg, self.smoothing_ms)
        }
    }
}

/// The vehicle's nominal model.
#[derive(Debug, serde::Deserialize, Clone, Copy, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum VehiclePreset {
    /// Bitcraze Crazyflie 2.1, with its PWM thrust map.
    Crazyflie21,
    /// AscTec X3D (no PWM map).
    X3d,
    /// A rigid body that is not a vehicle: a hand-held sensor rig, a tool on a robot arm, a
    /// ground robot. No force model (motor columns are an error), no floor (no sample is left
    /// out for its height), and an IMU read as ±16 g and ±2000 °/s
    /// ([`ImuRange::wide_mems`](crate::vehicle::params::ImuRange::wide_mems)).
    RigidBody,
}

impl VehiclePreset {
    /// The preset's name in a mapping file.
    pub fn name(self) -> &'static str {
        match self {
            VehiclePreset::Crazyflie21 => "crazyflie21",
            VehiclePreset::X3d => "x3d",
            VehiclePreset::RigidBody => "rigid_body",
        }
    }
}

/// One column of the log.
#[derive(Debug, Clone, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Column {
    /// The header's name of the column.
    pub column: String,
    /// Its unit, where the field has a choice.
    #[serde(default)]
    pub unit: Option<String>,
}

/// Three columns of one vector, and their unit.
#[derive(Debug, Clone, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Columns3 {
    /// The header's names of x, y, z.
    pub columns: [String; 3],
    /// Their unit.
    pub unit: String,
}

/// The attitude, body → world in the log's own frames: a quaternion (`columns` and `order`), or
/// Z-Y-X Euler angles (`euler: [roll, pitch, yaw]` and `unit`: R = R_z(yaw)·R_y(pitch)·R_x(roll)).
#[derive(Debug, Clone, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AttitudeCols {
    /// The quaternion's four columns, in `order`.
    #[serde(default)]
    pub columns: Option<[String; 4]>,
    /// The quaternion's component order.
    #[serde(default)]
    pub order: Option<QuatOrder>,
    /// The Euler angles' columns: roll, pitch, yaw.
    #[serde(default)]
    pub euler: Option<[String; 3]>,
    /// The Euler angles' unit (`rad` or `deg`).
    #[serde(default)]
    pub unit: Option<String>,
}

/// A quaternion's component order in the log.
#[derive(Debug, serde::Deserialize, Clone, Copy)]
#[serde(rename_all = "snake_case")]
pub enum QuatOrder {
    /// Vector part first (ROS, Eigen's storage).
    Xyzw,
    /// Scalar part first.
    Wxyz,
}

impl QuatOrder {
    /// Where x, y, z and w sit among the four cells.
    fn cells(self) -> super::streams::QuatCells {
        match self {
            QuatOrder::Xyzw => XYZW,
            QuatOrder::Wxyz => WXYZ,
        }
    }
}

/// The log's world frame: which of its axes points up (against gravity). The reader turns it so
/// that up is −z (NED-like; where north points does not matter to `identify`): a half-turn about
/// x for z up, a quarter-turn about x for y up or down, about y for x up or down. The global
/// start finds the world's tilt whatever it is, so a wrong axis here shows as a tilt of 90° or
/// 180° in its report rather than as a wrong calibration.
#[derive(Debug, serde::Deserialize, Clone, Copy, PartialEq)]
#[serde(rename_all = "snake_case")]
pub enum WorldUp {
    /// z up (ENU-like: Vicon, Qualisys, ROS): turned to NED by a half turn about x.
    ZUp,
    /// z down (NED): taken as it is.
    ZDown,
    /// y up (OptiTrack Motive's default, many graphics tools): (x, y, z) → (x, z, −y).
    YUp,
    /// y down: (x, y, z) → (x, −z, y).
    YDown,
    /// x up: (x, y, z) → (z, y, −x).
    XUp,
    /// x down: (x, y, z) → (−z, y, x).
    XDown,
}

impl WorldUp {
    /// The rotation that turns the log's world into the z-down one the readers give: it takes
    /// the log's up axis to −z.
    pub fn to_z_down(self) -> UnitQuaternion<f64> {
        let q = std::f64::consts::FRAC_PI_2;
        match self {
            WorldUp::ZDown => UnitQuaternion::identity(),
            WorldUp::ZUp => UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI),
            WorldUp::YUp => UnitQuaternion::from_axis_angle(&Vector3::x_axis(), -q),
            WorldUp::YDown => UnitQuaternion::from_axis_angle(&Vector3::x_axis(), q),
            WorldUp::XUp => UnitQuaternion::from_axis_angle(&Vector3::y_axis(), q),
            WorldUp::XDown => UnitQuaternion::from_axis_angle(&Vector3::y_axis(), -q),
        }
    }
}

/// The log's body axes.
#[derive(Debug, serde::Deserialize, Clone, Copy, PartialEq)]
#[serde(rename_all = "snake_case")]
pub enum BodyAxes {
    /// Forward, left, up (ROS): turned to FRD by a half turn about x.
    Flu,
    /// Forward, right, down: taken as they are.
    Frd,
}

/// The motor command columns.
#[derive(Debug, Clone, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Motors {
    /// One column per motor.
    pub columns: Vec<String>,
}

fn unit_factor(file: &str, what: &str, unit: &str, allowed: &[(&str, f64)]) -> Result<f64, InputError> {
    allowed.iter().find(|(u, _)| *u == unit).map(|x| x.1).ok_or_else(|| {
        InputError::invalid(
            file,
            format!(
                "{what}: unit `{unit}` is not one of {}",
                allowed.iter().map(|(u, _)| format!("`{u}`")).collect::<Vec<_>>().join(", ")
            ),
        )
    })
}

/// The SI factors of a mapping's units (time, position, gyro, accelerometer, Euler angles).
/// The header's index of each column the mapping names.
struct ColumnIndex {
    time: usize,
    pos: Vec<usize>,
    /// Four quaternion or three Euler columns.
    att: Vec<usize>,
    gyro: Vec<usize>,
    accel: Vec<usize>,
    motors: Vec<usize>,
    battery: Option<usize>,
}

struct Factors {
    time: f64,
    pos: f64,
    gyro: f64,
    acc: f64,
    euler: Option<f64>,
}

/// A cell's value when it is a finite number.
fn finite(cell: &str) -> Option<f64> {
    cell.trim().parse::<f64>().ok().filter(|x| x.is_finite())
}

/// A mapped log's pose cell (`column` of line `lineno`): a finite number, or a dropout (`None`:
/// empty or `NaN`); anything else is corrupted, an error naming line and column.
fn pose_cell(cell: &str, column: &str, file: &str, lineno: usize) -> Result<Option<f64>, InputError> {
    let c = cell.trim();
    if c.is_empty() || c.eq_ignore_ascii_case("nan") {
        return Ok(None);
    }
    finite(c).map(Some).ok_or_else(|| InputError::Row {
        file: file.to_string(),
        line: lineno,
        column: Some(column.to_string()),
        message: format!("`{c}` is neither a finite number nor a dropout (an empty cell or NaN)"),
    })
}

/// The column names of a header line (trimmed), or the error of an empty log.
fn header_names<'a>(line: Option<&'a str>, file: &str) -> Result<Vec<&'a str>, InputError> {
    let header = line.filter(|h| !h.trim().is_empty()).ok_or_else(|| InputError::log(file, "the log is empty"))?;
    Ok(header.split(',').map(str::trim).collect())
}

/// The error of a log with fewer than two rows left: saying so, and how many rows repeated the
/// time of the row before (a log whose clock stood still).
fn too_few_rows(file: &str, repairs: &[ReadNote]) -> InputError {
    let repeats = repairs.iter().filter(|r| matches!(r, ReadNote::Rows(Repair::RepeatedTime { .. }))).count();
    if repeats > 0 {
        InputError::log(
            file,
            format!("fewer than two rows with distinct times ({repeats} rows repeat the time of the row before)"),
        )
    } else {
        InputError::log(file, "fewer than two rows")
    }
}

/// The header's index of column `name`, which the mapping (`mapping`, its file) names in
/// `field`; a name the header lacks is an error that names the mapping's file and field and
/// suggests the closest header name the mapping does not already read (`taken`).
fn find_column(header: &[&str], name: &str, file: &str, at: (&str, &str), taken: &[&str]) -> Result<usize, InputError> {
    let (mapping, field) = at;
    header.iter().position(|h| *h == name).ok_or_else(|| {
        let close = crate::scenario::error::closest(name, header.iter().copied().filter(|h| !taken.contains(h)), 3);
        InputError::row(
            file,
            1,
            format!(
                "the header has no column `{name}`, which {mapping} names in `{field}`{}",
                close.map_or(String::new(), |c| format!(" (is it `{c}`?)"))
            ),
        )
    })
}

impl Split {
    /// The IMU CSV's time unit in nanoseconds, and its gyro and accelerometer factors to SI.
    fn factors(&self, file: &str) -> Result<(i128, f64, f64), InputError> {
        let deg = std::f64::consts::PI / 180.0;
        let time = self.time.unit.as_deref().unwrap_or("s");
        let unit_ns = [("s", 1_000_000_000), ("ms", 1_000_000), ("us", 1_000), ("ns", 1)]
            .into_iter()
            .find(|(u, _)| *u == time)
            .map(|x| x.1)
            .ok_or_else(|| {
                InputError::invalid(file, format!("time: unit `{time}` is not one of `s`, `ms`, `us`, `ns`"))
            })?;
        let gyro = unit_factor(file, "gyro", &self.gyro.unit, &[("rad/s", 1.0), ("deg/s", deg)])?;
        let acc = unit_factor(file, "accel", &self.accel.unit, &[("m/s2", 1.0), ("m/s²", 1.0), ("g", GRAVITY)])?;
        if let Some(u) = &self.poses.unit {
            unit_factor(file, "poses", u, &[("m", 1.0), ("mm", 1e-3)])?;
        }
        Ok((unit_ns, gyro, acc))
    }

    /// The IMU CSV at `path` as the stream the join takes: stamps in integer nanoseconds, gyro
    /// and accelerometer in SI units, in the log's own axes.
    /// `mapping` names the mapping's file in errors.
    fn read_imu(&self, path: &Path, mapping: &str) -> Result<Stream<6>, InputError> {
        let file = path.display().to_string();
        let (unit_ns, gyro_f, acc_f) = self.factors(mapping)?;
        let text = std::fs::read_to_string(path).map_err(|e| InputError::io(&file, e))?;
        let text = text.strip_prefix('\u{feff}').unwrap_or(&text);
        let mut lines = text.lines();
        let header = header_names(lines.next(), &file)?;
        let taken: Vec<&str> = std::iter::once(&self.time.column)
            .chain(&self.gyro.columns)
            .chain(&self.accel.columns)
            .map(String::as_str)
            .collect();
        let find = |name: &str, field: String| find_column(&header, name, &file, (mapping, &field), &taken);
        let ti = find(&self.time.column, "time.column".into())?;
        let many = |cols: &[String], key: &str| {
            cols.iter().enumerate().map(|(i, c)| find(c, format!("{key}.columns[{i}]"))).collect::<Result<Vec<_>, _>>()
        };
        let (gi, ai) = (many(&self.gyro.columns, "gyro")?, many(&self.accel.columns, "accel")?);
        let mut out = Stream::new();
        for (k, line) in lines.enumerate() {
            let lineno = k + 2;
            if line.trim().is_empty() {
                continue;
            }
            let cells: Vec<&str> = line.split(',').collect();
            let cell = |i: usize| -> Result<&str, InputError> {
                cells.get(i).copied().ok_or_else(|| {
                    InputError::row(&file, lineno, format!("{} cells, the header has {}", cells.len(), header.len()))
                })
            };
            let bad = |i: usize, what: &str| InputError::Row {
                file: file.clone(),
                line: lineno,
                column: Some(header[i].to_string()),
                message: format!("`{}` is not {what}", cells.get(i).map_or("", |c| c.trim())),
            };
            let t = super::streams::decimal_ns(cell(ti)?, unit_ns).ok_or_else(|| bad(ti, "a time"))?;
            let mut v = [0.0; 6];
            for (j, &i) in gi.iter().chain(&ai).enumerate() {
                let f = if j < 3 { gyro_f } else { acc_f };
                v[j] = finite(cell(i)?).ok_or_else(|| bad(i, "a finite number"))? * f;
            }
            match out.t.last() {
                Some(last) if *last > t => {
                    return Err(InputError::row(&file, lineno, "time goes backwards".to_string()));
                }
                // a repeated stamp: the first sample is kept
                Some(last) if *last == t => continue,
                _ => {}
            }
            out.push(t, v).map_err(|m| InputError::row(&file, lineno, m.to_string()))?;
        }
        if out.t.len() < 2 {
            return Err(InputError::log(&file, "fewer than two IMU samples"));
        }
        Ok(out)
    }
}

/// The `mav0/` folder of an ASL sequence given as the sequence's folder or as `mav0/` itself.
fn asl_root(input: &Path, asl: &Asl) -> Result<std::path::PathBuf, InputError> {
    let has = |p: &Path| p.join(&asl.imu).join("data.csv").is_file();
    if has(&input.join("mav0")) {
        return Ok(input.join("mav0"));
    }
    if has(input) {
        return Ok(input.to_path_buf());
    }
    Err(InputError::log(
        input.display(),
        format!(
            "not an ASL (EuRoC) folder: neither {} nor {} exists",
            input.join("mav0").join(&asl.imu).join("data.csv").display(),
            input.join(&asl.imu).join("data.csv").display()
        ),
    ))
}

/// A column mapping's "unknown field" message with the keys that make a mapping of another form
/// (`ros2:`, `px4:`, `asl:`, `poses:`) in its list of what is allowed, then a "did you mean".
fn with_blocks(message: &str) -> String {
    if !(message.starts_with("unknown field `") && message.contains("expected one of")) {
        return crate::scenario::error::with_suggestion(message);
    }
    // the suggestion is drawn from the keys alone, not from the words around them
    let keys = format!("{message}, ros2, px4, asl, poses");
    let suggested = crate::scenario::error::with_suggestion(&keys);
    let tail = suggested.strip_prefix(keys.as_str()).unwrap_or("");
    format!("{message}, or a block ros2, px4, asl or poses{tail}")
}

impl Mapping {
    /// The mapping reads two streams on clocks of their own (an ASL folder, or an IMU log beside
    /// a pose file): [`crate::identify::run`] joins them once their clocks are found.
    pub fn two_streams(&self) -> bool {
        self.asl.is_some() || self.split.is_some()
    }

    /// The two streams of an ASL folder `input`, or of the IMU log `input` beside the pose file
    /// `poses`, each on its own clock, in the logs' own axes and SI units.
    ///
    /// # Errors
    /// A file that cannot be read or a value that is not a number (the file, line and column); a
    /// pose file missing for an IMU log; a mapping that reads one file.
    pub(in crate::identify) fn read_streams(
        &self,
        input: &Path,
        poses: Option<&Path>,
    ) -> Result<super::joined::Streams, InputError> {
        let pos_factor = |unit: &Option<String>| if unit.as_deref() == Some("mm") { 1e-3 } else { 1.0 };
        let (imu, pose) = match (&self.asl, &self.split) {
            (Some(asl), _) => {
                let root = asl_root(input, asl)?;
                let pose_path = poses.map_or_else(|| root.join(&asl.poses).join("data.csv"), Path::to_path_buf);
                let imu = super::streams::read_asl_imu(&root.join(&asl.imu).join("data.csv"))?;
                (imu, super::streams::read_asl_poses(&pose_path, asl.order.map_or(WXYZ, QuatOrder::cells), 1.0)?)
            }
            (None, Some(sp)) => {
                let pose_path = poses.ok_or_else(|| {
                    InputError::invalid(
                        input.display(),
                        "this mapping reads the poses from a file of their own (`poses:`): give it with --poses FILE",
                    )
                })?;
                let imu = sp.read_imu(input, self.mapping_name())?;
                let f = pos_factor(&sp.poses.unit);
                let pose = match sp.poses.format {
                    PoseFormat::Tum => {
                        super::streams::read_tum(pose_path, sp.poses.order.map_or(XYZW, QuatOrder::cells), f)?
                    }
                    PoseFormat::Asl => {
                        super::streams::read_asl_poses(pose_path, sp.poses.order.map_or(WXYZ, QuatOrder::cells), f)?
                    }
                };
                (imu, pose)
            }
            (None, None) => {
                return Err(InputError::invalid(
                    input.display(),
                    "this mapping reads one log; two streams need an `asl:` or a `poses:` block",
                ));
            }
        };
        Ok(super::joined::Streams { pose, imu, motors: Stream::new(), n_motors: None, battery: Stream::new() })
    }

    /// The two streams joined onto the IMU's clock with the poses the mocap stamped
    /// `shift_ns` later than each IMU row (see [`super::joined::Streams::join_shifted`]), read
    /// as a series whose [`Clocks`](super::series::Clocks) say where its zero lies and what the
    /// join shifted; `file` names it.
    pub(in crate::identify) fn read_joined_streams(
        &self,
        streams: &super::joined::Streams,
        shift_ns: i128,
        file: &str,
    ) -> Result<Series, InputError> {
        let (text, repairs) = streams.join_shifted(shift_ns);
        let mut s = self.read_joined(&text, repairs, file)?;
        s.clocks.imu_origin_ns = streams.imu.t[0];
        s.clocks.pose_shift_s = shift_ns as f64 * 1e-9;
        Ok(s)
    }

    /// Reads and checks a mapping file.
    pub fn load(path: &Path) -> Result<Mapping, InputError> {
        let src = std::fs::read_to_string(path).map_err(|e| InputError::io(path.display(), e))?;
        Self::parse(&src, path)
    }

    /// Parses and checks a mapping (`path` names it in errors): unknown keys, the attitude's
    /// form, units, ranges.
    pub fn parse(src: &str, path: &Path) -> Result<Mapping, InputError> {
        let file = path.display().to_string();
        let located = |e: serde_saphyr::Error, suggest: &dyn Fn(&str) -> String| {
            InputError::Yaml(crate::scenario::error::from_yaml(src, path, &e, suggest))
        };
        let err = |e| located(e, &crate::scenario::error::with_suggestion);
        // a `ros2:` block makes it a mapping of topics, not columns
        let keys: std::collections::BTreeMap<String, serde::de::IgnoredAny> =
            serde_saphyr::from_str(src).map_err(err)?;
        let m: Mapping = if keys.contains_key("ros2") {
            serde_saphyr::from_str::<Ros2File>(src).map_err(err)?.into_mapping()
        } else if keys.contains_key("px4") {
            serde_saphyr::from_str::<Px4File>(src).map_err(err)?.into_mapping()
        } else if keys.contains_key("asl") {
            serde_saphyr::from_str::<AslFile>(src).map_err(err)?.into_mapping()
        } else if keys.contains_key("poses") {
            serde_saphyr::from_str::<SplitFile>(src).map_err(err)?.into_mapping()
        } else {
            // a column mapping's keys, and the blocks that make a mapping of another form
            serde_saphyr::from_str(src).map_err(|e| located(e, &|m| with_blocks(m)))?
        };
        let m = Mapping { file: file.clone(), ..m };
        if let Some(mass) = m.mass_kg
            && !(mass > 0.0 && mass < 100.0)
        {
            return Err(InputError::invalid(&file, format!("mass_kg {mass} is outside the allowed range (0, 100) kg")));
        }
        let a = &m.attitude;
        match (&a.columns, &a.order, &a.euler, &a.unit) {
            (Some(_), Some(_), None, None) | (None, None, Some(_), Some(_)) => {}
            _ => {
                return Err(InputError::invalid(
                    &file,
                    "attitude: give either a quaternion `{columns: [4 names], order: xyzw or wxyz}` or Z-Y-X Euler angles `{euler: [roll, pitch, yaw], unit: rad or deg}`",
                ));
            }
        }
        if let Some(sm) = m.smoothing_ms
            && !(2.0..=500.0).contains(&sm)
        {
            return Err(InputError::invalid(
                &file,
                format!("smoothing_ms {sm} is outside the allowed range [2, 500] ms"),
            ));
        }
        if let Some(mo) = &m.motors
            && mo.columns.is_empty()
            && m.ros2.is_none()
            && m.px4.is_none()
        {
            return Err(InputError::invalid(&file, "motors.columns is empty; give one column per motor"));
        }
        if m.motors.is_some() && m.vehicle == VehiclePreset::X3d {
            return Err(InputError::invalid(
                &file,
                "the `x3d` preset has no PWM thrust map; motors need `vehicle: crazyflie21`",
            ));
        }
        if m.motors.is_some() && m.vehicle == VehiclePreset::RigidBody {
            return Err(InputError::invalid(
                &file,
                "`vehicle: rigid_body` declares no force model; motors need `vehicle: crazyflie21`",
            ));
        }
        m.factors(&file)?;
        if let Some(sp) = &m.split {
            sp.factors(&file)?;
        }
        Ok(m)
    }

    fn factors(&self, file: &str) -> Result<Factors, InputError> {
        let deg = std::f64::consts::PI / 180.0;
        Ok(Factors {
            time: unit_factor(
                file,
                "time",
                self.time.unit.as_deref().unwrap_or("s"),
                &[("s", 1.0), ("ms", 1e-3), ("us", 1e-6), ("ns", 1e-9)],
            )?,
            pos: unit_factor(file, "position", &self.position.unit, &[("m", 1.0), ("mm", 1e-3)])?,
            gyro: unit_factor(file, "gyro", &self.gyro.unit, &[("rad/s", 1.0), ("deg/s", deg)])?,
            acc: unit_factor(file, "accel", &self.accel.unit, &[("m/s2", 1.0), ("m/s²", 1.0), ("g", GRAVITY)])?,
            euler: self
                .attitude
                .unit
                .as_deref()
                .map(|u| unit_factor(file, "attitude", u, &[("rad", 1.0), ("deg", deg)]))
                .transpose()?,
        })
    }

    /// Reads a CSV log, with a `ros2:` mapping a ROS 2 bag (MCAP), or with a `px4:` mapping a
    /// PX4 log (ULog), through the mapping.
    pub fn read(&self, path: &Path) -> Result<Series, InputError> {
        let file = path.display().to_string();
        if self.two_streams() {
            return Err(InputError::invalid(
                &file,
                "this mapping reads two streams on clocks of their own; `flyarena::identify::run` joins them",
            ));
        }
        let bytes = std::fs::read(path).map_err(|e| InputError::io(&file, e))?;
        self.read_bytes(&bytes, &file)
    }

    /// Reads the bytes of a log named `file` (see [`Mapping::read`]): a CSV, or a bag or a PX4
    /// log as the mapping's `ros2:` or `px4:` block says.
    pub fn read_bytes(&self, bytes: &[u8], file: &str) -> Result<Series, InputError> {
        if let Some(topics) = &self.px4 {
            let (text, repairs) = super::ulog::to_csv(bytes, topics, file, self.mapping_name())?;
            return self.read_joined(&text, repairs, file);
        }
        match &self.ros2 {
            Some(topics) => {
                let (text, repairs) = super::ros2::to_csv(bytes, topics, file)?;
                self.read_joined(&text, repairs, file)
            }
            None if bytes.starts_with(super::ros2::MAGIC) => Err(InputError::log(
                file,
                "an MCAP file needs a mapping with a `ros2:` block of topics (see mappings/ros2-crazyflie.yaml)",
            )),
            None if bytes.starts_with(super::ulog::MAGIC) => Err(InputError::log(
                file,
                "a PX4 log (ULog) needs a mapping with a `px4:` block of topics (see mappings/px4.yaml)",
            )),
            None => {
                let text =
                    std::str::from_utf8(bytes).map_err(|e| InputError::log(file, format!("not UTF-8 text ({e})")))?;
                self.read_str(text, file)
            }
        }
    }

    /// Reads the rows a bag or a PX4 log was joined into (`identify/input/joined.rs`): the motor columns
    /// are named by the header, and the route's repairs come first.
    fn read_joined(&self, text: &str, repairs: Vec<ReadNote>, file: &str) -> Result<Series, InputError> {
        let header = text.lines().next().unwrap_or("");
        let motors = self.motors.as_ref().map(|_| Motors {
            columns: header.split(',').filter(|c| c.starts_with('m')).map(str::to_string).collect(),
        });
        let m = Mapping { motors, ..self.clone() };
        let mut s = m.read_str(text, file)?;
        s.repairs.splice(0..0, repairs);
        Ok(s)
    }

    /// The header's index of every column the mapping names; a name the header lacks is an
    /// error that suggests the closest header name.
    fn column_index(&self, header: &[&str], file: &str) -> Result<ColumnIndex, InputError> {
        let (att_names, att_key): (&[String], &str) = match (&self.attitude.columns, &self.attitude.euler) {
            (Some(q), _) => (q, "attitude.columns"),
            (None, Some(e)) => (e, "attitude.euler"),
            (None, None) => return Err(InputError::invalid(self.mapping_name(), "it has no attitude columns")),
        };
        let motors: &[String] = self.motors.as_ref().map_or(&[], |m| &m.columns);
        let taken: Vec<&str> = [&self.position.columns[..], att_names, &self.gyro.columns, &self.accel.columns, motors]
            .into_iter()
            .flatten()
            .chain([&self.time.column])
            .chain(self.battery.as_ref().map(|b| &b.column))
            .map(String::as_str)
            .collect();
        let find = |name: &str, field: &str| find_column(header, name, file, (self.mapping_name(), field), &taken);
        let many = |cols: &[String], key: &str| {
            cols.iter().enumerate().map(|(i, c)| find(c, &format!("{key}[{i}]"))).collect::<Result<Vec<usize>, _>>()
        };
        Ok(ColumnIndex {
            time: find(&self.time.column, "time.column")?,
            pos: many(&self.position.columns, "position.columns")?,
            att: many(att_names, att_key)?,
            gyro: many(&self.gyro.columns, "gyro.columns")?,
            accel: many(&self.accel.columns, "accel.columns")?,
            motors: many(motors, "motors.columns")?,
            battery: self.battery.as_ref().map(|b| find(&b.column, "battery.column")).transpose()?,
        })
    }

    /// The mapping's file, or "the mapping" for one built in code.
    fn mapping_name(&self) -> &str {
        if self.file.is_empty() { "the mapping" } else { &self.file }
    }

    /// An empty series with the nominal model of the mapping's vehicle preset, and the preset's
    /// PWM thrust map (none for the x3d preset, which then cannot take motor columns).
    fn empty_series(&self, file: &str, cols: &ColumnIndex) -> Result<(Series, Option<PwmThrustMap>), InputError> {
        let (params, map) = match self.vehicle {
            VehiclePreset::Crazyflie21 => (VehicleParams::crazyflie21(), Some(PwmThrustMap::crazyflie21())),
            VehiclePreset::X3d | VehiclePreset::RigidBody => (VehicleParams::x3d(), None),
        };
        if !cols.motors.is_empty() && map.is_none() {
            return Err(InputError::invalid(
                self.mapping_name(),
                format!(
                    "the `{}` preset has no PWM thrust map; motors need `vehicle: crazyflie21`",
                    self.vehicle.name()
                ),
            ));
        }
        let rigid_body = self.vehicle == VehiclePreset::RigidBody;
        let s = Series {
            source: file.to_string(),
            t_s: Vec::new(),
            pos_mocap_nav: Vec::new(),
            att_mocap: Vec::new(),
            mocap_ok: Vec::new(),
            gyro_body: Vec::new(),
            accel_body: Vec::new(),
            thrust_n: (!cols.motors.is_empty()).then(Vec::new),
            vbat_v: cols.battery.map(|_| Vec::new()),
            segments: Vec::new(),
            model: NominalModel {
                vehicle: if rigid_body {
                    "a rigid body (no vehicle)".to_string()
                } else {
                    format!("{} preset", self.vehicle.name())
                },
                mass_kg: if rigid_body { 0.0 } else { self.mass_kg.unwrap_or(params.mass_kg) },
                rotor_drag_per_s: params.rotor_drag_per_s,
                rotor_radius_m: match self.vehicle {
                    VehiclePreset::Crazyflie21 => CRAZYFLIE21_ROTOR_RADIUS_M,
                    VehiclePreset::X3d => super::flyarena_log::X3D_ROTOR_RADIUS_M,
                    VehiclePreset::RigidBody => 0.0,
                },
                vbat_ref_v: map.map_or(0.0, |m| m.vbat_ref_v),
                gravity_m_s2: GRAVITY,
                // the PWM map's own error is a thrust scale, which identify fits
                thrust_rel_sd: 0.0,
                imu_range: if rigid_body { crate::vehicle::params::ImuRange::wide_mems() } else { params.imu_range },
                rigid_body,
            },
            repairs: Vec::new(),
            clocks: Default::default(),
        };
        Ok((s, map))
    }

    /// One row's pose cells (position, then the quaternion or Euler angles, in the mapping's
    /// units and axes) as the mocap position (m, NED) and attitude (FRD body to NED). A
    /// quaternion whose norm is off 1 by more than 1 % is an error (a wrong `order`, most likely).
    fn pose(
        &self,
        p: &[f64],
        euler_f: Option<f64>,
        pos_f: f64,
        file: &str,
        lineno: usize,
    ) -> Result<(Vector3<f64>, UnitQuaternion<f64>), InputError> {
        let flip = |v: Vector3<f64>| Vector3::new(v.x, -v.y, -v.z);
        let q_flip = UnitQuaternion::from_quaternion(Quaternion::new(0.0, 1.0, 0.0, 0.0));
        let mut pos = Vector3::new(p[0], p[1], p[2]) * pos_f;
        let mut q = match (self.attitude.order, euler_f) {
            (Some(order), _) => {
                let (w, x, y, z) = match order {
                    QuatOrder::Xyzw => (p[6], p[3], p[4], p[5]),
                    QuatOrder::Wxyz => (p[3], p[4], p[5], p[6]),
                };
                let norm = (w * w + x * x + y * y + z * z).sqrt();
                if (norm - 1.0).abs() > 0.01 {
                    return Err(InputError::row(
                        file,
                        lineno,
                        format!("the attitude quaternion has norm {norm:.4}, not 1: check the mapping's `order`"),
                    ));
                }
                UnitQuaternion::from_quaternion(Quaternion::new(w, x, y, z))
            }
            (None, Some(f)) => UnitQuaternion::from_euler_angles(p[3] * f, p[4] * f, p[5] * f),
            (None, None) => unreachable!("checked when the mapping was parsed"),
        };
        match self.world {
            WorldUp::ZDown => {}
            // the half-turn about x, written out (x kept, y and z negated)
            WorldUp::ZUp => {
                pos = flip(pos);
                q = q_flip * q;
            }
            other => {
                let w = other.to_z_down();
                pos = w * pos;
                q = w * q;
            }
        }
        if self.body == BodyAxes::Flu {
            q *= q_flip;
        }
        Ok((pos, q))
    }

    /// Reads a CSV log's text (`file` names it in errors and the report) through the mapping.
    ///
    /// A pose cell that is empty or `NaN` is a mocap dropout (the row's pose was not seen); any
    /// other cell that is not a finite number is an error, as is a row with more or fewer cells
    /// than the header (empty cells after the last column, a trailing comma, are allowed). A
    /// last line cut short without its newline (a log whose writer stopped) is dropped and
    /// reported among the repairs, and a UTF-8 byte-order mark before the header is skipped.
    pub fn read_str(&self, text: &str, file: &str) -> Result<Series, InputError> {
        let Factors { time: time_f, pos: pos_f, gyro: gyro_f, acc: acc_f, euler: euler_f } =
            self.factors(self.mapping_name())?;
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        let all: Vec<&str> = text.lines().collect();
        let last_data = all.iter().rposition(|l| !l.trim().is_empty());
        let cut_at_end = !text.ends_with('\n');
        let mut lines = all.iter().copied();
        let header = header_names(lines.next(), file)?;
        let cols = self.column_index(&header, file)?;
        let ColumnIndex { time: ti, pos: pi, att: qi, gyro: gi, accel: ai, motors: mi, battery: bi } = &cols;
        let (mut s, map) = self.empty_series(file, &cols)?;
        let flip = |v: Vector3<f64>| Vector3::new(v.x, -v.y, -v.z);
        let mut last_pose = (Vector3::zeros(), UnitQuaternion::identity());
        for (k, line) in lines.enumerate() {
            let lineno = k + 2;
            if line.trim().is_empty() {
                continue;
            }
            let last_cut_short = cut_at_end && last_data == Some(k + 1);
            let cells = crate::log::row_cells(line, header.len(), last_cut_short, lineno, &mut s.repairs)
                .map_err(|m| InputError::row(file, lineno, m))?;
            let Some(cells) = cells else { break };
            let num = |i: usize| finite(cells[i]);
            let need = |i: usize| -> Result<f64, InputError> {
                num(i).ok_or_else(|| InputError::Row {
                    file: file.to_string(),
                    line: lineno,
                    column: Some(header[i].to_string()),
                    message: format!("`{}` is not a finite number", cells[i].trim()),
                })
            };
            let t = need(*ti)? * time_f;
            if let Some(&prev) = s.t_s.last() {
                if t < prev {
                    return Err(InputError::row(file, lineno, format!("time goes backwards ({t} s after {prev} s)")));
                }
                if t == prev {
                    s.repairs.push(Repair::RepeatedTime { line: lineno, t_s: None }.into());
                    continue;
                }
            }
            let pose: Option<Vec<f64>> = pi
                .iter()
                .chain(qi)
                .map(|&i| pose_cell(cells[i], header[i], file, lineno))
                .collect::<Result<Vec<_>, _>>()?
                .into_iter()
                .collect();
            let seen = pose.is_some();
            if let Some(p) = pose {
                last_pose = self.pose(&p, euler_f, pos_f, file, lineno)?;
            }
            let body = |v: Vector3<f64>| if self.body == BodyAxes::Flu { flip(v) } else { v };
            let gyro = body(Vector3::new(need(gi[0])?, need(gi[1])?, need(gi[2])?) * gyro_f);
            let acc = body(Vector3::new(need(ai[0])?, need(ai[1])?, need(ai[2])?) * acc_f);
            let vbat = bi.map(&need).transpose()?;
            if let (Some(th), Some(map)) = (s.thrust_n.as_mut(), map) {
                let v = vbat.unwrap_or(map.vbat_ref_v);
                let per_motor = mi.iter().map(|&i| Ok(map.thrust_n(need(i)?, v))).sum::<Result<f64, InputError>>()?;
                // the map is per motor for four motors
                th.push(per_motor * 4.0 / mi.len() as f64);
            }
            if let (Some(vb), Some(v)) = (s.vbat_v.as_mut(), vbat) {
                vb.push(v);
            }
            s.t_s.push(t);
            // the mapping has turned the source's axes into the mocap's NED and the body's FRD
            s.pos_mocap_nav.push(Vec3::from_raw(last_pose.0));
            s.att_mocap.push(Rot::from_quaternion(last_pose.1));
            s.mocap_ok.push(seen);
            s.gyro_body.push(Vec3::from_raw(gyro));
            s.accel_body.push(Vec3::from_raw(acc));
        }
        if s.t_s.len() < 2 {
            return Err(too_few_rows(file, &s.repairs));
        }
        s.segments = crate::log::split_at_gaps(&s.t_s, &mut s.repairs);
        Ok(s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each `world:` turns its own up axis to −z (up in NED) by a proper rotation, and keeps
    /// gravity pointing down.
    /// A column mapping's unknown key lists the other forms' blocks, and its "did you mean"
    /// comes from the keys: `px5` → `px4`, `gyor` → `gyro`, and `b` (one edit from the list's
    /// word "a") gets none.
    #[test]
    fn an_unknown_key_lists_the_blocks_and_suggests_only_keys() {
        let m = "unknown field `KEY`, expected one of vehicle, time, gyro";
        let say = |k: &str| with_blocks(&m.replace("KEY", k));
        assert_eq!(
            say("px5"),
            "unknown field `px5`, expected one of vehicle, time, gyro, or a block ros2, px4, asl or poses; did you mean `px4`?"
        );
        assert!(say("gyor").ends_with("; did you mean `gyro`?"), "{}", say("gyor"));
        assert!(say("b").ends_with("asl or poses"), "{}", say("b"));
        assert_eq!(with_blocks("invalid type: string"), "invalid type: string");
    }

    #[test]
    fn each_world_turns_its_up_axis_to_minus_z() {
        for (w, up) in [
            (WorldUp::ZUp, Vector3::z()),
            (WorldUp::ZDown, -Vector3::z()),
            (WorldUp::YUp, Vector3::y()),
            (WorldUp::YDown, -Vector3::y()),
            (WorldUp::XUp, Vector3::x()),
            (WorldUp::XDown, -Vector3::x()),
        ] {
            let got = w.to_z_down() * up;
            assert!((got + Vector3::z()).norm() < 1e-15, "{w:?}: up goes to {got}");
        }
    }

    /// The two-stream forms: an `asl:` block reads a folder (its defaults imu0, vicon0, z up, the
    /// axes as they are), a `poses:` block an IMU CSV beside a pose file, and each says so when
    /// it is given one log alone; a pose file's unit outside m and mm is an error with the
    /// allowed ones; a `poses:` mapping given no pose file says to give it.
    #[test]
    fn the_two_stream_mappings_read_and_refuse_what_they_should() {
        let path = Path::new("m.yaml");
        let asl = Mapping::parse("vehicle: rigid_body\nasl: {}\n", path).unwrap();
        let a = asl.asl.as_ref().unwrap();
        assert!(asl.two_streams() && a.imu == "imu0" && a.poses == "vicon0");
        assert!(asl.world == WorldUp::ZUp && asl.body == BodyAxes::Frd);
        let err = asl.read(Path::new("seq")).unwrap_err().to_string();
        assert!(err.contains("two streams"), "{err}");
        let split = "vehicle: rigid_body\ntime: { column: t, unit: s }\ngyro: { columns: [gx, gy, gz], unit: rad/s }\naccel: { columns: [ax, ay, az], unit: m/s2 }\nworld: y_up\nbody: flu\nposes: { format: tum, unit: UNIT }\n";
        let m = Mapping::parse(&split.replace("UNIT", "mm"), path).unwrap();
        assert!(m.two_streams() && m.world == WorldUp::YUp);
        let err = Mapping::parse(&split.replace("UNIT", "cm"), path).unwrap_err().to_string();
        assert!(err.contains("m.yaml") && err.contains("`cm`") && err.contains("`mm`"), "{err}");
        let err = m.read_streams(Path::new("imu.csv"), None).err().unwrap().to_string();
        assert!(err.contains("--poses"), "{err}");
        let err = asl.read_streams(Path::new("/nonexistent-sequence"), None).err().unwrap().to_string();
        assert!(err.contains("not an ASL (EuRoC) folder") && err.contains("mav0/imu0/data.csv"), "{err}");
    }
}

//! A real log with a mount and a clock offset put on it that are known exactly: does the
//! calibration move by exactly that? The truth of a real log is not known, but what an
//! injection does to it is. Turning the IMU's readings by R (a new IMU frame, R·ω and R·f) and
//! stamping the poses δ later changes a correct calibration (R_off, r, b_a, b_g, τ, R_w) into
//! (R·R_off, R·r, R·b_a, R·b_g, τ + δ, R_w), whatever the first one is. So each injected case is
//! scored against the plain log's own result composed with its injection.
//!
//! | injection | drawn (case k of seed S) |
//! |---|---|
//! | the 24 rotations that permute the IMU's axes (with signs) | k ≡ 0 (mod 3): permutation k/3 mod 24 |
//! | a half-turn about an axis drawn uniformly on the sphere | k ≡ 1 (mod 3) |
//! | a rotation drawn uniformly on SO(3) (a unit quaternion of four normals) | k ≡ 2 (mod 3) |
//! | the poses stamped δ later | δ = ±2 ms, ±200 ms, ±3 s, +10⁶ s in turn (k mod 7) |
//!
//! Rotations are in the log's own IMU axes (what a lab that mounts the IMU otherwise records),
//! and turned into flyarena's body frame as the mapping turns the readings. An injection and the
//! case it gives are pure functions of (seed, k).
//!
//! **Scoring.** The rotation's error is the angle of R̂⁻¹·R·R_off and its components about the
//! IMU's axes (δ = Log(R·R_off·R̂⁻¹), the left error the intervals describe); the lever arm's the
//! norm of r̂ − R·r; the delay's |τ̂ − τ − δ|. A parameter *agrees* when its difference lies
//! inside the injected case's 95 % interval. Because the fit weighs each IMU axis by its own
//! residual (and whitens each by its own AR model), a rotation that mixes the axes changes the
//! weights: the composed result is the reference of a slightly different estimator, and the
//! differences are of the order of the intervals, not zero.

use crate::effects::Effect;
use crate::identify::fit::select::{Options, Report, identify};
use crate::identify::input::error::InputError;
use crate::identify::input::joined::{Stream, Streams};
use crate::identify::input::mapping::{BodyAxes, Mapping};
use crate::rng::{Component, Stream as Rng};
use nalgebra::{Matrix3, Quaternion, Rotation3, UnitQuaternion, Vector3};
use std::fmt::Write as _;

/// The clock offsets injected in turn (s).
pub const OFFSETS_S: [f64; 7] = [0.002, -0.002, 0.2, -0.2, 3.0, -3.0, 1e6];

/// What kind of mount an injection is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Mount {
    /// One of the 24 rotations that permute the axes (with signs), by its index.
    Permutation(usize),
    /// A half-turn about a random axis.
    HalfTurn,
    /// A rotation drawn uniformly on SO(3).
    Random,
}

/// One injection: the IMU turned by `rotation` (in the log's IMU axes: readings R·ω, R·f) and the
/// poses stamped `offset_s` later.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct Injection {
    /// Case k of the seed.
    pub index: u64,
    /// Its kind.
    pub mount: Mount,
    /// R, rows (log's IMU axes).
    pub rotation: [[f64; 3]; 3],
    /// δ (s).
    pub offset_s: f64,
}

/// The 24 proper rotations whose entries are 0 and ±1 (the cube's), in a fixed order: every
/// permutation of the axes with every choice of signs whose determinant is +1.
pub fn axis_permutations() -> Vec<Matrix3<f64>> {
    let perms = [[0, 1, 2], [0, 2, 1], [1, 0, 2], [1, 2, 0], [2, 0, 1], [2, 1, 0]];
    let mut out = Vec::new();
    for p in perms {
        for signs in 0..8u8 {
            let m =
                Matrix3::from_fn(|r, c| if p[r] == c { if signs & (1 << r) != 0 { -1.0 } else { 1.0 } } else { 0.0 });
            if m.determinant() > 0.0 {
                out.push(m);
            }
        }
    }
    out
}

/// Case `k` of seed `seed` (the table at the top).
pub fn injection(seed: u64, k: u64) -> Injection {
    let mut rng = Rng::new(seed, Component::Injection, k as usize);
    let (mount, r) = match k % 3 {
        0 => {
            let i = (k / 3 % 24) as usize;
            (Mount::Permutation(i), axis_permutations()[i])
        }
        1 => {
            let axis = Vector3::new(rng.normal(), rng.normal(), rng.normal()).normalize();
            (
                Mount::HalfTurn,
                *Rotation3::from_axis_angle(&nalgebra::Unit::new_unchecked(axis), std::f64::consts::PI).matrix(),
            )
        }
        _ => {
            let q = UnitQuaternion::from_quaternion(Quaternion::new(
                rng.normal(),
                rng.normal(),
                rng.normal(),
                rng.normal(),
            ));
            (Mount::Random, *q.to_rotation_matrix().matrix())
        }
    };
    Injection {
        index: k,
        mount,
        rotation: [0, 1, 2].map(|i| [0, 1, 2].map(|j| r[(i, j)])),
        offset_s: OFFSETS_S[(k % 7) as usize],
    }
}

impl Injection {
    /// R as a matrix.
    pub fn matrix(&self) -> Matrix3<f64> {
        Matrix3::from_fn(|i, j| self.rotation[i][j])
    }

    /// The streams with the injection on them: the IMU's readings turned, the poses' stamps moved.
    pub(in crate::identify) fn apply(&self, s: &Streams) -> Streams {
        let r = self.matrix();
        let turn = |v: &[f64; 6]| {
            let (w, f) = (r * Vector3::new(v[0], v[1], v[2]), r * Vector3::new(v[3], v[4], v[5]));
            [w.x, w.y, w.z, f.x, f.y, f.z]
        };
        let shift = (self.offset_s * 1e9).round() as i128;
        Streams {
            imu: Stream { t: s.imu.t.clone(), v: s.imu.v.iter().map(turn).collect() },
            pose: Stream { t: s.pose.t.iter().map(|t| t + shift).collect(), v: s.pose.v.clone() },
            motors: Stream::new(),
            n_motors: None,
            battery: Stream::new(),
        }
    }
}

/// One injected case scored against the plain log's result composed with its injection.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Outcome {
    /// The injection.
    pub injection: Injection,
    /// The angle between the case's rotation and R·R_off (deg).
    pub rotation_diff_deg: Option<f64>,
    /// ‖r̂ − R·r‖ (mm).
    pub lever_diff_mm: Option<f64>,
    /// τ̂ − τ − δ (ms).
    pub delay_diff_ms: Option<f64>,
    /// The angle between the case's and the plain log's gravity directions (deg).
    pub tilt_diff_deg: Option<f64>,
    /// Parameters whose difference lies inside the case's 95 % interval, of those compared.
    pub agree: [usize; 2],
    /// The case's report claimed its effects (no misalignment found).
    pub claimed: bool,
    /// The global start applied its rotation / its clock.
    pub start_applied: [bool; 2],
    /// Why the case could not be identified, if it could not.
    pub error: Option<String>,
}

/// The frame conversion the mapping applies to the IMU's axes: identity for `frd`, the half-turn
/// about x for `flu`.
fn body_turn(map: &Mapping) -> Matrix3<f64> {
    match map.body {
        BodyAxes::Frd => Matrix3::identity(),
        BodyAxes::Flu => Matrix3::from_diagonal(&Vector3::new(1.0, -1.0, -1.0)),
    }
}

/// The values of effect `e`'s parameters and their 95 % half-widths.
fn params(r: &Report, e: Effect) -> Option<(Vec<f64>, Vec<f64>)> {
    r.effect(e).map(|f| (f.params.iter().map(|p| p.value).collect(), f.params.iter().map(|p| p.ci95).collect()))
}

/// Scores `case` (the report of the injected log) against `plain` (the untouched log's) under
/// injection `inj`; `turn` is the mapping's body conversion.
fn score(plain: &Report, case: &Report, inj: &Injection, turn: &Matrix3<f64>) -> Outcome {
    let r = turn * inj.matrix() * turn.transpose();
    let mut out = Outcome {
        injection: *inj,
        rotation_diff_deg: None,
        lever_diff_mm: None,
        delay_diff_ms: None,
        tilt_diff_deg: None,
        agree: [0, 0],
        claimed: case.misaligned.is_empty(),
        start_applied: [case.start.applied.rotation, case.start.applied.clock],
        error: None,
    };
    let mut agree = |d: f64, ci: f64| {
        out.agree[1] += 1;
        out.agree[0] += usize::from(d.abs() <= ci);
    };
    let (pc, cc) = (plain.corrections, case.corrections);
    if let (Some(_), Some((_, ci))) = (params(plain, Effect::BodyOffset), params(case, Effect::BodyOffset)) {
        let want =
            UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(r)) * pc.body_offset.quaternion();
        let err = want * cc.body_offset.quaternion().inverse();
        out.rotation_diff_deg = Some(err.angle().to_degrees());
        let d = err.scaled_axis();
        for k in 0..3 {
            agree(d[k].to_degrees(), ci[k]);
        }
    }
    if let (Some((pv, _)), Some((cv, ci))) = (params(plain, Effect::LeverArm), params(case, Effect::LeverArm)) {
        let want = r * Vector3::from_column_slice(&pv);
        let d = Vector3::from_column_slice(&cv) - want;
        out.lever_diff_mm = Some(d.norm());
        for k in 0..3 {
            agree(d[k], ci[k]);
        }
    }
    if let (Some((pv, _)), Some((cv, ci))) = (params(plain, Effect::MocapDelay), params(case, Effect::MocapDelay)) {
        let d = cv[0] - pv[0] - inj.offset_s * 1e3;
        out.delay_diff_ms = Some(d);
        agree(d, ci[0]);
    }
    if let (Some((pv, _)), Some((cv, ci))) = (params(plain, Effect::WorldTilt), params(case, Effect::WorldTilt)) {
        let down = Vector3::z();
        out.tilt_diff_deg =
            Some((pc.world_tilt.quaternion() * down).angle(&(cc.world_tilt.quaternion() * down)).to_degrees());
        for k in 0..2 {
            agree(cv[k] - pv[k], ci[k]);
        }
    }
    for e in [Effect::AccelBias, Effect::GyroBias] {
        if let (Some((pv, _)), Some((cv, ci))) = (params(plain, e), params(case, e)) {
            let want = r * Vector3::from_column_slice(&pv);
            for k in 0..3 {
                agree(cv[k] - want[k], ci[k]);
            }
        }
    }
    out
}

/// The two streams of a log through a mapping that reads two (an ASL folder; an IMU log beside
/// a pose file is not a single path, so it is not taken here).
///
/// # Errors
/// The reader's.
pub fn streams(map: &Mapping, log: &std::path::Path) -> Result<Streams, InputError> {
    map.read_streams(log, None)
}

/// The plain log's report and cases 0..count of seed `seed` scored against it (in parallel; the
/// same outcomes whatever the thread count).
///
/// # Errors
/// The plain log's, when it cannot be joined or identified.
pub fn run_many(
    map: &Mapping,
    streams: &Streams,
    name: &str,
    seed: u64,
    count: u64,
    o: &Options,
) -> Result<(Report, Vec<Outcome>), InputError> {
    use rayon::prelude::*;
    let plain_series = crate::identify::fit::start::joined(map, streams, &o.clock, name)?;
    let plain = identify(&plain_series, o).map_err(|e| InputError::log(name, e.to_string()))?;
    let turn = body_turn(map);
    let outcomes = (0..count)
        .into_par_iter()
        .map(|k| {
            let inj = injection(seed, k);
            let case_name = format!("{name} (injected case {k})");
            let read = crate::identify::fit::start::joined(map, &inj.apply(streams), &o.clock, &case_name);
            match read.map_err(|e| e.to_string()).and_then(|s| identify(&s, o).map_err(|e| e.to_string())) {
                Ok(case) => score(&plain, &case, &inj, &turn),
                Err(e) => Outcome {
                    injection: inj,
                    rotation_diff_deg: None,
                    lever_diff_mm: None,
                    delay_diff_ms: None,
                    tilt_diff_deg: None,
                    agree: [0, 0],
                    claimed: false,
                    start_applied: [false, false],
                    error: Some(e),
                },
            }
        })
        .collect();
    Ok((plain, outcomes))
}

/// The largest of `x` (NaN for none).
fn largest(x: impl Iterator<Item = f64>) -> f64 {
    x.fold(f64::NAN, f64::max)
}

/// The batch as a table: per kind of mount and per offset, how many cases claimed their effects,
/// the largest differences from the composed plain result, and how many parameters agree within
/// the case's interval.
pub fn render(name: &str, outcomes: &[Outcome]) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "{name}: {} injected cases (mount in the IMU's axes, poses stamped later)\n", outcomes.len());
    let _ = writeln!(
        s,
        "| injection | cases | effects claimed | largest rotation diff | largest lever-arm diff | largest delay diff | within the 95 % interval |\n|---|---|---|---|---|---|---|"
    );
    // the rows: each kind of mount, each offset, all
    let kind = |m: &Mount| match m {
        Mount::Permutation(_) => 0,
        Mount::HalfTurn => 1,
        Mount::Random => 2,
    };
    let mut rows: Vec<(String, Vec<&Outcome>)> =
        ["24 axis permutations", "half-turns, random axes", "random rotations"]
            .iter()
            .enumerate()
            .map(|(k, label)| (label.to_string(), outcomes.iter().filter(|o| kind(&o.injection.mount) == k).collect()))
            .collect();
    for d in OFFSETS_S {
        let label = if d.abs() >= 1e5 { format!("δ = {d:+.0e} s") } else { format!("δ = {:+} ms", d * 1e3) };
        rows.push((label, outcomes.iter().filter(|o| o.injection.offset_s == d).collect()));
    }
    rows.push(("all".to_string(), outcomes.iter().collect()));
    for (label, g) in rows {
        if g.is_empty() {
            continue;
        }
        let fmt = |x: f64, unit: &str, d: usize| if x.is_nan() { "—".to_string() } else { format!("{x:.d$} {unit}") };
        let agree: [usize; 2] = g.iter().fold([0, 0], |a, o| [a[0] + o.agree[0], a[1] + o.agree[1]]);
        let _ = writeln!(
            s,
            "| {label} | {} | {} | {} | {} | {} | {} |",
            g.len(),
            g.iter().filter(|o| o.claimed && o.error.is_none()).count(),
            fmt(largest(g.iter().filter_map(|o| o.rotation_diff_deg)), "°", 3),
            fmt(largest(g.iter().filter_map(|o| o.lever_diff_mm)), "mm", 2),
            fmt(largest(g.iter().filter_map(|o| o.delay_diff_ms.map(f64::abs))), "ms", 3),
            if agree[1] == 0 {
                "—".to_string()
            } else {
                format!("{:.1} % ({}/{})", 100.0 * agree[0] as f64 / agree[1] as f64, agree[0], agree[1])
            }
        );
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The cube's rotation group: 24 distinct matrices, each orthogonal with determinant +1 and
    /// entries 0 or ±1, the identity and the half-turn about z among them.
    #[test]
    fn the_axis_permutations_are_the_cubes_24_rotations() {
        let p = axis_permutations();
        assert_eq!(p.len(), 24);
        for (i, m) in p.iter().enumerate() {
            assert!((m * m.transpose() - Matrix3::identity()).norm() < 1e-15 && (m.determinant() - 1.0).abs() < 1e-15);
            assert!(p[..i].iter().all(|q| (q - m).norm() > 0.5), "{m} twice");
        }
        assert!(p.contains(&Matrix3::identity()));
        assert!(p.contains(&Matrix3::from_diagonal(&Vector3::new(-1.0, -1.0, 1.0))));
    }

    /// Case k's kind and offset follow the table (k mod 3, k mod 7), a half-turn turns by π, and a
    /// case is a function of (seed, k).
    #[test]
    fn a_case_follows_the_table_and_its_seed() {
        for k in 0..21 {
            let i = injection(4, k);
            assert_eq!(i.offset_s, OFFSETS_S[(k % 7) as usize]);
            let angle = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(i.matrix())).angle();
            match k % 3 {
                0 => assert!(matches!(i.mount, Mount::Permutation(_))),
                1 => assert!(i.mount == Mount::HalfTurn && (angle - std::f64::consts::PI).abs() < 1e-12, "{angle}"),
                _ => assert_eq!(i.mount, Mount::Random),
            }
            assert_eq!(injection(4, k).rotation, i.rotation);
        }
        assert_ne!(injection(4, 2).rotation, injection(5, 2).rotation);
    }

    /// The injected streams: each IMU sample turned by R (gyro and accelerometer alike), each
    /// pose stamped δ later, nothing else touched.
    #[test]
    fn an_injection_turns_the_imu_and_moves_the_poses() {
        let mut imu = Stream::new();
        imu.push(0, [1.0, 0.0, 0.0, 0.0, 0.0, 9.81]).unwrap();
        let mut pose = Stream::new();
        pose.push(5, [1.0, 2.0, 3.0, 0.0, 0.0, 0.0, 1.0]).unwrap();
        let s = Streams { imu, pose, motors: Stream::new(), n_motors: None, battery: Stream::new() };
        // a quarter turn about z: x → y
        let inj = Injection {
            index: 0,
            mount: Mount::Random,
            rotation: [[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]],
            offset_s: 0.2,
        };
        let t = inj.apply(&s);
        assert_eq!(t.imu.v[0], [0.0, 1.0, 0.0, 0.0, 0.0, 9.81]);
        assert_eq!(t.pose.t[0], 5 + 200_000_000);
        assert_eq!(t.pose.v[0], s.pose.v[0]);
    }
}

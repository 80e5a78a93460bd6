//! Requirements R1–R4, evaluated per vehicle against the tolerances a scenario declares.
//!
//! * **R1 offsets recovered**: |estimate − truth| ≤ tolerance for roll, pitch (hover averaging) and
//!   yaw — from the gyro alignment when the plan flies `calibrate_gyro` (asserted), and from the
//!   paper's straight flight when it flies `calibrate_yaw` (shown; asserted only if
//!   `yaw_straight_flight_tol_deg` is set, because in rate mode that method cannot observe a
//!   marker yaw; `yaw-attitude-mode` sets it, where the onboard attitude mode lets it) — the
//!   truth being the Euler angles of R_off, the rigid fit of the template onto the mounted markers.
//! * **R2 hover drift reduced**: while yawing on the spot, the maximum horizontal distance from the
//!   commanded point with compensation is ≤ `max_m`, and ≤ `max_ratio` × the same run without
//!   compensation. When the uncompensated run itself stays within `max_m` there is no drift to
//!   reduce and the ratio is reported as not applicable (the absolute bound still applies).
//! * **R3 least squares = recursive least squares**: |ψ̂_LS − ψ̂_RLS| and |X̂_E0,LS − X̂_E0,RLS|.
//! * **R4 validity check**: equation (7) gives the verdict the scenario expects.

use crate::engine::{RunOutput, VehicleRun};
use crate::scenario::{HoverDriftReq, LsRlsReq, OffsetsReq, RequirementsCfg, ValidityReq, Verdict};
use std::fmt::Write as _;

/// One requirement check, as the table shows it.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Row {
    /// The vehicle checked.
    pub vehicle: String,
    /// R1 … R5.
    pub id: &'static str,
    /// What is checked (with the estimate and the truth where there are).
    pub what: String,
    /// The measured figure, with its unit.
    pub measured: String,
    /// The limit it is held to.
    pub limit: String,
    /// Whether it holds (always true for a row that is not asserted).
    pub pass: bool,
    /// False for a row that is shown but not checked (an estimate the architecture cannot
    /// observe, a ratio that does not apply): the table says "not asserted" instead of "pass",
    /// and it never makes a report pass or fail.
    pub asserted: bool,
}

/// The requirements of a run, evaluated.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Report {
    /// One per check, by vehicle and requirement.
    pub rows: Vec<Row>,
}

impl Report {
    /// Whether every row passed.
    pub fn passed(&self) -> bool {
        self.rows.iter().all(|r| r.pass)
    }

    /// The human table.
    pub fn table(&self) -> String {
        let headers = ["vehicle", "req", "what", "measured", "limit", "result"];
        let cells: Vec<[String; 6]> = self
            .rows
            .iter()
            .map(|r| {
                [
                    r.vehicle.clone(),
                    r.id.into(),
                    r.what.clone(),
                    r.measured.clone(),
                    r.limit.clone(),
                    if !r.asserted {
                        "not asserted".into()
                    } else if r.pass {
                        "pass".into()
                    } else {
                        "FAIL".into()
                    },
                ]
            })
            .collect();
        let mut w = headers.map(|h| h.chars().count());
        for c in &cells {
            for i in 0..6 {
                w[i] = w[i].max(c[i].chars().count());
            }
        }
        let line = |c: &[String]| {
            let mut s = String::new();
            for i in 0..6 {
                let pad = w[i] - c[i].chars().count();
                let _ = write!(s, "{}{}  ", c[i], " ".repeat(pad));
            }
            s.trim_end().to_string() + "\n"
        };
        let mut out = line(&headers.map(String::from));
        out += &line(&w.map(|n| "-".repeat(n)));
        for c in &cells {
            out += &line(c);
        }
        out
    }
}

fn deg(x: f64) -> String {
    // no "-0.0000°" for a rounding-level negative value
    let d = x.to_degrees();
    format!("{:.4}°", if d.abs() < 5e-5 { 0.0 } else { d })
}

/// Evaluates the declared requirements. `uncompensated` is the same scenario run with
/// `calibration.apply = false` (needed for R2 only).
pub fn evaluate(req: &RequirementsCfg, run: &RunOutput, uncompensated: Option<&RunOutput>) -> Report {
    let mut rows = Vec::new();
    for (i, v) in run.vehicles.iter().enumerate() {
        let mut out = Rows { vehicle: &v.name, rows: &mut rows };
        if let Some(r) = &req.offsets {
            offsets(r, v, &mut out);
        }
        if let Some(r) = &req.hover_drift {
            hover_drift(r, v, uncompensated.and_then(|u| u.vehicles.get(i)), &mut out);
        }
        if let Some(r) = &req.ls_equals_rls {
            ls_equals_rls(r, v, &mut out);
        }
        if let Some(r) = &req.validity {
            validity(r, v, &mut out);
        }
        if v.any_nan {
            out.row("sim", "state stays finite".into(), "NaN or infinity in the state".into(), "finite".into(), false);
        }
    }
    Report { rows }
}

/// The rows of one vehicle as they are written.
struct Rows<'a> {
    vehicle: &'a str,
    rows: &'a mut Vec<Row>,
}

impl Rows<'_> {
    /// An asserted row: `pass` decides.
    fn row(&mut self, id: &'static str, what: String, measured: String, limit: String, pass: bool) {
        self.rows.push(Row { vehicle: self.vehicle.to_string(), id, what, measured, limit, pass, asserted: true });
    }
    /// A row shown but not asserted (its result column says why).
    fn shown(&mut self, id: &'static str, what: String, measured: String, limit: String) {
        self.rows.push(Row {
            vehicle: self.vehicle.to_string(),
            id,
            what,
            measured,
            limit,
            pass: true,
            asserted: false,
        });
    }
}

/// R1: the roll/pitch offsets of the hover average, and a yaw row for each yaw method the plan
/// flies (the straight flight (8)–(9), the gyro telemetry).
fn offsets(r: &OffsetsReq, v: &VehicleRun, out: &mut Rows) {
    let tol = r.roll_pitch_tol_deg.to_radians();
    match v.calibration.roll_pitch {
        Some((roll, pitch, _)) => {
            for (name, est, truth) in [("roll", roll, v.truth.euler.roll), ("pitch", pitch, v.truth.euler.pitch)] {
                let err = (est - truth).abs();
                out.row(
                    "R1",
                    format!("{name} offset |est − truth| (est {}, truth {})", deg(est), deg(truth)),
                    deg(err),
                    format!("≤ {}", deg(tol)),
                    err <= tol,
                );
            }
        }
        None if v.external => out.shown(
            "R1",
            "roll/pitch offsets".into(),
            "the external controller reported no offset (FAOF)".into(),
            format!("≤ {}", deg(tol)),
        ),
        None => out.row(
            "R1",
            "roll/pitch offsets".into(),
            "not calibrated (no calibrate_roll_pitch phase)".into(),
            format!("≤ {}", deg(tol)),
            false,
        ),
    }
    // a yaw row exists for each yaw method the plan flies
    let flies = |phase: &str| v.phases.iter().any(|(_, name)| *name == phase);
    let truth = v.truth.euler.yaw;
    if flies("calibrate_yaw") {
        let est = v.calibration.yaw_offset;
        let what = match est {
            Some(e) => format!("yaw offset, straight flight (8)–(9) (est {}, truth {})", deg(e), deg(truth)),
            None => "yaw offset, straight flight (8)–(9)".into(),
        };
        let err = est.map(|e| crate::frames::wrap_pi(e - truth).abs());
        let measured = err.map_or("no estimate (flight too short to fit)".into(), deg);
        match r.yaw_straight_flight_tol_deg {
            Some(t) if err.is_none() && v.external => out.shown(
                "R1",
                what,
                "the external controller reported no yaw offset (FAOF)".into(),
                format!("≤ {}", deg(t.to_radians())),
            ),
            Some(t) => {
                let tol = t.to_radians();
                out.row("R1", what, measured, format!("≤ {}", deg(tol)), err.is_some_and(|e| e <= tol));
            }
            None => out.shown("R1", what, measured, "none: unobservable in rate mode (docs/findings.md)".into()),
        }
    }
    if flies("calibrate_gyro") {
        let tol = r.yaw_tol_deg.to_radians();
        match &v.calibration.gyro {
            Some(g) => {
                let err = crate::frames::wrap_pi(g.euler.yaw - truth).abs();
                let what = format!(
                    "yaw offset, gyro telemetry (est {} ± {} 1σ, truth {})",
                    deg(g.euler.yaw),
                    deg(g.sigma[2]),
                    deg(truth)
                );
                out.row("R1", what, deg(err), format!("≤ {}", deg(tol)), err <= tol);
            }
            None if v.external => out.shown(
                "R1",
                "yaw offset, gyro telemetry".into(),
                "the external controller flies it: no built-in gyro fit".into(),
                format!("≤ {}", deg(tol)),
            ),
            None => out.row(
                "R1",
                "yaw offset, gyro telemetry".into(),
                "no estimate (rotation about two axes needed)".into(),
                format!("≤ {}", deg(tol)),
                false,
            ),
        }
    }
}

/// R2: the drift while yawing, compensated, and against the uncompensated twin's (`unc`).
fn hover_drift(r: &HoverDriftReq, v: &VehicleRun, unc: Option<&VehicleRun>, out: &mut Rows) {
    let comp = v.spin_max_deviation_m;
    let unc = unc.and_then(|u| u.spin_max_deviation_m);
    match (comp, unc) {
        (Some(c), Some(u)) => {
            out.row(
                "R2",
                "max drift while yawing, compensated".into(),
                format!("{:.4} m", c),
                format!("≤ {:.4} m", r.max_m),
                c <= r.max_m,
            );
            if u > r.max_m {
                let ratio = c / u;
                out.row(
                    "R2",
                    format!("drift compensated / uncompensated ({:.4} m)", u),
                    format!("{:.2} %", 100.0 * ratio),
                    format!("≤ {:.0} %", 100.0 * r.max_ratio),
                    ratio <= r.max_ratio,
                );
            } else {
                out.shown(
                    "R2",
                    "drift compensated / uncompensated".into(),
                    format!("n/a: uncompensated {:.4} m is already within the bound", u),
                    format!("≤ {:.0} %", 100.0 * r.max_ratio),
                );
            }
        }
        _ => out.row(
            "R2",
            "max drift while yawing".into(),
            "no yaw_spin phase".into(),
            format!("≤ {:.4} m", r.max_m),
            false,
        ),
    }
}

/// R3: the batch least squares and the recursive one agree on the yaw flight.
fn ls_equals_rls(r: &LsRlsReq, v: &VehicleRun, out: &mut Rows) {
    match (&v.calibration.yaw_ls, &v.calibration.yaw_rls) {
        (Some(ls), Some(rls)) => {
            let dpsi = (ls.psi_offset - rls.psi_offset).abs();
            let dx = (ls.x_e0 - rls.x_e0).abs();
            out.row(
                "R3",
                format!("|ψ_LS − ψ_RLS| over {} samples", ls.n),
                format!("{dpsi:.1e} rad"),
                format!("≤ {:.0e} rad", r.yaw_tol_rad),
                dpsi <= r.yaw_tol_rad,
            );
            out.row(
                "R3",
                "|X_E0,LS − X_E0,RLS|".into(),
                format!("{dx:.1e} m"),
                format!("≤ {:.0e} m", r.x_e0_tol_m),
                dx <= r.x_e0_tol_m,
            );
        }
        _ if v.external => out.shown(
            "R3",
            "LS = RLS".into(),
            "n/a: an external controller flies it (its fits are its own)".into(),
            format!("≤ {:.0e} rad", r.yaw_tol_rad),
        ),
        _ => out.row(
            "R3",
            "LS = RLS".into(),
            "no yaw fit (no calibrate_yaw phase, or too short)".into(),
            format!("≤ {:.0e} rad", r.yaw_tol_rad),
            false,
        ),
    }
}

/// R4: the validity check (7) accepts or rejects as expected.
fn validity(r: &ValidityReq, v: &VehicleRun, out: &mut Rows) {
    let want = r.expect == Verdict::Accept;
    match &v.calibration.validity {
        Some(val) => out.row(
            "R4",
            format!("validity (7): mean ψ {}, mean φ {}", deg(val.mean_yaw), deg(val.mean_roll)),
            (if val.accepted { "accepted" } else { "rejected" }).into(),
            (if want { "accept" } else { "reject" }).into(),
            val.accepted == want,
        ),
        None if v.external => out.shown(
            "R4",
            "validity (7)".into(),
            "n/a: an external controller flies it".into(),
            (if want { "accept" } else { "reject" }).into(),
        ),
        None => out.row(
            "R4",
            "validity (7)".into(),
            "no yaw flight".into(),
            (if want { "accept" } else { "reject" }).into(),
            false,
        ),
    }
}

/// Does the scenario need the uncompensated counterpart run?
pub(crate) fn needs_uncompensated(req: &RequirementsCfg) -> bool {
    req.hover_drift.is_some()
}

/// Machine-readable summary of one vehicle, as `out/<scenario>.json` holds it (angles in
/// degrees, as the YAML; fields in alphabetical order, as the file has always listed them).
#[derive(Clone, Debug, serde::Serialize)]
pub struct VehicleSummary {
    /// The offset the controller used at the end (°: roll, pitch, yaw).
    pub applied_offset_deg: [f64; 3],
    /// What the mocap-outage failsafe did.
    pub failsafe: crate::engine::FailsafeReport,
    /// The true position at the end (m, true NED).
    pub final_position_m: crate::frames::Vec3<crate::frames::Nav>,
    /// The gyro-telemetry alignment, when the plan flies `calibrate_gyro`.
    pub gyro_alignment: Option<GyroSummary>,
    /// m·g of the declared model (N).
    pub hover_thrust_expected_n: f64,
    /// The mean commanded thrust while hover-averaging (N).
    pub hover_thrust_mean_n: Option<f64>,
    /// The mocap link's counts.
    pub link: crate::link::LinkStats,
    /// The vehicle's name.
    pub name: String,
    /// (φ̄_m, θ̄_m) of the hover average (°).
    pub roll_pitch_estimate_deg: Option<[f64; 2]>,
    /// Attitudes averaged.
    pub roll_pitch_samples: Option<u64>,
    /// R2: the largest horizontal drift while yawing on the spot, compensated (m).
    pub spin_max_deviation_m: Option<f64>,
    /// The same, flown uncompensated (m).
    pub spin_max_deviation_uncompensated_m: Option<f64>,
    /// The telemetry link's counts.
    pub telemetry_link: crate::link::LinkStats,
    /// The markers' true offset (°: roll, pitch, yaw).
    pub true_offset_deg: [f64; 3],
    /// RMS misfit of a rotation to displaced markers (mm; 0 for a pure rotation).
    pub true_offset_misfit_mm: f64,
    /// The straight flight's check (7).
    pub validity: Option<ValiditySummary>,
    /// The straight flight's batch line fit (9).
    pub yaw_ls: Option<LineSummary>,
    /// The paper's yaw offset estimate (°).
    pub yaw_offset_estimate_deg: Option<f64>,
    /// The same fit by recursive least squares.
    pub yaw_rls: Option<LineSummary>,
}

/// A straight-flight line fit in the summary.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct LineSummary {
    /// Samples fitted.
    pub n: usize,
    /// ψ̂_off (°).
    pub psi_offset_deg: f64,
    /// X̂_E,0 (m).
    pub x_e0_m: f64,
}

/// Check (7) in the summary.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct ValiditySummary {
    /// Both means within their bounds.
    pub accepted: bool,
    /// Mean measured roll (°).
    pub mean_roll_deg: f64,
    /// Mean measured yaw (°).
    pub mean_yaw_deg: f64,
}

/// The gyro alignment in the summary.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct GyroSummary {
    /// The gyro bias (°/s, body).
    pub gyro_bias_deg_s: [f64; 3],
    /// The offset's Z-Y-X angles (°).
    pub offset_deg: [f64; 3],
    /// RMS residual per component (° per window).
    pub rms_residual_deg: f64,
    /// 1σ about body x, y, z (°).
    pub sigma_deg: [f64; 3],
    /// The telemetry clock, when fitted.
    pub telemetry_clock: Option<ClockSummary>,
    /// Windows fitted.
    pub windows: u64,
}

/// The telemetry clock fit in the summary.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct ClockSummary {
    /// The windows' mean time on the Vicon clock (s).
    pub at_s: f64,
    /// Drift (ppm), when the windows span enough time.
    pub drift_ppm: Option<f64>,
    /// Its 1σ (ppm).
    pub drift_sigma_ppm: Option<f64>,
    /// Offset at `at_s` (ms).
    pub offset_ms: f64,
    /// Its 1σ (ms).
    pub offset_sigma_ms: f64,
}

/// The summary of one vehicle's run; `unc` is its uncompensated counterpart, if flown.
pub(crate) fn vehicle_summary(v: &VehicleRun, unc: Option<&VehicleRun>) -> VehicleSummary {
    let c = &v.calibration;
    let line = |f: &crate::calibrate::LineFit| LineSummary {
        n: f.n,
        psi_offset_deg: f.psi_offset.to_degrees(),
        x_e0_m: f.x_e0,
    };
    VehicleSummary {
        applied_offset_deg: c.applied.to_degrees(),
        failsafe: v.failsafe,
        final_position_m: v.final_pos,
        gyro_alignment: c.gyro.map(|g| GyroSummary {
            gyro_bias_deg_s: g.gyro_bias.map(f64::to_degrees),
            offset_deg: g.euler.to_degrees(),
            rms_residual_deg: g.rms_residual.to_degrees(),
            sigma_deg: g.sigma.map(f64::to_degrees),
            telemetry_clock: g.clock.map(|k| ClockSummary {
                at_s: k.t_mean_s,
                drift_ppm: k.drift_ppm,
                drift_sigma_ppm: k.drift_sigma_ppm,
                offset_ms: k.offset_s * 1e3,
                offset_sigma_ms: k.offset_sigma_s * 1e3,
            }),
            windows: g.windows,
        }),
        hover_thrust_expected_n: v.params.hover_thrust(),
        hover_thrust_mean_n: v.hover_thrust_mean_n,
        link: v.link,
        name: v.name.clone(),
        roll_pitch_estimate_deg: c.roll_pitch.map(|(r, p, _)| [r.to_degrees(), p.to_degrees()]),
        roll_pitch_samples: c.roll_pitch.map(|x| x.2),
        spin_max_deviation_m: v.spin_max_deviation_m,
        spin_max_deviation_uncompensated_m: unc.and_then(|u| u.spin_max_deviation_m),
        telemetry_link: v.telemetry,
        true_offset_deg: v.truth.euler.to_degrees(),
        true_offset_misfit_mm: v.truth.rms_misfit_m * 1e3,
        validity: c.validity.map(|x| ValiditySummary {
            accepted: x.accepted,
            mean_roll_deg: x.mean_roll.to_degrees(),
            mean_yaw_deg: x.mean_yaw.to_degrees(),
        }),
        yaw_ls: c.yaw_ls.as_ref().map(line),
        yaw_offset_estimate_deg: c.yaw_offset.map(f64::to_degrees),
        yaw_rls: c.yaw_rls.as_ref().map(line),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::clock::Nanos;

    /// A report's angle: radians in, degrees out to four places with the unit; a rounding-level
    /// negative prints as 0, not −0. A bug it catches: `deg` → "" and → "xyzzy".
    #[test]
    fn an_angle_is_reported_in_degrees_to_four_places() {
        assert_eq!(deg(std::f64::consts::FRAC_PI_4), "45.0000°");
        assert_eq!(deg(-0.5f64.to_radians()), "-0.5000°");
        assert_eq!(deg(-(3e-5f64).to_radians()), "0.0000°");
        assert_eq!(deg(-(2e-4f64).to_radians()), "-0.0002°");
    }

    /// A report of asserted rows, written as `evaluate` writes them.
    fn report(passes: &[bool]) -> Report {
        let mut rows = Vec::new();
        let mut out = Rows { vehicle: "x3d", rows: &mut rows };
        for &pass in passes {
            out.row("R1", "roll".into(), "0.1 deg".into(), "0.5 deg".into(), pass);
        }
        Report { rows }
    }

    /// The table by hand: a header, a rule as wide as each column's widest cell (counted in
    /// characters: "≤ 0.5°" is 6), one line per row, columns two spaces apart, no trailing blanks,
    /// and the result column reads pass, FAIL or "not asserted". A bug it catches: `table` → "".
    #[test]
    fn the_table_aligns_its_columns_and_names_each_result() {
        let mut rows = Vec::new();
        let mut out = Rows { vehicle: "x3d", rows: &mut rows };
        out.row("R1", "roll".into(), "0.1°".into(), "≤ 0.5°".into(), true);
        out.row("R2", "ratio".into(), "12".into(), "≥ 2".into(), false);
        out.shown("R4", "why".into(), "n/a".into(), "-".into());
        let want = [
            "vehicle  req  what   measured  limit   result",
            "-------  ---  -----  --------  ------  ------------",
            "x3d      R1   roll   0.1°      ≤ 0.5°  pass",
            "x3d      R2   ratio  12        ≥ 2     FAIL",
            "x3d      R4   why    n/a       -       not asserted",
        ];
        assert_eq!(Report { rows }.table(), want.map(|l| format!("{l}\n")).concat());
    }

    /// The one vehicle of `scenarios/fig6-roll-pitch-offsets.yaml` before its first tick: no
    /// estimate yet, no phase flown; each test sets what it checks.
    fn unflown() -> VehicleRun {
        let s = crate::scenario::Scenario::parse(
            include_str!("../scenarios/fig6-roll-pitch-offsets.yaml"),
            std::path::Path::new("fig6-roll-pitch-offsets.yaml"),
        )
        .unwrap();
        let mut v =
            crate::engine::Arena::new(s.spec(), crate::engine::RunOptions::default()).finish().vehicles.remove(0);
        v.phases.clear();
        v
    }

    /// R1 by hand: the markers roll 1° and pitch −0.5°; the hover average reads 1.05° and −0.7°, so
    /// roll is 0.05° off (within 0.1°: pass) and pitch 0.2° off (FAIL). Without a hover average the
    /// row fails ("not calibrated"); with `calibrate_gyro` flown and no gyro fit, the gyro yaw row
    /// fails; a straight-flight yaw without a tolerance is shown, not asserted. Flown by an
    /// external controller, each missing estimate is shown with why. A bug it catches: `offsets` →
    /// () (no R1 row at all) and the guard `None if v.external` as `true` and `false`.
    #[test]
    fn r1_holds_each_offset_to_its_tolerance_and_fails_a_missing_estimate() {
        let r = OffsetsReq { roll_pitch_tol_deg: 0.1, yaw_tol_deg: 0.05, yaw_straight_flight_tol_deg: None };
        let mut v = unflown();
        (v.truth.euler.roll, v.truth.euler.pitch) = (1.0f64.to_radians(), (-0.5f64).to_radians());
        v.calibration.roll_pitch = Some((1.05f64.to_radians(), (-0.7f64).to_radians(), 1000));
        let mut rows = Vec::new();
        offsets(&r, &v, &mut Rows { vehicle: "x3d", rows: &mut rows });
        let got: Vec<_> =
            rows.iter().map(|x| (x.id, x.measured.as_str(), x.limit.as_str(), x.pass, x.asserted)).collect();
        assert_eq!(got, [("R1", "0.0500°", "≤ 0.1000°", true, true), ("R1", "0.2000°", "≤ 0.1000°", false, true)]);
        assert!(rows[0].what.starts_with("roll offset") && rows[1].what.starts_with("pitch offset"), "{rows:?}");

        v.calibration.roll_pitch = None;
        v.calibration.gyro = None;
        v.phases = vec![(Nanos::ZERO, "calibrate_gyro"), (Nanos::from_millis(1), "calibrate_yaw")];
        let mut rows = Vec::new();
        offsets(&r, &v, &mut Rows { vehicle: "x3d", rows: &mut rows });
        let got: Vec<_> = rows.iter().map(|x| (x.what.as_str(), x.limit.as_str(), x.pass, x.asserted)).collect();
        assert_eq!(
            got,
            [
                ("roll/pitch offsets", "≤ 0.1000°", false, true),
                (
                    "yaw offset, straight flight (8)–(9)",
                    "none: unobservable in rate mode (docs/findings.md)",
                    true,
                    false
                ),
                ("yaw offset, gyro telemetry", "≤ 0.0500°", false, true),
            ]
        );

        // flown by an external controller, the same missing estimates are its to report: shown
        // with why, not failed (with a straight-flight tolerance set, that row too)
        v.external = true;
        let r = OffsetsReq { yaw_straight_flight_tol_deg: Some(0.5), ..r };
        let mut rows = Vec::new();
        offsets(&r, &v, &mut Rows { vehicle: "x3d", rows: &mut rows });
        let got: Vec<_> = rows.iter().map(|x| (x.measured.as_str(), x.pass, x.asserted)).collect();
        assert_eq!(
            got,
            [
                ("the external controller reported no offset (FAOF)", true, false),
                ("the external controller reported no yaw offset (FAOF)", true, false),
                ("the external controller flies it: no built-in gyro fit", true, false),
            ]
        );
    }

    /// A report passes iff every row passes: one failing row among passing ones fails it, and a
    /// report with no failing row passes. A bug it catches: `passed` → true.
    #[test]
    fn a_report_passes_only_if_every_row_passes() {
        assert!(report(&[true, true]).passed());
        assert!(!report(&[true, false, true]).passed());
        assert!(!report(&[false]).passed());
    }
}

//! Every scenario in scenarios/ runs and meets the requirements it declares; a rounded summary of
//! each run is pinned as an insta snapshot in the top-level snapshots/ folder (reviewed summaries,
//! not a substitute for the physics checks in physics.rs).

use flyarena::run::{Outcome, run_scenario};
use flyarena::scenario::Scenario;

fn round(x: f64, digits: i32) -> f64 {
    let k = 10f64.powi(digits);
    // + 0.0 turns −0.0 into 0.0: a truth of ±1e-17 must not flip the snapshot
    (x * k).round() / k + 0.0
}

/// Runs one scenario file and checks it meets its requirements; pins its summary.
fn meets_its_requirements(file: &str) {
    let f = super::root().join("scenarios").join(file);
    let s = Scenario::load(&f).unwrap_or_else(|e| panic!("{e}"));
    assert!(
        s.requirements().identify.is_none(),
        "{file}: R5 is checked by `flyarena identify` (tests/acceptance/identify.rs)"
    );
    let Outcome { main, uncompensated: unc, report } = run_scenario(&s, false);
    assert!(!report.rows.is_empty(), "{}: declares no requirements", s.name());
    assert!(report.passed(), "{}:\n{}", s.name(), report.table());
    let summary = serde_json::json!({
        "scenario": s.name(),
        "requirements": report.rows.iter().map(|r| format!("{} {} {}: {} ({}) {}", r.vehicle, r.id, r.what, r.measured, r.limit, if !r.asserted { "not asserted" } else if r.pass { "pass" } else { "FAIL" })).collect::<Vec<_>>(),
        "vehicles": main.vehicles.iter().enumerate().map(|(i, v)| serde_json::json!({
            "name": v.name,
            "true_offset_deg": v.truth.euler.to_degrees().map(|x| round(x, 3)),
            "spin_max_deviation_mm": v.spin_max_deviation_m.map(|d| round(d * 1e3, 1)),
            "spin_max_deviation_uncompensated_mm": unc.as_ref().and_then(|u| u.vehicles[i].spin_max_deviation_m).map(|d| round(d * 1e3, 1)),
            "link_received": v.link.received,
            "link_missing": v.link.missing_frames,
        })).collect::<Vec<_>>(),
    });
    insta::with_settings!({ snapshot_path => "../../snapshots", prepend_module_to_snapshot => false }, {
        insta::assert_json_snapshot!(s.name().to_string(), summary);
    });
}

/// One test per scenario, so that one failure does not hide the others' results.
macro_rules! scenario_tests {
    ($($name:ident: $file:literal,)*) => {
        $(
            #[test]
            fn $name() {
                meets_its_requirements($file);
            }
        )*
        /// Every scenario file has its test here (the identify scenarios have theirs in
        /// identify.rs): a new scenario without one fails this.
        #[test]
        fn every_scenario_file_has_a_test() {
            let listed = [$($file),*];
            let mut files: Vec<String> = std::fs::read_dir(super::root().join("scenarios")).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).filter(|n| n.ends_with(".yaml") && !n.starts_with("identify-")).collect();
            files.sort();
            let mut want: Vec<String> = listed.iter().map(|s| s.to_string()).collect();
            want.sort();
            assert_eq!(files, want);
        }
    };
}

scenario_tests! {
    displaced_markers: "displaced-markers.yaml",
    fig6_attitude_mode: "fig6-attitude-mode.yaml",
    fig6_roll_pitch_offsets: "fig6-roll-pitch-offsets.yaml",
    fig7_no_offsets: "fig7-no-offsets.yaml",
    fleet_4: "fleet-4.yaml",
    gyro_clock: "gyro-clock.yaml",
    lossy_link: "lossy-link.yaml",
    lost_marker: "lost-marker.yaml",
    mocap_outage: "mocap-outage.yaml",
    sweep_hover_duration: "sweep-hover-duration.yaml",
    validity_integral: "validity-integral.yaml",
    validity_reject: "validity-reject.yaml",
    yaw_attitude_mode: "yaw-attitude-mode.yaml",
    yaw_offset: "yaw-offset.yaml",
}

/// The scenario reference (docs/scenarios.md) states each field's range as `scenario::ranges`
/// declares it: the row of each field below contains its interval, written `±h` or `[−h, h]`
/// when symmetric, `(lo, hi]` when the lower bound is excluded, `[lo, hi]` otherwise.
#[test]
fn the_scenario_reference_states_the_declared_ranges() {
    use flyarena::scenario::ranges::*;
    let doc = std::fs::read_to_string(super::root().join("docs/scenarios.md")).unwrap();
    let row = |field: &str| {
        doc.lines()
            .find(|l| l.starts_with(&format!("| `{field}`")))
            .unwrap_or_else(|| panic!("no row for `{field}`"))
            .to_string()
    };
    let forms = |lo: f64, hi: f64, open: bool| -> Vec<String> {
        let n = |x: f64| if x < 0.0 { format!("−{}", -x) } else { format!("{x}") };
        if lo == -hi && !open {
            vec![format!("±{hi}"), format!("[{}, {}]", n(lo), n(hi))]
        } else if open {
            vec![format!("({}, {}]", n(lo), n(hi))]
        } else {
            vec![format!("[{}, {}]", n(lo), n(hi))]
        }
    };
    let cases: Vec<(&str, f64, f64, bool)> = vec![
        ("duration_s", duration_s::LO, duration_s::HI, duration_s::OPEN_LO),
        ("mocap.latency_ms", latency_ms::LO, latency_ms::HI, latency_ms::OPEN_LO),
        ("mocap.noise_mm", noise_mm::LO, noise_mm::HI, noise_mm::OPEN_LO),
        ("mocap.camera_error.rotation_deg", small_angle_deg::LO, small_angle_deg::HI, small_angle_deg::OPEN_LO),
        ("mocap.camera_error.translation_mm", offset_mm::LO, offset_mm::HI, offset_mm::OPEN_LO),
        ("link.latency_ms", latency_ms::LO, latency_ms::HI, latency_ms::OPEN_LO),
        ("telemetry.latency_ms", latency_ms::LO, latency_ms::HI, latency_ms::OPEN_LO),
        ("telemetry.clock.offset_ms", clock_offset_ms::LO, clock_offset_ms::HI, clock_offset_ms::OPEN_LO),
        ("telemetry.clock.offset_ms", clock_drift_ppm::LO, clock_drift_ppm::HI, clock_drift_ppm::OPEN_LO),
        ("radio.latency_ms", latency_ms::LO, latency_ms::HI, latency_ms::OPEN_LO),
        ("radio.rate_scale_deg_s", rate_scale_deg_s::LO, rate_scale_deg_s::HI, rate_scale_deg_s::OPEN_LO),
        ("radio.angle_scale_deg", angle_scale_deg::LO, angle_scale_deg::HI, angle_scale_deg::OPEN_LO),
        ("radio.thrust_max_n", thrust_n::LO, thrust_n::HI, thrust_n::OPEN_LO),
        ("radio.failsafe_ms", failsafe_ms::LO, failsafe_ms::HI, failsafe_ms::OPEN_LO),
        ("controller.k_x", gain_per_s::LO, gain_per_s::HI, gain_per_s::OPEN_LO),
        ("controller.k_att", gain_per_s::LO, gain_per_s::HI, gain_per_s::OPEN_LO),
        ("controller.max_tilt_deg", tilt_deg::LO, tilt_deg::HI, tilt_deg::OPEN_LO),
        ("controller.velocity_cutoff_hz", cutoff_hz::LO, cutoff_hz::HI, cutoff_hz::OPEN_LO),
        ("controller.failsafe_timeout_ms", timeout_ms::LO, timeout_ms::HI, timeout_ms::OPEN_LO),
        ("controller.failsafe_thrust_fraction", thrust_fraction::LO, thrust_fraction::HI, thrust_fraction::OPEN_LO),
        ("controller.failsafe_motors_off_s", duration_s::LO, duration_s::HI, duration_s::OPEN_LO),
        ("calibration.validity_max_mean_yaw_deg", tol_deg::LO, tol_deg::HI, tol_deg::OPEN_LO),
        ("calibration.rls_min_spread_m", spread_m::LO, spread_m::HI, spread_m::OPEN_LO),
        (".home_m", position_m::LO, position_m::HI, position_m::OPEN_LO),
        (".yaw0_deg", yaw_angle_deg::LO, yaw_angle_deg::HI, yaw_angle_deg::OPEN_LO),
        (".model.rate_loop_integral_per_s2", integral_per_s2::LO, integral_per_s2::HI, integral_per_s2::OPEN_LO),
        (".model.attitude_loop_gain_per_s", gain_per_s::LO, gain_per_s::HI, gain_per_s::OPEN_LO),
        (".markers.template_m", template_m::LO, template_m::HI, template_m::OPEN_LO),
        (".markers.rotation_deg", small_angle_deg::LO, small_angle_deg::HI, small_angle_deg::OPEN_LO),
        (".markers.displacement_mm", displacement_mm::LO, displacement_mm::HI, displacement_mm::OPEN_LO),
        (".imu", offset_mm::LO, offset_mm::HI, offset_mm::OPEN_LO),
        (".disturbance", force_n::LO, force_n::HI, force_n::OPEN_LO),
        (".disturbance", torque_nm::LO, torque_nm::HI, torque_nm::OPEN_LO),
        (".battery", cells::LO, cells::HI, cells::OPEN_LO),
        (".battery", capacity_mah::LO, capacity_mah::HI, capacity_mah::OPEN_LO),
        (".battery", resistance_ohm::LO, resistance_ohm::HI, resistance_ohm::OPEN_LO),
        (".battery", charge::LO, charge::HI, charge::OPEN_LO),
        (".undeclared", thrust_scale::LO, thrust_scale::HI, thrust_scale::OPEN_LO),
        (".undeclared", drag_per_s::LO, drag_per_s::HI, drag_per_s::OPEN_LO),
        (".undeclared", delay_ms::LO, delay_ms::HI, delay_ms::OPEN_LO),
        (".undeclared", ground_effect::LO, ground_effect::HI, ground_effect::OPEN_LO),
        (".undeclared", thrust_voltage_per_v::LO, thrust_voltage_per_v::HI, thrust_voltage_per_v::OPEN_LO),
        ("- takeoff", altitude_m::LO, altitude_m::HI, altitude_m::OPEN_LO),
        ("- calibrate_gyro", radius_m::LO, radius_m::HI, radius_m::OPEN_LO),
        ("- calibrate_gyro", period_s::LO, period_s::HI, period_s::OPEN_LO),
        ("- calibrate_gyro", turns::LO, turns::HI, turns::OPEN_LO),
    ];
    let mut wrong = Vec::new();
    for (field, lo, hi, open) in cases {
        let r = row(field);
        let want = forms(lo, hi, open);
        if !want.iter().any(|w| r.contains(w.as_str())) {
            wrong.push(format!("`{field}`: declared {}, the row says: {r}", want.join(" or ")));
        }
    }
    assert!(wrong.is_empty(), "{}", wrong.join("\n"));
}

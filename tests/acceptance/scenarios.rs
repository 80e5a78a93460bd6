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
    assert!(s.requirements.identify.is_none(), "{file}: R5 is checked by `flyarena identify` (tests/acceptance/identify.rs)");
    let Outcome { main, uncompensated: unc, report } = run_scenario(&s, false);
    assert!(!report.rows.is_empty(), "{}: declares no requirements", s.name);
    assert!(report.passed(), "{}:\n{}", s.name, report.table());
    let summary = serde_json::json!({
        "scenario": s.name,
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
        insta::assert_json_snapshot!(s.name.clone(), summary);
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

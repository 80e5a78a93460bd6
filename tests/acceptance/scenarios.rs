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

#[test]
fn every_scenario_meets_its_requirements() {
    let mut files: Vec<_> = std::fs::read_dir(super::root().join("scenarios")).unwrap().map(|e| e.unwrap().path()).filter(|p| p.extension().is_some_and(|x| x == "yaml")).collect();
    files.sort();
    assert!(files.len() >= 8, "expected the scenario set, found {files:?}");
    for f in files {
        let s = Scenario::load(&f).unwrap_or_else(|e| panic!("{e}"));
        if s.requirements.identify.is_some() {
            // R5 is checked by `flyarena identify` (tests/acceptance/identify.rs)
            continue;
        }
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
}

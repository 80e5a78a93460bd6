//! A failing twin for every requirement row: each scenario below is a passing scenario of the
//! repository with one physical change (or one limit below what is measured) that must make
//! exactly the named row fail. A row that can never fail in a test is not tested.

use flyarena::requirements::Report;
use flyarena::run::run_scenario;

fn yaw_offset(edit: impl Fn(String) -> String) -> Report {
    let text = std::fs::read_to_string(super::root().join("scenarios/yaw-offset.yaml")).unwrap();
    let edited = edit(text.clone());
    assert_ne!(edited, text, "the twin must change the scenario");
    run_scenario(&super::inline(&edited), false).report
}

/// The rows whose `what` starts with `prefix` (one or more), each with its pass flag.
fn rows<'a>(r: &'a Report, id: &str, prefix: &str) -> Vec<&'a flyarena::requirements::Row> {
    let v: Vec<_> = r.rows.iter().filter(|row| row.id == id && row.what.starts_with(prefix)).collect();
    assert!(!v.is_empty(), "no {id} row `{prefix}`:\n{}", r.table());
    v
}

/// Each such row's (pass, asserted).
fn verdicts(r: &Report, id: &str, prefix: &str) -> Vec<(bool, bool)> {
    rows(r, id, prefix).iter().map(|row| (row.pass, row.asserted)).collect()
}

fn only_failing(r: &Report, id: &str, prefix: &str) {
    for row in &r.rows {
        let named = row.id == id && row.what.starts_with(prefix);
        assert_eq!(
            row.pass,
            !named,
            "{} {} should {}:\n{}",
            row.id,
            row.what,
            if named { "fail" } else { "pass" },
            r.table()
        );
    }
    rows(r, id, prefix);
}

/// The scenario itself passes every row (the twins below differ from it in one place).
#[test]
fn the_original_passes_every_row() {
    let r = yaw_offset(|t| t.replace("seed: 11", "seed: 11 "));
    assert!(r.passed(), "{}", r.table());
}

/// R1 roll and pitch: hover averaging assumes the vehicle hovers level. A steady wind tilts it
/// into the wind (by atan(F/(m·g)): 0.3 N on the X3D's 6.67 N is 2.6°), the average takes that
/// tilt for a marker offset, and the row of that axis fails (roll −1.58° for a true 1°); the
/// other axis still passes. East wind → roll, North → pitch. (The wrong estimate then spoils
/// the compensation, so R2 fails too: that is the physics, not this row's logic.)
#[test]
fn r1_roll_and_pitch_fail_in_a_steady_wind() {
    for (force, axis, other) in [("[0, 0.3, 0]", "roll", "pitch"), ("[0.3, 0, 0]", "pitch", "roll")] {
        let r =
            yaw_offset(|t| t.replace("    imu: {", &format!("    disturbance: {{ force_n: {force} }}\n    imu: {{")));
        assert!(!rows(&r, "R1", axis)[0].pass && rows(&r, "R1", other)[0].pass, "{}", r.table());
        let err: f64 = rows(&r, "R1", axis)[0].measured.trim_end_matches('°').parse().unwrap();
        // the tilt of the wind, atan(0.3/(0.68·9.81)) = 2.575°, within the hover's residual motion
        assert!((err - 2.575).abs() < 0.1, "{axis} error {err}°\n{}", r.table());
    }
}

/// R1 gyro yaw: the gyro alignment's error (≈ 0.01°) against a limit of 0.0001°.
#[test]
fn r1_gyro_yaw_fails_below_its_measured_error() {
    only_failing(&yaw_offset(|t| t.replace("yaw_tol_deg: 0.5", "yaw_tol_deg: 0.0001")), "R1", "yaw offset, gyro");
}

/// R1 straight-flight yaw: not asserted by default (blind in rate mode, docs/findings.md); asserted at
/// 0.01°, the 4° marker yaw the flight cannot see makes it fail.
#[test]
fn r1_straight_flight_yaw_fails_when_asserted() {
    let r = yaw_offset(|t| t.replace("yaw_tol_deg: 0.5 }", "yaw_tol_deg: 0.5, yaw_straight_flight_tol_deg: 0.01 }"));
    only_failing(&r, "R1", "yaw offset, straight");
    let shown = yaw_offset(|t| t.replace("seed: 11", "seed: 11 "));
    let row = rows(&shown, "R1", "yaw offset, straight")[0];
    assert!(!row.asserted && shown.table().contains("not asserted"), "{}", shown.table());
}

/// R1 straight-flight yaw in attitude mode (`yaw-attitude-mode.yaml`) without the hover trim:
/// the accelerometer's −0.03 m/s² of y bias levels the onboard estimate off by
/// ε₀ = b_y/g = −3.06·10⁻³ rad (−0.175°), so (6)'s φ_com = 0 rolls the body by ε₀, and in
/// flight the level filter, which sees the thrust axis instead of gravity, rolls it further at
/// k_a·ε₀: ε(t) = ε₀·(1 + k_a·t). The flight drifts by g·ε₀·(t²/2 + k_a·t³/6), and (8)–(9) take
/// that for a heading: the LS slope of that drift along the flown profile (6 m, 0.75 m/s,
/// 0.5 m/s² ramps) is 101.8 per radian of ε₀, an error of −atan(101.8·ε₀) = 17.3°. Noise-free
/// gyro (so that the closed form is the whole error): flown within 10 % of it; R1's other rows
/// pass, (7) accepts the flight (its mean roll is inside ε_φ = 1°), and only the spin of R2,
/// compensated with the wrong yaw, may fail besides.
#[test]
fn r1_straight_flight_yaw_fails_in_attitude_mode_without_the_trim() {
    let text = std::fs::read_to_string(super::root().join("scenarios/yaw-attitude-mode.yaml")).unwrap();
    let twin = text
        .replace("gyro_noise_deg_s: 0.5", "gyro_noise_deg_s: 0")
        .replace("seed: 11\n", "seed: 11\ncalibration: { hover_trim: false }\n");
    assert!(twin.contains("hover_trim: false") && twin.contains("accel_bias_m_s2: [0.04, -0.03, 0]"), "{twin}");
    let r = run_scenario(&super::inline(&twin), false).report;
    for row in r.rows.iter().filter(|row| row.id != "R2") {
        assert_eq!(row.pass, !row.what.starts_with("yaw offset, straight"), "{} {}\n{}", row.id, row.what, r.table());
    }
    let eps0 = -0.03 / flyarena::vehicle::params::GRAVITY;
    let k_a = flyarena::vehicle::LEVEL_GAIN_PER_S;
    let (l, v, a) = (6.0, 0.75, 0.5);
    let (ta, tc) = (v / a, (l - v * v / a) / v);
    let total = 2.0 * ta + tc;
    let (mut n, mut e) = (Vec::new(), Vec::new());
    for k in 0..(total / 0.005) as usize {
        let t = k as f64 * 0.005;
        n.push(if t < ta {
            0.5 * a * t * t
        } else if t < ta + tc {
            0.5 * v * ta + v * (t - ta)
        } else {
            l - 0.5 * a * (total - t).powi(2)
        });
        e.push(flyarena::vehicle::params::GRAVITY * eps0 * (t * t / 2.0 + k_a * t.powi(3) / 6.0));
    }
    let (mn, me) = (n.iter().sum::<f64>() / n.len() as f64, e.iter().sum::<f64>() / e.len() as f64);
    let sxy: f64 = n.iter().zip(&e).map(|(x, y)| (x - mn) * (y - me)).sum();
    let sxx: f64 = n.iter().map(|x| (x - mn).powi(2)).sum();
    let predicted = -(sxy / sxx).atan().to_degrees();
    assert!((predicted - 17.3).abs() < 0.05, "{predicted}");
    let row = rows(&r, "R1", "yaw offset, straight")[0];
    let err: f64 = row.measured.trim_end_matches('°').parse().unwrap();
    assert!((err - predicted).abs() < 0.1 * predicted, "error {err}° vs the drift's {predicted}°\n{}", r.table());
}

/// R2 both rows: without the calibration in the controller the spin drifts as uncompensated.
#[test]
fn r2_fails_without_the_calibration() {
    let r = yaw_offset(|t| t.replace("seed: 11\n", "seed: 11\ncalibration: { apply: false }\n"));
    let r2 = rows(&r, "R2", "");
    assert_eq!(r2.len(), 2, "{}", r.table());
    assert!(r2.iter().all(|row| !row.pass), "{}", r.table());
}

/// The uncompensated twin run (what R2's ratio compares with) is flown only when the scenario
/// asks for R2: a scenario without it is flown once.
#[test]
fn only_r2_flies_the_uncompensated_twin() {
    let base = "name: once\nvehicles:\n  - name: v\nplan:\n  - takeoff: { altitude_m: 1.0, duration_s: 1 }\n";
    assert!(
        run_scenario(
            &super::inline(&format!("{base}requirements:\n  offsets: {{ roll_pitch_tol_deg: 0.1 }}\n")),
            false
        )
        .uncompensated
        .is_none()
    );
    assert!(
        run_scenario(&super::inline(&format!("{base}requirements:\n  hover_drift: {{ max_m: 0.03 }}\n")), false)
            .uncompensated
            .is_some()
    );
}

/// R3 both rows: LS and RLS see the same samples and agree to rounding, so no scenario makes
/// them differ short of a bug. The twin is the flown run with the recursion's result moved by
/// 2·10⁻⁹ (rad, then m), just beyond the 10⁻⁹ limits: each row must fail on its own.
#[test]
fn r3_fails_when_the_recursion_disagrees_with_the_batch() {
    let s = super::inline(&std::fs::read_to_string(super::root().join("scenarios/yaw-offset.yaml")).unwrap());
    let out = run_scenario(&s, false);
    for (k, prefix) in [(0, "|ψ_LS"), (1, "|X_E0")] {
        let mut main = out.main.clone();
        let rls = main.vehicles[0].calibration.yaw_rls.as_mut().unwrap();
        if k == 0 {
            rls.psi_offset += 2e-9;
        } else {
            rls.x_e0 += 2e-9;
        }
        let r = flyarena::requirements::evaluate(s.requirements(), &main, out.uncompensated.as_ref());
        only_failing(&r, "R3", prefix);
    }
}

/// R1 (each row), R2, R3 and R4 on a flight whose estimates are missing (no estimate is not a
/// small error, nothing to compare is not agreement, no check is not an accepted check): each
/// row fails. Only when an external controller flies the vehicle, and reported no offsets, are
/// they shown and not asserted (its fits are its own). The straight-flight yaw row is given a
/// tolerance, so that it is asserted.
#[test]
fn rows_without_their_estimates_fail_unless_flown_externally() {
    let text = std::fs::read_to_string(super::root().join("scenarios/yaw-offset.yaml")).unwrap();
    let out = run_scenario(&super::inline(&text), false);
    let with_tol = "offsets: { roll_pitch_tol_deg: 0.1, yaw_tol_deg: 0.5, yaw_straight_flight_tol_deg: 5 }";
    let s = super::inline(&text.replacen("offsets: { roll_pitch_tol_deg: 0.1, yaw_tol_deg: 0.5 }", with_tol, 1));
    assert_eq!(s.requirements().offsets.as_ref().unwrap().yaw_straight_flight_tol_deg, Some(5.0));
    let mut main = out.main.clone();
    let cal = &mut main.vehicles[0].calibration;
    (cal.roll_pitch, cal.yaw_offset, cal.gyro) = (None, None, None);
    (cal.yaw_ls, cal.yaw_rls, cal.validity) = (None, None, None);
    let named = [
        ("R1", "roll/pitch"),
        ("R1", "yaw offset, straight"),
        ("R1", "yaw offset, gyro"),
        ("R3", "LS = RLS"),
        ("R4", "validity"),
    ];
    let rows_of = |main: &flyarena::engine::RunOutput| {
        let r = flyarena::requirements::evaluate(s.requirements(), main, out.uncompensated.as_ref());
        named.iter().map(|(id, prefix)| verdicts(&r, id, prefix)).collect::<Vec<_>>()
    };
    assert_eq!(rows_of(&main), vec![vec![(false, true)]; 5]);
    // R2 without a spin to measure fails too (an external controller does not change that: R2 is
    // measured on the flown path)
    let mut unspun = out.main.clone();
    unspun.vehicles[0].spin_max_deviation_m = None;
    let r = flyarena::requirements::evaluate(s.requirements(), &unspun, out.uncompensated.as_ref());
    assert_eq!(verdicts(&r, "R2", ""), vec![(false, true)], "{}", r.table());
    main.vehicles[0].external = true;
    assert_eq!(rows_of(&main), vec![vec![(true, false)]; 5]);
    // an external controller that did report its straight-flight estimate is held to it (the
    // guard `err.is_none() && external` without its first half showed it unasserted)
    let mut reported = out.main.clone();
    reported.vehicles[0].external = true;
    let r = flyarena::requirements::evaluate(s.requirements(), &reported, out.uncompensated.as_ref());
    assert_eq!(verdicts(&r, "R1", "yaw offset, straight"), vec![(true, true)], "{}", r.table());
}

/// R4 (7): each half rejects on its own. The flight's mean yaw and mean roll are each a
/// fraction of a degree; a limit of 0.001° on one of them (the other left at 1°) rejects, so
/// the expected "accept" fails.
#[test]
fn r4_each_half_of_check_7_rejects_alone() {
    for field in ["validity_max_mean_yaw_deg: 0.001", "validity_max_mean_roll_deg: 0.001"] {
        let r = yaw_offset(|t| t.replace("seed: 11\n", &format!("seed: 11\ncalibration: {{ {field} }}\n")));
        only_failing(&r, "R4", "validity");
    }
    // and the expectation itself: "reject" on a flight that is accepted
    only_failing(
        &yaw_offset(|t| t.replace("validity: { expect: accept }", "validity: { expect: reject }")),
        "R4",
        "validity",
    );
}

fn identify_twin(name: &str, edit: impl Fn(String) -> String) -> Report {
    let text = std::fs::read_to_string(super::root().join(format!("scenarios/identify-{name}.yaml"))).unwrap();
    let edited = edit(text.clone());
    assert_ne!(edited, text, "the twin must change the scenario");
    let dir = super::Scratch::new(&format!("twin-{}", edited.len()));
    let path = dir.join(format!("twin-{name}.yaml"));
    std::fs::write(&path, edited).unwrap();
    let done = flyarena::identify::run(&flyarena::identify::Request::new(flyarena::identify::Source::Scenario(&path)))
        .unwrap();
    done.requirements.expect("R5 declared")
}

/// R5, each row: expecting another effect first; a value outside its tolerance; a held-out cut
/// the effect cannot reach; and a second hidden effect the expectation does not list.
#[test]
fn r5_each_row_fails_in_its_twin() {
    let first = identify_twin("rotor-drag", |t| {
        t.replace(
            "{ effect: rotor_drag, values: [0.35, 0.35], tolerance: [0.02, 0.02] }",
            "{ effect: thrust_scale, values: [0.0], tolerance: [0.01] }",
        )
    });
    assert!(!rows(&first, "R5", "effect found first")[0].pass, "{}", first.table());
    let value = identify_twin("rotor-drag", |t| t.replace("values: [0.35, 0.35]", "values: [0.40, 0.35]"));
    only_failing(&value, "R5", "rotor_drag k_x");
    let cut = identify_twin("rotor-drag", |t| {
        t.replace("tolerance: [0.02, 0.02] }", "tolerance: [0.02, 0.02] }\n    min_heldout_cut: 0.99")
    });
    only_failing(&cut, "R5", "rotor_drag held-out");
    // a marker offset hidden beside the drag: it is found (first, it is the larger), and the
    // expectation does not list it
    let extra = identify_twin("rotor-drag", |t| {
        t.replace("    imu: {", "    markers: { rotation_deg: [1.5, -1.0, 3.0] }\n    imu: {")
    });
    assert!(!rows(&extra, "R5", "no effect that is not there")[0].pass, "{}", extra.table());
    assert!(rows(&extra, "R5", "rotor_drag").iter().all(|row| row.pass), "{}", extra.table());
}

/// R1 gyro yaw on an unsynchronised telemetry clock (`gyro-clock.yaml`, 15 ms ahead, 100 ppm
/// fast): with `estimate: false` the station takes the vehicle's stamps for Vicon time and the
/// row fails, by less than the steady circle's Ω·δ (2π/1.5 s × 17.5 ms, the offset at the
/// circles' middle ≈ 25 s: 4.2°) — the ramps of the circles and the hover dilute it — and by
/// more than half of it; everything else still passes.
#[test]
fn r1_gyro_yaw_fails_when_an_unsynchronised_clock_is_taken_for_the_vicons() {
    let text = std::fs::read_to_string(super::root().join("scenarios/gyro-clock.yaml")).unwrap();
    let r = run_scenario(&super::inline(&text), false).report;
    assert!(r.passed(), "{}", r.table());
    let r = run_scenario(&super::inline(&text.replace("estimate: true", "estimate: false")), false).report;
    only_failing(&r, "R1", "yaw offset, gyro");
    let err: f64 = rows(&r, "R1", "yaw offset, gyro")[0].measured.trim_end_matches('°').parse().unwrap();
    let steady = 2.0 * std::f64::consts::PI / 1.5 * 0.0175;
    assert!(
        err > 0.5 * steady.to_degrees() && err < steady.to_degrees(),
        "yaw error {err}° against Ω·δ = {}°",
        steady.to_degrees()
    );
}

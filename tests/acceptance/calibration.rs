//! Mocap–IMU calibration of a rig that is not a vehicle, from the command line: hand-held logs
//! written by `trials --handheld --logs`, read through `mappings/handheld.yaml`
//! (`vehicle: rigid_body`) and calibrated by `identify --calibrate`.

use std::path::Path;

use super::flyarena;

fn json(path: &Path) -> serde_json::Value {
    serde_json::from_slice(&std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))).unwrap()
}

/// The guide's worked example: a rig's log written, then calibrated as a user would. The
/// report fits the six calibration effects, says it had no force model because the mapping
/// declared a rigid body, names how its intervals were computed, and lands every parameter of the rotation, tilt, lever arm and
/// delay within three half-widths of the truth the batch's JSON holds (on this seed each lies
/// within its 95 % interval but one; a sign or an axis lost between the generator's definitions
/// and identify's moves a parameter by its own size, tens of half-widths). Without
/// `--calibrate` the same log's selection runs on its own and fits none of them untested.
#[test]
fn a_hand_held_rig_is_calibrated_from_its_log() {
    let d = super::Scratch::new("calibration-cli");
    let (code, out, err) =
        flyarena(&["trials", "--handheld", "--flights", "1", "--seed", "4", "--logs", "--out", "o"], &d);
    assert_eq!(code, 0, "{out}{err}");
    assert!(
        out.contains("| rotation (angle) | 1/1 |")
            && out.contains("logs: o/handheld-4-1 ")
            && d.join("o/handheld-4-1/flight-0.csv").is_file(),
        "{out}"
    );
    // the six fitted untested are the hidden ones, not effects besides them
    assert!(out.contains("effects selected besides the calibration (the rigs have none): none"), "{out}");
    let batch = json(&d.join("o/handheld-4-1.json"));
    let truth = &batch["outcomes"][0]["trial"]["truth"];
    let mapping = super::root().join("mappings/handheld.yaml");
    let (code, out, err) = flyarena(
        &[
            "identify",
            "o/handheld-4-1/flight-0.csv",
            "--mapping",
            mapping.to_str().unwrap(),
            "--calibrate",
            "--out",
            "c",
            "--no-rrd",
        ],
        &d,
    );
    assert_eq!(code, 0, "{out}{err}");
    assert!(
        out.contains("a rigid body (`vehicle: rigid_body`): no force model")
            && out.contains("fitted without testing (forced)"),
        "{out}"
    );
    // effects were fitted: the nominal model is not what explains this log
    assert!(
        out.contains("no effect besides those fitted untested passes the tests") && !out.contains("explains the data"),
        "{out}"
    );
    let report = json(&d.join("c/flight-0.identify.json"));
    // no force model: the two channels a rig has, said in the JSON
    assert_eq!(report["report"]["channels"], serde_json::json!(["accel_kin", "gyro"]));
    // `--calibrate` fits the chosen model again on every usable sample, with one noise model
    // per sensor (the result turns with the IMU's mount), and says so
    assert_eq!(report["report"]["options"]["refit_every_sample"], serde_json::json!(true));
    assert_eq!(report["report"]["options"]["mount_invariant"], serde_json::json!(true));
    // at 20 ms, the Gaussian cut at 5σ, the intervals from Parzen-weighted scores, all said
    assert_eq!(report["report"]["options"]["refit_smoothing_s"], serde_json::json!(0.02));
    assert_eq!(report["report"]["options"]["design"]["reach_sigmas"], serde_json::json!(5.0));
    assert!(
        out.contains("effects found (least squares, 95 % intervals: Parzen-weighted scores over 2 s, Student's t):"),
        "{out}"
    );
    let effects = report["report"]["effects"].as_array().unwrap();
    let keys: Vec<&str> = effects.iter().map(|e| e["effect"].as_str().unwrap()).collect();
    for key in ["body_offset", "world_tilt", "mocap_delay", "accel_bias", "gyro_bias", "lever_arm"] {
        assert!(keys.contains(&key), "{key} not in {keys:?}");
    }
    let param = |effect: &str, k: usize| {
        let p = &effects.iter().find(|e| e["effect"] == effect).unwrap()["params"][k];
        (p["value"].as_f64().unwrap(), p["ci95"].as_f64().unwrap())
    };
    let checks =
        [("body_offset", "body_offset_deg", 3), ("world_tilt", "world_tilt_deg", 2), ("lever_arm", "lever_arm_mm", 3)];
    for (effect, field, n) in checks {
        for k in 0..n {
            let ((v, ci), t) = (param(effect, k), truth[field][k].as_f64().unwrap());
            assert!((v - t).abs() <= 3.0 * ci && ci > 0.0, "{effect}[{k}]: {v} ± {ci} against {t}");
        }
    }
    let ((v, ci), t) = (param("mocap_delay", 0), truth["mocap_delay_ms"].as_f64().unwrap());
    assert!((v - t).abs() <= 3.0 * ci, "delay {v} ± {ci} against {t}");
    let (code, out, err) = flyarena(
        &["identify", "o/handheld-4-1/flight-0.csv", "--mapping", mapping.to_str().unwrap(), "--out", "s", "--no-rrd"],
        &d,
    );
    assert_eq!(code, 0, "{out}{err}");
    assert!(!out.contains("fitted without testing"), "{out}");
}

/// A rigid body has no floor: a hand-held log moves below where it started, and read as the
/// `x3d` vehicle (a log taken to start at rest on the ground) every row more than 8 cm below its
/// first half second is left out as "under the floor"; read as `rigid_body` none is. The rows
/// the fit trains on are then more. A rigid body's mapping with motors is a usage error.
#[test]
fn a_rigid_body_has_no_floor_and_no_motors() {
    let d = super::Scratch::new("calibration-floor");
    let (code, out, err) =
        flyarena(&["trials", "--handheld", "--flights", "1", "--seed", "2", "--logs", "--out", "o"], &d);
    assert_eq!(code, 0, "{out}{err}");
    let rigid = std::fs::read_to_string(super::root().join("mappings/handheld.yaml")).unwrap();
    std::fs::write(d.join("x3d.yaml"), rigid.replace("vehicle: rigid_body", "vehicle: x3d")).unwrap();
    std::fs::write(d.join("rigid.yaml"), &rigid).unwrap();
    let mut train = Vec::new();
    for m in ["x3d.yaml", "rigid.yaml"] {
        let (code, out, err) = flyarena(
            &[
                "identify",
                "o/handheld-2-1/flight-0.csv",
                "--mapping",
                m,
                "--calibrate",
                "--out",
                &format!("out-{m}"),
                "--no-rrd",
                "--json",
                &format!("{m}.json"),
            ],
            &d,
        );
        assert_eq!(code, 0, "{out}{err}");
        train.push(json(&d.join(format!("{m}.json")))["report"]["train_samples"].as_u64().unwrap());
    }
    // on this seed 776 against 873 (one decimated sample per 50 ms: about 5 s of the log)
    assert!(train[1] >= train[0] + 50, "train samples x3d {} rigid body {}", train[0], train[1]);
    std::fs::write(d.join("motors.yaml"), rigid + "motors: { columns: [m1, m2, m3, m4] }\n").unwrap();
    let (code, out, err) = flyarena(
        &["identify", "o/handheld-2-1/flight-0.csv", "--mapping", "motors.yaml", "--out", "m", "--no-rrd"],
        &d,
    );
    assert_eq!(code, 2, "{out}{err}");
    assert!(err.contains("motors.yaml") && err.contains("`vehicle: rigid_body` declares no force model"), "{err}");
}

/// The Monte Carlo table of docs/calibration.md, rig for rig: 100 hand-held rigs of seed 1 at
/// MoCap2GT's setting, calibrated as `trials --handheld --flights 100 --seed 1` does, give the
/// guide's medians, 90th percentiles and largest errors (to their printed digit) and its
/// coverage counts exactly, and its two Cramér–Rao columns (an efficient estimator's median
/// errors under each rig's bound, with a perfect mocap and on the log as recorded) to their
/// digit, the fit's median above 0.9× each. A change in the generator,
/// the reader, the method or the bound moves one of them; then the guide's table is rerun with it.
#[test]
fn the_guides_monte_carlo_table_is_what_the_rigs_give() {
    use flyarena::identify::handheld::{BOUND_DRAWS, Outcome, Setting, options, run_many};
    let set = Setting::default();
    let out = run_many(1, 100, &set, &options());
    assert!(out.iter().all(|o| o.error.is_none()));
    let q = |mut v: Vec<f64>, p: f64| {
        v.sort_by(f64::total_cmp);
        let h = p * (v.len() - 1) as f64;
        let (lo, hi) = (h.floor() as usize, h.ceil() as usize);
        v[lo] + (v[hi] - v[lo]) * (h - lo as f64)
    };
    type Err = fn(&Outcome) -> Option<f64>;
    let rows: [(&str, Err, [f64; 3], f64); 4] = [
        ("rotation", |o| o.rotation_err_deg, [0.0070, 0.0118, 0.0201], 1e-4),
        ("tilt", |o| o.tilt_err_deg, [0.054, 0.119, 0.209], 1e-3),
        ("lever arm", |o| o.lever_err_mm, [0.54, 1.16, 1.76], 1e-2),
        ("time offset", |o| o.delay_err_us, [8.9, 21.6, 37.4], 0.1),
    ];
    for (name, err, want, digit) in rows {
        let e: Vec<f64> = out.iter().filter_map(err).collect();
        assert_eq!(e.len(), 100, "{name}");
        for (p, w) in [0.5, 0.9, 1.0].into_iter().zip(want) {
            let got = q(e.clone(), p);
            assert!((got - w).abs() <= digit / 2.0 + 1e-12, "{name} q{p}: {got} against the guide's {w}");
        }
    }
    for (prefix, covered, of) in [
        ("body_offset.", 284, 300),
        ("world_tilt.", 187, 200),
        ("lever_arm.", 283, 300),
        ("mocap_delay.", 97, 100),
        ("accel_bias.", 282, 300),
        ("gyro_bias.", 293, 300),
    ] {
        let est: Vec<_> = out.iter().flat_map(|o| &o.estimates).filter(|e| e.name.starts_with(prefix)).collect();
        assert_eq!((est.iter().filter(|e| e.covered()).count(), est.len()), (covered, of), "{prefix}");
    }
    // the Cramér–Rao columns: an efficient estimator's median errors with a perfect mocap and
    // on the log as recorded. The fit's median comes near them, and a median of 100 rigs may
    // fall a little below a floor (the lever arm's is 0.98× the one as recorded): its sampling
    // spread is about 8 % (the median of 100 draws of a norm of normals). Under 0.9× a floor, the
    // floor or the scoring would be wrong.
    type Floor = fn(&Outcome) -> Option<&flyarena::identify::handheld::Bound>;
    let floors: [(Floor, [(f64, f64); 4]); 2] = [
        (|o| o.bound.as_ref(), [(0.0054, 1e-4), (0.0477, 1e-4), (0.540, 1e-3), (6.7, 0.1)]),
        (|o| o.bound_as_recorded.as_ref(), [(0.0066, 1e-4), (0.0482, 1e-4), (0.556, 1e-3), (8.7, 0.1)]),
    ];
    for (floor, bounds) in floors {
        let draws: Vec<[f64; 4]> = out
            .iter()
            .flat_map(|o| {
                floor(o).expect("every rig's motion sees every parameter").draws(o.trial.index, BOUND_DRAWS).unwrap()
            })
            .collect();
        for (i, ((name, err, _, _), (want, digit))) in rows.into_iter().zip(bounds).enumerate() {
            let bound = q(draws.iter().map(|d| d[i]).collect(), 0.5);
            let achieved = q(out.iter().filter_map(err).collect(), 0.5);
            assert!(
                (bound - want).abs() <= digit / 2.0 + 1e-12 && 0.9 * bound < achieved,
                "{name}: bound {bound} against the guide's {want}, the fit's {achieved}"
            );
        }
    }
}

/// `trials --handheld --setting FILE` runs rigs at a setting the user writes, the fields left
/// out at MoCap2GT's, into a report named by the setting (`handheld-short-3-1.json`: another
/// setting's batch of the same seed and size does not overwrite it); a field out of its range is
/// refused with the file, line, column and the allowed range (exit 2), and nothing is written.
#[test]
fn a_rig_setting_is_read_from_yaml_and_checked() {
    let d = super::Scratch::new("rig-setting");
    std::fs::write(d.join("short.yaml"), "duration_s: 20\nimu_hz: 200\n").unwrap();
    let (code, out, err) = flyarena(
        &["trials", "--handheld", "--flights", "1", "--seed", "3", "--setting", "short.yaml", "--out", "o"],
        &d,
    );
    assert_eq!(code, 0, "{out}{err}");
    assert!(out.starts_with("1 hand-held flight of 20 s (mocap 300 Hz, IMU 200 Hz), 1 identified"), "{out}");
    assert!(!d.join("o/handheld-3-1.json").exists());
    let setting = &json(&d.join("o/handheld-short-3-1.json"))["setting"];
    assert_eq!(
        (setting["imu_hz"].as_f64(), setting["mocap_hz"].as_f64(), setting["gyro_noise_density"].as_f64()),
        (Some(200.0), Some(300.0), Some(8.39e-4))
    );
    std::fs::write(d.join("bad.yaml"), "imu_hz: 200\ngyro_noise_density: 0.5\n").unwrap();
    let (code, out, err) =
        flyarena(&["trials", "--handheld", "--flights", "1", "--setting", "bad.yaml", "--out", "bad"], &d);
    assert_eq!(code, 2, "{out}{err}");
    assert!(
        err.contains("bad.yaml")
            && err.contains("line 2 column 21")
            && err.contains("0.5 rad/s/√Hz is outside the allowed range [0, 0.1]"),
        "{err}"
    );
    assert!(!d.join("bad").exists());
}

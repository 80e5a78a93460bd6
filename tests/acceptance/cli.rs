//! The command line as a user runs it: exit codes, outputs, and the errors for bad scenarios.

use super::flyarena;

fn tmp(name: &str) -> super::Scratch {
    super::Scratch::new(&format!("test-{name}"))
}

#[test]
fn run_passes_prints_the_table_and_writes_the_summary() {
    let d = tmp("run");
    let scen = super::root().join("scenarios/fig6-roll-pitch-offsets.yaml");
    let (code, out, err) = flyarena(&["run", scen.to_str().unwrap(), "--out", "o"], &d);
    assert_eq!(code, 0, "{out}{err}");
    assert!(out.contains("R2") && out.contains("PASS"), "{out}");
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(d.join("o/fig6-roll-pitch-offsets.json")).unwrap()).unwrap();
    assert_eq!(json["passed"], true);
    assert!(json["vehicles"][0]["spin_max_deviation_uncompensated_m"].as_f64().unwrap() > 0.3);
    // the recording is there and decodes; no temporary files left behind
    let mut names: Vec<String> = std::fs::read_dir(d.join("o"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    let want: &[&str] = if cfg!(feature = "record") {
        &["fig6-roll-pitch-offsets.json", "fig6-roll-pitch-offsets.rrd"]
    } else {
        &["fig6-roll-pitch-offsets.json"]
    };
    assert_eq!(names, want);
    #[cfg(feature = "record")]
    {
        let rec = flyarena::record::decode(&std::fs::read(d.join("o/fig6-roll-pitch-offsets.rrd")).unwrap()).unwrap();
        assert!(!rec.scalars("/plots/x3d/attitude/roll/measured").is_empty());
    }
}

#[cfg(feature = "record")]
#[test]
fn rrd_path_and_no_rrd() {
    let d = tmp("rrd");
    let scen = super::root().join("scenarios/fig7-no-offsets.yaml");
    let (code, out, err) = flyarena(&["run", scen.to_str().unwrap(), "--out", "o", "--no-rrd", "-q"], &d);
    assert_eq!(code, 0, "{out}{err}");
    assert!(!d.join("o/fig7-no-offsets.rrd").exists());
    let (code, out, err) =
        flyarena(&["run", scen.to_str().unwrap(), "--out", "o", "--rrd", "r/x.rrd", "--rrd-every", "1", "-q"], &d);
    assert_eq!(code, 0, "{out}{err}");
    assert!(d.join("r/x.rrd").metadata().unwrap().len() > 10_000);
    let (code, _, err) = flyarena(&["run", scen.to_str().unwrap(), "--rrd", "a.rrd", "--no-rrd"], &d);
    assert_eq!(code, 2);
    assert!(err.contains("cannot be used with"), "{err}");
    let (code, _, err) = flyarena(&["run", scen.to_str().unwrap(), "--rrd-every", "0"], &d);
    assert_eq!(code, 2);
    assert!(err.contains("--rrd-every") && err.contains("1..=1000"), "{err}");
}

#[test]
fn a_failed_requirement_exits_1() {
    let d = tmp("fail");
    let y = std::fs::read_to_string(super::root().join("scenarios/fig6-roll-pitch-offsets.yaml")).unwrap();
    std::fs::write(d.join("s.yaml"), y.replace("roll_pitch_tol_deg: 0.1", "roll_pitch_tol_deg: 0.00001")).unwrap();
    let (code, out, _) = flyarena(&["run", "s.yaml"], &d);
    assert_eq!(code, 1, "{out}");
    assert!(out.contains("FAIL"));
}

/// Bad scenarios: exit 2 with file:line:column, field path and what is allowed. The exact
/// messages are pinned (insta) so that a regression in their quality is seen in review.
#[test]
fn bad_scenarios_exit_2_with_located_messages() {
    let good = std::fs::read_to_string(super::root().join("scenarios/fig6-roll-pitch-offsets.yaml")).unwrap();
    let cases: Vec<(&str, String)> = vec![
        ("unknown-field", good.replace("rotation_deg: [3, 3, 0]", "rotaton_deg: [3, 3, 0]")),
        ("out-of-range", good.replace("seed: 6", "seed: 6\nlink: { loss: { bernoulli: 1.5 } }")),
        ("negative-duration", good.replace("duration_s: 20", "duration_s: -20")),
        ("rate-not-dividing", good.replace("seed: 6", "seed: 6\nmocap: { rate_hz: 300 }")),
        ("wrong-type", good.replace("altitude_m: 1.0", "altitude_m: high")),
        ("duplicate-key", good.replace("seed: 6", "seed: 6\nseed: 7")),
        ("collinear-markers", good.replace("      rotation_deg: [3, 3, 0]", "      template_m: [[0, 0, 0], [0.1, 0, 0], [0.2, 0, 0], [0.3, 0, 0]]")),
        ("collinear-as-mounted", good.replace("      rotation_deg: [3, 3, 0]", "      displacement_mm: [[0, 0, 0], [0, -170, 0], [0, 0, 0], [100, 100, 20]]")),
        ("heavy-vehicle", good.replace("    markers:", "    model: { mass_kg: 3 }\n    markers:")),
        ("gyro-delay-off-period", good.replace("    markers:", "    undeclared: { gyro_delay_ms: 3 }\n    markers:")),
        (
            "duplicate-pattern",
            good.replace("  - name: x3d\n", "  - name: a\n    markers: { pattern: 2 }\n  - name: x3d\n    home_m: [2, 0]\n    markers: { pattern: 2 }\n  - name: c\n")
                .replace("    markers:\n      rotation_deg: [3, 3, 0]\n", ""),
        ),
        ("not-yaml", "name: [unclosed\n".into()),
    ];
    let d = tmp("bad");
    let mut report = String::new();
    for (name, yaml) in cases {
        let file = format!("{name}.yaml");
        std::fs::write(d.join(&file), yaml).unwrap();
        let (code, out, err) = flyarena(&["check", &file], &d);
        assert_eq!(code, 2, "{name}: {out}{err}");
        let first = err.lines().next().unwrap_or("").to_string();
        assert!(first.starts_with(&format!("error: {file}")), "{name}: {err}");
        assert!(!err.contains("panicked"), "{name}: {err}");
        report.push_str(&format!("{first}\n"));
        let (code, _, _) = flyarena(&["run", &file], &d);
        assert_eq!(code, 2, "{name}: run must refuse it too");
    }
    insta::with_settings!({ snapshot_path => "../../snapshots", prepend_module_to_snapshot => false }, {
        insta::assert_snapshot!("bad-scenario-messages", report);
    });
}

#[test]
fn usage_errors_exit_2() {
    let d = tmp("usage");
    assert_eq!(flyarena(&[], &d).0, 2);
    assert_eq!(flyarena(&["fly"], &d).0, 2);
    assert_eq!(flyarena(&["run"], &d).0, 2);
    assert_eq!(flyarena(&["run", "missing.yaml"], &d).0, 2);
    assert_eq!(flyarena(&["run", "x.yaml", "--seed", "minus"], &d).0, 2);
    assert_eq!(flyarena(&["--help"], &d).0, 0);
}

#[test]
fn identify_exit_codes_outputs_and_the_fragment_round_trip() {
    let d = tmp("identify");
    let scen = super::root().join("scenarios/identify-wind.yaml");
    let (code, out, err) = flyarena(&["identify", scen.to_str().unwrap(), "--out", "o"], &d);
    assert_eq!(code, 0, "{out}{err}");
    assert!(
        out.contains("constant force") && out.contains("closed loop") && out.contains("R5") && out.contains("PASS"),
        "{out}"
    );
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(d.join("o/identify-wind.identify.json")).unwrap()).unwrap();
    assert_eq!(json["report"]["effects"][0]["effect"], "constant_force");
    // a vehicle with motor commands: the force model's channel too
    assert_eq!(json["report"]["channels"], serde_json::json!(["accel_kin", "gyro", "force"]));
    let frag = std::fs::read_to_string(d.join("o/identify-wind.effects.yaml")).unwrap();
    assert!(frag.contains("vehicles[0].disturbance.force_n"), "{frag}");
    // the fragment is accepted by run and puts the wind into the nominal scenario
    let none = super::root().join("scenarios/identify-none.yaml");
    let (code, out, err) = flyarena(
        &["run", none.to_str().unwrap(), "--effects", "o/identify-wind.effects.yaml", "--no-rrd", "--json", "w.json"],
        &d,
    );
    assert_eq!(code, 0, "{out}{err}");
    // a wrong expectation fails R5: exit 1
    let src = std::fs::read_to_string(&scen).unwrap().replace("values: [0.4, -0.2, 0.0]", "values: [0.5, -0.2, 0.0]");
    std::fs::write(d.join("wrong.yaml"), src).unwrap();
    let (code, out, _) = flyarena(&["identify", "wrong.yaml", "--out", "o", "-q"], &d);
    assert_eq!(code, 1, "{out}");
    assert!(out.contains("FAIL"), "{out}");
    // bad input: exit 2 with the reason
    let (code, _, err) = flyarena(&["identify", "log.csv"], &d);
    assert_eq!(code, 2);
    assert!(err.contains("--scenario") && err.contains("--mapping"), "{err}");
    std::fs::write(d.join("frag.yaml"), "effects:\n  vehicles[0].undeclared.thrust_scale: 3.0\n").unwrap();
    let (code, _, err) = flyarena(&["run", none.to_str().unwrap(), "--effects", "frag.yaml", "--no-rrd"], &d);
    assert_eq!(code, 2);
    assert!(err.contains("thrust_scale") && err.contains("1.5"), "{err}");
    // a wrong value is named at the fragment's entry and line, not in the merged tree no file holds
    std::fs::write(
        d.join("frag.yaml"),
        "effects:\n  vehicles[0].disturbance.force_n: [0.1, 0, 0]\n  vehicles[0].undeclared.thrust_scale: x\n",
    )
    .unwrap();
    let (code, _, err) = flyarena(&["run", none.to_str().unwrap(), "--effects", "frag.yaml", "--no-rrd"], &d);
    assert_eq!(code, 2);
    assert_eq!(err.trim(), "error: frag.yaml:3: `vehicles[0].undeclared.thrust_scale`: invalid floating point");
    // the YAML parser's advice to programmers does not reach the file's author
    std::fs::write(
        d.join("frag.yaml"),
        "effects:\n  vehicles[0].undeclared.thrust_scale: 1.1\n  vehicles[0].undeclared.thrust_scale: 1.2\n",
    )
    .unwrap();
    let (code, _, err) = flyarena(&["run", none.to_str().unwrap(), "--effects", "frag.yaml", "--no-rrd"], &d);
    assert_eq!(code, 2);
    assert!(
        err.contains("duplicate mapping key")
            && err.contains("(a key may appear once)")
            && !err.contains("DuplicateKeyPolicy"),
        "{err}"
    );
    let (code, _, err) = flyarena(&["identify", "a.csv", "--mapping", "m.yaml", "--with", "magic"], &d);
    assert_eq!(code, 2);
    assert!(err.contains("`magic`") && err.contains("body_offset"), "{err}");
}

/// The mapping of [`circling_log`].
const CIRCLING_MAPPING: &str = "vehicle: crazyflie21\ntime: { column: t }\nposition: { columns: [px, py, pz], unit: m }\nattitude: { columns: [qw, qx, qy, qz], order: wxyz }\nworld: z_up\nbody: flu\ngyro: { columns: [gx, gy, gz], unit: rad/s }\naccel: { columns: [ax, ay, az], unit: g }\n";

/// A synthetic log of another tool, `rows` rows at 100 Hz: half a second on the ground, then
/// up to 1 m while circling.
fn circling_log(rows: usize) -> String {
    let mut csv = String::from("t,px,py,pz,qw,qx,qy,qz,gx,gy,gz,ax,ay,az\n");
    for k in 0..rows {
        let t = k as f64 * 0.01;
        let z = if k < 50 { 0.0 } else { (t - 0.5).min(1.0) };
        // level, circling at 0.3 m and 2 rad/s: the accelerometer reads the centripetal
        // acceleration (1.2 m/s²) and gravity, with a little noise (a reading repeated bit for
        // bit while the vehicle manoeuvres is a frozen sensor, which identify cuts out)
        let wob = 1e-4 * ((k * 7919 % 13) as f64 - 6.0);
        let (ax, ay) = (-1.2 * (2.0 * t).cos() / 9.81 + wob, -1.2 * (2.0 * t).sin() / 9.81 - wob);
        csv += &format!(
            "{t},{},{},{z},1,0,0,0,{wob},{},{},{ax},{ay},{}\n",
            0.3 * (2.0 * t).cos(),
            0.3 * (2.0 * t).sin(),
            -wob,
            0.5 * wob,
            1.0 + wob
        );
    }
    csv
}

/// `identify --quiet` on a log prints one line, its verdict: the effects found, or, for a flight
/// too short to try any, that nothing was identified and why (not "the nominal model explains
/// the data", which a flight without a usable sample cannot show).
#[test]
fn identify_quiet_prints_a_logs_verdict() {
    let d = tmp("quiet");
    std::fs::write(d.join("m.yaml"), CIRCLING_MAPPING).unwrap();
    std::fs::write(d.join("short.csv"), circling_log(10)).unwrap();
    std::fs::write(d.join("c.csv"), circling_log(1500)).unwrap();
    let (code, out, err) =
        flyarena(&["identify", "short.csv", "--mapping", "m.yaml", "--out", "o", "--no-rrd", "-q"], &d);
    assert_eq!(code, 0, "{out}{err}");
    assert_eq!(out, "short.csv: nothing identified: 0 usable training samples, 200 needed\n");
    let (code, out, err) = flyarena(&["identify", "short.csv", "--mapping", "m.yaml", "--out", "o", "--no-rrd"], &d);
    assert_eq!(code, 0, "{out}{err}");
    assert!(
        out.contains("too few usable samples to select effects (0 for training, 200 needed)")
            && !out.contains("explains the data")
            && !out.contains("p=1.00"),
        "{out}"
    );
    let (code, out, err) = flyarena(&["identify", "c.csv", "--mapping", "m.yaml", "--out", "o", "--no-rrd", "-q"], &d);
    assert_eq!(code, 0, "{out}{err}");
    assert!(out.lines().count() == 1 && out.starts_with("c.csv: ") && out.contains("found"), "{out}");
}

/// A mapping's errors end where the fix is: a column the log lacks names the mapping's file and
/// key and suggests the closest column the mapping does not already read (for `az`, not `ax`,
/// which `accel.columns[0]` reads; for `gx`, not `px`); a typo in a key
/// is one error, located in the mapping's file, whose list of keys holds the blocks of the
/// other forms (`px4`) and whose "did you mean" comes from that list; a log without a mapping
/// is pointed to the shipped one for its format.
#[test]
fn a_mappings_errors_name_the_file_the_key_and_the_fix() {
    let d = tmp("mapping-errors");
    std::fs::write(
        d.join("c.csv"),
        circling_log(300)
            .replace("t,px,py,pz,qw,qx,qy,qz,gx,gy,gz,ax,ay,az", "t,px,py,pz,qw,qx,qy,qz,gx,gy,gz,ax,ay,acc_z"),
    )
    .unwrap();
    std::fs::write(d.join("m.yaml"), CIRCLING_MAPPING).unwrap();
    let (code, _, err) = flyarena(&["identify", "c.csv", "--mapping", "m.yaml", "--no-rrd"], &d);
    assert_eq!(code, 2, "{err}");
    assert_eq!(
        err.trim(),
        "error: c.csv:1: the header has no column `az`, which m.yaml names in `accel.columns[2]` (is it `acc_z`?)"
    );
    std::fs::write(d.join("g.csv"), circling_log(300).replace(",gx,", ",g_x,")).unwrap();
    let (code, _, err) = flyarena(&["identify", "g.csv", "--mapping", "m.yaml", "--no-rrd"], &d);
    assert_eq!(code, 2, "{err}");
    assert_eq!(
        err.trim(),
        "error: g.csv:1: the header has no column `gx`, which m.yaml names in `gyro.columns[0]` (is it `g_x`?)"
    );
    std::fs::write(d.join("typo.yaml"), CIRCLING_MAPPING.replace("\ngyro:", "\ngyor:")).unwrap();
    let (code, _, err) = flyarena(&["identify", "c.csv", "--mapping", "typo.yaml", "--no-rrd"], &d);
    assert_eq!(code, 2, "{err}");
    let first = err.lines().next().unwrap();
    assert!(
        first.starts_with("error: typo.yaml:7:1: field `gyor`: unknown field `gyor`")
            && first.contains("px4")
            && first.ends_with("did you mean `gyro`?"),
        "{err}"
    );
    assert_eq!(err.matches("error:").count(), 1, "{err}");
    assert!(err.contains("--> typo.yaml:7:1") && !err.contains("<input>"), "{err}");
    let (code, _, err) = flyarena(&["identify", "flight.ulg", "--no-rrd"], &d);
    assert_eq!(code, 2, "{err}");
    assert!(err.contains("--mapping mappings/px4.yaml"), "{err}");
    let (_, _, err) = flyarena(&["identify", "c.csv", "--no-rrd"], &d);
    assert!(err.contains("mappings/nanobench.yaml") && err.contains("mappings/imu-tum.yaml"), "{err}");
}

/// Two logs of one name from two folders do not share a report: the second `identify` into the
/// same folder refuses (exit 2, naming the report, what made it and the ways out) and leaves the
/// first report as it was; the same log again replaces its own report, `--overwrite` replaces
/// the other's, and `--json` names a report of its own. The same holds for a cross-validation
/// of other flights.
#[test]
fn identify_never_silently_replaces_another_logs_report() {
    let d = tmp("collide");
    std::fs::write(d.join("m.yaml"), CIRCLING_MAPPING).unwrap();
    for (dir, n) in [("a", 600), ("b", 700)] {
        std::fs::create_dir_all(d.join(dir)).unwrap();
        std::fs::write(d.join(dir).join("flight.csv"), circling_log(n)).unwrap();
    }
    let ident = |extra: &[&str]| {
        flyarena(&[&["identify", "--mapping", "m.yaml", "--out", "o", "--no-rrd", "-q"], extra].concat(), &d)
    };
    let report = || std::fs::read(d.join("o/flight.identify.json")).unwrap();
    assert_eq!(ident(&["a/flight.csv"]).0, 0);
    let first = report();
    assert_eq!(ident(&["a/flight.csv"]).0, 0, "the same log replaces its own report");
    let (code, out, err) = ident(&["b/flight.csv"]);
    assert_eq!(code, 2, "{out}{err}");
    assert!(
        err.contains("o/flight.identify.json holds the report of `a/flight.csv`, not of `b/flight.csv`")
            && err.contains("--out DIR")
            && err.contains("--overwrite"),
        "{err}"
    );
    assert_eq!(report(), first, "the refused run left the first report as it was");
    assert_eq!(ident(&["b/flight.csv", "--json", "o/b.json"]).0, 0);
    assert_eq!(ident(&["b/flight.csv", "--overwrite"]).0, 0);
    let json: serde_json::Value = serde_json::from_slice(&report()).unwrap();
    assert_eq!(json["report"]["source"], "b/flight.csv");
    // a cross-validation of other flights
    std::fs::copy(d.join("a/flight.csv"), d.join("a/other.csv")).unwrap();
    assert_eq!(ident(&["a/flight.csv", "a/other.csv"]).0, 0);
    let (code, _, err) = ident(&["b/flight.csv", "a/other.csv", "a/flight.csv"]);
    assert_eq!(code, 2, "{err}");
    assert!(
        err.contains("holds the report of the flights flight, other, not of the flights flight, flight, other"),
        "{err}"
    );
}

/// Regression: the cross-validation table cut flight names at 12 bytes and panicked inside a
/// multi-byte character. Two synthetic logs through a mapping, one with such a name.
#[test]
fn cross_validation_with_non_ascii_flight_names() {
    let d = tmp("crossval");
    let csv = circling_log(600);
    std::fs::write(d.join("aéééééééé.csv"), &csv).unwrap();
    std::fs::write(d.join("b.csv"), &csv).unwrap();
    std::fs::write(d.join("m.yaml"), CIRCLING_MAPPING).unwrap();
    let (code, out, err) = flyarena(&["identify", "aéééééééé.csv", "b.csv", "--mapping", "m.yaml", "--out", "o"], &d);
    assert_eq!(code, 0, "{out}{err}");
    assert!(out.contains("cross-validation") && out.contains("aéééééééé"), "{out}");
}

/// Names that become file names are restricted to a safe set, checked where they are read (file,
/// line, column, the allowed set): a scenario from someone else cannot write outside `--out`.
/// Each hostile name exits 2 and writes nothing anywhere; a safe one runs.
#[test]
fn hostile_names_are_rejected_before_anything_is_written() {
    let d = tmp("hostile");
    let long = "a".repeat(101);
    let cases: [(&str, &str); 11] = [
        ("../escaped", "'/'"),
        ("/etc/flyarena", "'/'"),
        ("a/b", "'/'"),
        ("a\\\\b", "'\\\\'"),
        ("\"nul\\0byte\"", "'\\0'"),
        ("CON", "device name"),
        ("lpt1.json", "device name"),
        (".hidden", "starts with `.`"),
        ("..", "starts with `.`"),
        ("\"\"", "is empty"),
        (&long, "at most 100"),
    ];
    for (k, (name, why)) in cases.iter().enumerate() {
        let dir = d.join(format!("case{k}"));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(
            dir.join("s.yaml"),
            format!(
                "name: {name}\nvehicles:\n  - {{ name: v }}\nplan:\n  - takeoff: {{ altitude_m: 1, duration_s: 2 }}\n"
            ),
        )
        .unwrap();
        let (code, out, err) = flyarena(&["run", "s.yaml", "--out", "o", "--log", "o/log.csv"], &dir);
        assert_eq!(code, 2, "{name}: {out}{err}");
        assert!(
            err.contains("s.yaml:1:7")
                && err.contains(why)
                && err.contains("letters A–Z")
                    | err.contains("at most")
                    | err.contains("device")
                    | err.contains("starts with"),
            "{name}: {err}"
        );
        let entries: Vec<_> = std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().file_name()).collect();
        assert_eq!(entries, vec![std::ffi::OsString::from("s.yaml")], "{name}: something was written");
    }
    // a vehicle's name becomes PATH-<vehicle>.csv: the same rule, located at the vehicle
    let dir = d.join("vehicle");
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("s.yaml"), "name: ok\nvehicles:\n  - { name: a }\n  - { name: ../b }\nplan:\n  - takeoff: { altitude_m: 1, duration_s: 2 }\n").unwrap();
    let (code, _, err) = flyarena(&["run", "s.yaml", "--out", "o"], &dir);
    assert_eq!(code, 2);
    assert!(err.contains("s.yaml:4:") && err.contains("'/'"), "{err}");
    // the safe set runs
    std::fs::write(
        dir.join("s.yaml"),
        "name: Fig-6_v2.1\nvehicles:\n  - { name: x3d }\nplan:\n  - takeoff: { altitude_m: 1, duration_s: 2 }\n",
    )
    .unwrap();
    let (code, out, err) = flyarena(&["run", "s.yaml", "--out", "o", "--no-rrd"], &dir);
    assert_eq!(code, 0, "{out}{err}");
    assert!(dir.join("o/Fig-6_v2.1.json").exists());
}

/// A declared command line: every subcommand answers --help (exit 0) from its declaration,
/// --version names the crate's version, completions are generated, a bad value exits 2.
#[test]
fn every_command_has_help_version_and_completions() {
    let d = tmp("help");
    for cmd in ["run", "check", "sweep", "merge", "identify", "trials", "completions"] {
        let (code, out, err) = flyarena(&[cmd, "--help"], &d);
        assert_eq!(code, 0, "{cmd}: {err}");
        assert!(out.contains("Usage: flyarena") && out.contains(cmd), "{cmd}: {out}");
    }
    // `identify --help` names every hypothesis that is fitted only with --with
    let (_, help, _) = flyarena(&["identify", "--help"], &d);
    let help = help.split_whitespace().collect::<Vec<_>>().join(" ");
    for e in flyarena::identify::Effect::ALL.iter().filter(|e| !e.searched()) {
        assert!(help.contains(e.key()), "identify --help does not name the hypothesis {}: {help}", e.key());
    }
    // and every input format it reads
    for format in [".ulg", ".mcap", "ASL/EuRoC folder", "TUM", "--poses", "--scenario", "CSV"] {
        assert!(help.contains(format), "identify --help does not name {format}: {help}");
    }
    let (code, out, _) = flyarena(&["--version"], &d);
    assert_eq!((code, out.trim()), (0, format!("flyarena {}", env!("CARGO_PKG_VERSION")).as_str()));
    for shell in ["bash", "zsh", "fish"] {
        let (code, out, err) = flyarena(&["completions", shell], &d);
        assert_eq!(code, 0, "{err}");
        assert!(out.contains("identify") && out.contains("rrd-every"), "{shell}");
    }
    let (code, _, err) = flyarena(&["sweep", "x.yaml", "--shard", "3/2"], &d);
    assert_eq!(code, 2);
    assert!(err.contains("1 ≤ K ≤ N"), "{err}");
    let (code, _, err) = flyarena(&["run", "x.yaml", "--rrd", "a.rrd", "--no-rrd"], &d);
    assert_eq!(code, 2);
    assert!(err.contains("--no-rrd"), "{err}");
}

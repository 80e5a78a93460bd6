//! Sweeps: independent of thread count and sharding, bit for bit; bad specs rejected clearly.

use super::root;
use flyarena::sweep::{Sweep, SweepOutput, merge};
use std::process::Command;

fn scenario() -> std::path::PathBuf {
    root().join("scenarios/sweep-hover-duration.yaml")
}

fn flyarena(args: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_flyarena")).args(args).output().unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into(),
        String::from_utf8_lossy(&out.stderr).into(),
    )
}

fn flyarena_in(dir: &std::path::Path, args: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_flyarena")).args(args).current_dir(dir).output().unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into(),
        String::from_utf8_lossy(&out.stderr).into(),
    )
}

#[test]
fn results_do_not_depend_on_threads_or_shards() {
    let s = Sweep::load(&scenario()).unwrap();
    let pool = |n| rayon::ThreadPoolBuilder::new().num_threads(n).build().unwrap();
    let one = pool(1).install(|| s.run(16, None, &|| {})).unwrap();
    let three = pool(3).install(|| s.run(16, None, &|| {})).unwrap();
    assert_eq!(one, three);
    let shards: Vec<_> = (0..3).map(|k| s.run(16, Some((k, 3)), &|| {}).unwrap()).collect();
    assert_eq!(merge(shards).unwrap(), one);
    // every run has its own seed and its own draws
    let seeds: std::collections::BTreeSet<u64> = one.rows.iter().map(|r| r.seed).collect();
    assert_eq!(seeds.len(), 16);
}

/// Shard files edited by hand, cut and patched, or of another split are errors naming what is
/// wrong, never a summary. Before, a row without its metrics or requirement flags panicked
/// (exit 101), and a row with too few values, a shard of another split, a made-up grid point
/// or a "passed" beside a failed requirement was merged into the summary.
#[test]
fn tampered_shards_are_errors_not_summaries() {
    let s = Sweep::load(&scenario()).unwrap();
    // 8 runs over the scenario's 4 grid points: each point flown twice, once per shard
    let parts: Vec<SweepOutput> = (0..2).map(|k| s.run(8, Some((k, 2)), &|| {}).unwrap()).collect();
    assert!(merge(parts.clone()).is_ok());
    type Edit = fn(&mut Vec<SweepOutput>);
    let cases: [(Edit, &str); 15] = [
        (
            |p| p[1].rows[0].metrics.clear(),
            "run 1 (x3d) has 4 values, 0 metrics and 4 requirement flags; a row has 4, 8 and 4",
        ),
        (|p| p[1].rows[0].requirements.truncate(1), "1 requirement flags"),
        (|p| p[0].rows[1].params.truncate(1), "run 2 (x3d) has 1 values"),
        (
            |p| {
                p[1].grid.pop();
            },
            "3 grid flags for 4 fields",
        ),
        (|p| p[1].shard = Some([3, 2]), "shard 3 of 2 is no shard"),
        (|p| p[1].shard = Some([2, 3]), "run 3 is not one of this shard's (the runs i < 8 with i mod 3 = 1)"),
        (|p| p[1].runs = 9, "shard 2 of 2 does not belong with shard 1 of 2 of `sweep-hover-duration`: 9 runs, not 8"),
        (|p| p[1].sweep_seed += 1, "sweep seed"),
        (|p| p[1].fields[0] = "mocap.latency_ms".into(), "varied fields"),
        (|p| p[1] = p[0].clone(), "shard 1 of 2 is given twice"),
        (
            |p| {
                let row = p[1].rows[0].clone();
                p[1].rows.push(row);
            },
            "run 1 (x3d) appears twice",
        ),
        (
            |p| {
                p[1].rows[0].requirements[0] = Some(false);
                p[1].rows[0].passed = true;
            },
            "run 1 (x3d) passed with a failed requirement",
        ),
        (
            // both rows of grid point 1 renumbered alike: their values agree, their number does not
            |p| {
                p[1].rows[0].grid_point = 99;
                p[1].rows[2].grid_point = 99;
            },
            "run 1 (x3d) flew grid point 99, but run i flies grid point i mod 100",
        ),
        (|p| p[1].rows[2].params[0] += 0.25, "grid point 1 and its grid values do not match the other rows'"),
        (|p| p[0].rows[0].grid_point = 1, "grid point 1 and its grid values do not match"),
    ];
    for (edit, want) in cases {
        let mut p = parts.clone();
        edit(&mut p);
        let e = merge(p).unwrap_err().to_string();
        assert!(e.starts_with("merge: ") && e.contains(want), "{e}\n  wanted: {want}");
    }
}

/// Through the CLI: 3 shards merged give the same files, byte for byte, as one unsharded sweep.
#[test]
fn merged_shards_equal_the_unsharded_sweep_byte_for_byte() {
    let d = super::Scratch::absent("sweep");
    let (whole, parts, merged) = (d.join("whole"), d.join("parts"), d.join("merged"));
    let sc = scenario();
    let sc = sc.to_str().unwrap();
    let (code, out, err) = flyarena(&["sweep", sc, "--runs", "12", "--out", whole.to_str().unwrap(), "-q"]);
    assert!(code == 0 || code == 1, "{out}{err}");
    for k in 1..=3 {
        let (code, out, err) =
            flyarena(&["sweep", sc, "--runs", "12", "--shard", &format!("{k}/3"), "--out", parts.to_str().unwrap()]);
        assert_eq!(code, 0, "{out}{err}");
    }
    let shard_files: Vec<String> = (1..=3)
        .map(|k| parts.join(format!("sweep-hover-duration.sweep.shard-{k}-of-3.json")).to_str().unwrap().to_string())
        .collect();
    let mut args = vec!["merge"];
    args.extend(shard_files.iter().map(String::as_str));
    args.extend(["--out", merged.to_str().unwrap()]);
    let (code, out, err) = flyarena(&args);
    assert!(code == 0 || code == 1, "{out}{err}");
    for f in ["sweep-hover-duration.sweep.json", "sweep-hover-duration.sweep.csv"] {
        assert_eq!(std::fs::read(whole.join(f)).unwrap(), std::fs::read(merged.join(f)).unwrap(), "{f} differs");
    }
    // a missing shard is an error, not a silently smaller summary
    let (code, _, err) = flyarena(&["merge", &shard_files[0], &shard_files[2], "--out", merged.to_str().unwrap()]);
    assert_eq!(code, 2);
    assert!(err.contains("runs missing"), "{err}");
}

/// The averaging error of the hover calibration shrinks with the hover's length (noise averages
/// as 1/√T): the 95th percentile at 4 s is below the one at 0.5 s.
#[test]
fn longer_hovers_calibrate_better() {
    let s = Sweep::load(&scenario()).unwrap();
    let out = s.run(40, None, &|| {}).unwrap();
    let summary = flyarena::sweep::summary(&out);
    let p95 = |g: usize| summary.groups[g].metric("roll_err_deg").unwrap().p95;
    assert_eq!(summary.groups[0].grid["plan[1].calibrate_roll_pitch.average_s"], 0.5);
    assert_eq!(summary.groups[3].grid["plan[1].calibrate_roll_pitch.average_s"], 4.0);
    assert!(p95(3) < p95(0), "p95 at 4 s {} vs at 0.5 s {}", p95(3), p95(0));
}

#[test]
fn bad_sweeps_are_rejected_before_running() {
    let d = super::Scratch::new("badsweep");
    let good = std::fs::read_to_string(scenario()).unwrap();
    let cases = [
        (good.replace("field: \"mocap.noise_mm\"", "field: \"mocap.nosie.mm\""), "`nosie` is not set"),
        (good.replace("uniform: [0.1, 1.0]", "uniform: [0.1, 1.0], grid: [1]"), "only one of uniform, normal, grid"),
        (good.replace("uniform: [0.1, 1.0]", "uniform: [30, 40]"), "outside the allowed range [0, 20]"),
        (good.replace("\nsweep:", "\nsweeps:"), "unknown field"),
        // checked at load, at the values each variation reaches: a uniform's far end, a grid value
        (
            good.replace("uniform: [0.1, 1.0]", "uniform: [0.1, 100]"),
            "sweep: vary[3]: `mocap.noise_mm` = 100: 100 mm is outside the allowed range [0, 20]",
        ),
        (
            good.replace("grid: [0.5, 1, 2, 4]", "grid: [0.5, 1, -2, 4]"),
            "vary[0]: `plan[1].calibrate_roll_pitch.average_s` = -2: -2 s is outside the allowed range (0, 3600]",
        ),
        (
            good.replace("field: \"mocap.noise_mm\"", "field: \"mocap.nope\""),
            "vary[3]: `mocap.nope` = 0.1: unknown field `nope`",
        ),
        (
            good.replace("field: \"mocap.noise_mm\"", "field: \"vehicles[0].markers.rotation_deg[0]\""),
            "vary[1] and vary[3] both vary `vehicles[0].markers.rotation_deg[0]`",
        ),
        // a normal's tail is only found by drawing every run, before any flies: the lowest bad
        // run is named (runs 4, 5, 7 and 9 of the 12 draw below 0 mm), by its values, not by a
        // position in the patched tree, which no file holds. This case once expected run 7, the one a second
        // thread met first on an idle 2-core machine; under load another was named.
        (
            good.replace("uniform: [0.1, 1.0]", "normal: [0.5, 10]"),
            "run 4: sweep-bad8.yaml (plan[1].calibrate_roll_pitch.average_s = 0.5, vehicles[0].markers.rotation_deg[0] = 0.7560123947666195, vehicles[0].markers.rotation_deg[1] = 3.8711572881568763, mocap.noise_mm = -3.909324759173426): -3.909324759173426 mm is outside the allowed range [0, 20]",
        ),
    ];
    for (k, (yaml, want)) in cases.iter().enumerate() {
        let name = format!("sweep-bad{k}.yaml");
        std::fs::write(d.join(&name), yaml).unwrap();
        let (code, out, err) = flyarena_in(&d, &["sweep", &name, "--runs", "12", "--out", "o", "-q"]);
        assert_eq!(code, 2, "case {k}: {out}{err}");
        assert!(err.contains(want) && !err.contains("<input>"), "case {k}: {err}");
    }
    // a uniform whose lower end is an open bound (average_s in (0, 3600] s) never draws it
    // (probability 2⁻⁵³): accepted, as it ran before the load checks
    let open_end = good.replace("grid: [0.5, 1, 2, 4]", "uniform: [0, 4]");
    std::fs::write(d.join("open-end.yaml"), open_end).unwrap();
    assert!(Sweep::load(&d.join("open-end.yaml")).is_ok());
}

/// A sweep killed part way leaves its journal; the same command again reuses every finished run
/// (a run whose journal row was tampered with keeps the tampered value: it was not redone),
/// skips a line cut by the kill, computes the rest, and removes the journal at the end.
#[test]
fn an_interrupted_sweep_resumes_without_redoing_finished_runs() {
    let d = super::Scratch::new("resume");
    let s = Sweep::load(&scenario()).unwrap();
    let fresh = s.run(12, None, &|| {}).unwrap();
    let journal = d.join("sweep-hover-duration.sweep.journal.jsonl");
    let mut text = serde_json::to_string(&s.journal_header(12, None)).unwrap() + "\n";
    for run in 0..6u64 {
        let mut rows: Vec<_> = fresh.rows.iter().filter(|r| r.run == run).cloned().collect();
        if run == 3 {
            rows[0].metrics[0] = Some(123.0);
        }
        text += &(serde_json::to_string(&rows).unwrap() + "\n");
    }
    // lines no run of this sweep writes: run 8 without its metrics (a summary would have
    // indexed them and panicked) and a run beyond the sweep's 12; both are flown again
    let mut bad: Vec<_> = fresh.rows.iter().filter(|r| r.run == 8).cloned().collect();
    bad[0].metrics.clear();
    text += &(serde_json::to_string(&bad).unwrap() + "\n");
    bad[0].metrics = fresh.rows[0].metrics.clone();
    bad[0].run = 20;
    text += &(serde_json::to_string(&bad).unwrap() + "\n");
    text += "[{\"run\":7,\"se"; // cut by the kill
    std::fs::write(&journal, text).unwrap();
    let (code, out, err) =
        flyarena(&["sweep", scenario().to_str().unwrap(), "--runs", "12", "--out", d.to_str().unwrap()]);
    assert!(code == 0 || code == 1, "{out}{err}");
    assert!(err.contains("resuming: 6 of 12 runs already done"), "{err}");
    let csv = std::fs::read_to_string(d.join("sweep-hover-duration.sweep.csv")).unwrap();
    let want = flyarena::sweep::csv(&fresh);
    for (k, (got, exp)) in csv.lines().zip(want.lines()).enumerate() {
        if k == 4 {
            assert!(got.contains(",123,"), "run 3 was redone: {got}");
        } else {
            assert_eq!(got, exp, "line {k}");
        }
    }
    assert_eq!(csv.lines().count(), want.lines().count());
    assert!(!journal.exists(), "the journal is removed once the outputs are written");
}

/// SIGINT in the middle of a sweep: exit 130, no temporary files, no half-written outputs, the
/// journal kept; the same command then resumes and finishes.
#[cfg(unix)]
#[test]
fn an_interrupted_sweep_exits_130_and_resumes() {
    let d = super::Scratch::absent("sigint");
    let sc = scenario();
    let args = ["sweep", sc.to_str().unwrap(), "--runs", "300", "--out", d.to_str().unwrap(), "-q"];
    let mut child =
        Command::new(env!("CARGO_BIN_EXE_flyarena")).args(args).stderr(std::process::Stdio::piped()).spawn().unwrap();
    // wait until some runs are journalled, then interrupt
    let journal = d.join("sweep-hover-duration.sweep.journal.jsonl");
    let started = std::time::Instant::now();
    while std::fs::read_to_string(&journal).map_or(0, |t| t.lines().count()) < 5 {
        assert!(started.elapsed().as_secs() < 60, "no progress");
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    Command::new("kill").args(["-INT", &child.id().to_string()]).status().unwrap();
    let status = child.wait().unwrap();
    assert_eq!(status.code(), Some(130));
    let names: Vec<String> =
        std::fs::read_dir(&d).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    assert_eq!(names, ["sweep-hover-duration.sweep.journal.jsonl"], "only the journal remains");
    // complete lines only: a line cut by the exit would be skipped on resume
    let done = std::fs::read_to_string(&journal).unwrap().matches('\n').count() - 1;
    assert!(done < 300, "the sweep finished before the signal: {done}");
    let (code, out, err) = flyarena(&args[..args.len() - 1]);
    assert!(code == 0 || code == 1, "{out}{err}");
    assert!(err.contains(&format!("resuming: {done} of 300 runs already done")), "{err}");
    assert!(d.join("sweep-hover-duration.sweep.csv").exists() && !journal.exists());
}

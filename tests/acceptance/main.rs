//! flyarena acceptance suite: one test binary (every file directly in tests/ would link the whole
//! dependency tree again).

mod alloc;
mod calibration;
mod cli;
mod determinism;
mod faults;
mod identify;
mod layout;
mod left;
mod log;
mod physics;
mod project;
mod props;
mod px4;
mod quality;
#[cfg(feature = "record")]
mod record;
mod rigs;
mod ros2;
mod scenarios;
mod serve;
mod slurm;
mod sweep;
mod trials;
mod twins;
mod ulog;

use flyarena::scenario::Scenario;

#[global_allocator]
static ALLOCATOR: alloc::Counting = alloc::Counting;
use std::path::{Path, PathBuf};

/// A scratch directory under the system's temp dir (`flyarena-<name>-<pid>`), removed when the
/// test that made it ends, unless it ends by a panic (then it stays for a look).
pub struct Scratch(PathBuf);

impl Scratch {
    /// An empty directory, created.
    pub fn new(name: &str) -> Scratch {
        let s = Scratch::absent(name);
        std::fs::create_dir_all(&s.0).unwrap();
        s
    }
    /// A path that does not exist yet (for a command that must create it).
    pub fn absent(name: &str) -> Scratch {
        let d = std::env::temp_dir().join(format!("flyarena-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        Scratch(d)
    }
}

impl std::ops::Deref for Scratch {
    type Target = Path;
    fn deref(&self) -> &Path {
        &self.0
    }
}

impl AsRef<Path> for Scratch {
    fn as_ref(&self) -> &Path {
        &self.0
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        if !std::thread::panicking() {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }
}

/// Runs the `flyarena` binary with `args` in `dir`: its exit code, stdout and stderr.
pub fn flyarena(args: &[&str], dir: &Path) -> (i32, String, String) {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_flyarena")).args(args).current_dir(dir).output().unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into(),
        String::from_utf8_lossy(&out.stderr).into(),
    )
}

/// The checkout being tested. Read at run time (cargo sets it for `cargo test`): the compile-time
/// `env!` value goes stale when a shared `CARGO_TARGET_DIR` holds a build from another clone
/// whose sources are not newer, and the tests then read that other clone's files.
pub fn root() -> PathBuf {
    std::env::var_os("CARGO_MANIFEST_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")))
}

/// Parses an inline scenario (tests build variants without touching scenarios/).
pub fn inline(yaml: &str) -> Scenario {
    Scenario::parse(yaml, Path::new("inline.yaml")).unwrap_or_else(|e| panic!("{e}"))
}

/// Whether Python imports `module`. Without it a test fails under CI (where `.ci/run` installs
/// it, as `pip install {pip}`) and is skipped, said on stderr, elsewhere; `what` names it in
/// both messages.
pub fn python_module(module: &str, what: &str, pip: &str) -> bool {
    let have = std::process::Command::new("python3")
        .args(["-c", &format!("import {module}")])
        .status()
        .is_ok_and(|s| s.success());
    if !have {
        assert!(std::env::var_os("CI").is_none(), "CI must have Python's {what} (pip install {pip}, as .ci/run does)");
        eprintln!("skipped: no Python {what} here (pip install {pip})");
    }
    have
}

/// The real flight data the tests read: `FLYARENA_DATA`, else `data/` in the checkout (where
/// `scripts/fetch-data` puts it), else `../shared/data` beside the checkout. Missing, a test
/// that needs it is skipped (one line on stderr for the whole run says how to get it), except under
/// `CI=true`, where it fails: CI always has the data, so a CI run without it cannot pass for
/// one that checked it.
pub fn shared_data() -> Option<PathBuf> {
    let candidates = match std::env::var_os("FLYARENA_DATA") {
        Some(d) => vec![PathBuf::from(d)],
        None => vec![root().join("data"), root().join("../shared/data")],
    };
    if let Some(dir) = candidates.iter().find(|d| d.join("nanobench").is_dir()) {
        return Some(dir.clone());
    }
    let looked = candidates.iter().map(|d| d.display().to_string()).collect::<Vec<_>>().join(" or ");
    if std::env::var_os("CI").is_some() {
        panic!("the real data is missing at {looked} (CI is set: CI must have it; scripts/fetch-data gets it)");
    }
    // once per run, and past the test harness's capture (which holds a passing test's output back)
    static SAID: std::sync::Once = std::sync::Once::new();
    SAID.call_once(|| {
        use std::io::Write;
        let line = format!("skipped: the tests on real flights (no data at {looked}; `scripts/fetch-data` downloads it, or set FLYARENA_DATA)\n");
        let _ = std::io::stderr().write_all(line.as_bytes());
    });
    None
}

/// Another route's report of a flight is the CSV route's: the same rows, the same effects in the
/// same order, and every parameter (and with `intervals` every interval) within a twentieth of
/// the CSV's interval (a bag's or a PX4 log's stamps are integers and its values float32, not the
/// CSV's doubles bit for bit, so a decimated sample on the edge of a held-out block may change
/// sides, and a candidate at ΔBIC ≈ 0 may become half-supported and widen the intervals it would
/// move).
pub fn same_report(csv: &flyarena::identify::Report, other: &flyarena::identify::Report, name: &str, intervals: bool) {
    assert_eq!(csv.samples, other.samples, "{name}");
    assert!(
        csv.train_samples.abs_diff(other.train_samples) <= 2,
        "{name}: {} vs {} training samples",
        csv.train_samples,
        other.train_samples
    );
    let effects = |r: &flyarena::identify::Report| r.effects.iter().map(|f| f.effect).collect::<Vec<_>>();
    assert_eq!(effects(csv), effects(other), "{name}");
    for (fa, fb) in csv.effects.iter().zip(&other.effects) {
        for (pa, pb) in fa.params.iter().zip(&fb.params) {
            assert_eq!(pa.identifiable, pb.identifiable, "{name}: {} {}", fa.effect.key(), pa.name);
            assert!(
                (pa.value - pb.value).abs() <= 0.05 * pa.ci95,
                "{name}: {} {} {} against the CSV's {} ± {}",
                fa.effect.key(),
                pa.name,
                pb.value,
                pa.value,
                pa.ci95
            );
            assert!(
                !intervals || (pa.ci95 - pb.ci95).abs() <= 0.05 * pa.ci95.max(1e-9),
                "{name}: {} {} interval {} against the CSV's {}",
                fa.effect.key(),
                pa.name,
                pb.ci95,
                pa.ci95
            );
        }
    }
}

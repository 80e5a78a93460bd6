//! flyarena acceptance suite: one test binary (every file directly in tests/ would link the whole
//! dependency tree again).

mod alloc;
mod cli;
mod determinism;
mod faults;
mod identify;
mod layout;
mod left;
mod log;
mod physics;
mod props;
mod quality;
#[cfg(feature = "record")]
mod record;
mod ros2;
mod scenarios;
mod serve;
mod sweep;
mod trials;
mod twins;

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

/// The checkout being tested. Read at run time (cargo sets it for `cargo test`): the compile-time
/// `env!` value goes stale when a shared `CARGO_TARGET_DIR` holds a build from another clone
/// whose sources are not newer, and the tests then read that other clone's files.
pub fn root() -> PathBuf {
    std::env::var_os("CARGO_MANIFEST_DIR").map(PathBuf::from).unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")))
}

/// Parses an inline scenario (tests build variants without touching scenarios/).
pub fn inline(yaml: &str) -> Scenario {
    Scenario::parse(yaml, Path::new("inline.yaml")).unwrap_or_else(|e| panic!("{e}"))
}

/// The shared real data (`FLYARENA_DATA`, default ../shared/data). Missing, the tests that need
/// it fail, so that a suite run without the data cannot pass for one that checked it; set
/// `FLYARENA_SKIP_REAL_DATA=1` to skip them on purpose (said on stderr).
pub fn shared_data() -> Option<PathBuf> {
    let dir = std::env::var_os("FLYARENA_DATA").map(PathBuf::from).unwrap_or_else(|| root().join("../shared/data"));
    if dir.join("nanobench").is_dir() {
        return Some(dir);
    }
    if std::env::var("FLYARENA_SKIP_REAL_DATA").is_ok_and(|v| v == "1") {
        eprintln!("skipped on purpose (FLYARENA_SKIP_REAL_DATA=1): no real data at {}", dir.display());
        return None;
    }
    panic!("the real data is missing at {} (set FLYARENA_DATA, or FLYARENA_SKIP_REAL_DATA=1 to skip these tests)", dir.display());
}

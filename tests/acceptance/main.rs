//! flyarena acceptance suite: one test binary (every file directly in tests/ would link the whole
//! dependency tree again).

mod alloc;
mod cli;
mod determinism;
mod faults;
mod log;
mod physics;
mod props;
#[cfg(feature = "record")]
mod record;
mod scenarios;
mod sweep;

use flyarena::scenario::Scenario;

#[global_allocator]
static ALLOCATOR: alloc::Counting = alloc::Counting;
use std::path::{Path, PathBuf};

pub fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// Parses an inline scenario (tests build variants without touching scenarios/).
pub fn inline(yaml: &str) -> Scenario {
    Scenario::parse(yaml, Path::new("inline.yaml")).unwrap_or_else(|e| panic!("{e}"))
}

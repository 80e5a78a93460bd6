//! What the foreign-log targets share: any bytes through one of flyarena's shipped mappings
//! (the dependency's parser, flyarena's topic reading and the join onto the IMU's clock, then
//! the CSV reader) give an error naming the file or a series of finite, ordered rows; never a
//! panic of flyarena's own nor an abort.
//!
//! A panic inside the dependency is caught by flyarena and becomes an error naming the byte; the
//! hook installed here lets such a panic unwind to that catch (libFuzzer's hook would abort on
//! it) and prints each new place in the dependency that panicked once, so the run reports the
//! dependency's panics and goes on fuzzing flyarena's side.
use flyarena::identify::mapping::Mapping;
use std::collections::BTreeSet;
use std::sync::{Mutex, Once, OnceLock};

/// A foreign log format: the mapping that reads it and the crate that parses it.
pub struct Route {
    /// The shipped mapping's text and its file name.
    pub mapping: (&'static str, &'static str),
    /// The parsing crate's name as its source path spells it (`px4-ulog`, `mcap`).
    pub dependency: &'static str,
    /// The name the fuzzed bytes go by (its extension picks the reader).
    pub file: &'static str,
}

static MAP: OnceLock<Mapping> = OnceLock::new();
static HOOK: Once = Once::new();
static SEEN: Mutex<BTreeSet<String>> = Mutex::new(BTreeSet::new());

/// Reads `data` by `route` and checks what came out.
pub fn check(route: &'static Route, data: &[u8]) {
    HOOK.call_once(|| {
        let abort = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            // the place is in the dependency or, for a failed allocation, in `alloc` called from it
            let at = info.location().map(|l| format!("{}:{}", l.file(), l.line())).unwrap_or_default();
            let tag = format!("/{}-", route.dependency);
            if at.contains(&tag) || std::backtrace::Backtrace::force_capture().to_string().contains(&(tag + "0.")) {
                if SEEN.lock().map(|mut s| s.insert(at.clone())).unwrap_or(false) {
                    eprintln!("{} panicked at {at}: {info}", route.dependency);
                }
                return;
            }
            abort(info)
        }));
    });
    let map = MAP.get_or_init(|| {
        Mapping::parse(route.mapping.0, std::path::Path::new(route.mapping.1)).expect("the shipped mapping parses")
    });
    match map.read_bytes(data, route.file) {
        Ok(s) => {
            assert!(s.t_s.iter().all(|t| t.is_finite()));
            assert!(s.t_s.windows(2).all(|w| w[0] <= w[1]));
        }
        Err(e) => {
            let e = e.to_string();
            assert!(e.starts_with(route.file), "{e}");
        }
    }
}

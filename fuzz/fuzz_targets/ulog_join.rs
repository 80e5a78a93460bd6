//! Any bytes through the PX4 route: `px4-ulog`'s parser, flyarena's topic reading and the join
//! onto the IMU's clock, then the CSV reader. An error or a series of finite rows, never a
//! panic of flyarena's own nor an abort.
//!
//! A panic inside `px4-ulog` is caught by flyarena and becomes an error naming the byte; the
//! target lets such a panic unwind to that catch (libFuzzer's hook would abort on it) and prints
//! each new place in `px4-ulog` that panicked once, so the run reports the dependency's panics
//! and goes on fuzzing flyarena's side.
#![no_main]
use libfuzzer_sys::fuzz_target;
use std::collections::BTreeSet;
use std::sync::{Mutex, Once, OnceLock};

static MAP: OnceLock<flyarena::identify::mapping::Mapping> = OnceLock::new();
static HOOK: Once = Once::new();
static SEEN: Mutex<BTreeSet<String>> = Mutex::new(BTreeSet::new());

fuzz_target!(|data: &[u8]| {
    HOOK.call_once(|| {
        let abort = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            // the place is in `px4-ulog` or, for a failed allocation, in `alloc` called from it
            let at = info.location().map(|l| format!("{}:{}", l.file(), l.line())).unwrap_or_default();
            if at.contains("/px4-ulog-")
                || std::backtrace::Backtrace::force_capture().to_string().contains("/px4-ulog-0.")
            {
                if SEEN.lock().map(|mut s| s.insert(at.clone())).unwrap_or(false) {
                    eprintln!("px4-ulog panicked at {at}: {info}");
                }
                return;
            }
            abort(info)
        }));
    });
    let map = MAP.get_or_init(|| {
        flyarena::identify::mapping::Mapping::parse(
            include_str!("../../mappings/px4.yaml"),
            std::path::Path::new("px4.yaml"),
        )
        .expect("the shipped mapping parses")
    });
    match map.read_bytes(data, "fuzz.ulg") {
        Ok(s) => {
            assert!(s.t_s.iter().all(|t| t.is_finite()));
            assert!(s.t_s.windows(2).all(|w| w[0] <= w[1]));
        }
        Err(e) => {
            let e = e.to_string();
            assert!(e.starts_with("fuzz.ulg"), "{e}");
        }
    }
});

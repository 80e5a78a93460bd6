//! Any text through the flight-log reader: an error or a log, never a panic.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(src) = std::str::from_utf8(data) else { return };
    if let Ok(log) = flyarena::log::read_csv(src, "fuzz.csv") {
        assert!(log.segments.iter().all(|(a, b)| a < b && *b <= log.rows()));
    }
});

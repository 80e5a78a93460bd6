//! Any text through the NanoBench column mapping, and what it accepts through `identify`.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(src) = std::str::from_utf8(data) else { return };
    let map = flyarena::identify::mapping::Mapping::parse(
        include_str!("../../mappings/nanobench.yaml"),
        std::path::Path::new("nanobench.yaml"),
    )
    .expect("the shipped mapping parses");
    if let Ok(series) = map.read_str(src, "fuzz.csv") {
        if let Ok(r) = flyarena::identify::identify(&series, &flyarena::identify::Options::default()) {
            assert!(r.errors.iter().all(|e| !e.rmse_before.is_nan()));
        }
    }
});

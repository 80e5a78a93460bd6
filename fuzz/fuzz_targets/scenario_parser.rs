//! Any text through the scenario parser: an error or a scenario that stays valid, never a panic.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(src) = std::str::from_utf8(data) else { return };
    if let Ok(s) = flyarena::scenario::Scenario::parse(src, std::path::Path::new("fuzz.yaml")) {
        for i in 0..s.vehicles.value.len() {
            assert!(s.vehicle_params(i).is_ok() && s.template(i).is_ok());
        }
        assert!(s.run_time_s().is_finite());
    }
});

//! Any text through the scenario parser: an error or a scenario that stays valid, never a panic.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(src) = std::str::from_utf8(data) else { return };
    if let Ok(s) = flyarena::scenario::Scenario::parse(src, std::path::Path::new("fuzz.yaml")) {
        for i in 0..s.vehicle_cfgs().len() {
            assert!(s.vehicle_params(i).mass_kg > 0.0 && s.template(i).len() >= 3);
        }
        assert!(s.run_time_s().is_finite());
    }
});

//! Any text through the scenario parser: an error or a scenario that stays valid, never a panic.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(src) = std::str::from_utf8(data) else { return };
    if let Ok(s) = flyarena::scenario::Scenario::parse(src, std::path::Path::new("fuzz.yaml")) {
        let spec = s.spec();
        assert!(!spec.vehicles.is_empty());
        for v in &spec.vehicles {
            assert!(v.params.mass_kg > 0.0 && v.true_params.mass_kg > 0.0 && v.template.len() >= 3);
        }
        assert!(spec.run_time.0 > 0 && !spec.phases.is_empty());
    }
});

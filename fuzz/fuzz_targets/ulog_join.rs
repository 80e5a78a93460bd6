//! Any bytes through the PX4 route: `px4-ulog`'s parser, flyarena's topic reading and the join
//! onto the IMU's clock, then the CSV reader (`common/foreign_log.rs` says what is checked).
#![no_main]
use libfuzzer_sys::fuzz_target;

#[path = "common/foreign_log.rs"]
mod foreign_log;

static ROUTE: foreign_log::Route = foreign_log::Route {
    mapping: (include_str!("../../mappings/px4.yaml"), "px4.yaml"),
    dependency: "px4-ulog",
    file: "fuzz.ulg",
};

fuzz_target!(|data: &[u8]| foreign_log::check(&ROUTE, data));

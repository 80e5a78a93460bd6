//! Any bytes through the ROS 2 route: the `mcap` reader, flyarena's CDR decoding and the join
//! onto the IMU's clock, then the CSV reader (`common/foreign_log.rs` says what is checked).
#![no_main]
use libfuzzer_sys::fuzz_target;

#[path = "common/foreign_log.rs"]
mod foreign_log;

static ROUTE: foreign_log::Route = foreign_log::Route {
    mapping: (include_str!("../../mappings/ros2-crazyflie.yaml"), "ros2-crazyflie.yaml"),
    dependency: "mcap",
    file: "fuzz.mcap",
};

fuzz_target!(|data: &[u8]| foreign_log::check(&ROUTE, data));

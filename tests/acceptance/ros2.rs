//! ROS 2 bags (MCAP) as identify input, against the CSV route, with bags written by the
//! independent ROS 2 writer `mcap-ros2-support` (PyPI; `.ci/run` installs it).

use flyarena::identify::Mapping;
use flyarena::identify::{Effect, Options, identify};
use std::path::Path;
use std::process::Command;

/// Writes `flight` (a NanoBench CSV) as a bag with `scripts/nanobench-to-mcap.py` ([`have_writer`]
/// says what happens without the writer).
fn bag_of(flight: &Path, out: &Path) -> Option<()> {
    if !have_writer() {
        return None;
    }
    let st = Command::new("python3")
        .arg(super::root().join("scripts/nanobench-to-mcap.py"))
        .arg(flight)
        .arg(out)
        .status()
        .unwrap();
    assert!(st.success(), "the bag writer failed on {}", flight.display());
    Some(())
}

/// Whether Python has the independent writer `mcap_ros2` (see [`super::python_module`]).
fn have_writer() -> bool {
    super::python_module("mcap_ros2.writer", "mcap-ros2-support", "mcap-ros2-support==0.6.0")
}

fn tmp(name: &str) -> super::Scratch {
    super::Scratch::new(&format!("ros2-{name}"))
}

/// A NanoBench flight as a ROS 2 bag gives the CSV route's report: the same rows, the same
/// effects in the same order and every parameter within a twentieth of its interval (the bag
/// stamps time in integer nanoseconds from the first IMU message where the CSV has epoch
/// seconds in a double, and BatteryState carries volts as float32: neither is bit for bit the
/// CSV's, so a sample on the edge of a held-out block may change sides).
#[test]
fn a_ros2_bag_gives_the_csv_report() {
    let Some(data) = super::shared_data() else { return };
    let d = tmp("same");
    for name in ["B3_figure8_medium_rep2", "B7_oval_fast_rep1"] {
        let csv = data.join(format!("nanobench/dataset/{name}.csv"));
        let bag = d.join(format!("{name}.mcap"));
        if bag_of(&csv, &bag).is_none() {
            return;
        }
        let opts = |m: &Mapping| {
            let mut o = Options { forced: vec![Effect::BodyOffset], ..Options::default() };
            o.design.smoothing_s = m.smoothing_ms.unwrap() * 1e-3;
            o
        };
        let csv_map = Mapping::load(&super::root().join("mappings/nanobench.yaml")).unwrap();
        let bag_map = Mapping::load(&super::root().join("mappings/ros2-crazyflie.yaml")).unwrap();
        let a = identify(&csv_map.read(&csv).unwrap(), &opts(&csv_map)).unwrap();
        let b = identify(&bag_map.read(&bag).unwrap(), &opts(&bag_map)).unwrap();
        super::same_report(&a, &b, name, true);
    }
}

/// Hostile bags: cut short, a flipped byte inside a chunk (the writer's CRCs), the CSV mapping
/// given a bag, a bag given where a topic is missing or has the wrong type: each is an error
/// naming the file, never a panic or a number.
#[test]
fn broken_bags_are_errors_not_numbers() {
    let Some(data) = super::shared_data() else { return };
    let d = tmp("broken");
    let bag = d.join("b.mcap");
    if bag_of(&data.join("nanobench/dataset/B6_linear_ramp_rep2.csv"), &bag).is_none() {
        return;
    }
    let bytes = std::fs::read(&bag).unwrap();
    let map = Mapping::load(&super::root().join("mappings/ros2-crazyflie.yaml")).unwrap();
    let read = |b: &[u8], m: &Mapping| {
        let p = d.join("x.mcap");
        std::fs::write(&p, b).unwrap();
        m.read(&p).map(|_| ()).unwrap_err().to_string()
    };
    let cut = read(&bytes[..bytes.len() / 2], &map);
    assert!(cut.contains("x.mcap"), "{cut}");
    // a byte flipped in the middle of the first chunk (records: opcode u8, length u64 LE; a
    // chunk is opcode 0x06): the chunk's CRC catches it (a flip in a message index, which only
    // serves seeking, would change no measurement)
    let mut at = 8;
    while bytes[at] != 0x06 {
        at += 9 + u64::from_le_bytes(bytes[at + 1..at + 9].try_into().unwrap()) as usize;
    }
    let len = u64::from_le_bytes(bytes[at + 1..at + 9].try_into().unwrap()) as usize;
    let mut flipped = bytes.clone();
    flipped[at + 9 + len / 2] ^= 0x5a;
    let e = read(&flipped, &map);
    assert!(e.contains("x.mcap") && (e.contains("crc") || e.contains("CRC")), "{e}");
    let csv_map = Mapping::load(&super::root().join("mappings/nanobench.yaml")).unwrap();
    let e = read(&bytes, &csv_map);
    assert!(e.contains("needs a mapping with a `ros2:` block"), "{e}");
    let src = std::fs::read_to_string(super::root().join("mappings/ros2-crazyflie.yaml")).unwrap();
    let missing = Mapping::parse(&src.replace("/cf/imu", "/cf/imu_typo"), Path::new("m.yaml")).unwrap();
    let e = read(&bytes, &missing);
    assert!(e.contains("no message on topic `/cf/imu_typo`"), "{e}");
    let swapped = Mapping::parse(&src.replace("pose: /vicon/cf/pose", "pose: /cf/imu"), Path::new("m.yaml")).unwrap();
    let e = read(&bytes, &swapped);
    assert!(e.contains("must be geometry_msgs/msg/PoseStamped"), "{e}");
    // a mapping with an unknown key in its ros2 block names it
    let e = Mapping::parse(&src.replace("imu: /cf/imu", "imu: /cf/imu\n  gps: /cf/gps"), Path::new("m.yaml"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("gps"), "{e}");
}

/// Poses on their own clock: every second IMU row has a pose, stamped 5 ms after the row it
/// was sampled at, and pose 202 is dropped. Each IMU row t then gets the pose interpolated
/// between its neighbours, the truth at t − 5 ms: linear interpolation over 20 ms of
/// x = 0.3·cos 2t errs by at most (0.02²/8)·1.2 = 6·10⁻⁵ m, where the nearest pose would be off
/// by up to 0.6 m/s · 10 ms = 6 mm. The rows between poses 200 and 204 (40 ms apart: a dropped
/// frame) are frames in which the vehicle was not seen, and no other row is.
#[test]
fn poses_are_interpolated_onto_the_imu_clock_and_not_across_a_dropped_frame() {
    let bytes = super::props::ros2_fuzz::bag_with(2, 5_000_000, &[202]);
    let d = tmp("interp");
    let p = d.join("i.mcap");
    std::fs::write(&p, bytes).unwrap();
    interpolated_on_the_imu_clock(&super::props::ros2_fuzz::mapping().read(&p).unwrap(), 0);
}

/// The same flight written by the independent writer (`mcap-ros2-support`,
/// `tests/acceptance/clients/ros2_clock_bag.py`), every topic on its own clock: the IMU at
/// 100 Hz, the poses at 50 Hz 5 ms after their rows, the motors 3 ms after each IMU message,
/// the battery at 10 Hz 7 ms after; the same closed form holds row by row. The first IMU
/// message comes before any motor or battery message, so its row is left out (the join holds
/// those channels' last value and has none yet).
#[test]
fn poses_are_interpolated_on_a_bag_whose_topics_have_their_own_clocks() {
    if !have_writer() {
        return;
    }
    let d = tmp("clocks");
    let p = d.join("clocks.mcap");
    let st = Command::new("python3")
        .arg(super::root().join("tests/acceptance/clients/ros2_clock_bag.py"))
        .arg(&p)
        .status()
        .unwrap();
    assert!(st.success(), "the bag writer failed");
    let m = Mapping::parse("vehicle: crazyflie21\nros2: { pose: /vicon/cf/pose, imu: /cf/imu, motors: /cf/motors, battery: /cf/battery }\nsmoothing_ms: 50\n", Path::new("m.yaml"))
        .unwrap();
    interpolated_on_the_imu_clock(&m.read(&p).unwrap(), 1);
}

/// The checks of the two tests above on 400 IMU messages at 10 ms with poses every 20 ms, 5 ms
/// late, pose 202 dropped; the series starts at IMU message `first`.
fn interpolated_on_the_imu_clock(s: &flyarena::identify::Series, first: usize) {
    assert_eq!(s.len(), 400 - first);
    let mut checked = 0;
    for row in 0..s.len() {
        let k = row + first;
        let t = k as f64 * 0.01;
        let inside = (3..=396).contains(&k);
        // poses 200 and 204 are stamped at rows 200.5 and 204.5: rows 201–204 lie between them
        let dropped = (201..=204).contains(&k);
        if !inside {
            continue;
        }
        assert_eq!(s.mocap_ok[row], !dropped, "IMU message {k}");
        if dropped {
            continue;
        }
        // the mapping turns the z-up world by π about x: y and z change sign
        let x_true = 0.3 * (2.0 * (t - 0.005)).cos();
        assert!(
            (s.pos_mocap_nav[row].x() - x_true).abs() < 1e-4,
            "IMU message {k}: x {} vs {x_true}",
            s.pos_mocap_nav[row].x()
        );
        let y_true = -0.3 * (2.0 * (t - 0.005)).sin();
        assert!(
            (s.pos_mocap_nav[row].y() - y_true).abs() < 1e-4,
            "IMU message {k}: y {} vs {y_true}",
            s.pos_mocap_nav[row].y()
        );
        checked += 1;
    }
    assert!(checked > 380, "{checked}");
}

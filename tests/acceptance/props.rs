//! Property tests: RLS = batch LS, the rigid fit recovers any pose, no NaN or panic for scenarios
//! inside the documented ranges.

use flyarena::calibrate::{Rls, batch_ls};
use flyarena::engine::{RunOptions, run};
use flyarena::frames::{Body, Euler, Nav, Rot, Vec3};
use flyarena::mocap::{builtin_pattern, rigid_fit};
use proptest::prelude::*;

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    /// RLS initialised from the information matrix reproduces (9) to rounding on random lines.
    #[test]
    fn rls_equals_batch_ls(slope in -1.0f64..1.0, x_e0 in -5.0f64..5.0, start in -5.0f64..5.0,
                           step in 0.001f64..0.02, n in 50usize..3000, noise in 0.0f64..0.01, seed in 0u64..1000) {
        let mut r = flyarena::rng::Stream::new(seed, flyarena::rng::Component::MocapNoise, 0);
        let north: Vec<f64> = (0..n).map(|k| start + k as f64 * step + noise * r.normal()).collect();
        let east: Vec<f64> = north.iter().map(|x| x_e0 + slope * x + noise * r.normal()).collect();
        let ls = batch_ls(&north, &east).unwrap();
        let mut rls = Rls::new(0.2);
        for (x, y) in north.iter().zip(&east) { rls.update(*x, *y); }
        if let Some(est) = rls.estimate() {
            prop_assert!((est.psi_offset - ls.psi_offset).abs() <= 1e-9, "{} vs {}", est.psi_offset, ls.psi_offset);
            prop_assert!((est.x_e0 - ls.x_e0).abs() <= 1e-9, "{} vs {}", est.x_e0, ls.x_e0);
        } else {
            // the recursion starts once X_N has spread 0.2 m; shorter tracks give no estimate
            prop_assert!(north.iter().cloned().fold(f64::NEG_INFINITY, f64::max) - north.iter().cloned().fold(f64::INFINITY, f64::min) < 0.2);
        }
    }

    /// The rigid-body fit recovers any pose from noiseless markers, with any one marker lost.
    #[test]
    fn rigid_fit_recovers_any_pose(r in -3.1f64..3.1, p in -1.5f64..1.5, y in -3.1f64..3.1,
                                   tx in -10.0f64..10.0, ty in -10.0f64..10.0, tz in -10.0f64..10.0,
                                   pattern in 0usize..8, lost in 0usize..5) {
        let m: Vec<Vec3<Body>> = builtin_pattern(pattern).iter().map(|v| v.assume_same_as()).collect();
        let rot: Rot<Body, Nav> = Rot::from_euler(Euler::new(r, p, y));
        let t = Vec3::<Nav>::new(tx, ty, tz);
        let obs: Vec<Vec3<Nav>> = m.iter().map(|v| rot.apply(*v) + t).collect();
        let mut vis = [true; 4];
        if lost < 4 { vis[lost] = false; }
        let fit = rigid_fit(&m, &obs, &vis).unwrap();
        prop_assert!((fit.rotation.inverse() * rot).angle() < 1e-9);
        prop_assert!((fit.translation - t).norm() < 1e-9);
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(12))]

    /// Any scenario inside the documented ranges runs without NaN or panic (short flights).
    #[test]
    fn no_nan_or_panic_inside_documented_ranges(
        seed in 0u64..u64::MAX, noise in 0.0f64..20.0, lat in 0.0f64..100.0, jit in 0.0f64..50.0,
        loss in 0.0f64..0.5, rot in prop::array::uniform3(-30.0f64..30.0), mass in 0.3f64..1.5,
        alt in 0.2f64..3.0, spin in -720.0f64..720.0, rate in prop::sample::select(vec![50u32, 100, 200, 250, 500]),
        euler_comp in any::<bool>(), gyro_noise in 0.0f64..5.0, wind in prop::array::uniform3(-1.0f64..1.0)) {
        let y = format!(r#"
name: fuzz
seed: {seed}
mocap: {{ rate_hz: {rate}, latency_ms: {lat}, noise_mm: {noise} }}
link: {{ latency_ms: {lat}, jitter_ms: {jit}, loss: {{ bernoulli: {loss} }} }}
controller: {{ compensation: {comp} }}
vehicles:
  - name: v
    model: {{ mass_kg: {mass} }}
    markers: {{ rotation_deg: [{r0}, {r1}, {r2}] }}
    imu: {{ gyro_noise_deg_s: {gyro_noise} }}
    disturbance: {{ force_n: [{w0}, {w1}, {w2}] }}
plan:
  - takeoff: {{ altitude_m: {alt}, duration_s: 2 }}
  - calibrate_roll_pitch: {{ settle_s: 1, average_s: 1 }}
  - yaw_spin: {{ settle_s: 0.5, angle_deg: {spin}, duration_s: 2 }}
  - calibrate_yaw: {{ settle_s: 0.5, distance_m: 1, speed_m_s: 0.5 }}
  - land: {{ duration_s: 1 }}
"#, comp = if euler_comp { "euler" } else { "rotation" }, r0 = rot[0], r1 = rot[1], r2 = rot[2], w0 = wind[0], w1 = wind[1], w2 = wind[2]);
        let s = super::inline(&y);
        let out = run(s.spec(), RunOptions { trace: true, apply_calibration: None });
        let v = &out.vehicles[0];
        prop_assert!(!v.any_nan);
        prop_assert!(v.trace.iter().all(|t| t.pos.is_finite() && t.thrust_n.is_finite()));
    }
}

/// Fuzzing the scenario parser inside `cargo test` (cargo-fuzz needs a nightly toolchain, which
/// this project's machines do not have): random edits of real scenarios — characters deleted,
/// inserted (including multi-byte, control and YAML-special ones) or replaced, lines duplicated
/// or cut — must give a scenario or a located error, never a panic, and an accepted scenario
/// must pass validation again.
mod parser_fuzz {
    use flyarena::scenario::Scenario;
    use proptest::prelude::*;
    use std::path::Path;

    fn corpus() -> Vec<String> {
        let dir = super::super::root().join("scenarios");
        let mut v: Vec<String> =
            std::fs::read_dir(dir).unwrap().map(|e| std::fs::read_to_string(e.unwrap().path()).unwrap()).collect();
        v.sort();
        v
    }

    #[derive(Debug, Clone)]
    pub(super) enum Edit {
        Delete(usize, usize),
        Insert(usize, String),
        Replace(usize, char),
        DuplicateLine(usize),
        Truncate(usize),
    }

    pub(super) fn edit() -> impl Strategy<Value = Edit> {
        let special = prop::sample::select(vec![
            "{", "}", "[", "]", ":", "- ", "\n", "\t", "#", "&a", "*a", "!!str", "'", "\"", "é", "\u{0}", "1e999", "-",
            ".nan", "~", "<<: *a", "?",
        ]);
        prop_oneof![
            (any::<usize>(), 1usize..20).prop_map(|(a, n)| Edit::Delete(a, n)),
            (any::<usize>(), special).prop_map(|(a, s)| Edit::Insert(a, s.to_string())),
            (any::<usize>(), any::<char>()).prop_map(|(a, c)| Edit::Replace(a, c)),
            any::<usize>().prop_map(Edit::DuplicateLine),
            any::<usize>().prop_map(Edit::Truncate),
        ]
    }

    pub(super) fn apply(src: &str, e: &Edit) -> String {
        let chars: Vec<char> = src.chars().collect();
        let at = |a: usize| if chars.is_empty() { 0 } else { a % chars.len() };
        match e {
            Edit::Delete(a, n) => {
                let a = at(*a);
                chars[..a].iter().chain(chars[(a + n).min(chars.len())..].iter()).collect()
            }
            Edit::Insert(a, s) => {
                let a = at(*a);
                chars[..a].iter().collect::<String>() + s + &chars[a..].iter().collect::<String>()
            }
            Edit::Replace(a, c) => {
                let mut v = chars.clone();
                if !v.is_empty() {
                    let a = at(*a);
                    v[a] = *c;
                }
                v.into_iter().collect()
            }
            Edit::DuplicateLine(a) => {
                let lines: Vec<&str> = src.lines().collect();
                let k = a % lines.len().max(1);
                let mut out: Vec<&str> = lines.clone();
                if let Some(l) = lines.get(k) {
                    out.insert(k, l);
                }
                out.join("\n")
            }
            Edit::Truncate(a) => chars[..at(*a)].iter().collect(),
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(400))]
        #[test]
        fn parser_never_panics(which in any::<usize>(), edits in prop::collection::vec(edit(), 1..4)) {
            let corpus = corpus();
            let mut src = corpus[which % corpus.len()].clone();
            for e in &edits {
                src = apply(&src, e);
            }
            match Scenario::parse(&src, Path::new("fuzz.yaml")) {
                Ok(s) => {
                    // what is accepted became a runnable spec: every vehicle with a model that
                    // can lift itself and a template the mocap can fit
                    prop_assert_eq!(s.spec().vehicles.len(), s.vehicle_cfgs().len());
                    for v in &s.spec().vehicles {
                        prop_assert!(v.template.len() >= 3 && v.truth.rotation.angle().is_finite());
                        prop_assert!(v.params.thrust_max() > v.params.hover_thrust());
                    }
                    prop_assert!(s.spec().run_time.as_secs_f64().is_finite() && s.spec().run_time.as_secs_f64() > 0.0);
                }
                Err(e) => {
                    let msg = e.to_string();
                    prop_assert!(msg.starts_with("fuzz.yaml"), "{msg}");
                    prop_assert!(msg.len() > 15);
                }
            }
        }
    }
}

/// Other tools' logs and mappings, edited at random: the mapping parser and the mapped log
/// reader return a located error or data, never panic; whatever they accept, `identify` digests
/// without panicking and without NaN in its errors.
mod mapping_fuzz {
    use super::parser_fuzz::{apply, edit};
    use flyarena::identify::Mapping;
    use flyarena::identify::{Options, identify};
    use proptest::prelude::*;
    use std::path::Path;

    fn log() -> String {
        let mut s = String::from("t,px,py,pz,qx,qy,qz,qw,gx,gy,gz,ax,ay,az,m1,m2,m3,m4,vbat\n");
        for k in 0..400 {
            let t = k as f64 * 0.01;
            let (c, sn) = ((t * 2.0).cos(), (t * 2.0).sin());
            let z = if k < 50 { 0.02 } else { 0.02 + (t - 0.5).min(1.0) };
            let m = if k < 50 { 0 } else { 47000 };
            // the IMU wobbles a little (a reading repeated bit for bit while the vehicle turns
            // is a frozen sensor, which identify's data-quality gate cuts out)
            let w = 1e-3 * ((k * 7919 % 13) as f64 - 6.0);
            s += &format!(
                "{t},{},{},{z},0.01,-0.02,{},{},{},{},{},{},{},{},{m},{m},{m},{m},3.9\n",
                0.3 * c,
                0.3 * sn,
                (t * 0.1).sin(),
                (t * 0.1).cos(),
                0.1 + w,
                -0.1 - w,
                0.05 + w,
                0.01 + w,
                0.02 - w,
                1.0 + w
            );
        }
        s
    }

    fn mapping_src() -> String {
        std::fs::read_to_string(super::super::root().join("mappings/nanobench.yaml"))
            .unwrap()
            .replace("imu_gyro_", "g")
            .replace("imu_acc_", "a")
            .replace("motor_motor_", "")
            .replace("pwr_pm_vbat", "vbat")
    }

    /// The unedited corpus is read and identified (so that the fuzzing starts from valid input).
    #[test]
    fn corpus_is_valid() {
        let map = Mapping::parse(&mapping_src(), Path::new("m.yaml")).unwrap();
        let s = map.read_str(&log(), "corpus.csv").unwrap();
        assert_eq!(s.len(), 400);
        assert!(s.thrust_n.as_ref().unwrap()[100] > 0.0);
        let r = identify(&s, &Options::default()).unwrap();
        assert!(!r.errors.is_empty());
        assert!(r.data_quality.cuts.is_empty(), "{:?}", r.data_quality);
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(150))]
        #[test]
        fn mapped_reader_and_identify_never_panic(edits in prop::collection::vec(edit(), 0..4), map_edits in prop::collection::vec(edit(), 0..2)) {
            let mut m = mapping_src();
            for e in &map_edits {
                m = apply(&m, e);
            }
            let Ok(map) = Mapping::parse(&m, Path::new("m.yaml")) else { return Ok(()) };
            let mut text = log();
            for e in &edits {
                text = apply(&text, e);
            }
            match map.read_str(&text, "fuzz.csv") {
                Ok(series) => {
                    // a report with finite errors, or a data-quality refusal that names the file
                    match identify(&series, &Options::default()) {
                        Ok(r) => prop_assert!(r.errors.iter().all(|e| !e.rmse_before.is_nan() && !e.rmse_after.is_nan())),
                        Err(e) => prop_assert!(e.to_string().starts_with("fuzz.csv"), "{e}"),
                    }
                }
                // the mapping parsed, so every defect left is the log's, at its file (the units
                // and the preset's motors are the mapping's and checked when it is parsed)
                Err(e) => prop_assert!(e.to_string().starts_with("fuzz.csv"), "{e}"),
            }
        }
    }
}

/// ROS 2 bags: a small valid bag (written here with the `mcap` crate's writer, uncompressed so
/// that edits reach the messages), then bytes flipped, cut or inserted. The reader returns an
/// error naming the file or rows, never panics; whatever it accepts, `identify` digests.
pub(crate) mod ros2_fuzz {
    use flyarena::identify::Mapping;
    use flyarena::identify::{Options, identify};
    use proptest::prelude::*;
    use std::collections::BTreeMap;
    use std::path::Path;

    /// CDR (little endian) with XCDR1 alignment from the payload start.
    struct Cdr(Vec<u8>);
    impl Cdr {
        fn new() -> Cdr {
            Cdr(vec![0, 1, 0, 0])
        }
        fn pad(&mut self, a: usize) {
            while !(self.0.len() - 4).is_multiple_of(a) {
                self.0.push(0);
            }
        }
        fn u32(&mut self, x: u32) -> &mut Self {
            self.pad(4);
            self.0.extend(x.to_le_bytes());
            self
        }
        fn f32(&mut self, x: f32) -> &mut Self {
            self.pad(4);
            self.0.extend(x.to_le_bytes());
            self
        }
        fn f64(&mut self, x: f64) -> &mut Self {
            self.pad(8);
            self.0.extend(x.to_le_bytes());
            self
        }
        fn string(&mut self, s: &str) -> &mut Self {
            self.u32(s.len() as u32 + 1);
            self.0.extend(s.as_bytes());
            self.0.push(0);
            self
        }
        fn header(&mut self, ns: u64) -> &mut Self {
            self.u32((ns / 1_000_000_000) as u32).u32((ns % 1_000_000_000) as u32).string("f")
        }
    }

    pub(super) fn bag() -> Vec<u8> {
        bag_with(1, 0, &[])
    }

    /// The bag with a pose on every `pose_every`-th IMU row only, stamped `pose_lag_ns` after the
    /// row it was sampled at (its values are the truth at the row's time), the rows in `dropped`
    /// without their pose.
    pub(crate) fn bag_with(pose_every: u64, pose_lag_ns: u64, dropped: &[u64]) -> Vec<u8> {
        let mut buf = std::io::Cursor::new(Vec::new());
        let opts = mcap::WriteOptions::new().compression(None);
        let mut w = mcap::Writer::with_options(&mut buf, opts).unwrap();
        let none = BTreeMap::new();
        let mut ch = |name: &str, topic: &str| {
            let s = w.add_schema(name, "ros2msg", b"").unwrap();
            w.add_channel(s, topic, "cdr", &none).unwrap()
        };
        let (pose, imu, motors, battery) = (
            ch("geometry_msgs/msg/PoseStamped", "/p"),
            ch("sensor_msgs/msg/Imu", "/i"),
            ch("std_msgs/msg/Float64MultiArray", "/m"),
            ch("sensor_msgs/msg/BatteryState", "/b"),
        );
        for k in 0..400u64 {
            let ns = 1_000_000_000 + k * 10_000_000;
            let t = k as f64 * 0.01;
            let (c, sn) = ((t * 2.0).cos(), (t * 2.0).sin());
            let z = if k < 50 { 0.02 } else { 0.02 + (t - 0.5).min(1.0) };
            let m = if k < 50 { 0.0 } else { 47000.0 };
            let wob = 1e-3 * ((k * 7919 % 13) as f64 - 6.0);
            let (qx, qy, qz) = (0.01, -0.02, (t * 0.1).sin());
            let qw = (1.0 - qx * qx - qy * qy - qz * qz).sqrt();
            let mut msgs = vec![];
            let mut p = Cdr::new();
            p.header(ns + pose_lag_ns).f64(0.3 * c).f64(0.3 * sn).f64(z).f64(qx).f64(qy).f64(qz).f64(qw);
            if k % pose_every == 0 && !dropped.contains(&k) {
                msgs.push((pose, p.0));
            }
            let mut i = Cdr::new();
            i.header(ns);
            for x in [0.0, 0.0, 0.0, 1.0].iter().chain(&[0.0; 9]) {
                i.f64(*x);
            }
            for x in [0.1 + wob, -0.1 - wob, 0.05 + wob].iter().chain(&[0.0; 9]) {
                i.f64(*x);
            }
            for x in [0.1 + wob, 0.2 - wob, 9.81 + wob].iter().chain(&[0.0; 9]) {
                i.f64(*x);
            }
            msgs.push((imu, i.0));
            let mut mo = Cdr::new();
            mo.u32(0).u32(0).u32(4).f64(m).f64(m).f64(m).f64(m);
            msgs.push((motors, mo.0));
            let mut b = Cdr::new();
            b.header(ns).f32(3.9);
            msgs.push((battery, b.0));
            for (channel_id, data) in msgs {
                let stamp = if channel_id == pose { ns + pose_lag_ns } else { ns };
                w.write_to_known_channel(
                    &mcap::records::MessageHeader {
                        channel_id,
                        sequence: k as u32,
                        log_time: stamp,
                        publish_time: stamp,
                    },
                    &data,
                )
                .unwrap();
            }
        }
        w.finish().unwrap();
        drop(w);
        buf.into_inner()
    }

    pub(crate) fn mapping() -> Mapping {
        Mapping::parse(
            "vehicle: crazyflie21\nros2: { pose: /p, imu: /i, motors: /m, battery: /b }\nsmoothing_ms: 50\n",
            Path::new("m.yaml"),
        )
        .unwrap()
    }

    fn read(bytes: &[u8]) -> Result<flyarena::identify::Series, flyarena::identify::InputError> {
        let d = super::super::Scratch::new(&format!("ros2-fuzz-{:?}", std::thread::current().id()));
        let p = d.join("fuzz.mcap");
        std::fs::write(&p, bytes).unwrap();
        mapping().read(&p)
    }

    #[test]
    fn corpus_is_valid() {
        let s = read(&bag()).unwrap();
        assert_eq!(s.len(), 400);
        assert!(s.mocap_ok.iter().all(|x| *x));
        assert!(s.thrust_n.as_ref().unwrap()[100] > 0.0);
        identify(&s, &Options::default()).unwrap();
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(150))]
        #[test]
        fn the_bag_reader_never_panics(edits in prop::collection::vec((any::<prop::sample::Index>(), 0u8..3, any::<u8>()), 1..4)) {
            let mut b = bag();
            for (at, kind, byte) in &edits {
                let k = at.index(b.len());
                match kind {
                    0 => b[k] ^= byte | 1,
                    1 => b.truncate(k),
                    _ => b.insert(k, *byte),
                }
            }
            match read(&b) {
                Ok(series) => {
                    if let Ok(r) = identify(&series, &Options::default()) {
                        prop_assert!(r.errors.iter().all(|e| !e.rmse_before.is_nan() && !e.rmse_after.is_nan()));
                    }
                }
                Err(e) => prop_assert!(e.to_string().contains("fuzz.mcap"), "{e}"),
            }
        }
    }
}

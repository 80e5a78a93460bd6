//! `flyarena serve`: the scenario's mocap as OptiTrack NatNet, received by clients nobody on this
//! project wrote (`natnet` and libmotioncapture's `motioncapture`, both from PyPI; `.ci/run`
//! installs them). Loopback only; every child process is killed when its test ends.

use flyarena::engine::{RunOptions, run};
use flyarena::serve::{ServeOptions, serve};
use serde_json::Value;
use std::collections::HashMap;
use std::net::UdpSocket;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

fn fixture() -> PathBuf {
    super::root().join("tests/acceptance/fixtures/serve-hover.yaml")
}

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("flyarena-serve-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A port nobody listens on now (the OS's choice of a free one).
fn free_port() -> u16 {
    UdpSocket::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port()
}

/// Whether Python has `module`. Without it the test fails under CI (where `.ci/run` installs
/// it) and is skipped, said on stderr, elsewhere.
fn python_has(module: &str) -> bool {
    let have = Command::new("python3").args(["-c", &format!("import {module}")]).status().is_ok_and(|s| s.success());
    if !have {
        assert!(std::env::var("CI").is_err(), "CI must have Python's {module} (pip install motioncapture==1.1 natnet==0.3.0, as .ci/run does)");
        eprintln!("skipped: no Python {module} here (pip install motioncapture==1.1 natnet==0.3.0)");
    }
    have
}

/// A child process killed when dropped (a failed assertion must not leave a server running).
struct Killed(Child);

impl Drop for Killed {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

impl Killed {
    /// Waits at most `limit` for the exit; the exit code.
    fn wait_for(&mut self, limit: Duration) -> i32 {
        let start = Instant::now();
        loop {
            if let Some(st) = self.0.try_wait().unwrap() {
                return st.code().unwrap_or(-1);
            }
            assert!(start.elapsed() < limit, "the process did not finish within {limit:?}");
            std::thread::sleep(Duration::from_millis(20));
        }
    }
}

/// `flyarena serve` on the fixture at twice real time (3.5 s), waiting up to 30 s for a client.
fn server(port: u16, data_port: u16, out: &Path) -> Killed {
    let child = Command::new(env!("CARGO_BIN_EXE_flyarena"))
        .arg("serve")
        .arg(fixture())
        .args(["--command-port", &port.to_string(), "--data-port", &data_port.to_string(), "--speed", "2", "--wait-s", "30", "--no-rrd", "-q"])
        .arg("--out")
        .arg(out)
        .arg("--log")
        .arg(out.join("served.csv"))
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    Killed(child)
}

/// Runs a client script with a time limit; its last stdout line, parsed. Its output is read
/// while it runs (a full pipe would block it).
fn client(script: &str, args: &[String], limit: Duration) -> Value {
    let mut child =
        Command::new("python3").arg(super::root().join("tests/acceptance/clients").join(script)).args(args).stdout(Stdio::piped()).stderr(Stdio::piped()).spawn().unwrap();
    let mut stdout = child.stdout.take().unwrap();
    let mut stderr = child.stderr.take().unwrap();
    let out = std::thread::spawn(move || {
        let mut s = String::new();
        std::io::Read::read_to_string(&mut stdout, &mut s).map(|_| s)
    });
    let err = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = std::io::Read::read_to_string(&mut stderr, &mut s);
        s
    });
    let mut child = Killed(child);
    let code = child.wait_for(limit);
    let text = out.join().unwrap().unwrap();
    assert_eq!(code, 0, "{script} failed: {}", err.join().unwrap());
    serde_json::from_str(text.lines().last().unwrap_or("")).unwrap_or_else(|e| panic!("{script}: {e}: {text}"))
}

/// One row of a flight log: frame number → (capture time, position NED, quaternion w x y z).
type LogPoses = HashMap<u32, (f64, [f64; 3], [f64; 4])>;

fn log_poses(path: &Path) -> LogPoses {
    let text = std::fs::read_to_string(path).unwrap();
    let mut m = HashMap::new();
    for line in text.lines().skip(1) {
        let c: Vec<&str> = line.split(',').collect();
        if c[2] == "1" {
            let f = |i: usize| c[i].parse::<f64>().unwrap();
            m.insert(c[1].parse().unwrap(), (f(0), [f(3), f(4), f(5)], [f(6), f(7), f(8), f(9)]));
        }
    }
    m
}

/// A pose as NatNet carries it: position, quaternion (x, y, z, w).
type Pose32 = ([f32; 3], [f32; 4]);

/// NED → Z-up as derived by hand: (n, e, d) → (n, −e, −d); a quaternion (w, x, y, z) of the
/// body → world rotation → (x, −y, −z, w), both as the f32 NatNet carries.
fn z_up(pos: [f64; 3], q: [f64; 4]) -> Pose32 {
    ([pos[0] as f32, -pos[1] as f32, -pos[2] as f32], [q[1] as f32, -q[2] as f32, -q[3] as f32, q[0] as f32])
}

fn f32s<const N: usize>(v: &Value) -> [f32; N] {
    let a = v.as_array().unwrap();
    std::array::from_fn(|i| a[i].as_f64().unwrap() as f32)
}

/// Roll and pitch (°) of a Z-up quaternion (x, y, z, w), Z-Y-X convention.
fn roll_pitch_deg(q: [f32; 4]) -> (f64, f64) {
    let [x, y, z, w] = q.map(|a| a as f64);
    let roll = (2.0 * (w * x + y * z)).atan2(1.0 - 2.0 * (x * x + y * y));
    let pitch = (2.0 * (w * y - z * x)).clamp(-1.0, 1.0).asin();
    (roll.to_degrees(), pitch.to_degrees())
}

/// The served run is the run: the same arena, bit for bit, whatever the pacing; and every pose
/// that reached a station was sent (poses = Σ delivered frames).
#[test]
fn a_served_run_is_the_run_bit_for_bit() {
    let s = flyarena::scenario::Scenario::load(&fixture()).unwrap();
    let opts = ServeOptions { command_port: 0, speed: 1000.0, wait_for_client: Duration::ZERO, ..ServeOptions::default() };
    let (served, net) = serve(&s, &opts, RunOptions::default()).unwrap();
    let plain = run(&s, RunOptions::default());
    for (a, b) in served.vehicles.iter().zip(&plain.vehicles) {
        assert_eq!(a.trace.len(), b.trace.len());
        for (x, y) in a.trace.iter().zip(&b.trace) {
            assert_eq!(x.pos.to_array().map(f64::to_bits), y.pos.to_array().map(f64::to_bits), "{} at {:?}", a.name, x.t);
        }
        assert_eq!(a.link, b.link);
    }
    let delivered: u64 = plain.vehicles.iter().map(|v| v.link.received).sum();
    assert!(delivered > 2000, "{delivered}");
    assert_eq!(net.poses, delivered);
    // two vehicles whose frames mostly arrive together: fewer packets than poses, more than half
    assert!(net.frames < net.poses && 2 * net.frames > net.poses, "{} frames for {} poses", net.frames, net.poses);
    assert!(net.clients.is_empty() && net.send_errors == 0);
}

/// The `natnet` client (PyPI, unicast): the server info, both rigid bodies with their marker
/// templates, and every frame it receives is the one flyarena's log holds for that frame number,
/// in Z-up, with the mocap's latency in its timestamps and the link's losses as gaps.
#[test]
fn the_natnet_client_receives_the_poses_flyarena_sent() {
    if !python_has("natnet") {
        return;
    }
    let (port, data_port, out) = (free_port(), free_port(), tmp("natnet"));
    let mut srv = server(port, data_port, &out);
    let got = client("natnet_client.py", &[port.to_string(), "3".into()], Duration::from_secs(60));
    assert_eq!(srv.wait_for(Duration::from_secs(60)), 0);
    assert_eq!(got["application"], "flyarena");
    assert_eq!(got["natnet_version"], "3.1.0.0");
    let s = flyarena::scenario::Scenario::load(&fixture()).unwrap();
    let bodies = got["bodies"].as_array().unwrap();
    assert_eq!(bodies.len(), 2);
    for (i, b) in bodies.iter().enumerate() {
        assert_eq!((b[0].as_str().unwrap(), b[1].as_i64().unwrap()), (s.vehicle(i).name.as_str(), i as i64 + 1));
        let markers: Vec<[f32; 3]> = b[2].as_array().unwrap().iter().map(f32s::<3>).collect();
        let expected: Vec<[f32; 3]> = s.template(i).unwrap().iter().map(|m| [m.x() as f32, -m.y() as f32, -m.z() as f32]).collect();
        assert_eq!(markers, expected, "vehicle {i}'s marker template in Z-up");
    }
    let logs = [log_poses(&out.join("served-cf1.csv")), log_poses(&out.join("served-cf2.csv"))];
    let frames = got["frames"].as_array().unwrap();
    assert!(frames.len() > 300, "{} frames in 3 s at 200 Hz", frames.len());
    let latency_ns = (s.mocap.latency_ms * 1e6) as u64;
    let mut numbers = [Vec::new(), Vec::new()];
    for f in frames {
        let number = f["number"].as_u64().unwrap() as u32;
        let stamps: Vec<u64> = f["stamps"].as_array().unwrap().iter().map(|x| x.as_u64().unwrap()).collect();
        for b in f["bodies"].as_array().unwrap() {
            let i = b[0].as_i64().unwrap() as usize - 1;
            let (t, pos, q) = logs[i][&number];
            let (p32, q32) = z_up(pos, q);
            assert_eq!((f32s::<3>(&b[1]), f32s::<4>(&b[2])), (p32, q32), "vehicle {i}, frame {number}");
            assert_eq!(b[3], true);
            assert_eq!(f["timestamp"].as_f64().unwrap(), t, "frame {number}: the timestamp is the exposure time");
            assert_eq!(stamps[0], (t * 1e9).round() as u64);
            numbers[i].push(number);
        }
        assert_eq!((stamps[1] - stamps[0], stamps[2]), (latency_ns, stamps[1]), "frame {number}: camera latency = mocap.latency_ms");
    }
    for (i, n) in numbers.iter().enumerate() {
        assert!(n.windows(2).all(|w| w[1] > w[0]), "vehicle {i}: frame numbers increase");
        let span = (n[n.len() - 1] - n[0] + 1) as usize;
        let missing = span - n.len();
        // 5 % Bernoulli loss: over ~600 frames, between 1 % and 12 % missing (binomial, > 4 sd)
        assert!(missing * 100 > span && missing * 100 < 12 * span, "vehicle {i}: {missing} of {span} frames missing");
    }
    // closed forms at the end of the hover (each body's last pose received): cf2 at home (1, 2) m NED and 1 m up is (1, −2, 1) in
    // Z-up; cf1's markers are turned by roll 3°, pitch −2°: the level body reads roll +3° and,
    // with y and z flipped, pitch +2°
    let by_id = |id: i64| frames.iter().rev().flat_map(|f| f["bodies"].as_array().unwrap()).find(|b| b[0].as_i64() == Some(id)).unwrap_or_else(|| panic!("body {id} received"));
    let p2 = f32s::<3>(&by_id(2)[1]);
    assert!((p2[0] - 1.0).abs() < 0.05 && (p2[1] + 2.0).abs() < 0.05 && (p2[2] - 1.0).abs() < 0.05, "cf2 at {p2:?}");
    let (roll, pitch) = roll_pitch_deg(f32s::<4>(&by_id(1)[2]));
    assert!((roll - 3.0).abs() < 0.3 && (pitch - 2.0).abs() < 0.3, "cf1 reads roll {roll:.2}°, pitch {pitch:.2}°");
}

/// libmotioncapture's `optitrack` backend (the `motioncapture` wheel, as Crazyswarm2 uses it):
/// it finds both rigid bodies by name, and every pose it hands out is one flyarena's log holds
/// for that vehicle, in Z-up.
#[test]
fn libmotioncapture_receives_the_poses_flyarena_sent() {
    if !python_has("motioncapture") {
        return;
    }
    let (port, data_port, out) = (free_port(), free_port(), tmp("motioncapture"));
    let mut srv = server(port, data_port, &out);
    let got = client("motioncapture_client.py", &[port.to_string(), "300".into()], Duration::from_secs(60));
    assert_eq!(srv.wait_for(Duration::from_secs(60)), 0);
    let logs: HashMap<&str, Vec<Pose32>> =
        [("cf1", "served-cf1.csv"), ("cf2", "served-cf2.csv")].into_iter().map(|(n, f)| (n, log_poses(&out.join(f)).values().map(|(_, p, q)| z_up(*p, *q)).collect())).collect();
    let poses = got["poses"].as_array().unwrap();
    assert!(poses.len() >= 300, "{} poses from 300 frames", poses.len());
    let mut names = std::collections::BTreeSet::new();
    for p in poses {
        let name = p[0].as_str().unwrap();
        let pose = (f32s::<3>(&p[1]), f32s::<4>(&p[2]));
        assert!(logs[name].contains(&pose), "{name}: {pose:?} is no pose flyarena logged for it");
        names.insert(name.to_string());
    }
    assert_eq!(names.into_iter().collect::<Vec<_>>(), ["cf1", "cf2"]);
}

/// A port already taken is bad input: exit 2 with what to do, nothing written.
#[test]
fn a_taken_port_is_refused_with_exit_2() {
    let taken = UdpSocket::bind("127.0.0.1:0").unwrap();
    let port = taken.local_addr().unwrap().port();
    let out = tmp("taken");
    let o = Command::new(env!("CARGO_BIN_EXE_flyarena"))
        .arg("serve")
        .arg(fixture())
        .args(["--command-port", &port.to_string(), "--wait-s", "0"])
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains(&format!("cannot listen on 127.0.0.1:{port}")) && err.contains("--command-port"), "{err}");
    assert_eq!(std::fs::read_dir(&out).unwrap().count(), 0, "nothing written");
}

//! Speed of the closed loop (recording off unless named):
//! * `loop_200hz/one_vicon_period`: one 5 ms Vicon period for one vehicle (mocap fit, link,
//!   estimation, control, radio, five 1 kHz physics and rate-loop steps);
//! * `fleet/N`: one Vicon period for a fleet of N = 1, 4, 16 vehicles (should grow linearly);
//! * `scenario/fig6`: the Fig. 6 scenario end to end (the compensated and the uncompensated run);
//! * `scenario/fig6_recorded`: the same plus the `.rrd` recording (encoding into memory), to
//!   show what recording costs.

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use flyarena::engine::{Arena, RunOptions};
use flyarena::scenario::Scenario;
use std::path::Path;

fn fig6() -> Scenario {
    // the checkout at run time, not the one this binary was built from (a shared target dir)
    let root = std::env::var_os("CARGO_MANIFEST_DIR")
        .map(std::path::PathBuf::from)
        .unwrap_or_else(|| env!("CARGO_MANIFEST_DIR").into());
    Scenario::load(&root.join("scenarios/fig6-roll-pitch-offsets.yaml")).unwrap()
}

const NO_TRACE: RunOptions = RunOptions { trace: false, apply_calibration: None };

/// Steps an arena in flight, five ticks (one Vicon period) per iteration.
fn bench_periods(b: &mut criterion::Bencher, s: &Scenario) {
    let mut arena = Arena::new(s.spec(), NO_TRACE);
    // fly into the hover first so that the benchmark measures flight, not the floor
    for _ in 0..6000 {
        arena.step();
    }
    b.iter(|| {
        for _ in 0..5 {
            arena.step();
        }
        if arena.done() {
            arena = Arena::new(s.spec(), NO_TRACE);
        }
    })
}

fn loop_200hz(c: &mut Criterion) {
    let s = fig6();
    let mut g = c.benchmark_group("loop_200hz");
    g.throughput(Throughput::Elements(1));
    g.bench_function("one_vicon_period", |b| bench_periods(b, &s));
    g.finish();
}

fn fleet(c: &mut Criterion) {
    let mut g = c.benchmark_group("fleet");
    for n in [1usize, 4, 16] {
        let vehicles: String = (0..n)
            .map(|i| {
                format!(
                    "  - {{ name: v{i}, home_m: [{}, {}], markers: {{ pattern: {}, rotation_deg: [2, -1, 0] }} }}\n",
                    (i % 4) as f64 * 2.0 - 3.0,
                    (i / 4) as f64 * 2.0 - 3.0,
                    i % 8
                )
            })
            .collect();
        // patterns repeat beyond 8 vehicles; give the others explicit, distinct templates
        let vehicles = if n > 8 {
            (0..n)
                .map(|i| {
                    let k = 0.10 + 0.008 * i as f64;
                    format!("  - {{ name: v{i}, home_m: [{}, {}], markers: {{ template_m: [[{k}, 0, -0.03], [0, 0.12, -0.03], [-0.13, 0, -0.03], [0, -0.09, -0.05]], rotation_deg: [2, -1, 0] }} }}\n", (i % 4) as f64 * 2.0 - 3.0, (i / 4) as f64 * 2.0 - 3.0)
                })
                .collect()
        } else {
            vehicles
        };
        let y = format!(
            "name: fleet{n}\nvehicles:\n{vehicles}plan:\n  - takeoff: {{ altitude_m: 1, duration_s: 3 }}\n  - calibrate_roll_pitch: {{ settle_s: 3, average_s: 20 }}\n"
        );
        let s = Scenario::parse(&y, Path::new("fleet.yaml")).unwrap_or_else(|e| panic!("{e}"));
        g.throughput(Throughput::Elements(n as u64));
        g.bench_with_input(BenchmarkId::from_parameter(n), &s, bench_periods);
    }
    g.finish();
}

fn scenario(c: &mut Criterion) {
    let s = fig6();
    let mut g = c.benchmark_group("scenario");
    g.sample_size(20);
    g.bench_function("fig6", |b| b.iter(|| flyarena::run::run_scenario(&s, false)));
    // the recording needs the `record` feature (Rerun); the build without it benches the rest
    #[cfg(feature = "record")]
    g.bench_function("fig6_recorded", |b| {
        b.iter(|| {
            let flyarena::run::Outcome { main, uncompensated: unc, report } = flyarena::run::run_scenario(&s, true);
            flyarena::record::encode(&main, unc.as_ref(), &report, flyarena::record::RecordOptions::default())
                .unwrap()
                .len()
        })
    });
    g.finish();
}

/// A 10-minute flight at 200 Hz (120,000 rows) with rotor drag hidden: circles, straight
/// flights there and back, and yaw turns, repeated.
fn ten_minute_log() -> flyarena::identify::Series {
    let mut plan = String::from("  - idle: { duration_s: 1 }\n  - takeoff: { altitude_m: 1, duration_s: 3 }\n");
    for _ in 0..19 {
        plan += "  - calibrate_gyro: { settle_s: 1, radius_m: 0.4, period_s: 2.5, turns: 3 }\n";
        plan += "  - waypoint: { pos_m: [5, 0, -1], speed_m_s: 1.5, accel_m_s2: 1.5, hold_s: 1 }\n";
        plan += "  - waypoint: { pos_m: [0, 0, -1], speed_m_s: 1.5, accel_m_s2: 1.5, hold_s: 1 }\n";
        plan += "  - yaw_spin: { settle_s: 1, angle_deg: 360, duration_s: 8 }\n";
    }
    plan += "  - land: { duration_s: 3 }\n";
    let yaml = format!(
        "name: ten-minutes\nduration_s: 600\nmocap: {{ noise_mm: 0.1 }}\nvehicles:\n  - name: x3d\n    imu: {{ gyro_noise_deg_s: 0.3, accel_noise_m_s2: 0.05 }}\n    undeclared: {{ rotor_drag_per_s: [0.3, 0.3] }}\nplan:\n{plan}"
    );
    let s = Scenario::parse(&yaml, std::path::Path::new("bench.yaml")).expect("valid");
    flyarena::identify::run_and_log(&s, 0, "ten minutes").expect("runs").1
}

/// `identify` on a 10-minute 200 Hz log (the whole method: residuals, selection, refits).
fn identify(c: &mut Criterion) {
    let series = ten_minute_log();
    assert_eq!(series.len(), 120_000);
    let mut g = c.benchmark_group("identify");
    g.sample_size(10);
    g.throughput(Throughput::Elements(series.len() as u64));
    g.bench_function("ten_minutes_200hz", |b| {
        b.iter(|| flyarena::identify::identify(&series, &flyarena::identify::Options::default()).expect("clean data"))
    });
    // the global start alone (the clock search over ±5 s, Wahba, the linear solve): its share of
    // the above, held to under 0.2 s per minute of data (docs/calibration.md)
    g.bench_function("global_start_ten_minutes_200hz", |b| {
        b.iter(|| flyarena::identify::start::start(&series, &flyarena::identify::start::ClockWindow::default(), 0.02))
    });
    g.finish();
}

/// `identify --calibrate` on a hand-held rig's 64 s log at MoCap2GT's setting (32,001 rows at
/// 500 Hz, read through `mappings/handheld.yaml`): the target is under 1 s per minute of data on
/// one core (docs/calibration.md); and the Cramér–Rao floor of that log as recorded, which
/// `trials --handheld` computes for each rig.
fn handheld(c: &mut Criterion) {
    use flyarena::identify::handheld;
    let series = handheld::draw(1, 0).series(&handheld::Setting::default()).expect("a drawn rig reads");
    let mut g = c.benchmark_group("identify");
    g.sample_size(10);
    g.throughput(Throughput::Elements(series.len() as u64));
    g.bench_function("handheld_64s_calibrate", |b| {
        b.iter(|| flyarena::identify::identify(&series, &handheld::options()).expect("clean data"))
    });
    // the floor of the same log as recorded: 32,001 samples of 12 nuisance variables eliminated
    let trial = handheld::draw(1, 0);
    g.bench_function("handheld_64s_floor_as_recorded", |b| {
        b.iter(|| handheld::bound_as_recorded(&trial, &handheld::Setting::default()).expect("every parameter is seen"))
    });
    g.finish();
}

criterion_group!(benches, loop_200hz, fleet, scenario, identify, handheld);
criterion_main!(benches);

//! `loop_200hz`: one 5 ms Vicon period of the closed loop for one vehicle (mocap fit, link,
//! estimation, control, radio, five 1 kHz physics and rate-loop steps), recording off.
//! `scenario`: the Fig. 6 scenario end to end (both the compensated and the uncompensated run).

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use flyarena::engine::{Arena, RunOptions};
use flyarena::scenario::Scenario;
use std::path::Path;

fn fig6() -> Scenario {
    Scenario::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("scenarios/fig6-roll-pitch-offsets.yaml")).unwrap()
}

fn loop_200hz(c: &mut Criterion) {
    let s = fig6();
    let mut g = c.benchmark_group("loop_200hz");
    g.throughput(Throughput::Elements(1));
    g.bench_function("one_vicon_period", |b| {
        let mut arena = Arena::new(&s, RunOptions { trace: false, apply_calibration: None });
        // fly into the hover first so that the benchmark measures flight, not the floor
        for _ in 0..6000 {
            arena.step();
        }
        b.iter(|| {
            for _ in 0..5 {
                arena.step();
            }
            if arena.done() {
                arena = Arena::new(&s, RunOptions { trace: false, apply_calibration: None });
            }
        })
    });
    g.finish();
}

fn scenario(c: &mut Criterion) {
    let s = fig6();
    c.bench_function("scenario/fig6", |b| b.iter(|| flyarena::cli::run_scenario(&s)));
}

criterion_group!(benches, loop_200hz, scenario);
criterion_main!(benches);

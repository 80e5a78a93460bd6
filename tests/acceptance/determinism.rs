//! Same scenario + seed → bit-identical trajectory, whatever the thread count.

use flyarena::engine::{RunOptions, RunOutput, run};
use flyarena::scenario::Scenario;

fn bits(out: &RunOutput) -> Vec<u64> {
    let mut b = Vec::new();
    for v in &out.vehicles {
        for s in &v.trace {
            b.push(s.t.0 as u64);
            for x in s.pos.to_array().into_iter().chain(s.vel.to_array()).chain([
                s.att_true.roll,
                s.att_true.pitch,
                s.att_true.yaw,
                s.thrust_n,
            ]) {
                b.push(x.to_bits());
            }
            if let Some(m) = s.att_measured {
                let q = m.quaternion();
                b.extend([q.i.to_bits(), q.j.to_bits(), q.k.to_bits(), q.w.to_bits()]);
            }
            if let Some(p) = s.ppm {
                b.extend(p.channels.iter().map(|c| *c as u64));
            }
        }
        b.push(v.calibration.roll_pitch.map_or(0, |x| x.0.to_bits()));
    }
    b
}

fn load(name: &str) -> Scenario {
    Scenario::load(&super::root().join("scenarios").join(name)).unwrap()
}

#[test]
fn two_runs_are_bit_identical() {
    let s = load("lossy-link.yaml");
    let a = bits(&run(s.spec(), RunOptions::default()));
    let b = bits(&run(s.spec(), RunOptions::default()));
    assert!(a.len() > 50_000);
    assert_eq!(a, b);
}

#[test]
fn runs_on_other_threads_match_the_sequential_run() {
    let s = load("fleet-4.yaml");
    let reference = bits(&run(s.spec(), RunOptions::default()));
    let parallel: Vec<Vec<u64>> = std::thread::scope(|sc| {
        let hs: Vec<_> = (0..3).map(|_| sc.spawn(|| bits(&run(s.spec(), RunOptions::default())))).collect();
        hs.into_iter().map(|h| h.join().unwrap()).collect()
    });
    for p in parallel {
        assert_eq!(p, reference);
    }
}

/// The RK4 step runs compiled for AVX2 where the CPU has it (`flyarena::cpu`); the any-CPU build
/// must give the same bits, with rotor drag (the full rotations) and without (the shortcut).
#[test]
fn the_avx2_and_the_any_cpu_step_give_the_same_bits() {
    if !flyarena::cpu::has_avx2() {
        eprintln!("this CPU has no AVX2: only the any-CPU build runs here");
        return;
    }
    for name in ["fig6-roll-pitch-offsets.yaml", "identify-rotor-drag.yaml"] {
        let s = load(name);
        let avx2 = bits(&run(s.spec(), RunOptions::default()));
        flyarena::cpu::set_baseline_only(true);
        let any_cpu = bits(&run(s.spec(), RunOptions::default()));
        flyarena::cpu::set_baseline_only(false);
        assert!(avx2.len() > 50_000);
        assert!(avx2 == any_cpu, "{name}: the two builds of the step differ");
    }
}

#[test]
fn a_different_seed_gives_a_different_trajectory() {
    let s = load("fig6-roll-pitch-offsets.yaml");
    let a = bits(&run(s.spec(), RunOptions::default()));
    let next = s.seed() + 1;
    assert_ne!(a, bits(&run(s.with_seed(next).spec(), RunOptions::default())));
}

/// Adding a vehicle must not change the draws of the others (one stream per component and vehicle).
#[test]
fn adding_a_vehicle_leaves_the_others_unchanged() {
    let fleet = load("fleet-4.yaml");
    let out4 = run(fleet.spec(), RunOptions::default());
    let y = std::fs::read_to_string(super::root().join("scenarios/fleet-4.yaml")).unwrap();
    let cut = y.find("  - name: bravo").unwrap();
    let rest = &y[y.find("plan:").unwrap()..];
    let single = super::inline(&format!("{}{}", &y[..cut], rest));
    let out1 = run(single.spec(), RunOptions::default());
    let a = bits(&RunOutput { vehicles: vec![out4.vehicles[0].clone()], ..out4.clone() });
    assert_eq!(a, bits(&out1));
}

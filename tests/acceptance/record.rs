//! The Rerun recording, decoded back: entities exist, values equal the engine's, no wall clock,
//! deterministic content.

use super::root;
use flyarena::record::{RecordOptions, decode, encode, recording_id};
use flyarena::run::{Outcome, run_scenario};
use flyarena::scenario::Scenario;

fn fig6() -> (Scenario, flyarena::engine::RunOutput, Option<flyarena::engine::RunOutput>, flyarena::requirements::Report)
{
    let s = Scenario::load(&root().join("scenarios/fig6-roll-pitch-offsets.yaml")).unwrap();
    let Outcome { main, uncompensated: unc, report } = run_scenario(&s, true);
    (s, main, unc, report)
}

#[test]
fn recording_holds_the_engine_values() {
    let (s, main, unc, report) = fig6();
    let bytes = encode(&main, unc.as_ref(), &report, RecordOptions { every: 4 }).unwrap();
    let rec = decode(&bytes).unwrap();
    assert_eq!(rec.recording_id.as_deref(), Some(recording_id(s.name(), s.seed()).as_str()));
    for e in [
        "/world",
        "/world/arena",
        "/world/x3d/true_body",
        "/world/x3d/true_body/markers",
        "/world/x3d/mocap_body",
        "/world/x3d/mocap_body/template",
        "/world/x3d/flown_path",
        "/world/x3d/reference_path",
        "/world/x3d/uncompensated_path",
        "/plots/x3d/attitude/roll/measured",
        "/plots/x3d/attitude/pitch/compensated",
        "/plots/x3d/ppm/thrust",
        "/plots/x3d/link/missing_frames",
        "/plots/x3d/position/uncompensated_deviation_m",
        "/events",
    ] {
        assert!(!rec.entity(e).is_empty(), "missing entity {e}");
    }
    // every 4th Vicon sample, values bit-equal to the engine's trace (degrees at the edge)
    let v = &main.vehicles[0];
    let want: Vec<(i64, f64)> = v.trace.iter().step_by(4).map(|s| (s.t.0, s.att_true.roll.to_degrees())).collect();
    assert_eq!(rec.scalars("/plots/x3d/attitude/roll/true"), want);
    let thrust: Vec<(i64, f64)> =
        v.trace.iter().step_by(4).filter_map(|s| s.ppm.map(|p| (s.t.0, p.channels[3] as f64))).collect();
    assert!(thrust.len() > 1000);
    assert_eq!(rec.scalars("/plots/x3d/ppm/thrust"), thrust);
    // the running hover average ends on the report's estimate
    let hover = rec.scalars("/plots/x3d/calibration/roll_hover_deg");
    assert_eq!(hover.len() as u64, v.calibration.roll_pitch.unwrap().2);
    assert_eq!(hover.last().unwrap().1, v.calibration.roll_pitch.unwrap().0.to_degrees());
    // the uncompensated counterpart circles: its recorded deviation peaks near the R2 figure
    let unc_dev = rec.scalars("/plots/x3d/position/uncompensated_deviation_m");
    let peak = unc_dev.iter().map(|x| x.1).fold(0.0, f64::max);
    let r2 = unc.as_ref().unwrap().vehicles[0].spin_max_deviation_m.unwrap();
    assert!(peak >= 0.9 * r2, "recorded peak {peak} m vs R2 {r2} m");
    // sim_time and tick only: no wall-clock timeline anywhere
    for c in &rec.chunks {
        for name in c.timelines().keys() {
            assert!(["sim_time", "tick"].contains(&name.as_str()), "unexpected timeline {name} on {}", c.entity_path());
        }
    }
    // the requirement results are events
    let events: usize = rec.entity("/events").iter().map(|c| c.num_rows()).sum();
    assert!(events >= v.phases.len() + report.rows.len(), "{events} events");
}

/// Same run → same recording content (ids of chunks and rows aside, as `rerun rrd compare`).
#[test]
fn identical_runs_give_identical_recordings() {
    let (_, a, ua, ra) = fig6();
    let (_, b, ub, rb) = fig6();
    let da = decode(&encode(&a, ua.as_ref(), &ra, RecordOptions::default()).unwrap()).unwrap();
    let db = decode(&encode(&b, ub.as_ref(), &rb, RecordOptions::default()).unwrap()).unwrap();
    assert_eq!(da.chunks.len(), db.chunks.len());
    for (x, y) in da.chunks.iter().zip(&db.chunks) {
        rerun::log::Chunk::ensure_similar(x, y).unwrap();
    }
}

/// Decimation keeps every `every`-th frame.
#[test]
fn decimation_is_applied() {
    let (_, main, unc, report) = fig6();
    let n = |every| {
        decode(&encode(&main, unc.as_ref(), &report, RecordOptions { every }).unwrap())
            .unwrap()
            .scalars("/plots/x3d/attitude/yaw/true")
            .len()
    };
    let frames = main.vehicles[0].trace.len();
    assert_eq!(n(1), frames);
    assert_eq!(n(10), frames.div_ceil(10));
}

/// The identify recording holds the residuals of the report, bit for bit, before and after.
#[test]
fn identify_recording_holds_the_residuals() {
    use flyarena::identify::residual::residual_series;
    use flyarena::identify::{Options, identify};
    let s = flyarena::scenario::Scenario::load(&super::root().join("scenarios/identify-rotor-drag.yaml")).unwrap();
    let (_, series) = flyarena::identify::run_and_log(&s, 0, "drag").unwrap();
    let opts = Options::default();
    let r = identify(&series, &opts).unwrap();
    let res = residual_series(&series, &opts, &r);
    let rec = decode(&flyarena::record::encode_identify("drag", &r, &res).unwrap()).unwrap();
    assert_eq!(rec.recording_id.as_deref(), Some("flyarena/identify/drag"));
    let fx = res.iter().find(|x| x.channel == flyarena::identify::Channel::Force && x.axis == 'x').unwrap();
    for (which, values) in [("nominal", &fx.before), ("with_effects", &fx.after)] {
        let got = rec.scalars(&format!("/identify/force/x/{which}"));
        assert_eq!(got.len(), values.len(), "{which}");
        assert!(got.iter().zip(values.iter()).all(|(g, v)| g.1.to_bits() == v.to_bits()), "{which}");
    }
    // the drag is visible in the nominal force x residual and gone with the effect
    let rms = |v: &[f64]| (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt();
    assert!(rms(&fx.after) < 0.2 * rms(&fx.before), "{} vs {}", rms(&fx.after), rms(&fx.before));
}

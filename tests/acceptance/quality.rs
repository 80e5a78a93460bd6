//! `identify`'s data-quality gate: each check catches the corruption it is for (and the others
//! would not), nothing is cut from clean flights, no parameter comes out of corrupted samples,
//! and a log with too little clean data is refused with a message that says where.

use flyarena::frames::Vec3;
use flyarena::identify::Mapping;
use flyarena::identify::quality::{Cut, QualityChannel};
use flyarena::identify::run_and_log;
use flyarena::identify::{Effect, Options, Series, identify};
use flyarena::scenario::Scenario;

const G: f64 = 9.81;

fn drag_flight() -> Series {
    let s = Scenario::load(&super::root().join("scenarios/identify-rotor-drag.yaml")).unwrap();
    run_and_log(&s, 0, "drag").unwrap().1
}

/// Rows with t in [from, to) s from the log's start.
fn rows(s: &Series, from: f64, to: f64) -> std::ops::Range<usize> {
    let t0 = s.t_s[0];
    let a = s.t_s.iter().position(|t| t - t0 >= from).unwrap();
    let b = s.t_s.iter().position(|t| t - t0 >= to).unwrap_or(s.len());
    a..b
}

fn cuts_of(r: &flyarena::identify::Report, ch: QualityChannel) -> Vec<&Cut> {
    r.data_quality.cuts.iter().filter(|c| c.channel == ch).collect()
}

/// The clean flight is not touched, and the rotor drag is found (the baseline of every test here).
#[test]
fn a_clean_simulated_flight_is_not_cut() {
    for preset in ["x3d", "crazyflie21"] {
        let s = Scenario::parse(
            &std::fs::read_to_string(super::root().join("scenarios/identify-rotor-drag.yaml"))
                .unwrap()
                .replace("  - name: x3d\n", &format!("  - name: x3d\n    model: {{ preset: {preset} }}\n")),
            std::path::Path::new("drag.yaml"),
        )
        .unwrap();
        let (_, series) = run_and_log(&s, 0, preset).unwrap();
        let r = identify(&series, &Options::default()).unwrap();
        assert!(r.data_quality.cuts.is_empty(), "{preset}: {:?}", r.data_quality);
    }
}

/// Each check on its own: a corruption that only it can see is cut, at the right time and on
/// the right channel, and the drag still comes out within its tolerance (0.35 1/s).
#[test]
fn each_check_cuts_what_it_is_for() {
    let clean = drag_flight();
    let g_fs = clean.model.imu_range.gyro_rad_s;
    type Corrupt = Box<dyn Fn(&mut Series)>;
    let cases: Vec<(&str, QualityChannel, f64, Corrupt)> = vec![
        // the gyro at 99 % of its full scale: its disagreement with the mocap (≈ 0.99·FS) stays
        // under the 300 °/s bound, so only the full-scale check sees it
        (
            "gyro full scale",
            QualityChannel::Gyro,
            11.0,
            Box::new(move |s: &mut Series| {
                for i in rows(s, 11.0, 11.03) {
                    s.gyro_body[i] = Vec3::new(0.99 * g_fs, s.gyro_body[i].y(), s.gyro_body[i].z());
                }
            }),
        ),
        // the accelerometer saturated while the mocap has lost the vehicle for 0.2 s: with no
        // pose to compare with, only the full scale can tell
        (
            "accel full scale, no mocap",
            QualityChannel::Accel,
            12.5,
            Box::new(|s: &mut Series| {
                for i in rows(s, 12.4, 12.6) {
                    s.mocap_ok[i] = false;
                }
                let i = rows(s, 12.5, 13.0).start;
                s.accel_body[i] =
                    Vec3::new(s.accel_body[i].x(), s.accel_body[i].y(), -0.99 * s.model.imu_range.accel_m_s2);
            }),
        ),
        // +5 g on the accelerometer's x for one sample: 49 m/s², under the ±6 g full scale
        (
            "accel spike",
            QualityChannel::Accel,
            15.0,
            Box::new(|s: &mut Series| {
                let i = rows(s, 15.0, 16.0).start;
                s.accel_body[i] += Vec3::new(5.0 * G, 0.0, 0.0);
            }),
        ),
        // the mocap teleports 1 m for 0.1 s (a marker swap): a jump, excluded from the IMU check
        (
            "mocap jump",
            QualityChannel::Mocap,
            18.0,
            Box::new(|s: &mut Series| {
                for i in rows(s, 18.0, 18.1) {
                    s.pos_mocap_nav[i] += Vec3::new(1.0, 0.0, 0.0);
                }
            }),
        ),
        // the accelerometer repeats one reading for 0.5 s while the vehicle flies its circles
        (
            "accel stuck",
            QualityChannel::Accel,
            9.5,
            Box::new(|s: &mut Series| {
                let r = rows(s, 9.5, 10.0);
                let v = s.accel_body[r.start];
                for i in r {
                    s.accel_body[i] = v;
                }
            }),
        ),
        // the mocap freezes for 0.5 s during the yaw spin (the gyro turns ≈ 20°)
        (
            "mocap frozen",
            QualityChannel::Mocap,
            24.0,
            Box::new(|s: &mut Series| {
                let r = rows(s, 24.0, 24.5);
                let (p, q) = (s.pos_mocap_nav[r.start], s.att_mocap[r.start]);
                for i in r {
                    s.pos_mocap_nav[i] = p;
                    s.att_mocap[i] = q;
                }
            }),
        ),
    ];
    for (name, channel, at, corrupt) in cases {
        let mut s = clean.clone();
        corrupt(&mut s);
        let r = identify(&s, &Options::default()).unwrap();
        let cuts = cuts_of(&r, channel);
        assert_eq!(r.data_quality.cuts.len(), 1, "{name}: {:?}", r.data_quality);
        assert_eq!(cuts.len(), 1, "{name}: {:?}", r.data_quality);
        let c = cuts[0];
        assert!(c.from_s <= at && c.to_s >= at && c.to_s - c.from_s < 1.5, "{name}: {c:?}");
        assert!(!c.at_floor, "{name}: {c:?}");
        assert!(
            matches!(&r.notes[0], flyarena::identify::Note::DataQualityCut { cuts, .. } if cuts.len() == 1)
                && r.notes[0].to_string().contains(channel.name()),
            "{name}: {}",
            r.notes[0]
        );
        let k = r
            .param(Effect::RotorDrag, "k_x")
            .unwrap_or_else(|| panic!("{name}: no drag\n{}", flyarena::identify::report::render(&r)));
        assert!((k - 0.35).abs() < 0.02, "{name}: k_x {k}");
        assert_eq!(r.effects.len(), 1, "{name}: {:?}", r.effects.iter().map(|e| e.effect).collect::<Vec<_>>());
    }
}

/// The gyro against the mocap, on the Crazyflie preset (±2000 °/s full scale, so the 300 °/s
/// disagreement bound is what decides): 10 rad/s of gyro in hover is cut.
#[test]
fn gyro_that_disagrees_with_the_mocap_is_cut() {
    let src = std::fs::read_to_string(super::root().join("scenarios/identify-rotor-drag.yaml"))
        .unwrap()
        .replace("  - name: x3d\n", "  - name: x3d\n    model: { preset: crazyflie21 }\n");
    let scen = Scenario::parse(&src, std::path::Path::new("cf.yaml")).unwrap();
    let (_, mut s) = run_and_log(&scen, 0, "cf").unwrap();
    for i in rows(&s, 6.0, 6.05) {
        s.gyro_body[i] = Vec3::new(s.gyro_body[i].x(), 10.0, s.gyro_body[i].z());
    }
    let r = identify(&s, &Options::default()).unwrap();
    let cuts = cuts_of(&r, QualityChannel::Gyro);
    assert_eq!(cuts.len(), 1, "{:?}", r.data_quality);
    assert!(
        matches!(cuts[0].findings[..], [flyarena::identify::quality::Finding::GyroDisagrees { .. }]),
        "{:?}",
        cuts[0]
    );
    assert!(cuts[0].from_s <= 6.0 && cuts[0].to_s >= 6.05, "{:?}", cuts[0]);
}

/// The plotted residuals' times are seconds from the log's first sample, whatever its clock reads
/// there: the drag flight cut to start 8 s in plots from 0 (its first usable row) to at most its
/// own length, not from 16 s. A bug it catches: `t − t₀` as `t + t₀` passed, because every log
/// whose residuals a test read started at t₀ = 0.
#[test]
fn residuals_are_plotted_in_seconds_from_the_logs_first_sample() {
    let clean = drag_flight();
    let late = clean.slice(rows(&clean, 8.0, 1e9).start, clean.len());
    let (t0, length) = (late.t_s[0], late.t_s[late.len() - 1] - late.t_s[0]);
    assert!(t0 - clean.t_s[0] >= 8.0, "the cut flight starts at {t0} s");
    let r = identify(&late, &Options::default()).unwrap();
    let plotted = flyarena::identify::residual::residual_series(&late, &Options::default(), &r);
    assert!(!plotted.is_empty());
    for x in &plotted {
        let (first, last) = (x.t_s[0], x.t_s[x.t_s.len() - 1]);
        assert!(
            (0.0..0.5).contains(&first) && last <= length,
            "{:?} {}: {first}..{last} s for a log of {length} s",
            x.channel,
            x.axis
        );
    }
}

/// Corrupted from 20 s to the end (accelerometer spikes to ~21 g, a gyro of tens of rad/s):
/// the log is identified from its clean first part, with the same drag as that part alone.
/// Corrupted from the start: refused, with the file and the stretch in the message.
#[test]
fn a_corrupted_tail_is_cut_and_a_corrupted_log_is_refused() {
    let clean = drag_flight();
    let corrupt_from = |s: &mut Series, from: f64| {
        let r = rows(s, from, 1e9);
        for (k, i) in r.enumerate() {
            let w = ((k * 7919) % 97) as f64 / 97.0 - 0.5;
            s.accel_body[i] = if k % 5 == 0 {
                Vec3::new(0.0, 0.0, -21.0 * G)
            } else {
                Vec3::new(8.0 * w * G, -6.0 * w * G, -G + 10.0 * w * G)
            };
            s.gyro_body[i] = Vec3::new(60.0 * w, -40.0 * w, 20.0 * w);
        }
    };
    let mut tail = clean.clone();
    corrupt_from(&mut tail, 20.0);
    let r = identify(&tail, &Options::default()).unwrap();
    let first = r.data_quality.cuts.iter().map(|c| c.from_s).fold(f64::INFINITY, f64::min);
    assert!((19.7..=20.0).contains(&first), "{:?}", r.data_quality);
    assert!(r.data_quality.cuts.iter().all(|c| !c.at_floor));
    // the plotted residuals and the cross-validation errors come from the samples the fit saw
    let plotted = flyarena::identify::residual::residual_series(&tail, &Options::default(), &r);
    assert!(plotted.iter().all(|x| x.t_s.iter().all(|t| *t < first)), "residuals plotted from cut samples");
    let evaluated = flyarena::identify::residual::evaluate(&tail, &Options::default(), &r);
    assert!(
        evaluated.iter().filter(|e| e.channel == flyarena::identify::Channel::AccelKin).all(|e| e.rmse_before < 1.0),
        "{evaluated:?}"
    );
    let clean_part = identify(&clean.slice(0, rows(&clean, 0.0, first).end), &Options::default()).unwrap();
    for p in ["k_x", "k_y"] {
        let (a, b) = (r.param(Effect::RotorDrag, p).unwrap(), clean_part.param(Effect::RotorDrag, p).unwrap());
        assert!((a - b).abs() < 0.005, "{p}: {a} vs the clean part's {b}");
    }
    let mut all = clean.clone();
    corrupt_from(&mut all, 0.5);
    let e = identify(&all, &Options::default()).unwrap_err().to_string();
    assert!(
        e.starts_with("drag:")
            && e.contains("data-quality gate")
            && e.contains("accel 0.30–")
            && e.contains("gyro 0.30–"),
        "{e}"
    );
}

/// The real flights: nothing airborne is cut (touchdowns are, and are said to be contact); a
/// flight whose IMU is corrupted from 32 s gives the clean part's body offset instead of
/// nonsense, and lists the stretch.
#[test]
fn nanobench_gate_cuts_touchdowns_only_and_rescues_a_corrupted_flight() {
    let Some(data) = super::shared_data() else { return };
    let map = Mapping::load(&super::root().join("mappings/nanobench.yaml")).unwrap();
    let mut opts = Options { forced: vec![Effect::BodyOffset], ..Options::default() };
    opts.design.smoothing_s = map.smoothing_ms.unwrap() * 1e-3;
    let dir = data.join("nanobench/dataset");
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "csv"))
        .collect();
    files.sort();
    for f in &files {
        let s = map.read(f).unwrap();
        let (_, q) = flyarena::identify::quality::gate(
            &s,
            &opts.quality,
            opts.design.smoothing_s,
            opts.design.min_height_m,
            &flyarena::identify::series::Corrections::default(),
        );
        assert!(q.corrupted().next().is_none(), "{}: {:?}", f.display(), q.cuts);
    }
    let s = map.read(&dir.join("B7_oval_fast_rep1.csv")).unwrap();
    let clean = identify(&s, &opts).unwrap();
    let mut bad = s.clone();
    for (k, i) in rows(&s, 32.0, 1e9).enumerate() {
        let w = ((k * 7919) % 97) as f64 / 97.0 - 0.5;
        bad.accel_body[i] = if k % 4 == 0 {
            Vec3::new(3.0 * G, 2.0 * G, -21.0 * G)
        } else {
            bad.accel_body[i] + Vec3::new(6.0 * w * G, 0.0, 5.0 * w * G)
        };
        bad.gyro_body[i] = Vec3::new(90.0 * w, -60.0 * w, 30.0 * w);
    }
    let r = identify(&bad, &opts).unwrap();
    let c = r.data_quality.corrupted().next().expect("the corrupted stretch is listed");
    assert!((31.7..=32.0).contains(&c.from_s), "{c:?}");
    for p in ["roll", "pitch"] {
        let (a, b) = (r.param(Effect::BodyOffset, p).unwrap(), clean.param(Effect::BodyOffset, p).unwrap());
        assert!((a - b).abs() < 0.3, "{p}: {a} with the tail cut, {b} on the clean flight");
    }
    let ts = r.param(Effect::ThrustScale, "scale − 1").unwrap();
    assert!((-0.35..-0.1).contains(&ts), "thrust scale {ts}");
}

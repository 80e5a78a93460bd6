use super::agreement::max_bias_tilt_deg;
use super::summary::{binomial_upper_tail, mann_whitney_greater};
use super::*;
use crate::frames::{Body, Rot, Vec3};
use crate::identify::fit::note::Note;
use crate::identify::input::series::NominalModel;
use crate::identify::input::series::Series;
use nalgebra::{UnitQuaternion, Vector3};

/// The report's notes on agreement `a`, as sentences.
fn agreement_notes(a: &GroundAgreement) -> Vec<String> {
    crate::identify::fit::note::of_ground_agreement(a).iter().map(ToString::to_string).collect()
}

const G: f64 = 9.81;

/// 1 s at rest (motors off), 0.6 s spinning at `fraction` of the weight on the floor, then a
/// climb; 100 Hz, level markers. The accelerometer reads a frame tilt of `rest_deg` (roll,
/// pitch) at rest and `spin_deg` more while the motors run.
fn flight(rest_deg: [f64; 2], spin_deg: [f64; 2], fraction: f64) -> Series {
    let n = 300;
    let dt = 0.01;
    let (rest_rows, spin_rows) = (100, 60);
    let tilt = |i: usize| {
        let extra = if i >= rest_rows { spin_deg } else { [0.0; 2] };
        // the accelerometer's frame turned by (roll, pitch) against the markers, in the sign
        // the ground check reports (δ = f̂ × f / |f̂|²): f = C·(−g·e_D), C the small rotation
        let c = UnitQuaternion::from_euler_angles(
            (rest_deg[0] + extra[0]).to_radians(),
            (rest_deg[1] + extra[1]).to_radians(),
            0.0,
        );
        c.transform_vector(&Vector3::new(0.0, 0.0, -G))
    };
    Series {
        source: "spin".into(),
        t_s: (0..n).map(|i| i as f64 * dt).collect(),
        pos_mocap_nav: (0..n)
            .map(|i| {
                Vec3::new(
                    0.0,
                    0.0,
                    if i < rest_rows + spin_rows { 0.0 } else { -0.01 * (i - rest_rows - spin_rows) as f64 },
                )
            })
            .collect(),
        att_mocap: vec![Rot::identity(); n],
        mocap_ok: vec![true; n],
        gyro_body: vec![Vec3::zeros(); n],
        // a little alternating noise so that the standard errors are finite
        accel_body: (0..n)
            .map(|i| Vec3::from_raw(tilt(i) + Vector3::new(0.01, -0.01, 0.0) * if i % 2 == 0 { 1.0 } else { -1.0 }))
            .collect(),
        thrust_n: Some((0..n).map(|i| if i < rest_rows { 0.0 } else { fraction * G }).collect()),
        vbat_v: None,
        segments: vec![(0, n)],
        // no battery column: the voltage reference is never read
        model: NominalModel::for_tests(G),
        repairs: vec![],
        clocks: Default::default(),
    }
}

/// The spin-up reads the rest's tilt plus what the spinning rotors add, over the rows from
/// 50 ms after the motors start until the lift (rows 105..161, the first climbing row at 161:
/// 0.56 s), at the thrust's fraction of the
/// weight; the rest keeps its own tilt.
#[test]
fn the_spin_up_reads_what_the_rotors_add() {
    let s = flight([0.4, -1.0], [0.0, 0.5], 0.9);
    let rest = ground_check(&s).unwrap();
    assert!((rest.roll_deg - 0.4).abs() < 1e-3 && (rest.pitch_deg + 1.0).abs() < 1e-3, "{rest:?}");
    let sp = spin_up(&s, Vec3::zeros()).unwrap();
    assert!((sp.check.roll_deg - 0.4).abs() < 1e-3 && (sp.check.pitch_deg + 0.5).abs() < 1e-3, "{sp:?}");
    assert!((sp.thrust_fraction - 0.9).abs() < 1e-12);
    assert!((sp.duration_s - 0.56).abs() < 1e-9 && sp.check.samples == 56, "{sp:?}");
    // a bias removed from every sample moves both alike: b_y/g in roll
    let b = spin_up(&s, Vec3::new(0.0, 0.0981, 0.0)).unwrap();
    assert!((sp.check.roll_deg - b.check.roll_deg - 0.0981f64.atan2(G).to_degrees()).abs() < 0.01, "{b:?}");
}

/// The markers' frame turned by `turn` over the whole flight, and the IMU offset from it by
/// `c`: the mocap reports R_m = turn and the accelerometer reads c·R_mᵀ·(−g·e_D), noise-free.
fn turned(turn: UnitQuaternion<f64>, c: UnitQuaternion<f64>) -> Series {
    let mut s = flight([0.0; 2], [0.0; 2], 0.9);
    for i in 0..s.len() {
        s.att_mocap[i] = Rot::from_quaternion(turn);
        s.accel_body[i] = Vec3::from_raw(c * turn.inverse_transform_vector(&Vector3::new(0.0, 0.0, -G)));
    }
    s
}

/// The ground check is the exact rotation between the two forces, about the body axes that
/// are level at rest, whichever axis is up: an IMU turned from the markers by α = 6° about a
/// level axis n reads α·n, by hand (a rotation about an axis perpendicular to gravity turns
/// it by exactly its angle), where the small-angle f̂ × f/|f̂|² read sin α (0.02° less). With
/// the markers level (z up) n = (cos β, sin β, 0) reads as roll and pitch; with the body on
/// its front face (turned 90° about y: x up) n = (0, cos β, sin β) reads about y and z; on its
/// side (turned −90° about x: y up) n = (sin β, 0, cos β) reads about z and x.
#[test]
fn the_ground_check_is_the_exact_rotation_about_the_level_axes() {
    let (alpha, beta) = (6f64.to_radians(), 0.7_f64);
    let (cb, sb) = (beta.cos(), beta.sin());
    for (turn, n, up) in [
        (UnitQuaternion::identity(), Vector3::new(cb, sb, 0.0), UpAxis::Z),
        (UnitQuaternion::from_euler_angles(0.0, 90f64.to_radians(), 0.0), Vector3::new(0.0, cb, sb), UpAxis::X),
        (UnitQuaternion::from_euler_angles(-90f64.to_radians(), 0.0, 0.0), Vector3::new(sb, 0.0, cb), UpAxis::Y),
    ] {
        let s = turned(turn, UnitQuaternion::from_scaled_axis(n * alpha));
        let g = ground_check(&s).unwrap();
        let [a, b] = up.level();
        let want = [n[a], n[b]].map(|x| (x * alpha).to_degrees());
        assert_eq!(g.up_axis, up);
        assert!(
            (g.roll_deg - want[0]).abs() < 1e-9 && (g.pitch_deg - want[1]).abs() < 1e-9,
            "{up:?} up: {g:?} against {want:?}"
        );
        assert!(rest_off_axis_deg(&s).unwrap() < 1e-9);
    }
    assert_eq!(UpAxis::X.tilt_names(), ["about y", "about z"]);
    // the JSON names the up axis only when it is not z
    let json = |turn| serde_json::to_string(&ground_check(&turned(turn, UnitQuaternion::identity())).unwrap()).unwrap();
    assert!(json(UnitQuaternion::from_euler_angles(0.0, 90f64.to_radians(), 0.0)).contains(r#""up_axis":"x""#));
    assert!(!json(UnitQuaternion::identity()).contains("up_axis"));
}

/// The flight's side reads what the ground check reads when the frames are the model's: an
/// accelerometer that measures Cᵀ·(−g·e_D) + b, C the IMU attitude the corrections give
/// (series::correct: W⁻¹·R_m·O⁻¹), at a rest turned 35° in yaw, with an offset of 5° roll,
/// −4° pitch and 30° yaw, a 6° world tilt and a 0.3 m/s² bias. The ground check of f − b is
/// the frame part, that of f the whole; a frame
/// composed the other way round (O·R_mᵀ·W⁻¹) misses by degrees.
#[test]
fn the_predicted_tilt_is_what_the_ground_check_reads_of_the_model() {
    use crate::identify::input::series::{Corrections, correct};
    let turn = UnitQuaternion::from_euler_angles(0.0, 0.0, 35f64.to_radians());
    let offset = UnitQuaternion::from_euler_angles(5f64.to_radians(), -4f64.to_radians(), 30f64.to_radians());
    let world = UnitQuaternion::from_euler_angles(6f64.to_radians(), -2f64.to_radians(), 0.0);
    let bias = Vector3::new(0.3, -0.2, 0.1);
    let mut s = turned(turn, UnitQuaternion::identity());
    let corr = Corrections {
        body_offset: Rot::from_quaternion(offset),
        world_tilt: Rot::from_quaternion(world),
        ..Corrections::default()
    };
    let att = correct(&s, &corr).att_body;
    for i in 0..s.len() {
        s.accel_body[i] =
            Vec3::from_raw(att[i].quaternion().inverse_transform_vector(&Vector3::new(0.0, 0.0, -G)) + bias);
    }
    let rest = rest_before_takeoff(&s).unwrap();
    let (offset, world, bias) = (corr.body_offset, corr.world_tilt, Vec3::<Body>::from_raw(bias));
    for (b, read) in [(Vec3::zeros(), tilt_at_rest(&s, bias).unwrap()), (bias, ground_check(&s).unwrap())] {
        let p = predicted_tilt(&s, &rest, &offset, &world, b).map(f64::to_degrees);
        assert!((p[0] - read.roll_deg).abs() < 1e-9 && (p[1] - read.pitch_deg).abs() < 1e-9, "{p:?} against {read:?}");
        // the world tilt's inverse, which the model does not make
        let swapped = predicted_tilt(&s, &rest, &offset, &world.inverse().assume_frames(), b).map(f64::to_degrees);
        assert!((swapped[0] - read.roll_deg).abs().max((swapped[1] - read.pitch_deg).abs()) > 1.0, "{swapped:?}");
    }
}

/// A body whose vertical is far from every body axis at rest gets no ground check: turned
/// 40° about x the vertical is 40° from z, where neither y nor z is level and gravity shows
/// only a mix of the tilts about them; 20° still reads, about x and y, the part of the
/// accelerometer's 0.4°/−1° offset that gravity shows (the offset's rotation vector less its
/// component along the body's up, to second order in 1.1°: 0.02°).
#[test]
fn a_body_resting_between_its_axes_gets_no_ground_check() {
    let c = UnitQuaternion::from_euler_angles(0.4f64.to_radians(), -1f64.to_radians(), 0.0);
    let s = turned(UnitQuaternion::from_euler_angles(20f64.to_radians(), 0.0, 0.0), c);
    let g = ground_check(&s).unwrap();
    let (gamma, up) = (c.scaled_axis(), s.att_mocap[0].quaternion().inverse_transform_vector(&-Vector3::z()));
    let want = (gamma - up * gamma.dot(&up)).map(f64::to_degrees);
    assert!(
        (g.roll_deg - want.x).abs() < 0.02 && (g.pitch_deg - want.y).abs() < 0.02 && want.y.abs() > 0.5,
        "{g:?} against {want:?}"
    );
    let turn = UnitQuaternion::from_euler_angles(40f64.to_radians(), 0.0, 0.0);
    let s = turned(turn, c);
    let off = rest_off_axis_deg(&s).unwrap();
    assert!((off - 40.0).abs() < 1e-9, "{off}");
    assert!(ground_check(&s).is_none());
    let r = crate::identify::identify(&climbing(s), &crate::identify::Options::default()).unwrap();
    assert!(
        r.ground_check.is_none()
            && r.notes
                .iter()
                .any(|n| n.to_string().starts_with("the log rests with the vertical 40° from the nearest body axis")),
        "{:?}",
        r.notes
    );
    // a level rest that gets no check for another reason (its accelerometer ramps by
    // 0.01 m/s² a row: no 0.5 s of still rows) is not said to rest off its axes
    let mut s = turned(UnitQuaternion::identity(), c);
    for i in 0..100 {
        s.accel_body[i] += Vec3::new(0.01 * i as f64, 0.0, 0.0);
    }
    let r = crate::identify::identify(&climbing(s), &crate::identify::Options::default()).unwrap();
    assert!(
        r.ground_check.is_none() && !r.notes.iter().any(|n| matches!(n, Note::RestOffAxis { .. })),
        "{:?}",
        r.notes
    );
}

/// `s` with its climb carried on to 43 s, long enough to select (a note comes with a full
/// report).
fn climbing(mut s: Series) -> Series {
    let n = 4300;
    let turn = s.att_mocap[0];
    for i in s.len()..n {
        s.t_s.push(i as f64 * 0.01);
        s.pos_mocap_nav.push(Vec3::new(0.0, 0.0, -0.01 * (i - 160) as f64));
        s.att_mocap.push(turn);
        s.mocap_ok.push(true);
        s.gyro_body.push(Vec3::zeros());
        s.accel_body.push(s.accel_body[i - 2]);
        s.thrust_n.as_mut().unwrap().push(0.9 * G);
    }
    s.segments = vec![(0, n)];
    s
}

/// No spin-up without a thrust column, or when the vehicle lifts within 0.3 s of the motors.
#[test]
fn no_spin_up_without_thrust_or_time_on_the_floor() {
    let mut s = flight([0.0; 2], [0.0; 2], 0.9);
    s.thrust_n = None;
    assert!(spin_up(&s, Vec3::zeros()).is_none());
    let mut s = flight([0.0; 2], [0.0; 2], 0.9);
    // lifts 0.3 s after the motors start: 0.25 s of usable rows
    for i in 130..s.len() {
        s.pos_mocap_nav[i] = Vec3::new(s.pos_mocap_nav[i].x(), s.pos_mocap_nav[i].y(), -0.004);
    }
    assert!(spin_up(&s, Vec3::zeros()).is_none());
}

/// The lift is measured from the floor's own height: on a platform 0.5 m up (z = −0.5 m in
/// NED) the spin-up is the same 56 rows as on the floor.
#[test]
fn the_lift_is_measured_from_the_rest_height() {
    let mut s = flight([0.0; 2], [0.0, 0.5], 0.9);
    for p in &mut s.pos_mocap_nav {
        *p += Vec3::new(0.0, 0.0, -0.5);
    }
    let sp = spin_up(&s, Vec3::zeros()).unwrap();
    assert_eq!(sp.check.samples, 56, "{sp:?}");
}

/// A flight's frame tilt (deg) with a tight interval.
fn tilt(deg: [f64; 2]) -> FlightTilt {
    FlightTilt {
        offset_rad: deg.map(f64::to_radians),
        sd_rad: [0.001; 2],
        widen_rad: [0.0; 2],
        frame_fitted: true,
        accel_bias_fitted: false,
    }
}

/// A rotation at rest never agrees because a bias no sensor has explains it: the ground
/// reads a 104° pitch, a fitted bias of 1.6 g takes it to 0°, the flight's frames say 0°, and
/// the agreement is a DISAGREE. A bias tilt of 5° (0.85 m/s²) that does the same agrees.
#[test]
fn an_impossible_bias_makes_no_agreement() {
    let check = |pitch: f64| GroundCheck {
        roll_deg: 0.0,
        pitch_deg: pitch,
        roll_se_deg: 0.01,
        pitch_se_deg: 0.01,
        up_axis: UpAxis::Z,
        samples: 100,
        mocap_sd_deg: [0.01; 2],
    };
    let flight = FlightTilt {
        offset_rad: [0.0; 2],
        sd_rad: [0.001; 2],
        widen_rad: [0.0; 2],
        frame_fitted: true,
        accel_bias_fitted: true,
    };
    let a = agreement(&check(104.0), &check(0.0), &flight, None, None);
    assert!(!a.pitch.covers && a.roll.covers, "{a:?}");
    let a = agreement(&check(5.0), &check(0.0), &flight, None, None);
    assert!(a.pitch.covers, "{a:?}");
    assert!((max_bias_tilt_deg() - (2.0f64 / crate::vehicle::params::GRAVITY).asin().to_degrees()).abs() < 1e-12);
}

/// The agreement's spin-up: change = spin-up − rest, difference = spin-up − flight.
#[test]
fn the_spin_up_agreement_compares_with_rest_and_flight() {
    let s = flight([0.4, -1.0], [0.0, 0.5], 0.9);
    let (raw, sp) = (ground_check(&s).unwrap(), spin_up(&s, Vec3::zeros()).unwrap());
    // a flight that pins its tilt down only to ±2.2° (σ 0.02 rad) covers a 1.2° difference,
    // and the note says so at the interval's precision
    let loose = FlightTilt { sd_rad: [0.02; 2], ..tilt([0.4, 0.2]) };
    let notes = agreement_notes(&agreement(&raw, &raw, &loose, None, None));
    assert_eq!(
        notes,
        [
            "ground check and flight differ by -1.2 ± 2.2° in pitch, within what this flight determines: the flight cannot pin its tilt down to 1°"
        ]
    );
    let a = agreement(&raw, &raw, &tilt([0.4, -0.6]), Some(&sp), None);
    let su = a.spin_up.unwrap();
    assert!((su.pitch.change_deg - 0.5).abs() < 1e-3 && su.roll.change_deg.abs() < 1e-3, "{su:?}");
    // the report names the reference that agrees where the rest does not: a flight at the
    // spin-up's pitch disagrees with the rest by 0.5° and agrees with the spin-up
    let notes = agreement_notes(&agreement(&raw, &raw, &tilt([0.4, -0.5]), Some(&sp), None));
    assert_eq!(notes.len(), 1, "{notes:?}");
    assert!(
        notes[0].contains("disagree in pitch")
            && notes[0].contains("the spin-up (motors on, still on the floor) moved +0.501 ± 0.020°")
            && notes[0].contains("agrees with it (+0.00 ±"),
        "{notes:?}"
    );
    assert!((su.pitch.difference_deg - 0.1).abs() < 1e-3 && (a.pitch.difference_deg + 0.4).abs() < 1e-3, "{a:?}");
    // with a bias removed from both checks the change is the same (the bias cancels) and
    // the difference moves by the bias tilt
    let b = Vec3::new(0.0981, 0.0, 0.0);
    let (rc, spc) = (tilt_at_rest(&s, b).unwrap(), spin_up(&s, b).unwrap());
    let ab = agreement(&raw, &rc, &tilt([0.4, -0.6]), Some(&spc), None);
    let sb = ab.spin_up.unwrap();
    assert!((sb.pitch.change_deg - 0.5).abs() < 1e-3, "{sb:?}");
    assert!(
        (sb.pitch.difference_deg - su.pitch.difference_deg - ab.pitch.bias_tilt_deg.abs()).abs() < 1e-3
            || (sb.pitch.difference_deg - su.pitch.difference_deg + ab.pitch.bias_tilt_deg.abs()).abs() < 1e-3,
        "{sb:?} {ab:?}"
    );
    assert!(ab.pitch.bias_tilt_deg.abs() > 0.5, "{ab:?}");
}

/// The sign test against the binomial by hand: P(X ≥ 8 | n = 9, ½) = (9 + 1)/512;
/// P(X ≥ 0) = 1; P(X ≥ 5 | 9) = ½.
#[test]
fn binomial_tail_by_hand() {
    assert!((binomial_upper_tail(9, 8) - 10.0 / 512.0).abs() < 1e-15);
    assert_eq!(binomial_upper_tail(9, 0), 1.0);
    assert!((binomial_upper_tail(9, 5) - 0.5).abs() < 1e-15);
    assert!((binomial_upper_tail(4, 4) - 1.0 / 16.0).abs() < 1e-15);
}

/// The summary counts a change as toward the flight when it has the opposite sign of
/// rest − flight, and takes the medians of both differences.
#[test]
fn the_summary_counts_moves_toward_the_flight() {
    let s = flight([0.0, 0.0], [0.0, 0.5], 0.9);
    let (raw, sp) = (ground_check(&s).unwrap(), spin_up(&s, Vec3::zeros()).unwrap());
    // flights at pitch 0.4 (toward: rest − flight = −0.4, change +0.5), and one at −0.4 (away)
    let at = |p: f64| agreement(&raw, &raw, &tilt([0.0, p]), Some(&sp), None);
    let v = [at(0.4), at(0.4), at(-0.4)];
    let sum = spin_up_summary(v.iter()).unwrap();
    assert_eq!((sum.flights, sum.pitch.toward_flight), (3, 2));
    assert!(
        (sum.pitch.median_rest_deg - 0.4).abs() < 1e-3 && (sum.pitch.median_spin_up_deg - 0.1).abs() < 1e-3,
        "{sum:?}"
    );
    assert!((sum.pitch.sign_test_p - 0.5).abs() < 1e-12);
    assert!(spin_up_summary(v[..2].iter()).is_none());
}

/// Mann–Whitney by hand. a = {3, 4, 5}, b = {1, 2}: ranks 3 + 4 + 5 = 12, U = 12 − 6 = 6,
/// mean 3, variance 3·2·6/12 = 3, z = √3, P = 0.04163. With ties, a = {2, 2}, b = {1, 2}:
/// ranks 1 | 3, 3, 3, R_a = 6, U = 3, mean 2, tie term 3³ − 3 = 24, variance
/// (4/12)·(5 − 24/12) = 1, z = 1, P = 0.15866. The same sample twice: z = 0, P = ½; the
/// other way round: 1 − 0.04163.
#[test]
fn mann_whitney_matches_a_hand_computed_value() {
    // exact, by counting: {3, 4, 5} above {1, 2} is the one arrangement of C(5, 3) = 10 with
    // the largest rank sum, p = 1/10
    assert!((mann_whitney_greater(&[3.0, 4.0, 5.0], &[1.0, 2.0]) - 0.1).abs() < 1e-12);
    // ties: pooled 1, 2, 2, 2 has midranks 1, 3, 3, 3; a = {2, 2} has rank sum 6, and of the
    // C(4, 2) = 6 pairs, three sum to 6 ({3, 3}) and three to 4 ({1, 3}): p = 3/6
    assert!((mann_whitney_greater(&[2.0, 2.0], &[1.0, 2.0]) - 0.5).abs() < 1e-12);
    // a = {1, 2} of pooled 1, 1, 2, 2 (midranks 1.5, 1.5, 3.5, 3.5): sum 5; of 6 pairs, one
    // sums to 3, four to 5, one to 7: P(≥ 5) = 5/6
    assert!((mann_whitney_greater(&[1.0, 2.0], &[1.0, 2.0]) - 5.0 / 6.0).abs() < 1e-12);
    // below: {1, 2} against {3, 4, 5} is the smallest sum, every arrangement reaches it
    assert!((mann_whitney_greater(&[1.0, 2.0], &[3.0, 4.0, 5.0]) - 1.0).abs() < 1e-12);
    // 3 against 6, the three largest: 1 of C(9, 3) = 84
    assert!((mann_whitney_greater(&[7.0, 8.0, 9.0], &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0]) - 1.0 / 84.0).abs() < 1e-12);
    // the normal approximation above 50 pooled samples: 26 against 25 with a's ranks 26..=51,
    // U = 650 − 0, mean 325, sd √(650·52/12) = 53.07: z = 6.124, p = 4.6e-10
    let a: Vec<f64> = (26..52).map(f64::from).collect();
    let b: Vec<f64> = (1..26).map(f64::from).collect();
    let p = mann_whitney_greater(&a, &b);
    assert!((p / 4.57e-10 - 1.0).abs() < 0.02, "{p}");
    // with ties above 50: thirty 1s against fifteen 0s and fifteen 1s; midranks 8 and 38,
    // U = 30·38 − 465 = 675, mean 450, tie term Σ(t³ − t) = 3360 + 91080 over 60·59, so
    // var = (900/12)·(61 − 26.678) = 2574.2, z = 4.4347, p = 4.610e-6 (without the tie term
    // z = 3.327, p = 4.4e-4)
    let b: Vec<f64> = [0.0; 15].into_iter().chain([1.0; 15]).collect();
    let p = mann_whitney_greater(&[1.0; 30], &b);
    assert!((p / 4.6098e-6 - 1.0).abs() < 1e-3, "{p}");
}

/// The test's size: under "both from one distribution" (uniform draws; 31 against 37 as the
/// held-out split, normal approximation), p < 0.05 in about 5 % of 4000 draws (binomial 95 %
/// band 4.3–5.7 %) and p < 0.01 in about 1 %. 3 against 6 (the shared split) is exact: its p
/// takes the values k/84, and P(p ≤ 4/84) = 4/84 = 4.76 % exactly, P(p < 0.01) = 0.
#[test]
fn mann_whitney_holds_its_level_under_the_null() {
    for (na, nb) in [(3, 6), (31, 37)] {
        let mut rng = crate::rng::Stream::new(7, crate::rng::Component::Sweep, na);
        let (mut at5, mut at1, n) = (0, 0, 4000);
        for _ in 0..n {
            let a: Vec<f64> = (0..na).map(|_| rng.uniform()).collect();
            let b: Vec<f64> = (0..nb).map(|_| rng.uniform()).collect();
            let p = mann_whitney_greater(&a, &b);
            at5 += usize::from(p < 0.05);
            at1 += usize::from(p < 0.01);
        }
        let (f5, f1) = (at5 as f64 / n as f64, at1 as f64 / n as f64);
        if na == 3 {
            // binomial 95 % band of 4000 draws around 4/84
            assert!((f5 - 4.0 / 84.0).abs() < 0.007 && at1 == 0, "{na} vs {nb}: {f5} at 5 %, {f1} at 1 %");
        } else {
            assert!((f5 - 0.05).abs() < 0.007 && (f1 - 0.01).abs() < 0.004, "{na} vs {nb}: {f5} at 5 %, {f1} at 1 %");
        }
    }
}

/// A rest whose mocap roll scatters by more than STILL_POSE_SD_DEG is flagged, its
/// disagreement says why the rest is unreliable, and the summary splits the flights by it:
/// still flights at roll 0.1, 0.2 (ground 0, so |difference| 0.1, 0.2: median 0.15), scattering
/// ones at 0.6, 0.8 and 1.2 (median 0.8, one beyond 1°).
#[test]
fn a_rest_whose_pose_scatters_is_flagged_and_summarised_apart() {
    let raw = ground_check(&flight([0.0, 0.0], [0.0; 2], 0.9)).unwrap();
    let scatter = GroundCheck { mocap_sd_deg: [0.1, 0.1], ..raw };
    let edge = GroundCheck { mocap_sd_deg: [STILL_POSE_SD_DEG, 0.5], ..raw };
    assert!(
        !agreement(&edge, &edge, &tilt([0.0, 0.0]), None, None).rest_pose_scatters,
        "the threshold itself is still, pitch does not count"
    );
    let at = |g: &GroundCheck, roll: f64| agreement(g, g, &tilt([roll, 0.0]), None, None);
    let v = [at(&raw, 0.1), at(&raw, 0.2), at(&scatter, 0.6), at(&scatter, 0.8), at(&scatter, 1.2)];
    assert!(!v[0].rest_pose_scatters && v[2].rest_pose_scatters);
    let notes = agreement_notes(&v[2]);
    assert!(notes.iter().any(|n| n.contains("disagree in roll") && n.contains("scatters by 0.100°")), "{notes:?}");
    assert!(!agreement_notes(&at(&raw, 0.6)).iter().any(|n| n.contains("scatters")));
    // with two still flights more, at 0.05° and 0.3° (their median stays 0.15°)
    let w: Vec<GroundAgreement> = v.iter().cloned().chain([at(&raw, 0.05), at(&raw, 0.3)]).collect();
    let sum = rest_pose_summary(w.iter()).unwrap();
    assert_eq!((sum.still, sum.scattering, sum.roll.still_beyond_1deg, sum.roll.scattering_beyond_1deg), (4, 3, 0, 1));
    // (the constructed rest reads 0.0007° of roll from its noise)
    assert!(
        (sum.roll.median_still_deg - 0.15).abs() < 2e-3 && (sum.roll.median_scattering_deg - 0.8).abs() < 2e-3,
        "{sum:?}"
    );
    // every scattering difference above every still one: exact, 1 of C(7, 3) = 35 arrangements
    assert!((sum.roll.mann_whitney_p - 1.0 / 35.0).abs() < 1e-12, "{sum:?}");
    // 3 against 2 cannot be significant: its smallest p is 1/10
    let few = rest_pose_summary(v.iter()).unwrap();
    assert!((few.roll.mann_whitney_p - 0.1).abs() < 1e-12, "{few:?}");
    assert!(rest_pose_summary(v[1..].iter()).is_none(), "one still flight is too few");
    // two in each group is enough, one scattering flight is too few
    assert!(rest_pose_summary(v[..4].iter()).is_some_and(|s| (s.still, s.scattering) == (2, 2)));
    assert!(rest_pose_summary(v[..3].iter()).is_none(), "one scattering flight is too few");
}

/// `flight` followed by a landing: from row 300 back on the floor (z = `end_z`, NED), motors
/// off, 100 rows whose accelerometer reads a frame tilt of `after_deg` (the rest before
/// keeps `before_deg`).
fn landed(before_deg: [f64; 2], after_deg: [f64; 2], end_z: f64) -> Series {
    let mut s = flight(before_deg, [0.0; 2], 0.9);
    let c = UnitQuaternion::from_euler_angles(after_deg[0].to_radians(), after_deg[1].to_radians(), 0.0);
    for i in 0..100 {
        s.t_s.push((300 + i) as f64 * 0.01);
        s.pos_mocap_nav.push(Vec3::new(0.0, 0.0, end_z));
        s.att_mocap.push(Rot::identity());
        s.mocap_ok.push(true);
        s.gyro_body.push(Vec3::zeros());
        s.accel_body.push(Vec3::from_raw(
            c.transform_vector(&Vector3::new(0.0, 0.0, -G))
                + Vector3::new(0.01, -0.01, 0.0) * if i % 2 == 0 { 1.0 } else { -1.0 },
        ));
        s.thrust_n.as_mut().unwrap().push(0.0);
    }
    s.segments = vec![(0, 400)];
    s
}

/// A rest whose accelerometer ramps while the markers sit still (as every NanoBench log's
/// last 0.2–0.3 s do: the logger extrapolates past the sensor's last sample) is read over its
/// still rows only: a ramp of 0.05 m/s² per row from row 60 of the rest's 0..81 is read over
/// rows 0..64, where it stays within the tolerance max(0.098, 8σ) = 0.168 m/s² (σ = 0.021
/// m/s² from the ±0.01 alternation). The three ramp rows inside it leak
/// (0.05 + 0.10 + 0.15)/64/g rad = 0.027° into pitch (f_x reads as −pitch); all 21 ramp rows
/// would move it by 0.76°. A ramp over the whole rest leaves no still run of 0.5 s: no
/// ground check.
#[test]
fn a_rest_whose_accelerometer_ramps_is_read_over_its_still_rows() {
    let clean = ground_check(&flight([0.4, -1.0], [0.0; 2], 0.9)).unwrap();
    assert_eq!(clean.samples, 81);
    let mut s = flight([0.4, -1.0], [0.0; 2], 0.9);
    for i in 60..100 {
        s.accel_body[i] += Vec3::new(0.05 * (i - 60) as f64, 0.0, 0.0);
    }
    let rest = ground_check(&s).unwrap();
    assert_eq!(rest.samples, 64, "{rest:?}");
    let leak = (0.30 / 64.0 / G).to_degrees();
    assert!((rest.roll_deg - 0.4).abs() < 1e-3 && (rest.pitch_deg - (-1.0 - leak)).abs() < 1e-3, "{rest:?}");
    for i in 0..100 {
        s.accel_body[i] += Vec3::new(0.05 * i as f64, 0.0, 0.0);
    }
    assert!(ground_check(&s).is_none());
    // a non-finite reading is not still: the rest is read after it (rows 11..81)
    let mut s = flight([0.4, -1.0], [0.0; 2], 0.9);
    s.accel_body[10] = Vec3::new(s.accel_body[10].x(), f64::NAN, s.accel_body[10].z());
    let rest = ground_check(&s).unwrap();
    assert!(rest.samples == 70 && (rest.roll_deg - 0.4).abs() < 1e-3, "{rest:?}");
}

/// The rest after landing reads its own tilt over the rows from 0.5 s after the landing (50
/// of 100), wherever the landing spot is within 5 cm of the take-off's; the agreement's
/// bracket is the two rests' mean against the flight, its interval at least half their change.
#[test]
fn the_rest_after_landing_reads_its_own_tilt_and_brackets_the_flight() {
    for end_z in [0.0, 0.02, -0.04] {
        let s = landed([0.4, -1.0], [0.2, -0.4], end_z);
        let after = tilt_after_landing(&s, Vec3::zeros()).unwrap();
        assert!(
            (after.roll_deg - 0.2).abs() < 1e-3 && (after.pitch_deg + 0.4).abs() < 1e-3 && after.samples == 50,
            "{after:?}"
        );
    }
    let s = landed([0.4, -1.0], [0.2, -0.4], 0.0);
    let (raw, after) = (ground_check(&s).unwrap(), tilt_after_landing(&s, Vec3::zeros()).unwrap());
    let a = agreement(&raw, &raw, &tilt([0.3, -0.9]), None, Some(&after));
    let l = a.after_landing.unwrap();
    // after − before, after − flight, (before + after)/2 − flight
    assert!((l.roll.check.change_deg + 0.2).abs() < 1e-3 && (l.pitch.check.change_deg - 0.6).abs() < 1e-3, "{l:?}");
    assert!(
        (l.roll.check.difference_deg + 0.1).abs() < 1e-3 && (l.pitch.check.difference_deg - 0.5).abs() < 1e-3,
        "{l:?}"
    );
    assert!(l.roll.bracket_difference_deg.abs() < 1e-3 && (l.pitch.bracket_difference_deg - 0.2).abs() < 1e-3, "{l:?}");
    assert!(l.pitch.bracket_ci95_deg >= 0.3 && l.pitch.bracket_covers && !l.pitch.check.covers, "{l:?}");
    // the change's interval is the two rests' standard errors combined, 1.96·√(se_a² + se_b²)
    let change_ci = 1.959964 * after.roll_se_deg.hypot(raw.roll_se_deg);
    assert!(change_ci > 0.0 && (l.roll.check.change_ci95_deg / change_ci - 1.0).abs() < 1e-5, "{l:?} vs {change_ci}");
    // the bracket's half-width: the mean of the two rests' standard errors and the flight's
    // scatter (each ×1.96, in quadrature), plus half the change (0.6° in pitch) and the flight's
    // widening (0.05° here), each added once
    let wide = FlightTilt { widen_rad: [0.05f64.to_radians(); 2], ..tilt([0.3, -0.9]) };
    let lw = agreement(&raw, &raw, &wide, None, Some(&after)).after_landing.unwrap();
    let z = 1.959963984540054;
    let by_hand =
        (z * 0.5 * after.pitch_se_deg.hypot(raw.pitch_se_deg)).hypot(z * 0.001f64.to_degrees()) + 0.5 * 0.6 + 0.05;
    assert!(
        (lw.pitch.bracket_ci95_deg - by_hand).abs() < 1e-3,
        "{} against {by_hand} by hand",
        lw.pitch.bracket_ci95_deg
    );
    // this flight sits between its rests (before − flight: +0.1 roll, −0.1 pitch; after −
    // flight: −0.1, +0.5); one at pitch −1.2 does not in pitch (+0.2, +0.8; bracket +0.5)
    // a flight at pitch −0.6 disagrees with the rest before (−0.4) and agrees with the
    // mean of the two rests (−0.1 ± at least 0.3): the report says so
    let notes = agreement_notes(&agreement(&raw, &raw, &tilt([0.4, -0.6]), None, Some(&after)));
    assert_eq!(notes.len(), 1, "{notes:?}");
    assert!(
        notes[0].contains("disagree in pitch")
            && notes[0].contains("the mean of the rests before and after the flight agrees with it (-0.10 ±"),
        "{notes:?}"
    );
    let out = agreement(&raw, &raw, &tilt([0.3, -1.2]), None, Some(&after));
    let b = [a, out, agreement(&raw, &raw, &tilt([1.9, -0.9]), None, None)];
    assert!(landed_summary(b.iter()).is_none(), "fewer than 3 flights with both rests");
    let b = [b[0], b[0], b[1], b[2]];
    let sum = landed_summary(b.iter()).unwrap();
    assert_eq!((sum.flights, sum.with_both, sum.roll.between, sum.pitch.between), (4, 3, 3, 2));
    assert!(
        (sum.pitch.median_change_deg - 0.6).abs() < 1e-3 && (sum.pitch.median_bracket_deg - 0.2).abs() < 1e-3,
        "{sum:?}"
    );
    // the flight without a rest after landing is judged by its rest before: 0.4 − 1.9
    assert_eq!((sum.roll.beyond_1deg, sum.roll.beyond_1deg_covered), (1, 0));
}

/// No rest after landing when the log ends in the air, 6 cm off the take-off's floor, with
/// the motors on, after less than 0.5 s still (beyond the settling), or without a flight.
#[test]
fn no_rest_after_landing_unless_it_landed_and_stayed() {
    assert!(tilt_after_landing(&landed([0.0; 2], [0.0; 2], -0.5), Vec3::zeros()).is_none());
    assert!(tilt_after_landing(&landed([0.0; 2], [0.0; 2], -0.06), Vec3::zeros()).is_none());
    let mut s = landed([0.0; 2], [0.0; 2], 0.0);
    s.thrust_n.as_mut().unwrap()[399] = 1.0;
    assert!(tilt_after_landing(&s, Vec3::zeros()).is_none());
    let s = landed([0.0; 2], [0.0; 2], 0.0).slice(0, 399);
    assert!(tilt_after_landing(&s, Vec3::zeros()).is_none(), "0.49 s still after the settling");
    let s = landed([0.0; 2], [0.0; 2], 0.0).slice(0, 400);
    assert!(tilt_after_landing(&s, Vec3::zeros()).is_some());
    // a log that never leaves the floor has no landing
    let mut s = landed([0.0; 2], [0.0; 2], 0.0);
    s.thrust_n = Some(vec![0.0; 400]);
    s.pos_mocap_nav.iter_mut().for_each(|p| *p = Vec3::new(p.x(), p.y(), 0.0));
    assert!(tilt_after_landing(&s, Vec3::zeros()).is_none());
}

/// The mocap's own tilt scatter at rest, by hand: a pose rolled +0.1° and −0.1° on
/// alternate rows (pitch still) over m rows (m odd: one more +0.1°, mean 0.1°/m) has a
/// per-sample standard deviation of 0.1°·√((m − 1/m)/(m − 1)) in roll and 0 in pitch,
/// whatever the accelerometer reads; a still pose has 0.
#[test]
fn the_mocap_scatter_at_rest_is_the_poses_own() {
    let mut s = flight([0.3, -0.2], [0.0; 2], 0.9);
    assert_eq!(ground_check(&s).unwrap().mocap_sd_deg, [0.0, 0.0]);
    for i in 0..100 {
        s.att_mocap[i] = Rot::from_quaternion(UnitQuaternion::from_euler_angles(
            if i % 2 == 0 { 0.1f64 } else { -0.1 }.to_radians(),
            0.0,
            0.0,
        ));
    }
    let g = ground_check(&s).unwrap();
    let m = g.samples as f64;
    assert_eq!(g.samples % 2, 1);
    assert!(
        (g.mocap_sd_deg[0] - 0.1 * ((m - 1.0 / m) / (m - 1.0)).sqrt()).abs() < 1e-6 && g.mocap_sd_deg[1].abs() < 1e-9,
        "{g:?}"
    );
}

//! Closed-loop checks against expectations derived by hand, independent of the code.

use super::inline;
use flyarena::engine::{RunOptions, run};
use flyarena::vehicle::params::GRAVITY;

const HOVER: &str = r#"
name: hover
seed: 3
vehicles:
  - name: x3d
    markers: { rotation_deg: [ROLL, 0, 0] }
calibration: { apply: APPLY }
controller: { k_x: [KX, KX, 1], k_v: [KV, KV, 3] }
plan:
  - takeoff: { altitude_m: 1.0, duration_s: 3 }
  - calibrate_roll_pitch: { settle_s: 8, average_s: 6 }
"#;

fn hover(roll_deg: f64, apply: bool, kx: f64, kv: f64) -> flyarena::engine::RunOutput {
    let y = HOVER
        .replace("ROLL", &roll_deg.to_string())
        .replace("APPLY", &apply.to_string())
        .replace("KX", &kx.to_string())
        .replace("KV", &kv.to_string());
    run(inline(&y).spec(), RunOptions::default())
}

/// In a steady hover the vertical acceleration averages zero, so the thrust the radio delivers
/// averages m·g (0.68 kg · 9.81 m/s² = 6.671 N), whatever the 0.094 N thrust quantization.
#[test]
fn hover_thrust_equals_weight() {
    let out = hover(0.0, true, 1.0, 2.0);
    let v = &out.vehicles[0];
    let mg = 0.68 * GRAVITY;
    let t = v.hover_thrust_mean_n.unwrap();
    assert!((t - mg).abs() / mg < 0.005, "mean hover thrust {t} N vs m·g {mg} N");
}

/// An uncompensated roll offset δ makes the attitude loop hold the *measured* roll at φ_com, so the
/// true roll is φ_com − δ; the vehicle is at rest only where φ_com = δ, i.e. v̇_com = g·sin δ, i.e.
/// a lateral position error Δy = g·sin δ/(K_V·K_X) ≈ g·δ/(K_V·K_X), in the body y direction (East
/// at heading 0): the vehicle sits West of its reference by that distance.
#[test]
fn roll_offset_gives_the_steady_error_g_delta_over_kv_kx() {
    for &(delta_deg, kx, kv) in &[(3.0, 1.0, 2.0), (2.0, 1.5, 2.5)] {
        let out = hover(delta_deg, false, kx, kv);
        let tr = &out.vehicles[0].trace;
        let tail = &tr[tr.len() - 800..]; // the last 4 s of the hover
        let dy: f64 = tail.iter().map(|s| s.reference.y() - s.pos.y()).sum::<f64>() / tail.len() as f64;
        let dx: f64 = tail.iter().map(|s| s.reference.x() - s.pos.x()).sum::<f64>() / tail.len() as f64;
        let expected = GRAVITY * f64::to_radians(delta_deg) / (kv * kx);
        assert!((dy - expected).abs() / expected < 0.05, "δ={delta_deg}°: Δy {dy} m vs g·δ/(K_V·K_X) = {expected} m");
        assert!(dx.abs() < 0.05 * expected, "no error along x: {dx}");
    }
}

/// Hover averaging (Sec. IV.A) of the same vehicle recovers the 3° offset: 6 s at 200 Hz.
#[test]
fn hover_average_recovers_the_roll_offset() {
    let out = hover(3.0, true, 1.0, 2.0);
    let (roll, pitch, n) = out.vehicles[0].calibration.roll_pitch.unwrap();
    assert!(n >= 1190, "{n} samples averaged");
    assert!((roll.to_degrees() - 3.0).abs() < 0.02, "roll estimate {}°", roll.to_degrees());
    assert!(pitch.to_degrees().abs() < 0.02, "pitch estimate {}°", pitch.to_degrees());
}

/// The paper's straight-flight yaw estimate (deg) after a take-off, the hover calibration and
/// the flight (6) of 6 m at 0.75 m/s, for a pure marker yaw of `yaw_deg`; `extra` is added to the
/// scenario's top level (noise, radio).
fn straight_flight_yaw(seed: u64, yaw_deg: f64, extra: &str) -> f64 {
    straight_flight_yaw_in("rate", seed, yaw_deg, extra)
}

/// [`straight_flight_yaw`] with the vehicle's onboard mode (`rate` or `attitude`).
fn straight_flight_yaw_in(mode: &str, seed: u64, yaw_deg: f64, extra: &str) -> f64 {
    let y = format!(
        "name: yaw-flight\nseed: {seed}\n{extra}vehicles:\n  - name: x3d\n    home_m: [-3, 0]\n    model: {{ onboard_mode: {mode} }}\n    markers: {{ rotation_deg: [0, 0, {yaw_deg}] }}\nplan:\n  - takeoff: {{ altitude_m: 1.0, duration_s: 3 }}\n  - calibrate_roll_pitch: {{ settle_s: 6, average_s: 5 }}\n  - calibrate_yaw: {{ settle_s: 3, distance_m: 6, speed_m_s: 0.75 }}\n"
    );
    run(inline(&y).spec(), RunOptions { trace: false, apply_calibration: None }).vehicles[0]
        .calibration
        .yaw_offset
        .unwrap()
        .to_degrees()
}

/// Yaw observability (docs/findings.md): with the attitude loop closed on the mocap, the thrust axis is
/// tilted in the mocap frame, and a marker rotation about the body z axis leaves that axis
/// unchanged, so the straight flight (6) goes along *measured* North to first order and the fit
/// (8)–(9) sees only a small part of a yaw offset. Pinned here so that a change in this physics is
/// noticed: with 4° of marker yaw the estimate moves by less than half of it against the same
/// seed without (with the default 1.5 °/s per count and noise, the estimate itself scatters by the
/// error budget of docs/findings.md, ±1.7° over seeds and 3.2° on one: it is not ~0).
#[test]
fn straight_flight_is_nearly_blind_to_a_marker_yaw_offset() {
    for seed in 1..=3 {
        let est = |yaw: f64| straight_flight_yaw(seed, yaw, "");
        let with = est(4.0);
        let without = est(0.0);
        eprintln!("seed {seed}: estimate {with:.3}° with 4° of marker yaw, {without:.3}° with none");
        // same seed, same noise: the difference is the method's response to the offset
        assert!((with - without).abs() < 2.0, "seed {seed}: responds to {:.2}° of the 4°", with - without);
    }
}

const GYRO: &str = r#"
name: gyro
seed: SEED
mocap: { noise_mm: NOISE }
vehicles:
  - name: x3d
    markers: { rotation_deg: [2.0, -1.5, -6.0] }
    imu: { gyro_noise_deg_s: 0.5, gyro_bias_deg_s: [0.3, -0.2, 0.4] }
telemetry: { rate_hz: 100, latency_ms: 15, loss: { bernoulli: 0.05 } }
plan:
  - takeoff: { altitude_m: 1.0, duration_s: 3 }
  - hover: { duration_s: 2 }
  - yaw_spin: { settle_s: 1, angle_deg: 180, duration_s: 10 }
  - calibrate_gyro: { settle_s: 1, radius_m: 0.25, period_s: 2, turns: 3 }
"#;

/// Gyro telemetry against mocap attitude increments: θ_b = R_off·θ_m + b_g·W holds exactly, so
/// the fit returns the marker rotation the scenario declares (all three axes) and its gyro bias,
/// through a lossy, late telemetry link and a noisy gyro. With noiseless markers the only errors
/// are the gyro noise and the trapezoid integration: within 0.02° and 0.015 °/s (4σ of the gyro noise over ~500 windows). With the default
/// 0.1 mm marker noise the error must lie within 3 reported σ (the σ is conservative).
#[test]
fn gyro_alignment_recovers_the_marker_rotation_and_the_gyro_bias() {
    let truth = [2.0, -1.5, -6.0];
    for (seed, noise_mm) in [(1, 0.0), (1, 0.1), (2, 0.1), (3, 0.1)] {
        let y = GYRO.replace("SEED", &seed.to_string()).replace("NOISE", &noise_mm.to_string());
        let out = run(inline(&y).spec(), RunOptions::default());
        let v = &out.vehicles[0];
        let g = v.calibration.gyro.expect("a gyro fit");
        let est = g.euler.to_degrees();
        for (i, axis) in ["roll", "pitch", "yaw"].iter().enumerate() {
            let tol = if noise_mm == 0.0 { 0.02 } else { 3.0 * g.sigma[i].to_degrees() };
            assert!(tol < 0.5, "σ too large to be useful: {tol}°");
            assert!(
                (est[i] - truth[i]).abs() < tol,
                "seed {seed}, noise {noise_mm} mm: {axis} {}° vs {}° (tol {tol}°)",
                est[i],
                truth[i]
            );
        }
        if noise_mm == 0.0 {
            for (b, t) in g.gyro_bias.iter().zip([0.3, -0.2, 0.4]) {
                assert!((b.to_degrees() - t).abs() < 0.015, "bias {}°/s vs {t}°/s", b.to_degrees());
            }
        }
        assert!(v.telemetry.lost_on_link > 0, "the link must have lost frames");
        // the yaw is applied at the end of calibrate_gyro
        assert!((v.calibration.applied.yaw.to_degrees() - est[2]).abs() < 1e-12);
    }
}

/// Fig. 6 without compensation, in closed form. The markers are turned by 3° in roll and in
/// pitch, so the vehicle that holds its *measured* attitude level is tilted by θ with
/// cos θ = cos 3°·cos 3° (θ = 4.2417°); with the height held, T·cos θ = m·g and the horizontal
/// acceleration error is a = g·tan θ = 0.72757 m/s², fixed in the body. Each horizontal axis of
/// the position loop is ẍ = −K_V·ẋ − K_V·K_X·x + d, so a body-fixed d turning with the yaw rate
/// Ω = 2π/20 s leaves the vehicle on a circle of radius a/|K_V·K_X − Ω² + j·K_V·Ω| = 0.36335 m
/// (K_X = 1, K_V = 2), and at rest before the turn a/(K_V·K_X) = 0.36379 m. The largest
/// distance the spin records lies between them, to the mocap noise and the transient (0.5 %).
/// Swapping K_X and K_V (the same product) would give 0.37755 m; dropping the turn's dynamics,
/// the hover value.
#[test]
fn fig6_uncompensated_radius_is_the_closed_form() {
    let s = flyarena::scenario::Scenario::load(&super::root().join("scenarios/fig6-roll-pitch-offsets.yaml")).unwrap();
    let out = flyarena::run::run_scenario(&s, false);
    let r = out.uncompensated.expect("R2 runs the uncompensated flight").vehicles[0].spin_max_deviation_m.unwrap();
    let d = 3f64.to_radians();
    let theta = (d.cos() * d.cos()).acos();
    let a = GRAVITY * theta.tan();
    let (kx, kv, omega) = (1.0, 2.0, std::f64::consts::TAU / 20.0);
    let spin = a / ((kv * kx - omega * omega).powi(2) + (kv * omega).powi(2)).sqrt();
    let rest = a / (kv * kx);
    assert!((spin - 0.36335).abs() < 1e-5 && (rest - 0.36379).abs() < 1e-5, "{spin} {rest}");
    assert!(r >= 0.995 * spin && r <= 1.005 * rest, "radius {r} m, closed form {spin}–{rest} m");
}

/// The straight-flight yaw against the truth, noise-free (no mocap or IMU noise) and with a fine
/// rate scale (0.05 °/s per count, so the PPM deadband ±s/(2K_φ) = ±0.004° no longer biases the
/// fit by g·ε·T²/(2L)): without an offset the estimate is 0 to 0.001°; with a pure 4° marker yaw
/// it is the leak through the rotated rate axes only, below 3 % of the offset (0.12°; flown:
/// 0.024°). A method that saw the offset would give 4°; one that is broken, anything.
#[test]
fn straight_flight_yaw_is_the_leak_alone_without_noise() {
    let est = |yaw: f64| straight_flight_yaw(1, yaw, "mocap: { noise_mm: 0 }\nradio: { rate_scale_deg_s: 0.05 }\n");
    let (none, four) = (est(0.0), est(4.0));
    assert!(none.abs() < 1e-3, "no offset: {none}°");
    assert!(four.abs() < 0.03 * 4.0, "4° of marker yaw leaks {four}°");
    assert!(four > 0.0, "the leak has the offset's sign: {four}°");
}

/// The same straight flight in the onboard attitude mode, noise-free as above: φ_com = 0 is a
/// level *physical* body, the pitch command tilts it about its own y axis, so the track's course
/// is the body's heading ψ_m − ψ_off and (8)–(9) with the mean yaw returns ψ_off itself. For 4°
/// and −6° of marker yaw the estimate is the truth within 0.02° (flown: 0.0006° and 0.011°, the
/// onboard level filter's small part), for none within 0.001°; the rate-mode leak above is below
/// 0.12° for the same 4°.
#[test]
fn the_straight_flight_sees_a_marker_yaw_in_attitude_mode() {
    let quiet = "mocap: { noise_mm: 0 }\nradio: { rate_scale_deg_s: 0.05 }\n";
    let est = |yaw: f64| straight_flight_yaw_in("attitude", 1, yaw, quiet);
    assert!(est(0.0).abs() < 1e-3, "no offset: {}°", est(0.0));
    for truth in [4.0, -6.0] {
        let e = est(truth);
        eprintln!("attitude mode: {truth}° of marker yaw, estimate {e}°");
        assert!((e - truth).abs() < 0.02, "{truth}° of marker yaw: estimate {e}°");
    }
}

/// A straight flight in attitude mode whose trace is kept; `vehicle` is added to the vehicle's
/// YAML (an IMU, a disturbance), `plan0` before the take-off; `trim` is `calibration.hover_trim`.
fn attitude_flight(vehicle: &str, plan0: &str, trim: bool) -> flyarena::engine::VehicleRun {
    let y = format!(
        "name: att\nseed: 1\nmocap: {{ noise_mm: 0 }}\ncalibration: {{ hover_trim: {trim} }}\nvehicles:\n  - name: x3d\n    home_m: [-3, 0]\n    model: {{ onboard_mode: attitude }}\n{vehicle}plan:\n{plan0}  - takeoff: {{ altitude_m: 1.0, duration_s: 3 }}\n  - calibrate_roll_pitch: {{ settle_s: 6, average_s: 5 }}\n  - calibrate_yaw: {{ settle_s: 3, distance_m: 6, speed_m_s: 0.75 }}\n"
    );
    run(inline(&y).spec(), RunOptions::default()).vehicles.remove(0)
}

/// The true roll (deg) averaged over the cruise of the straight flight (φ_com = 0): from 4 s to
/// 7 s after the flight starts (inside the 0.75 m/s cruise, 1.5 s to 8 s with the default
/// 0.5 m/s² ramps).
fn cruise_roll_deg(v: &flyarena::engine::VehicleRun) -> f64 {
    let start = v.phases.iter().find(|p| p.1 == "calibrate_yaw").expect("the yaw phase").0.as_secs_f64() + 3.0;
    let r: Vec<f64> = v
        .trace
        .iter()
        .filter(|t| (start + 4.0..start + 7.0).contains(&t.t.as_secs_f64()))
        .map(|t| t.att_true.roll)
        .collect();
    (r.iter().sum::<f64>() / r.len() as f64).to_degrees()
}

/// Attitude mode's level, in closed form. A constant roll torque τ (a bent rotor) needs the
/// rate loop's error τ/(J_x·K_ω) and the P attitude loop then stands off its estimate by
/// ε₀ = τ/(J_x·K_ω·K_φ): 2.44·10⁻³ N·m on J_x = 0.007 kg·m², K_ω = 25, K_φ = 8 is 0.0999°. In
/// flight the accelerometer reads the thrust axis, not gravity, so the level filter pulls the
/// estimate toward the body's own axis at k_a·ε, and the loop, holding the estimate, rolls the
/// body further: ε(t) = ε₀·(1 + k_a·t) from the start of (6), 2.1·ε₀ = 0.2097° averaged over 4–7 s
/// of the flight (flown: 0.2015°, 4 % under it; held to 5 %). The hover trim (`calibration.hover_trim`, the
/// default) commands the hover's mean roll instead of 0, which is the roll the estimate holds
/// level at, and the body stays within 1 % of ε₀ of level (flown: 0.4 %). A gyro bias of 1 °/s
/// in roll would stand off by b/K_φ = 0.125° in the same way, but the power-on calibration (the
/// rest before the first thrust) removes it: the roll stays within 0.001° (and the noise-free
/// gyro needs no `idle`).
#[test]
fn the_attitude_mode_holds_its_own_level() {
    let tau: f64 = 2.44e-3;
    let eps0 = (tau / (0.007 * 25.0 * 8.0)).to_degrees();
    assert!((eps0 - 0.0999).abs() < 1e-4, "{eps0}");
    let predicted = eps0 * (1.0 + flyarena::vehicle::LEVEL_GAIN_PER_S * 5.5);
    let torque = format!("    disturbance: {{ torque_nm: [{tau}, 0, 0] }}\n");
    let bent = cruise_roll_deg(&attitude_flight(&torque, "", false));
    assert!((bent - predicted).abs() < 0.05 * predicted, "roll {bent}° vs {predicted}°");
    let trimmed = cruise_roll_deg(&attitude_flight(&torque, "", true));
    assert!(trimmed.abs() < 0.01 * eps0, "trimmed roll {trimmed}°");
    let biased = cruise_roll_deg(&attitude_flight("    imu: { gyro_bias_deg_s: [1.0, 0, 0] }\n", "", true));
    eprintln!("roll {bent}° (closed form {predicted}°), trimmed {trimmed}°; with a calibrated 1 °/s bias {biased}°");
    assert!(biased.abs() < 1e-3, "a calibrated gyro bias tilts the body by {biased}°");
}

/// Fig. 6 and Fig. 7 in both onboard modes, uncompensated. In rate mode the 3°+3° markers turn
/// the vehicle on a 0.36 m circle (closed form above); in attitude mode a level command is a
/// level body, T_w⁻¹ acts onboard on the true angles, and the largest deviation while yawing is
/// Fig. 7's noise level, below 1 cm (flown: 1.6 mm, and 1.4 mm for Fig. 7 in attitude mode).
#[test]
fn fig6_does_not_circle_in_attitude_mode() {
    let dev = |file: &str, edit: &dyn Fn(String) -> String| {
        let text = edit(std::fs::read_to_string(super::root().join("scenarios").join(file)).unwrap());
        let out = flyarena::run::run_scenario(&inline(&text), false);
        out.uncompensated.map(|u| u.vehicles[0].spin_max_deviation_m.unwrap())
    };
    let same = |t: String| t;
    let rate6 = dev("fig6-roll-pitch-offsets.yaml", &same).expect("R2 flies it uncompensated");
    let att6 = dev("fig6-attitude-mode.yaml", &same).expect("R2 flies it uncompensated");
    let att7 = dev("fig7-no-offsets.yaml", &|t: String| {
        t.replace("  - name: x3d\n", "  - name: x3d\n    model: { onboard_mode: attitude }\n")
    })
    .expect("R2 flies it uncompensated");
    eprintln!("uncompensated: rate mode {rate6} m; attitude mode Fig. 6 {att6} m, Fig. 7 {att7} m");
    assert!(rate6 > 0.35, "rate mode: {rate6} m");
    assert!(att6 < 0.01 && att7 < 0.01, "attitude mode: Fig. 6 {att6} m, Fig. 7 {att7} m");
}

/// A flight that reaches the tilt limit: the waypoint asks for 3 m/s² (atan(3/g) = 17° of tilt)
/// with `max_tilt_deg: 5`, so φ_com, θ_com saturate at 5°. The true tilt then peaks at the limit,
/// plus what the attitude and rate loops overshoot (≤ 0.5°; flown: 5.06°), and not at the 17°
/// the demand asks for. (A limit read in degrees as radians, 5 rad, limits nothing: 27.9°, tried.)
#[test]
fn a_hard_demand_is_held_at_the_tilt_limit() {
    let s = inline(
        "
name: tilt-limit
seed: 2
controller: { max_tilt_deg: 5 }
vehicles:
  - { name: x3d }
plan:
  - takeoff: { altitude_m: 1.0, duration_s: 3 }
  - hover: { duration_s: 2 }
  - waypoint: { pos_m: [6, 0, -1], speed_m_s: 4, accel_m_s2: 3, hold_s: 3 }
",
    );
    let out = run(s.spec(), RunOptions { trace: true, apply_calibration: None });
    let peak = out.vehicles[0]
        .trace
        .iter()
        .map(|t| t.att_true.roll.abs().max(t.att_true.pitch.abs()))
        .fold(0.0, f64::max)
        .to_degrees();
    assert!(peak > 4.9 && peak < 5.5, "peak tilt {peak}°");
}

/// The calibration circles as flown in `yaw-offset` (0.25 m, 2 s): nominally
/// atan(r·ω²/g) = atan(0.25·π²/9.81) = 14.1° of tilt turning at ω = π rad/s, a roll and pitch
/// rate of 0.246·π = 0.77 rad/s = 44 °/s. The position loop overshoots the circle, so the
/// vehicle flies a wider one: over the middle turn the mean tilt and the mean |(p, q)| are
/// pinned here at their flown values, 20° and 64 °/s (docs/findings.md; flown 20.3° and 64.3 °/s), within 3 %.
#[test]
fn calibration_circles_as_flown() {
    let s = flyarena::scenario::Scenario::load(&super::root().join("scenarios/yaw-offset.yaml")).unwrap();
    let out = run(s.spec(), RunOptions { trace: true, apply_calibration: Some(true) });
    let v = &out.vehicles[0];
    let k = v.phases.iter().position(|(_, name)| *name == "calibrate_gyro").unwrap();
    // settle 2 s, then three turns of 2 s: the middle turn is 4–6 s into the phase
    let t0 = v.phases[k].0.as_secs_f64() + 4.0;
    let turn: Vec<_> = v.trace.iter().filter(|t| (t0..t0 + 2.0).contains(&t.t.as_secs_f64())).collect();
    assert!(turn.len() > 300, "{}", turn.len());
    let n = turn.len() as f64;
    let tilt = turn.iter().map(|t| (t.att_true.roll.cos() * t.att_true.pitch.cos()).acos()).sum::<f64>() / n;
    let rate = turn.iter().map(|t| t.omega.x().hypot(t.omega.y())).sum::<f64>() / n;
    let nominal_tilt = (0.25 * std::f64::consts::PI.powi(2) / 9.81).atan();
    assert!((nominal_tilt.to_degrees() - 14.1).abs() < 0.05);
    assert!((tilt.to_degrees() / 20.0 - 1.0).abs() < 0.03, "mean tilt {}°", tilt.to_degrees());
    assert!((rate.to_degrees() / 64.0 - 1.0).abs() < 0.03, "mean rate {} °/s", rate.to_degrees());
}

/// `validity-reject` in closed form: a constant yaw torque τ = 0.02 N·m (a bent rotor) is held
/// by the onboard rate loop, τ_motor = J_z·K_ω,z·(r_com − r) with r = 0 in steady state, so the
/// yaw-rate command settles at r_com = −τ/(J_z·K_ω,z), and the station's yaw loop
/// r_com = K_ψ·(ψ_com − ψ) leaves a stand-off ψ − ψ_com = τ/(J_z·K_ω,z·K_ψ)
/// = 0.02/(0.012·10·3) rad = 3.183°. The PPM rate steps (1.5 °/s) put a deadband of
/// ±s/(2K_ψ) = ±0.25° around it; check (7) sees the mean yaw over the flight.
#[test]
fn validity_reject_yaw_stand_off_is_the_closed_form() {
    let s = flyarena::scenario::Scenario::load(&super::root().join("scenarios/validity-reject.yaml")).unwrap();
    let out = run(s.spec(), RunOptions { trace: false, apply_calibration: None });
    let val = out.vehicles[0].calibration.validity.as_ref().expect("the yaw flight ran");
    let stand_off = (0.02f64 / (0.012 * 10.0 * 3.0)).to_degrees();
    assert!((stand_off - 3.183).abs() < 1e-3);
    let deadband = 1.5 / (2.0 * 3.0);
    assert!(
        (val.mean_yaw.to_degrees() - stand_off).abs() <= deadband,
        "mean yaw {}° vs {stand_off}°",
        val.mean_yaw.to_degrees()
    );
    assert!(!val.accepted);
}

/// The same bent rotor with an integrating onboard rate loop (`validity-integral.yaml`, yaw
/// K_I = 25 1/s²): the integral holds the 0.02 N·m, the yaw loop needs no stand-off, and the
/// straight flight's mean yaw falls from 3.18° to within the PPM deadband of 0 (±0.25°), so (7)
/// accepts it. In closed form, on the rate loop alone: a step torque τ_d leaves a rate error
/// τ_d/(J·K_ω) with K_I = 0 and none once ∫ has settled at τ_d/(J·K_I) (unit test in
/// `vehicle::rate_loop`).
#[test]
fn an_integrating_rate_loop_removes_the_yaw_stand_off() {
    let s = flyarena::scenario::Scenario::load(&super::root().join("scenarios/validity-integral.yaml")).unwrap();
    let out = run(s.spec(), RunOptions { trace: false, apply_calibration: None });
    let val = out.vehicles[0].calibration.validity.as_ref().expect("the yaw flight ran");
    let deadband = 1.5 / (2.0 * 3.0);
    assert!(val.mean_yaw.to_degrees().abs() <= deadband, "mean yaw {}°", val.mean_yaw.to_degrees());
    assert!(val.accepted);
}

/// The run summary in its units, against the truth `gyro-clock.yaml` declares (markers rotated
/// 1°, −0.5°, 4°; gyro bias 0.1, −0.1, 0.2 °/s; telemetry clock 15 ms ahead and 100 ppm fast).
/// Each bound is far tighter than a unit slip (10³ between s and ms, 57 between rad and deg):
/// the offsets within 0.1° and the bias within 0.02 °/s of the truth; the gyro fit's σ and
/// residual a few hundredths of a degree (0.03° measured); the clock offset at the windows' mean
/// time within 1 ms of 15 ms + 100 ppm of that time, its σ a fraction of a millisecond (0.21 ms
/// is the mean over 40 seeds), the drift within 4σ of 100 ppm.
#[test]
fn the_run_summary_states_each_quantity_in_its_unit() {
    let s = flyarena::scenario::Scenario::load(&super::root().join("scenarios/gyro-clock.yaml")).unwrap();
    let summary = flyarena::run::run_scenario(&s, false).summary(&s);
    let v = &summary.vehicles[0];
    let near = |got: &[f64], want: &[f64], tol: f64| got.iter().zip(want).all(|(g, w)| (g - w).abs() < tol);
    let rp = v.roll_pitch_estimate_deg.unwrap();
    assert!(near(&rp, &[1.0, -0.5], 0.1), "{rp:?}");
    let g = v.gyro_alignment.as_ref().expect("the gyro alignment ran");
    assert!(near(&g.offset_deg, &[1.0, -0.5, 4.0], 0.1) && near(&g.gyro_bias_deg_s, &[0.1, -0.1, 0.2], 0.02), "{g:?}");
    assert!(g.sigma_deg.iter().chain([&g.rms_residual_deg]).all(|x| (0.005..0.2).contains(x)), "{g:?}");
    let c = g.telemetry_clock.expect("the clock is fitted");
    let truth_ms = 15.0 + 100e-6 * c.at_s * 1e3;
    assert!(c.at_s > 1.0 && (c.offset_ms - truth_ms).abs() < 1.0, "{c:?} against {truth_ms} ms");
    assert!((0.02..1.0).contains(&c.offset_sigma_ms), "{c:?}");
    let (drift, sd) = (c.drift_ppm.unwrap(), c.drift_sigma_ppm.unwrap());
    // and it is measured: its 1σ is under a quarter of the 100 ppm (a bug it catches: `· 1e6` as `+
    // 1e6` gave ~1e6 ppm, inside every lower bound)
    assert!(sd > 0.0 && sd < 25.0 && (drift - 100.0).abs() < 4.0 * sd, "{c:?}");
    // the markers only rotate (1°, −0.5°, 4°): the truth is a rigid displacement, no misfit
    assert!(
        near(&v.true_offset_deg, &[1.0, -0.5, 4.0], 1e-9) && v.true_offset_misfit_mm.abs() < 1e-9,
        "{:?} {}",
        v.true_offset_deg,
        v.true_offset_misfit_mm
    );
}

/// The summary's marker misfit is the truth's rigid-fit residual in mm. displaced-markers.yaml
/// moves two markers by (0, 6, −4) and (0, 0, 5) mm: no rigid motion maps the template onto them,
/// so the misfit is above 0, and at most the RMS displacement √((36 + 16 + 25)/4) = 4.39 mm (the
/// identity's residual: the best rigid fit does no worse). `· 1e3` as `+ 1e3`
/// fails it, and `/ 1e3` would give 0.004 mm.
#[test]
fn the_run_summary_states_the_markers_misfit_in_mm() {
    use flyarena::{Body, Vec3};
    let s = flyarena::scenario::Scenario::load(&super::root().join("scenarios/displaced-markers.yaml")).unwrap();
    let got = flyarena::run::run_scenario(&s, false).summary(&s).vehicles[0].true_offset_misfit_mm;
    let d: [Vec3<Body>; 4] = [Vec3::new(0.0, 0.006, -0.004), Vec3::zeros(), Vec3::new(0.0, 0.0, 0.005), Vec3::zeros()];
    let truth = flyarena::mocap::MarkerSet::displaced(
        flyarena::mocap::builtin_pattern(0).to_vec(),
        flyarena::frames::Euler::ZERO,
        &d,
    )
    .true_offset()
    .unwrap();
    assert!(
        (got - truth.rms_misfit_m * 1e3).abs() < 1e-12 && got > 0.0 && got <= (77.0f64 / 4.0).sqrt() + 1e-12,
        "{got} mm against {} m",
        truth.rms_misfit_m
    );
}

/// The gyro alignment on an unsynchronised telemetry clock (`scenarios/gyro-clock.yaml`, offset
/// 0–20 ms, drift ±100 ppm): over 40 seeds the fitted yaw stays within 0.05° of the markers' 4°,
/// and the 95 % intervals of the yaw and of the clock offset at the windows' mean time cover the
/// truth in at least 34 of 40 (P(X ≤ 33) = 0.5 % for a true 95 %). Measured: the clock offset's
/// σ is honest (RMS error 0.20 ms against a mean σ of 0.21 ms); the yaw's is conservative (RMS
/// error 0.011° against a mean σ of 0.030°): it treats the windows as independent, while
/// consecutive windows share a mocap frame and their noise telescopes.
#[test]
fn gyro_alignment_fits_an_unsynchronised_clock_with_intervals_that_cover() {
    let text = std::fs::read_to_string(super::root().join("scenarios/gyro-clock.yaml")).unwrap();
    let (mut yaw_covered, mut clock_covered) = (0, 0);
    for k in 0..40u64 {
        let (offset_ms, drift_ppm) = ((k % 5) as f64 * 5.0, -100.0 + 5.0 * k as f64);
        let y = text
            .replace("seed: 11", &format!("seed: {}", 100 + k))
            .replace("offset_ms: 15, drift_ppm: 100", &format!("offset_ms: {offset_ms}, drift_ppm: {drift_ppm}"));
        let out = run(inline(&y).spec(), RunOptions::default());
        let g = out.vehicles[0].calibration.gyro.unwrap_or_else(|| panic!("seed {k}: no gyro fit"));
        let err = g.euler.yaw.to_degrees() - 4.0;
        assert!(err.abs() < 0.05, "seed {k}: yaw error {err}°");
        if err.abs() <= 1.96 * g.sigma[2].to_degrees() {
            yaw_covered += 1;
        }
        let c = g.clock.unwrap();
        let truth_ms = offset_ms + drift_ppm * 1e-6 * c.t_mean_s * 1e3;
        if (c.offset_s * 1e3 - truth_ms).abs() <= 1.96 * c.offset_sigma_s * 1e3 {
            clock_covered += 1;
        }
    }
    assert!(
        yaw_covered >= 34 && clock_covered >= 34,
        "95 % intervals cover the yaw in {yaw_covered} of 40, the clock offset in {clock_covered}"
    );
}

/// `mocap.noise_in_loop: false` keeps the marker noise out of the loop and in the record: the
/// vehicle flies exactly as with no noise at all (every true state bit for bit, the station
/// having seen the same noise-free poses), while the recorded poses carry the noise (their
/// spread about the noise-free ones is of the order of the marker σ = 0.5 mm over √4 markers).
/// With the noise in the loop, the default, the flight itself changes. A bug it catches: the
/// noise-free twin recorded and the noisy frame sent (the flight would change and the record
/// not), or the noisy frame sent to both.
#[test]
fn noise_kept_out_of_the_loop_reaches_the_record_and_not_the_flight() {
    let fly = |mocap: &str| {
        let y = format!(
            "name: n\nseed: 3\nmocap: {mocap}\nvehicles:\n  - name: x3d\n    home_m: [0, 0]\nplan:\n  - takeoff: {{ altitude_m: 1.0, duration_s: 3 }}\n  - hover: {{ duration_s: 2 }}\n"
        );
        run(inline(&y).spec(), RunOptions { trace: true, apply_calibration: None }).vehicles.remove(0)
    };
    let (quiet, outside, inside) =
        (fly("{ noise_mm: 0 }"), fly("{ noise_mm: 0.5, noise_in_loop: false }"), fly("{ noise_mm: 0.5 }"));
    assert_eq!(quiet.trace.len(), outside.trace.len());
    let same_flight =
        quiet.trace.iter().zip(&outside.trace).all(|(a, b)| a.pos == b.pos && a.att_true_rot == b.att_true_rot);
    assert!(same_flight, "the noise kept out of the loop moved the vehicle");
    let moved = quiet.trace.iter().zip(&inside.trace).any(|(a, b)| a.pos != b.pos);
    assert!(moved, "the noise in the loop left the flight as without noise");
    let d: Vec<f64> = quiet
        .trace
        .iter()
        .zip(&outside.trace)
        .filter_map(|(a, b)| Some((a.captured?.pos - b.captured?.pos).norm()))
        .collect();
    let rms = (d.iter().map(|x| x * x).sum::<f64>() / d.len() as f64).sqrt();
    assert!(
        d.len() > 500 && (1e-4..1e-3).contains(&rms),
        "recorded poses {rms} m from the noise-free ones over {}",
        d.len()
    );
}

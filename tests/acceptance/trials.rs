//! `flyarena trials`: identify on flights it was not tuned to. A small sample of the random
//! generator runs here with tolerances derived from its size (the 300-flight table of docs/trials.md comes
//! from `flyarena trials --flights 300 --seed 1`); the generator is a pure function of (seed,
//! index); a known hard case is reported honestly.

use flyarena::identify::trials::{Trial, draw, run, run_many, score};
use flyarena::identify::{Effect, Options};

/// A trial kept as a fixture (`fixtures/trial-<seed>-<index>.yaml`): the flight the generator
/// drew, kept so that a regression test keeps flying the flight it was written for when the
/// generator changes.
fn fixture(master_seed: u64, index: u64, preset: &'static str, hidden: Vec<(Effect, Vec<f64>)>) -> Trial {
    let yaml = std::fs::read_to_string(
        super::root().join(format!("tests/acceptance/fixtures/trial-{master_seed}-{index}.yaml")),
    )
    .unwrap();
    let seed = yaml.lines().find_map(|l| l.strip_prefix("seed: ")).unwrap().trim().parse().unwrap();
    Trial { index, seed, preset: preset.to_string(), plan: vec![], hidden, yaml }
}

/// The flight of a trial, logged as `identify` reads it (what `trials::run` flies).
fn flight(t: &Trial) -> flyarena::identify::Series {
    let s =
        flyarena::scenario::Scenario::parse(&t.yaml, std::path::Path::new(&format!("trial-{}.yaml", t.index))).unwrap();
    flyarena::identify::run_and_log(&s, 0, &format!("trial {}", t.index)).unwrap().1
}

/// Three binomial standard deviations around a proportion p for n trials.
fn band(p: f64, n: usize) -> f64 {
    3.0 * (p * (1.0 - p) / n.max(1) as f64).sqrt()
}

/// The intervals claim 95 %. Measured on the 300 flights of docs/trials.md: 95.5 % (seed 1), 95.3 %
/// (seed 2) and 94.5 % (seed 3), every effect at 90.8 % or more but the constant force on seed 2
/// (87.5 %). The sample here must agree with 95 % within its
/// binomial band: intervals that narrow (or widen) by a quarter fail it.
const NOMINAL_COVERAGE: f64 = 0.95;

/// 48 random flights (seed 7, not the guide's): recall where the excitation suffices, precision,
/// the intervals' coverage and the share of confidently wrong parameters, each within three
/// binomial standard deviations of its target for this sample size (coverage: of the nominal
/// 95 %, see [`NOMINAL_COVERAGE`]).
#[test]
fn identify_generalises_to_random_flights() {
    let outcomes = run_many(7, 48, &Options::default());
    assert!(
        outcomes.iter().all(|o| o.error.is_none()),
        "{:?}",
        outcomes.iter().filter_map(|o| o.error.as_ref()).collect::<Vec<_>>()
    );
    let (_, total) = score(&outcomes);
    let n_rec = total.found_excited + total.missed_excited;
    let recall = total.recall_excited().unwrap();
    let precision = total.precision().unwrap();
    let coverage = total.coverage().unwrap();
    let table = flyarena::identify::trials::render(&outcomes);
    assert!(n_rec >= 40 && total.params >= 80, "too small a sample\n{table}");
    assert!(recall >= 0.95 - band(0.95, n_rec), "recall {recall}\n{table}");
    assert!(precision >= 0.95 - band(0.95, total.found_all + total.invented), "precision {precision}\n{table}");
    assert!(
        (coverage - NOMINAL_COVERAGE).abs() <= band(NOMINAL_COVERAGE, total.params),
        "coverage {coverage} of {} parameters\n{table}",
        total.params
    );
    let wrong = total.confidently_wrong as f64 / total.params as f64;
    assert!(wrong <= 0.01 + band(0.01, total.params), "confidently wrong {wrong}\n{table}");
}

/// Each trial is a pure function of (seed, index): drawn twice, the same scenario text; and a
/// different index gives a different flight.
#[test]
fn trials_are_drawn_deterministically() {
    for i in 0..20 {
        assert_eq!(draw(3, i).yaml, draw(3, i).yaml);
    }
    assert_ne!(draw(3, 0).yaml, draw(3, 1).yaml);
    assert_ne!(draw(3, 0).yaml, draw(4, 0).yaml);
    // every drawn scenario parses (ranges, plan) for a few hundred indices
    for i in 0..300 {
        let t = draw(1, i);
        flyarena::scenario::Scenario::parse(&t.yaml, std::path::Path::new("t.yaml"))
            .unwrap_or_else(|e| panic!("trial {i}: {e}\n{}", t.yaml));
    }
}

/// Trial 287 of seed 1 (as drawn before the lever arm joined the generator: a fixture) hides a world tilt, an accelerometer bias and rotor drag on a flight that
/// never yaws: a constant force with the accelerometer bias makes the same residual as the world
/// tilt with it. The report must say so (world tilt flagged, not missed) and claim no interval
/// it cannot back (nothing confidently wrong).
#[test]
fn a_confounded_mix_is_flagged_not_answered_with_confidence() {
    use flyarena::identify::Effect::*;
    let t = fixture(
        1,
        287,
        "crazyflie21",
        vec![
            (WorldTilt, vec![1.365, 0.838]),
            (AccelBias, vec![0.0891, 0.0993, -0.2852]),
            (RotorDrag, vec![0.242, 0.258]),
        ],
    );
    let o = run(&t, &Options::default());
    // the accelerometer bias absorbs the tilt in the model that was selected; its interval
    // must reach the estimate of the swapped model (with the world tilt), where the truth is
    let bias = o.hidden.iter().find(|h| h.effect == AccelBias).unwrap();
    for ((est, hw), truth) in bias.estimates.iter().zip(&bias.truth) {
        assert!((est - truth).abs() <= *hw, "accel bias {est} ± {hw} for {truth}: {o:#?}");
    }
    let tilt = o.hidden.iter().find(|h| h.effect == WorldTilt).unwrap();
    assert!(tilt.found || tilt.flagged, "{o:#?}");
    for h in o.hidden.iter().filter(|h| h.identifiable) {
        for ((est, hw), truth) in h.estimates.iter().zip(&h.truth) {
            assert!((est - truth).abs() <= 3.0 * hw, "{:?}: {est} ± {hw} for {truth}", h.effect);
        }
    }
}

/// The F statistic with which `effect` joins at the first step of identify on a scenario's
/// flight (default options), and the excitation of each truth on that flight.
fn first_step_f_and_excitation(
    scenario: &str,
    effect: Effect,
    truths: &[(Effect, Vec<f64>)],
) -> (f64, Vec<flyarena::identify::residual::Excitation>) {
    let s = flyarena::scenario::Scenario::load(&super::root().join("scenarios").join(scenario)).unwrap();
    let (_, series) = flyarena::identify::run_and_log(&s, 0, scenario).unwrap();
    let o = Options::default();
    let r = flyarena::identify::identify(&series, &o).unwrap();
    let step = &r.steps[0];
    assert_eq!(step.added, effect, "{scenario}");
    let f = step.candidates.iter().find(|c| c.effect == effect).unwrap().f;
    (f, flyarena::identify::residual::excitation(&series, &o, truths))
}

/// The excitation's noncentrality against the F statistic the selection computes: for a block
/// of k parameters, E[F] = 1 + λ/k, so on the rotor-drag flight (drag alone hidden, first step)
/// F·k and λ must agree to within the difference of their noise models; doubling the truth
/// quadruples λ (a quadratic form), and a zero truth has λ = 0.
#[test]
fn excitation_matches_the_selections_f_statistic() {
    use flyarena::identify::Effect::RotorDrag;
    let (f, ex) = first_step_f_and_excitation(
        "identify-rotor-drag.yaml",
        RotorDrag,
        &[(RotorDrag, vec![0.35, 0.35]), (RotorDrag, vec![0.7, 0.7]), (RotorDrag, vec![0.0, 0.0])],
    );
    let ratio = 2.0 * f / ex[0].lambda;
    assert!((0.7..1.4).contains(&ratio), "F·k = {}, λ = {}", 2.0 * f, ex[0].lambda);
    assert!((ex[1].lambda / ex[0].lambda - 4.0).abs() < 1e-9 && ex[2].lambda == 0.0, "{ex:?}");
    assert!(ex[0].sufficient() && ex[0].heldout_share > 0.5, "{ex:?}");
    // the share is E/(E + N) with the held-out energy E quadratic in the truth: from the share
    // s at the truth, E/N = s/(1 − s), so twice the truth gives 4(E/N)/(4(E/N) + 1); none, 0
    let en = ex[0].heldout_share / (1.0 - ex[0].heldout_share);
    assert!((ex[1].heldout_share - 4.0 * en / (4.0 * en + 1.0)).abs() < 1e-9 && ex[2].heldout_share == 0.0, "{ex:?}");
}

/// The excitation takes a truth in the report's units (here deg/s) and computes λ from its SI
/// value, as the selection's F statistic sees it: on the gyro-bias flight (the bias hidden, found
/// at the first step) F·k and λ agree (1.02) as on the rotor-drag flight, whose factor is 1 and
/// cannot tell a lost conversion (a bug it catches: `v / f` as `v % f`, which leaves 1.0 deg/s at
/// 1.0).
#[test]
fn excitation_reads_the_truth_in_the_reported_units() {
    use flyarena::identify::Effect::GyroBias;
    let (f, ex) = first_step_f_and_excitation("identify-gyro-bias.yaml", GyroBias, &[(GyroBias, vec![1.0, -0.6, 0.8])]);
    let ratio = 3.0 * f / ex[0].lambda;
    assert!((0.7..1.4).contains(&ratio), "F·k = {}, λ = {}", 3.0 * f, ex[0].lambda);
}

/// Regression for the pair step: trial 228 of seed 1 (a fixture, as drawn then) hides a body offset, a world tilt and a
/// constant force. Alone, the body offset extrapolated so badly to the held-out blocks (its
/// error grew 3.7×) that it failed the held-out gate, and an accelerometer bias got in instead
/// with three confidently wrong parameters. Tried together, the two frame effects pass.
#[test]
fn two_effects_that_only_explain_the_data_together_join_together() {
    use flyarena::identify::Effect::*;
    let t = fixture(
        1,
        228,
        "x3d",
        vec![
            (BodyOffset, vec![-0.984, 1.971, 0.594]),
            (WorldTilt, vec![0.866, 1.07]),
            (ConstantForce, vec![0.3284, 0.3038, 0.0125]),
        ],
    );
    let o = run(&t, &Options::default());
    assert!(o.extra.is_empty(), "{:?}", o.extra);
    for h in &o.hidden {
        assert!(h.found, "{:?} missed", h.effect);
        for ((est, hw), truth) in h.estimates.iter().zip(&h.truth) {
            assert!((est - truth).abs() <= 3.0 * hw, "{:?}: {est} ± {hw} for {truth}", h.effect);
        }
    }
}

/// The same outcomes, to the bit, on one thread and on the default pool: each trial is a pure
/// function of (seed, index) and the outcomes are collected in index order.
#[test]
fn trials_do_not_depend_on_the_thread_count() {
    let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    let serial = one.install(|| run_many(11, 6, &Options::default()));
    let parallel = run_many(11, 6, &Options::default());
    assert_eq!(serde_json::to_string(&serial).unwrap(), serde_json::to_string(&parallel).unwrap());
}

/// Regression (seed 2, flight 249): displaced markers (a lever arm of 17, −32, −27 mm) beside
/// rotor drag. The drag acts on the IMU's (here the centre of mass's) velocity, and the mocap
/// tracks a point 45 mm away whose velocity differs by ω×r: while the lever arm was a linear
/// column of `accel_kin` only, the drag column used the tracked point's velocity and k_x came
/// out 0.391 ± 0.0025 for 0.401 (4 half-widths off). The lever arm is now folded into the
/// corrected trajectory (the IMU's point), so the drag sees the right velocity.
#[test]
fn a_lever_arm_does_not_bias_the_drag() {
    use flyarena::identify::Effect::*;
    let t = fixture(
        2,
        249,
        "crazyflie21",
        vec![(RotorDrag, vec![0.401, 0.175]), (LeverArm, vec![17.2, -32.2, -27.3]), (GroundEffect, vec![1.158])],
    );
    let o = run(&t, &Options::default());
    for h in o.hidden.iter().filter(|h| h.effect != GroundEffect) {
        assert!(h.found, "{:?} not found: {o:#?}", h.effect);
        for ((est, hw), truth) in h.estimates.iter().zip(&h.truth) {
            assert!((est - truth).abs() <= *hw, "{:?}: {est} ± {hw} for {truth}", h.effect);
        }
    }
}

/// Trial 179 of seed 1 (a fixture) hides a thrust scale of −0.133 and a thrust against voltage
/// of 0.0994 /V on the `crazyflie21`. The design fits them additively, T·(1 + a + b·ΔV); the
/// simulation multiplies, T·(1 + a)·(1 + c·ΔV), so b = (1 + a)·c. Reported as b, the voltage
/// came out 0.0851 ± 0.0048 (6 half-widths short); reported as c = b/(1 + a), both intervals
/// hold the truth.
#[test]
fn thrust_against_voltage_is_reported_as_the_simulation_multiplies_it() {
    use flyarena::identify::Effect::*;
    let t = fixture(1, 179, "crazyflie21", vec![(ThrustScale, vec![-0.1327]), (ThrustVoltage, vec![0.0994])]);
    let o = run(&t, &Options::default());
    for h in &o.hidden {
        assert!(h.found && h.identifiable, "{:?}: {o:#?}", h.effect);
        let ((est, hw), truth) = (h.estimates[0], h.truth[0]);
        assert!((est - truth).abs() <= hw, "{:?}: {est} ± {hw} for {truth}", h.effect);
    }
}

/// Trial 169 of seed 1 (a fixture): a thrust scale of −0.128, a thrust against voltage of
/// 0.0244 /V and a lever arm on the `x3d`, whose pack sits 0.8 V above V_ref with little
/// variation. The step that adds the thrust scale finds it collinear with the voltage
/// (canonical correlation > 0.99), and the thrust scale then holds the voltage's mean (−0.112).
/// The report must not claim an interval for it, and the voltage counts as flagged, not missed.
/// (Flight 294 showed the danger first: a thrust scale that claimed 0.131 ± 0.0006 for 0.084.
/// Since the held-out gate judges the voltage on force z alone, 294 selects both; see below.)
#[test]
fn a_thrust_scale_that_holds_a_voltage_effect_claims_no_interval() {
    use flyarena::identify::Effect::*;
    let t = fixture(
        1,
        169,
        "x3d",
        vec![(ThrustScale, vec![-0.1278]), (ThrustVoltage, vec![0.0244]), (LeverArm, vec![-18.2, -14.3, -31.3])],
    );
    let o = run(&t, &Options::default());
    let by = |e| o.hidden.iter().find(|h| h.effect == e).unwrap();
    assert!(by(ThrustScale).found && !by(ThrustScale).identifiable, "{o:#?}");
    assert!(!by(ThrustVoltage).found && by(ThrustVoltage).flagged, "{o:#?}");
}

/// Trial 294 of seed 1 (a fixture): a world tilt, a thrust scale of 0.0836 and a thrust against
/// voltage of 0.0569 /V on the `x3d`. The two thrust effects are collinear to 0.999 but the
/// flight holds enough of the voltage's variation to select both; their estimates then trade
/// off along the collinear direction, and the intervals must be wide enough that neither is
/// confidently wrong (beyond 3 half-widths).
#[test]
fn a_collinear_thrust_pair_is_not_confidently_wrong() {
    use flyarena::identify::Effect::*;
    let t = fixture(
        1,
        294,
        "x3d",
        vec![(WorldTilt, vec![-1.425, 1.43]), (ThrustScale, vec![0.0836]), (ThrustVoltage, vec![0.0569])],
    );
    let o = run(&t, &Options::default());
    for h in &o.hidden {
        assert!(h.found || h.flagged, "{:?} missed: {o:#?}", h.effect);
        for ((est, hw), truth) in h.estimates.iter().zip(&h.truth) {
            assert!(!h.identifiable || (est - truth).abs() <= 3.0 * hw, "{:?}: {est} ± {hw} for {truth}", h.effect);
        }
    }
}

/// The excitation's held-out share counts only what the flight's other hidden effects leave. On
/// flight 1-294 (`x3d`, its pack 0.8 V above V_ref with little variation), a thrust against
/// voltage beside a hidden thrust scale is mostly the scale's mean; alone it is all its own. λ,
/// which conditions on every candidate, does not depend on the partners.
#[test]
fn excitation_share_discounts_what_the_other_hidden_effects_explain() {
    use flyarena::identify::Effect::*;
    use flyarena::identify::residual::excitation;
    let t = fixture(1, 294, "x3d", vec![]);
    let series = flight(&t);
    let o = Options::default();
    let tv = (ThrustVoltage, vec![0.0569]);
    let alone = excitation(&series, &o, std::slice::from_ref(&tv))[0];
    let beside = excitation(&series, &o, &[(ThrustScale, vec![0.0836]), tv.clone()])[1];
    assert_eq!(alone.lambda.to_bits(), beside.lambda.to_bits());
    assert!(alone.heldout_share > 0.95, "{alone:?}");
    assert!(beside.heldout_share < 0.5, "{beside:?}");
    // λ conditions on every candidate: the Schur complement G_CC − G_CO·G_OO⁻¹·G_OC is at most
    // G_CC, so with thrust voltage the only candidate (nothing to condition on) λ can only grow,
    // and here, where the thrust scale takes most of it, it grows ninefold (457 → 4259)
    let only = Options { candidates: vec![ThrustVoltage], forced: vec![], ..Options::default() };
    let marginal = excitation(&series, &only, std::slice::from_ref(&tv))[0];
    assert!(
        alone.lambda < 0.5 * marginal.lambda,
        "conditional λ {} against marginal {}",
        alone.lambda,
        marginal.lambda
    );
}

/// Trial 168 of seed 1 (a fixture): a ground effect (c_g 1.238) on the `x3d`, hovering 4 s at
/// 0.265 m (1.1 % more thrust there). The ground effect acts on force z alone; its held-out cut
/// was averaged with force x and y, which it cannot change, and came out 9.5 %, under the 10 %
/// gate, although ΔBIC was −4740. Judged on the axis it acts on, it is found, and its interval
/// holds the truth.
#[test]
fn a_single_axis_effect_is_judged_on_its_own_axis() {
    use flyarena::identify::Effect::*;
    let t = fixture(1, 168, "x3d", vec![(GroundEffect, vec![1.238])]);
    let o = run(&t, &Options::default());
    let h = &o.hidden[0];
    assert!(h.found && o.extra.is_empty(), "{o:#?}");
    let (est, hw) = h.estimates[0];
    assert!((est - 1.238).abs() <= hw, "c_g {est} ± {hw} for 1.238");
}

/// Trial 78 of seed 3 (a fixture): an accelerometer bias (−0.15, 0.25, 0.17) m/s², rotor drag
/// and a thrust scale of −0.097 on the `crazyflie21`. The accelerometer bias sits in the force
/// channel too, so at step 1 a constant force explains force x, y *and* z best (ΔBIC −22584
/// against −18871 for the thrust scale). Once the bias and the thrust scale are in, the force
/// adds nothing (ΔBIC +27, p 0.74); without a backward check it stayed in the model as an
/// invented effect. It must leave, and the three hidden effects' intervals must hold the truth.
#[test]
fn an_effect_that_later_ones_explain_leaves_the_model() {
    use flyarena::identify::Effect::*;
    let t = fixture(
        3,
        78,
        "crazyflie21",
        vec![(AccelBias, vec![-0.1515, 0.2479, 0.1714]), (RotorDrag, vec![0.12, 0.176]), (ThrustScale, vec![-0.0973])],
    );
    let o = run(&t, &Options::default());
    assert!(o.extra.is_empty(), "invented: {:?}", o.extra);
    for h in &o.hidden {
        assert!(h.found, "{:?} missed: {o:#?}", h.effect);
        // none confidently wrong (one of the 9 parameters, the bias x, misses its 95 % interval
        // by 1.45 half-widths: about what 9 intervals are expected to do)
        for ((est, hw), truth) in h.estimates.iter().zip(&h.truth) {
            assert!((est - truth).abs() <= 3.0 * hw, "{:?}: {est} ± {hw} for {truth}", h.effect);
        }
    }
    let scale = &o.hidden.iter().find(|h| h.effect == ThrustScale).unwrap().estimates[0];
    assert!((scale.0 - -0.0973).abs() <= scale.1, "thrust scale {scale:?}");
}

/// Trial 216 of seed 3 (a fixture): a thrust scale of −0.087 and a thrust against voltage of
/// 0.016 /V on the `x3d`, whose pack varies little. The step that adds the thrust scale names
/// the voltage not identifiable from it (canonical correlation 0.997), and the thrust scale then
/// holds the voltage's mean (−0.0765 for −0.0868). With the final model's noise model the
/// correlation fell below 0.99, so the final check let the thrust scale claim ± 0.0004: 24
/// half-widths off. A pair named at its step stays one: no interval is claimed.
#[test]
fn a_thrust_scale_named_beside_a_voltage_effect_claims_no_interval() {
    use flyarena::identify::Effect::*;
    let t = fixture(3, 216, "x3d", vec![(ThrustScale, vec![-0.0868]), (ThrustVoltage, vec![0.0158])]);
    let r = flyarena::identify::identify(&flight(&t), &Options::default()).unwrap();
    let scale = r.effect(ThrustScale).unwrap_or_else(|| panic!("thrust scale missed: {r:#?}"));
    assert!(scale.params.iter().any(|p| !p.identifiable), "{scale:#?}");
    assert!(r.effect(ThrustVoltage).is_none(), "{r:#?}");
    // the final check meets the pair again and lists it (and writes its note) only if no step did:
    // once in the report, which flags the voltage effect beside the selected thrust scale. A bug it
    // catches: "not yet listed" as "already listed" listed every pair named at its step twice (and
    // no new one) and passed
    let listed = r
        .not_identifiable
        .iter()
        .filter(|(a, b, _)| [*a, *b] == [ThrustScale, ThrustVoltage] || [*b, *a] == [ThrustScale, ThrustVoltage])
        .count();
    assert_eq!(listed, 1, "{:?}", r.not_identifiable);
    assert!(!r.notes.iter().any(|n| matches!(n, flyarena::identify::Note::ExplainAlike { .. })), "{:?}", r.notes);
}

/// Trial 20 of batch 3: a body offset, a 5 ms mocap delay the selection only half supports, and
/// an accelerometer bias.
fn half_supported_delay_flight() -> Trial {
    use flyarena::identify::Effect::*;
    fixture(
        3,
        20,
        "x3d",
        vec![
            (BodyOffset, vec![-2.748, -1.582, 2.09]),
            (MocapDelay, vec![5.0]),
            (AccelBias, vec![0.2373, 0.057, 0.2207]),
        ],
    )
}

/// Trial 20 of seed 3 (a fixture): a body offset (−2.75, −1.58, 2.09)°, an accelerometer bias
/// and a 5 ms mocap delay on the `x3d`, flown as calibration circles and a yaw turn. Over the
/// circles the rate vector turns at Ω ≈ 2.7 rad/s, so the delay looks like a body-offset yaw of
/// Ω·δt ≈ 0.8°. The delay is significant in the fit but cuts the held-out error by 8 %, short of
/// the gate, and stays out; the yaw then claimed 2.99 ± 0.13° for 2.09. The selected effects'
/// intervals must cover the estimates with such a half-supported candidate in the model too.
#[test]
fn a_half_supported_delay_widens_the_body_offset_yaw() {
    use flyarena::identify::Effect::*;
    let t = half_supported_delay_flight();
    let o = run(&t, &Options::default());
    for h in o.hidden.iter().filter(|h| h.effect != MocapDelay) {
        assert!(h.found && h.identifiable, "{:?}: {o:#?}", h.effect);
        for ((est, hw), truth) in h.estimates.iter().zip(&h.truth) {
            assert!((est - truth).abs() <= 3.0 * hw, "{:?}: {est} ± {hw} for {truth}", h.effect);
        }
    }
    let offset = &o.hidden.iter().find(|h| h.effect == BodyOffset).unwrap().estimates;
    assert!((offset[2].0 - 2.09).abs() <= offset[2].1, "body offset yaw {:?} for 2.09", offset[2]);
}

/// The same flight's rest, against the fit: the half-supported delay widens the ground
/// agreement's interval by what the alternative moves the tilt at rest, |Δ(frame roll + b_y/g)|
/// (`widen::half_supported`), and without the delay among the candidates nothing is widened.
/// The note gives the alternative's body-offset roll as +0.019°; the bias moves too little to
/// be listed (asserted), so the roll interval grows by about that.
/// The flight's mocap starts a frame after its IMU (the undeclared 5 ms delay): its rest must
/// begin at the first pose, or it has no rest and no ground agreement at all.
#[test]
fn a_half_supported_delay_widens_the_ground_agreement_by_the_tilt_it_moves() {
    use flyarena::identify::Effect::*;
    let t = half_supported_delay_flight();
    let s = flyarena::scenario::Scenario::parse(&t.yaml, std::path::Path::new("trial-3-20.yaml")).unwrap();
    let (_, series) = flyarena::identify::run_and_log(&s, 0, "trial 20").unwrap();
    let agreement = |o: &Options| {
        let r = flyarena::identify::identify(&series, o).unwrap();
        let a = r.ground_agreement.expect("the flight starts at rest");
        ([a.roll.ci95_deg, a.pitch.ci95_deg], r.notes)
    };
    let (with, notes) = agreement(&Options::default());
    let note = notes
        .iter()
        .find(|n| matches!(n, flyarena::identify::Note::HalfSupported { effect: MocapDelay, very_strong: true, .. }))
        .unwrap_or_else(|| panic!("{notes:?}"))
        .to_string();
    // it lists what moves beyond its own interval (the roll, by 0.019°), not what stays inside
    // it (the bias)
    assert!(note.contains("body_offset roll +0.019 deg") && !note.contains("accel_bias"), "{note}");
    let mut without_delay = Options::default();
    without_delay.candidates.retain(|e| *e != MocapDelay);
    let (own, notes) = agreement(&without_delay);
    assert!(
        !notes.iter().any(|n| matches!(n, flyarena::identify::Note::HalfSupported { very_strong: false, .. })),
        "{notes:?}"
    );
    let widen = [with[0] - own[0], with[1] - own[1]];
    assert!((widen[0] - 0.019).abs() < 0.002, "roll widened by {widen:?} for the alternative's 0.019°");
    assert!((0.0..widen[0]).contains(&widen[1]), "pitch widened by {widen:?}: the delay moves the roll");
}

/// `trials --shard K/N` flies every Nth flight from K − 1, and `flyarena merge` of the N shard
/// files writes the unsharded report byte for byte (6 flights of seed 3 in 3 shards); a shard of
/// another seed, one given twice and one missing are refused (exit 2, naming it), and nothing is
/// written then.
#[test]
fn sharded_trials_merge_to_the_unsharded_report_byte_for_byte() {
    let d = super::Scratch::new("trials-shards");
    let fly = |args: &[&str]| {
        std::process::Command::new(env!("CARGO_BIN_EXE_flyarena")).args(args).current_dir(&*d).output().unwrap()
    };
    assert_eq!(fly(&["trials", "--flights", "6", "--seed", "3", "--out", "full"]).status.code(), Some(0));
    for k in ["1/3", "2/3", "3/3"] {
        assert_eq!(
            fly(&["trials", "--flights", "6", "--seed", "3", "--shard", k, "--out", "s"]).status.code(),
            Some(0)
        );
    }
    assert_eq!(
        fly(&["trials", "--flights", "6", "--seed", "4", "--shard", "3/3", "--out", "other"]).status.code(),
        Some(0)
    );
    let shard = |k: u32| format!("s/trials-3-6.shard-{k}-of-3.json");
    let merged = fly(&["merge", &shard(1), &shard(2), &shard(3), "--out", "m"]);
    assert_eq!(merged.status.code(), Some(0), "{}", String::from_utf8_lossy(&merged.stderr));
    assert_eq!(
        std::fs::read(d.join("m/trials-3-6.json")).unwrap(),
        std::fs::read(d.join("full/trials-3-6.json")).unwrap(),
        "merged ≠ unsharded"
    );
    for (files, why) in [
        (vec![shard(1), shard(2), "other/trials-4-6.shard-3-of-3.json".into()], "seed 4, not 3"),
        (vec![shard(1), shard(2), shard(2)], "shard 2 of 3 is given twice"),
        (vec![shard(1), shard(3)], "shard 2 of 3 is missing"),
    ] {
        let mut args = vec!["merge".to_string()];
        args.extend(files);
        args.extend(["--out".into(), "bad".into()]);
        let out = fly(&args.iter().map(String::as_str).collect::<Vec<_>>());
        assert_eq!(out.status.code(), Some(2), "{why}");
        assert!(String::from_utf8_lossy(&out.stderr).contains(why), "{why}: {}", String::from_utf8_lossy(&out.stderr));
        assert!(!d.join("bad").exists(), "{why}: nothing written");
    }
}

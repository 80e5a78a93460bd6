//! Whether a fit describes a sensor that can exist. Least squares always returns numbers; when
//! the frames or the clocks of a log are not what the fit assumes (an IMU mounted at a half-turn
//! and a fit that starts at the identity, streams 0.2 s apart), the numbers that come out
//! explain the mismatch with effects no sensor has: an accelerometer bias of 1.6 g, a lever arm
//! of a metre and a half. None of them may be reported as found. After the fit:
//!
//! | check | bound | why |
//! |---|---|---|
//! | accelerometer bias ‖b_a‖ | [`MAX_ACCEL_BIAS_M_S2`] (≈ 0.2 g) | MEMS accelerometers are specified to tens of milli-g (±50–150 mg for consumer parts) |
//! | gyro bias ‖b_g‖ | [`MAX_GYRO_BIAS_DEG_S`] | consumer MEMS gyros: a few °/s, ±20 °/s at worst before calibration |
//! | lever arm ‖r‖ | [`MAX_LEVER_ARM_M`] | the tracked point and the IMU sit on one rigid body, within reach of each other |
//! | the gyro's motion unexplained | more than [`MAX_GYRO_UNEXPLAINED`] of its rms, and more than [`FLOOR_FACTOR`] × what the best rotation of the rates leaves, where the motion is ≥ [`MIN_MOTION_RAD_S`] | a gyro and a mocap that agree in frame and clock agree to their noise; a turned or shifted rate leaves a residual as large as the motion |
//!
//! The floor of the gyro's residual is read off the log itself: the global start's Wahba fit
//! ([`crate::identify::fit::start::FrameStart`]) turns the mocap's rates onto the gyro's by the best
//! rotation (and bias), and what it leaves is the gyro's and the mocap's noise together, whatever
//! the rig. A fit that fails any check
//! claims no effect ([`Report::unclaimed`](super::Report) keeps what it gave, for the
//! diagnosis), and `identify` says the frames or the clocks are not aligned, names what to try
//! and exits 1.

use super::Report;
use crate::effects::{Channel, Effect, MAX_ACCEL_BIAS_M_S2, MAX_GYRO_BIAS_DEG_S, MAX_LEVER_ARM_M};
/// The largest share of the gyro's motion (rms about its mean) a fit may leave unexplained.
pub const MAX_GYRO_UNEXPLAINED: f64 = 0.5;
/// The gyro check applies where the motion's rms is at least this (rad/s, ≈ 1 °/s): a log that
/// barely turns has nothing to explain.
pub const MIN_MOTION_RAD_S: f64 = 0.02;
/// A fit's gyro residual must exceed the best rotation's by this factor to count as unexplained.
pub const FLOOR_FACTOR: f64 = 2.0;

/// One way a fit is not physically possible.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
#[non_exhaustive]
pub enum Implausible {
    /// An accelerometer bias larger than any sensor's.
    AccelBias {
        /// ‖b_a‖ (m/s²).
        norm_m_s2: f64,
        /// The largest a sensor has ([`MAX_ACCEL_BIAS_M_S2`](crate::effects::MAX_ACCEL_BIAS_M_S2)).
        bound_m_s2: f64,
    },
    /// A gyro bias larger than any sensor's.
    GyroBias {
        /// ‖b_g‖ (°/s).
        norm_deg_s: f64,
        /// The largest a sensor has ([`MAX_GYRO_BIAS_DEG_S`](crate::effects::MAX_GYRO_BIAS_DEG_S)).
        bound_deg_s: f64,
    },
    /// A lever arm longer than a rigid body holds.
    LeverArm {
        /// ‖r‖ (m).
        norm_m: f64,
        /// The longest a rigid body holds ([`MAX_LEVER_ARM_M`](crate::effects::MAX_LEVER_ARM_M)).
        bound_m: f64,
    },
    /// The gyro's motion is left largely unexplained.
    GyroUnexplained {
        /// The held-out residual's rms over the gyro's rms about its mean (fraction).
        fraction: f64,
        /// The gyro's rms about its mean on the held-out samples (rad/s).
        motion_rad_s: f64,
        /// What the best rotation of the rates leaves (the global start's residual, rad/s).
        floor_rad_s: f64,
        /// The largest share a fit may leave (0.5).
        bound: f64,
    },
}

/// The checks of the table above on the fitted report `r` (with its global start).
pub(crate) fn check(r: &Report) -> Vec<Implausible> {
    let mut out = Vec::new();
    let norm = |e: Effect| -> Option<f64> {
        r.effect(e).map(|f| f.params.iter().take(3).map(|p| p.value * p.value).sum::<f64>().sqrt())
    };
    if let Some(b) = norm(Effect::AccelBias).filter(|b| *b > MAX_ACCEL_BIAS_M_S2) {
        out.push(Implausible::AccelBias { norm_m_s2: b, bound_m_s2: MAX_ACCEL_BIAS_M_S2 });
    }
    if let Some(b) = norm(Effect::GyroBias).filter(|b| *b > MAX_GYRO_BIAS_DEG_S) {
        out.push(Implausible::GyroBias { norm_deg_s: b, bound_deg_s: MAX_GYRO_BIAS_DEG_S });
    }
    // the lever arm is reported in mm
    if let Some(l) = norm(Effect::LeverArm).map(|l| l * 1e-3).filter(|l| *l > MAX_LEVER_ARM_M) {
        out.push(Implausible::LeverArm { norm_m: l, bound_m: MAX_LEVER_ARM_M });
    }
    // the gyro's unexplained share: Σ residual² over Σ (y − ȳ)², the latter from each axis's fit
    // (fit = 1 − ‖residual‖/‖y − ȳ‖), against what the best rotation of the rates leaves (the
    // global start's residual: the floor the gyro's and the mocap's noise set together)
    let (mut res, mut motion, mut n) = (0.0, 0.0, 0usize);
    for e in r.errors.iter().filter(|e| e.channel == Channel::Gyro) {
        let ss = e.rmse_after * e.rmse_after * e.samples as f64;
        if let Some(fit) = e.fit_after_pct.filter(|f| *f < 100.0) {
            res += ss;
            motion += ss / (1.0 - fit / 100.0).powi(2);
            n += e.samples;
        }
    }
    if let Some(f) = &r.start.frames
        && n > 0
        && motion > 0.0
    {
        let (residual_rad_s, motion_rad_s) = ((res / n as f64).sqrt(), (motion / n as f64).sqrt());
        let fraction = residual_rad_s / motion_rad_s;
        if motion_rad_s >= MIN_MOTION_RAD_S
            && fraction > MAX_GYRO_UNEXPLAINED
            && residual_rad_s > FLOOR_FACTOR * f.gyro_residual_rad_s
        {
            out.push(Implausible::GyroUnexplained {
                fraction,
                motion_rad_s,
                floor_rad_s: f.gyro_residual_rad_s,
                bound: MAX_GYRO_UNEXPLAINED,
            });
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::identify::fit::select::{AxisError, Options, identify};
    use crate::identify::input::series::Series;
    use nalgebra::UnitQuaternion;

    /// An exact rig calibrated: nothing is implausible.
    fn calibrated() -> Report {
        let s = Series::rig_for_tests(UnitQuaternion::identity(), UnitQuaternion::identity(), 0.0);
        identify(&s, &Options { forced: Effect::CALIBRATION.to_vec(), ..Options::default() }).unwrap()
    }

    fn set(r: &mut Report, e: Effect, values: [f64; 3]) {
        let f = r.effects.iter_mut().find(|f| f.effect == e).unwrap();
        for (p, v) in f.params.iter_mut().zip(values) {
            p.value = v;
        }
    }

    /// Each bound of the table, on both sides: a bias of 2.5 m/s² (norm) is flagged and one of
    /// √3 m/s² is not; 30 °/s is, 20 and 15 °/s (norm 25) is not; 1.1 m of lever arm is, 0.9 m is
    /// not; and an exact rig's own calibration passes every check.
    #[test]
    fn each_bound_flags_what_lies_beyond_it_and_nothing_within() {
        let r = calibrated();
        assert!(check(&r).is_empty(), "{:?}", check(&r));
        let flagged = |e: Effect, v: [f64; 3]| {
            let mut r = calibrated();
            set(&mut r, e, v);
            check(&r)
        };
        assert!(
            matches!(flagged(Effect::AccelBias, [2.5, 0.0, 0.0])[..], [Implausible::AccelBias { norm_m_s2, .. }] if (norm_m_s2 - 2.5).abs() < 1e-12)
        );
        assert!(flagged(Effect::AccelBias, [1.0, 1.0, 1.0]).is_empty());
        assert!(matches!(flagged(Effect::GyroBias, [0.0, 30.0, 0.0])[..], [Implausible::GyroBias { .. }]));
        assert!(flagged(Effect::GyroBias, [20.0, 15.0, 0.0]).is_empty());
        assert!(
            matches!(flagged(Effect::LeverArm, [0.0, 0.0, -1100.0])[..], [Implausible::LeverArm { norm_m, .. }] if (norm_m - 1.1).abs() < 1e-12)
        );
        assert!(flagged(Effect::LeverArm, [900.0, 0.0, 0.0]).is_empty());
    }

    /// The gyro's unexplained share, by hand: an axis fit of f % leaves a share 1 − f/100 of the
    /// motion. At 30 % (70 % left, over half, and far above the exact rig's floor) it is
    /// flagged; at 60 % (40 % left) it is not, nor where the motion is under 0.02 rad/s.
    #[test]
    fn a_gyro_left_unexplained_is_flagged_above_half_and_above_the_floor() {
        let with_gyro = |fit_pct: f64, rmse: f64| {
            let mut r = calibrated();
            r.errors.retain(|e| e.channel != Channel::Gyro);
            r.errors.extend(['x', 'y', 'z'].map(|axis| AxisError {
                channel: Channel::Gyro,
                axis,
                unit: "rad/s".into(),
                samples: 100,
                rmse_before: 1.0,
                rmse_after: rmse,
                fit_before_pct: None,
                fit_after_pct: Some(fit_pct),
            }));
            check(&r)
        };
        match &with_gyro(30.0, 0.07)[..] {
            [Implausible::GyroUnexplained { fraction, motion_rad_s, .. }] => {
                assert!(
                    (fraction - 0.7).abs() < 1e-12 && (motion_rad_s - 0.1).abs() < 1e-12,
                    "{fraction} {motion_rad_s}"
                );
            }
            other => panic!("{other:?}"),
        }
        assert!(with_gyro(60.0, 0.04).is_empty());
        assert!(with_gyro(30.0, 0.0105).is_empty(), "a motion of 0.015 rad/s has nothing to explain");
    }
}

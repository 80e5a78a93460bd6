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

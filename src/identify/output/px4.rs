//! PX4 parameters from an identification: the values a PX4 user sets for EKF2's fusion of a
//! mocap pose, each from the effect it comes from, with its 95 % interval.
//!
//! PX4's definitions (`src/modules/ekf2/params_external_vision.yaml` and the IMU position
//! parameters of EKF2; body frame FRD, origin at the centre of gravity):
//! - `EKF2_EV_DELAY` (ms, 0 to 300): "Vision Position Estimator delay relative to IMU
//!   measurements"; PX4's guide sets it to the difference between the measurement's timestamp
//!   and its actual capture time. `identify`'s mocap delay τ is that difference against the IMU's
//!   clock: the log stamps a pose τ after it was captured (`undeclared.mocap_delay_ms` simulates
//!   it so). So `EKF2_EV_DELAY` = τ, for the stamps the EKF uses (`timestamp_sample` of the
//!   odometry, which the PX4 log reader uses where it can). A negative τ (poses stamped before
//!   they were captured: a clock offset) has no PX4 setting, and none is written.
//! - `EKF2_IMU_POS_X/Y/Z` (m): the IMU's position from the centre of gravity. `identify`'s
//!   `imu_offset` r_c is that vector, so `EKF2_IMU_POS` = r_c. It is fitted only when asked for
//!   (`--with imu_offset`, with a force model).
//! - `EKF2_EV_POS_X/Y/Z` (m): the position of the vision sensor's focal point from the centre of
//!   gravity; for a mocap, the point whose position it reports (the rigid body's origin).
//!   `identify`'s `lever_arm` r runs from that point to the IMU, so the point sits at r_c − r
//!   from the centre of gravity: `EKF2_EV_POS` = r_c − r, and −r where the IMU is taken to sit
//!   at the centre of gravity (no `imu_offset` fitted; said in the notes). Its interval adds the
//!   two half-widths in quadrature (the two fits taken as independent).
//!
//! The body offset has no PX4 parameter: it is a rotation to apply where the pose is made (the
//! mocap's rigid-body definition or the bridge). `identify`'s body offset R_off maps the mocap
//! body frame M to the IMU's body frame B (q_mocap = q_true·R_off, body → world), so the rigid
//! body's axes must turn by R_off⁻¹ about themselves: q_new = q_mocap·R_off⁻¹ = q_true. Written in
//! the rigid body's own axes of the user's mocap ([`MocapAxes`]; C maps FRD to them), that is
//! C·R_off⁻¹·Cᵀ, whose rotation vector is C·(−φ) for φ the rotation vector of R_off.
//!
//! An effect not found, or found but not identifiable, gives no value: a parameter not written
//! keeps whatever the vehicle has.

use crate::effects::Effect;
use crate::identify::Report;
use crate::identify::fit::select::Found;
use crate::identify::precision::{signed_with_interval, with_interval};
use nalgebra::{Matrix3, Rotation3, UnitQuaternion, Vector3};
use std::fmt::Write as _;

/// The axes of a rigid body in the user's mocap software (the same three conventions as
/// `serve --up`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum MocapAxes {
    /// x forward, y left, z up (Vicon, Qualisys, OptiTrack set to Z up, ROS's FLU).
    #[default]
    ZUp,
    /// x forward, y up, z right (OptiTrack Motive's default, Y up).
    YUp,
    /// x forward, y right, z down (FRD, as PX4 and flyarena).
    Frd,
}

impl MocapAxes {
    /// C: a vector in FRD body axes → the same vector in these axes.
    fn frd_to_axes(self) -> Matrix3<f64> {
        match self {
            MocapAxes::ZUp => Matrix3::new(1.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, -1.0),
            MocapAxes::YUp => Matrix3::new(1.0, 0.0, 0.0, 0.0, 0.0, -1.0, 0.0, 1.0, 0.0),
            MocapAxes::Frd => Matrix3::identity(),
        }
    }

    /// The axes in words, for the notes.
    pub fn describe(self) -> &'static str {
        match self {
            MocapAxes::ZUp => "z up: x forward, y left, z up",
            MocapAxes::YUp => "y up: x forward, y up, z right",
            MocapAxes::Frd => "FRD: x forward, y right, z down",
        }
    }
}

/// The rotation that removes the body offset, in the rigid body's own axes of the user's mocap.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct BodyOffsetFix {
    /// The axes it is written in.
    pub axes: MocapAxes,
    /// Its rotation vector (°) per axis of [`Self::axes`], each with the half-width of its 95 %
    /// interval (the body offset's roll, pitch and yaw intervals, carried to first order).
    pub rotation_vector_deg: [(f64, f64); 3],
    /// The same rotation as a quaternion (x, y, z, w), for a bridge that turns each pose as
    /// q·r before sending it.
    pub quaternion_xyzw: [f64; 4],
}

/// The fix for a body offset of Z-Y-X roll, pitch, yaw (rad) with 95 % half-widths (rad), in
/// `axes` (module doc: C·R_off⁻¹·Cᵀ).
fn body_offset_fix(rpy: [f64; 3], ci: [f64; 3], axes: MocapAxes) -> BodyOffsetFix {
    let r_off = Rotation3::from_euler_angles(rpy[0], rpy[1], rpy[2]);
    let c = axes.frd_to_axes();
    let fix = Rotation3::from_matrix_unchecked(c * r_off.inverse().matrix() * c.transpose());
    let v = fix.scaled_axis();
    let ci_conv = c.abs() * Vector3::from(ci);
    let q = UnitQuaternion::from_rotation_matrix(&fix);
    BodyOffsetFix {
        axes,
        rotation_vector_deg: [0, 1, 2].map(|k| (v[k].to_degrees(), ci_conv[k].to_degrees())),
        quaternion_xyzw: [q.i, q.j, q.k, q.w],
    }
}

/// One PX4 parameter with its value, interval and origin.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Px4Param {
    /// PX4's name.
    pub name: &'static str,
    /// The value, in PX4's unit.
    pub value: f64,
    /// Half-width of its 95 % interval.
    pub ci95: f64,
    /// PX4's unit.
    pub unit: &'static str,
    /// The effect (or effects) it comes from.
    pub from: &'static str,
}

/// What an identification gives a PX4 user.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct Px4Parameters {
    /// The parameters to set.
    pub params: Vec<Px4Param>,
    /// What was not written and why, and what has no parameter.
    pub notes: Vec<Px4Note>,
    /// The body offset's fix in the mocap software, where one was found and is identifiable.
    pub body_offset_fix: Option<BodyOffsetFix>,
}

/// What [`parameters`] says beside the parameters: one variant per parameter group left out (and
/// why), or written on an assumption. `Display` is the sentence the command line prints, and the
/// JSON holds that sentence.
#[derive(Clone, Copy, Debug, PartialEq)]
#[non_exhaustive]
pub enum Px4Note {
    /// `EKF2_EV_DELAY` not written: the flight cannot tell the mocap delay from another effect.
    DelayNotIdentifiable {
        /// The fitted delay (ms).
        delay_ms: f64,
    },
    /// `EKF2_EV_DELAY` not written: the poses are stamped before the IMU's time of the same
    /// motion, which no delay makes up for.
    PosesLead {
        /// How far ahead the poses are stamped (ms, positive).
        lead_ms: f64,
        /// Its 95 % half-width (ms).
        ci95_ms: f64,
    },
    /// `EKF2_EV_DELAY` not written: the mocap delay was not fitted.
    DelayNotFitted,
    /// `EKF2_IMU_POS_*` not written: the IMU's offset from the centre of mass is not identifiable.
    ImuPosNotIdentifiable,
    /// `EKF2_IMU_POS_*` not written: the IMU's offset was not fitted.
    ImuPosNotFitted,
    /// `EKF2_EV_POS_*` written as −(lever arm), the IMU taken to sit at the centre of gravity.
    EvPosAssumesImuAtCog,
    /// `EKF2_EV_POS_*` not written: the lever arm is not identifiable.
    EvPosNotIdentifiable,
    /// `EKF2_EV_POS_*` not written: no lever arm was selected.
    EvPosNoLeverArm,
    /// The body offset has no PX4 parameter: the fix is in the mocap software.
    BodyOffsetInMocap {
        /// Roll, pitch and yaw (deg, FRD, Z-Y-X) with their 95 % half-widths.
        offset_deg: [(f64, f64); 3],
    },
    /// The body offset is not identifiable: no fix for the rigid body.
    BodyOffsetNotIdentifiable,
}

impl std::fmt::Display for Px4Note {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Px4Note::DelayNotIdentifiable { delay_ms } => write!(
                f,
                "EKF2_EV_DELAY not written: the mocap delay ({delay_ms:.2} ms) is not identifiable from another effect on this flight"
            ),
            Px4Note::PosesLead { lead_ms, ci95_ms } => write!(
                f,
                "EKF2_EV_DELAY not written: the poses are stamped {} ms before the IMU's time of the same motion, which no delay (PX4: 0 to 300 ms) makes up for; the pose's stamps are off (a clock offset between the mocap and the flight controller)",
                with_interval(*lead_ms, *ci95_ms)
            ),
            Px4Note::DelayNotFitted => {
                f.write_str("EKF2_EV_DELAY not written: the mocap delay was not fitted (identify --px4 always fits it)")
            }
            Px4Note::ImuPosNotIdentifiable => f.write_str(
                "EKF2_IMU_POS not written: the IMU's offset from the centre of mass is not identifiable on this flight",
            ),
            Px4Note::ImuPosNotFitted => f.write_str(
                "EKF2_IMU_POS not written: the IMU's offset from the centre of mass was not fitted (`--with imu_offset`, which needs a force model)",
            ),
            Px4Note::EvPosAssumesImuAtCog => f.write_str(
                "EKF2_EV_POS is −(lever arm): the mocap origin against the IMU, the IMU taken to sit at the centre of gravity (fit `--with imu_offset` to place it)",
            ),
            Px4Note::EvPosNotIdentifiable => {
                f.write_str("EKF2_EV_POS not written: the lever arm is not identifiable on this flight")
            }
            Px4Note::EvPosNoLeverArm => f.write_str(
                "EKF2_EV_POS not written: no lever arm between the mocap origin and the IMU was selected on this flight",
            ),
            Px4Note::BodyOffsetInMocap { offset_deg: [r, p, y] } => write!(
                f,
                "the body offset (roll {}°, pitch {}°, yaw {}°, FRD, Z-Y-X: the mocap's body frame against the IMU's) has no PX4 parameter: turn the rigid body's axes in the mocap software as below",
                with_interval(r.0, r.1),
                with_interval(p.0, p.1),
                with_interval(y.0, y.1)
            ),
            Px4Note::BodyOffsetNotIdentifiable => {
                f.write_str("the body offset is not identifiable on this flight: no fix for the rigid body")
            }
        }
    }
}

impl serde::Serialize for Px4Note {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_str(self)
    }
}

/// The PX4 parameters `report` supports (see the module doc for each derivation), with the body
/// offset's fix written in the rigid body's `axes`.
pub fn parameters(report: &Report, axes: MocapAxes) -> Px4Parameters {
    parameters_of(&report.effects, axes)
}

/// The PX4 parameters the effects of a final model support.
fn parameters_of(effects: &[Found], axes: MocapAxes) -> Px4Parameters {
    let mut out = Px4Parameters::default();
    let found = |e: Effect| effects.iter().find(|f| f.effect == e);
    let identifiable = |e: Effect| found(e).is_some_and(|f| f.params.iter().all(|p| p.identifiable));
    match found(Effect::MocapDelay) {
        Some(f) if !identifiable(Effect::MocapDelay) => {
            out.notes.push(Px4Note::DelayNotIdentifiable { delay_ms: f.params[0].value })
        }
        Some(f) if f.params[0].value < 0.0 => {
            out.notes.push(Px4Note::PosesLead { lead_ms: -f.params[0].value, ci95_ms: f.params[0].ci95 })
        }
        Some(f) => out.params.push(Px4Param {
            name: "EKF2_EV_DELAY",
            value: f.params[0].value,
            ci95: f.params[0].ci95,
            unit: "ms",
            from: "mocap_delay",
        }),
        None => out.notes.push(Px4Note::DelayNotFitted),
    }
    let mm = |e: Effect| {
        found(e)
            .filter(|_| identifiable(e))
            .map(|f| f.params.iter().map(|p| (p.value * 1e-3, p.ci95 * 1e-3)).collect::<Vec<_>>())
    };
    let imu = mm(Effect::ImuOffset);
    let lever = mm(Effect::LeverArm);
    const IMU_POS: [&str; 3] = ["EKF2_IMU_POS_X", "EKF2_IMU_POS_Y", "EKF2_IMU_POS_Z"];
    const EV_POS: [&str; 3] = ["EKF2_EV_POS_X", "EKF2_EV_POS_Y", "EKF2_EV_POS_Z"];
    match &imu {
        Some(r_c) => {
            for k in 0..3 {
                out.params.push(Px4Param {
                    name: IMU_POS[k],
                    value: r_c[k].0,
                    ci95: r_c[k].1,
                    unit: "m",
                    from: "imu_offset",
                });
            }
        }
        None if found(Effect::ImuOffset).is_some() => out.notes.push(Px4Note::ImuPosNotIdentifiable),
        None => out.notes.push(Px4Note::ImuPosNotFitted),
    }
    match &lever {
        Some(r) => {
            let zero = [(0.0, 0.0); 3];
            let r_c = imu.as_deref().unwrap_or(&zero);
            for k in 0..3 {
                let (v, ci) = (r_c[k].0 - r[k].0, (r_c[k].1.powi(2) + r[k].1.powi(2)).sqrt());
                out.params.push(Px4Param {
                    name: EV_POS[k],
                    value: v,
                    ci95: ci,
                    unit: "m",
                    from: if imu.is_some() { "imu_offset − lever_arm" } else { "−lever_arm" },
                });
            }
            if imu.is_none() {
                out.notes.push(Px4Note::EvPosAssumesImuAtCog);
            }
        }
        None if found(Effect::LeverArm).is_some() => out.notes.push(Px4Note::EvPosNotIdentifiable),
        None => out.notes.push(Px4Note::EvPosNoLeverArm),
    }
    match found(Effect::BodyOffset) {
        Some(f) if identifiable(Effect::BodyOffset) => {
            let p = &f.params;
            let fix = body_offset_fix(
                [0, 1, 2].map(|k| p[k].value.to_radians()),
                [0, 1, 2].map(|k| p[k].ci95.to_radians()),
                axes,
            );
            out.notes.push(Px4Note::BodyOffsetInMocap { offset_deg: [0, 1, 2].map(|k| (p[k].value, p[k].ci95)) });
            out.body_offset_fix = Some(fix);
        }
        Some(_) => out.notes.push(Px4Note::BodyOffsetNotIdentifiable),
        None => {}
    }
    out
}

/// The parameters as a QGroundControl parameter file (tab-separated: vehicle id, component id,
/// name, value, MAVLink type; 9 is `MAV_PARAM_TYPE_REAL32`), for vehicle 1, component 1.
pub fn qgc_file(p: &Px4Parameters, source: &str) -> String {
    let mut s = format!(
        "# PX4 parameters identified by flyarena from {source}\n#\n# Vehicle-Id\tComponent-Id\tName\tValue\tType\n"
    );
    for q in &p.params {
        let _ = writeln!(s, "1\t1\t{}\t{:.6}\t9", q.name, q.value);
    }
    s
}

/// The parameters and notes as text, one line each, for the command line.
pub fn render(p: &Px4Parameters) -> String {
    let mut s = String::from("PX4 parameters (95 % intervals; body frame FRD, origin at the centre of gravity):\n");
    if p.params.is_empty() {
        s.push_str("  none: nothing this flight supports\n");
    }
    for q in &p.params {
        let (v, ci) = if q.unit == "m" {
            (format!("{:.4}", q.value), format!("{:.4}", q.ci95))
        } else {
            (format!("{:.2}", q.value), format!("{:.2}", q.ci95))
        };
        let _ = writeln!(s, "  {:<15} {v:>8} ± {ci} {:<2}  from {}", q.name, q.unit, q.from);
    }
    for n in &p.notes {
        let _ = writeln!(s, "  {n}");
    }
    if let Some(f) = &p.body_offset_fix {
        let [x, y, z] = f.rotation_vector_deg;
        let q = f.quaternion_xyzw;
        let _ = writeln!(
            s,
            "  rigid body ({}): turn its axes about themselves by the rotation vector ({}°, {}°, {}°); as a quaternion (x, y, z, w) = ({:.6}, {:.6}, {:.6}, {:.6}), applied as q·r to each pose in a bridge",
            f.axes.describe(),
            signed_with_interval(x.0, x.1),
            signed_with_interval(y.0, y.1),
            signed_with_interval(z.0, z.1),
            q[0],
            q[1],
            q[2],
            q[3]
        );
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::identify::fit::select::Param;

    fn found(effect: Effect, values: &[(f64, f64)], identifiable: bool) -> Found {
        let params = values
            .iter()
            .map(|&(value, ci95)| Param { name: "p".into(), value, ci95, unit: "u".into(), identifiable })
            .collect();
        Found { effect, name: effect.key().into(), params }
    }

    fn parameters_of_frd(effects: &[Found]) -> Px4Parameters {
        parameters_of(effects, MocapAxes::Frd)
    }

    fn names(p: &Px4Parameters) -> Vec<&str> {
        p.params.iter().map(|q| q.name).collect()
    }

    /// What is not written, and why: a delay that is not identifiable, a negative delay (PX4
    /// takes 0 to 300 ms), a delay of exactly 0 (written: 0 is PX4's own default and in range),
    /// an IMU offset or a lever arm found but not identifiable, and each one not fitted at all;
    /// each has its own note.
    #[test]
    fn what_is_not_written_is_said_with_its_reason() {
        let p = parameters_of_frd(&[found(Effect::MocapDelay, &[(4.0, 1.0)], false)]);
        assert!(names(&p).is_empty() && p.notes[0] == Px4Note::DelayNotIdentifiable { delay_ms: 4.0 }, "{p:?}");
        let p = parameters_of_frd(&[found(Effect::MocapDelay, &[(-3.0, 0.5)], true)]);
        assert!(names(&p).is_empty() && p.notes[0] == Px4Note::PosesLead { lead_ms: 3.0, ci95_ms: 0.5 }, "{p:?}");
        assert!(p.notes[0].to_string().contains("stamped 3.00 ± 0.50 ms before the IMU's time"), "{p:?}");
        let p = parameters_of_frd(&[found(Effect::MocapDelay, &[(0.0, 0.5)], true)]);
        assert_eq!(names(&p), ["EKF2_EV_DELAY"]);
        let p = parameters_of_frd(&[]);
        assert_eq!(p.notes[..3], [Px4Note::DelayNotFitted, Px4Note::ImuPosNotFitted, Px4Note::EvPosNoLeverArm]);
        let mm = [(10.0, 1.0), (-5.0, 1.0), (30.0, 1.0)];
        let p = parameters_of_frd(&[found(Effect::ImuOffset, &mm, false), found(Effect::LeverArm, &mm, false)]);
        assert!(names(&p).is_empty(), "{p:?}");
        assert_eq!(p.notes[1..3], [Px4Note::ImuPosNotIdentifiable, Px4Note::EvPosNotIdentifiable], "{p:?}");
    }

    /// EV_POS = r_c − r by hand, in metres, with the half-widths in quadrature: r_c = (20, 0,
    /// 15) ± (3, 3, 4) mm and r = (30, −5, 10) ± (4, 4, 3) mm give (−0.010, 0.005, 0.005) ±
    /// 0.005 m; IMU_POS is r_c.
    #[test]
    fn ev_pos_is_the_imu_offset_less_the_lever_arm() {
        let p = parameters_of_frd(&[
            found(Effect::ImuOffset, &[(20.0, 3.0), (0.0, 3.0), (15.0, 4.0)], true),
            found(Effect::LeverArm, &[(30.0, 4.0), (-5.0, 4.0), (10.0, 3.0)], true),
        ]);
        let get = |n: &str| p.params.iter().find(|q| q.name == n).map(|q| (q.value, q.ci95)).unwrap();
        for (n, v) in [
            ("EKF2_EV_POS_X", -0.010),
            ("EKF2_EV_POS_Y", 0.005),
            ("EKF2_EV_POS_Z", 0.005),
            ("EKF2_IMU_POS_X", 0.020),
            ("EKF2_IMU_POS_Z", 0.015),
        ] {
            assert!((get(n).0 - v).abs() < 1e-12, "{n}: {:?}", get(n));
        }
        assert!((get("EKF2_EV_POS_X").1 - 0.005).abs() < 1e-12);
    }

    /// The body offset's fix by hand, one axis at a time (each 2° so that the second-order terms
    /// are nil). The markers' frame is the IMU's turned by R_off, so the rigid body's axes must
    /// turn back by −φ about themselves, written in the mocap's axes (FRD → z up: x, −y, −z; FRD
    /// → y up: x, −z, y):
    /// - yaw +2° (about down): −2° about down = +2° about z up, +2° about y up, −2° about FRD z;
    /// - roll +2° (about forward): −2° about x in all three;
    /// - pitch +2° (about right): −2° about right = +2° about z-up's y (left), −2° about y-up's z
    ///   (right).
    ///
    /// The quaternion is the same rotation (w = cos 1°, one component ±sin 1°), and the interval
    /// moves with its axis. A bug it catches: R_off instead of its inverse (every sign flips), C
    /// instead of Cᵀ or the y-up rows swapped (the pitch lands on the wrong axis).
    #[test]
    fn the_body_offset_fix_turns_the_rigid_body_back_in_its_own_axes() {
        let d = 2f64.to_radians();
        let ci = [0.1f64.to_radians(), 0.2f64.to_radians(), 0.3f64.to_radians()];
        let cases = [
            ([0.0, 0.0, d], MocapAxes::ZUp, [0.0, 0.0, 2.0]),
            ([0.0, 0.0, d], MocapAxes::YUp, [0.0, 2.0, 0.0]),
            ([0.0, 0.0, d], MocapAxes::Frd, [0.0, 0.0, -2.0]),
            ([d, 0.0, 0.0], MocapAxes::ZUp, [-2.0, 0.0, 0.0]),
            ([d, 0.0, 0.0], MocapAxes::YUp, [-2.0, 0.0, 0.0]),
            ([0.0, d, 0.0], MocapAxes::ZUp, [0.0, 2.0, 0.0]),
            ([0.0, d, 0.0], MocapAxes::YUp, [0.0, 0.0, -2.0]),
        ];
        for (rpy, axes, want) in cases {
            let f = body_offset_fix(rpy, ci, axes);
            for k in 0..3 {
                assert!(
                    (f.rotation_vector_deg[k].0 - want[k]).abs() < 1e-9,
                    "{rpy:?} in {axes:?}: {:?}",
                    f.rotation_vector_deg
                );
            }
            let q = f.quaternion_xyzw;
            assert!((q[3] - 1f64.to_radians().cos()).abs() < 1e-12, "{q:?}");
            for k in 0..3 {
                assert!(
                    (q[k] - want[k].signum() * 1f64.to_radians().sin() * (want[k] != 0.0) as u8 as f64).abs() < 1e-12,
                    "{q:?} for {want:?}"
                );
            }
        }
        // intervals follow the axes: yaw's 0.3° sits on y in y-up, on z in z-up
        let f = body_offset_fix([0.0; 3], ci, MocapAxes::YUp);
        assert!(
            (f.rotation_vector_deg[1].1 - 0.3).abs() < 1e-12 && (f.rotation_vector_deg[2].1 - 0.2).abs() < 1e-12,
            "{:?}",
            f.rotation_vector_deg
        );
        let f = body_offset_fix([0.0; 3], ci, MocapAxes::ZUp);
        assert!((f.rotation_vector_deg[2].1 - 0.3).abs() < 1e-12 && (f.rotation_vector_deg[1].1 - 0.2).abs() < 1e-12);
    }

    /// A body offset that is not identifiable gets no fix, and a note says so; one that is gets
    /// the fix and a note with its angles.
    #[test]
    fn a_body_offset_that_is_not_identifiable_gets_no_fix() {
        let p = parameters_of_frd(&[found(Effect::BodyOffset, &[(1.0, 0.1), (0.0, 0.1), (2.0, 0.1)], false)]);
        assert!(p.body_offset_fix.is_none() && p.notes.contains(&Px4Note::BodyOffsetNotIdentifiable), "{p:?}");
        let p = parameters_of_frd(&[found(Effect::BodyOffset, &[(1.0, 0.1), (0.0, 0.1), (2.0, 0.1)], true)]);
        assert!(
            p.body_offset_fix.is_some()
                && p.notes
                    .iter()
                    .any(|n| n.to_string().contains("roll 1.00 ± 0.10°, pitch 0.00 ± 0.10°, yaw 2.00 ± 0.10°")),
            "{p:?}"
        );
    }

    /// Lengths print to 0.1 mm (4 decimals of a metre), milliseconds to 0.01 ms. A bug it
    /// catches: the unit test inverted (a lever arm of 12.3 mm printed as 0.01 m).
    #[test]
    fn render_prints_metres_to_a_tenth_of_a_millimetre() {
        let p = Px4Parameters {
            params: vec![
                Px4Param { name: "EKF2_EV_POS_X", value: -0.01234, ci95: 0.00051, unit: "m", from: "−lever_arm" },
                Px4Param { name: "EKF2_EV_DELAY", value: 9.8372, ci95: 0.512, unit: "ms", from: "mocap_delay" },
            ],
            ..Default::default()
        };
        let r = render(&p);
        assert!(r.contains("-0.0123 ± 0.0005 m") && r.contains("9.84 ± 0.51 ms"), "{r}");
    }
}

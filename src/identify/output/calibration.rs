//! A calibration as the tools of the field take it: the transform T_BS in the ASL/Kalibr
//! convention, and the trajectory of the IMU's frame in the TUM format.
//!
//! **T_BS** (`<log>.T_BS.yaml`, ASL's `sensor.yaml` convention): the mocap's body S (the marker
//! frame) in the IMU's frame B, p_B = T_BS·p_S, with R_BS = R_off (v_IMU = R_off·v_marker) and
//! t_BS = −r (the marker origin as the IMU sees it; r is the lever arm from the marker origin to
//! the IMU, IMU axes). The time offset τ: a pose the mocap stamped t was taken at IMU time t − τ
//! (`time_offset_s`); Kalibr's `timeshift_cam_imu` convention, t_imu = t_sensor + shift, is
//! `timeshift_mocap_imu` = −τ. Every number is in the log's own axes (the mapping's `body` and
//! `world` undone), with its 95 % half-width: the rotation's as a small rotation about the IMU's
//! x, y, z (R_BS ← Exp(δ)·R_BS, |δ_k| within it).
//!
//! **The trajectory** (`<log>.imu.tum`, `t x y z qx qy qz qw`): at every IMU sample with a pose on
//! either side, the pose of the IMU's frame in the mocap's world as the log gives it (its axes,
//! its tilt), on the IMU's clock: R_IMU(t) = R_m(t + τ)·R_offᵀ, p_IMU(t) = p_m(t + τ) +
//! R_IMU(t)·r, the mocap's pose interpolated at the stamp that was taken at IMU time t.

use crate::effects::Effect;
use crate::identify::fit::select::Report;
use crate::identify::input::mapping::{BodyAxes, WorldUp};
use crate::identify::input::series::{Corrections, Series, correct};
use nalgebra::{Matrix3, UnitQuaternion, Vector3};
use std::fmt::Write as _;

/// The axes a log is written in: its world's up axis and its body's axes (the mapping's).
#[derive(Clone, Copy, Debug)]
pub struct LogAxes {
    /// The world's up axis.
    pub world: WorldUp,
    /// The body's axes.
    pub body: BodyAxes,
}

impl LogAxes {
    /// The axes of flyarena's own logs: a z-down world, an FRD body.
    pub fn flyarena() -> LogAxes {
        LogAxes { world: WorldUp::ZDown, body: BodyAxes::Frd }
    }

    /// The log's body axes from flyarena's: F with v_log = F·v_flyarena (its own inverse).
    fn body_from_internal(self) -> Matrix3<f64> {
        match self.body {
            BodyAxes::Frd => Matrix3::identity(),
            BodyAxes::Flu => Matrix3::from_diagonal(&Vector3::new(1.0, -1.0, -1.0)),
        }
    }
}

/// The calibration of `r` when it holds one to write: aligned (no misalignment), with the body
/// offset, the lever arm and the mocap delay fitted.
fn calibrated(r: &Report) -> bool {
    r.misaligned.is_empty()
        && [Effect::BodyOffset, Effect::LeverArm, Effect::MocapDelay].iter().all(|e| r.effect(*e).is_some())
}

/// The 95 % half-widths of `e`'s parameters, in its reported units.
fn ci95(r: &Report, e: Effect) -> Vec<f64> {
    r.effect(e).map_or_else(Vec::new, |f| f.params.iter().map(|p| p.ci95).collect())
}

fn list(v: &[f64]) -> String {
    format!("[{}]", v.iter().map(|x| format!("{x:.9}")).collect::<Vec<_>>().join(", "))
}

/// T_BS as YAML (see the module doc); `None` when the report holds no calibration to write.
pub fn t_bs_yaml(r: &Report, axes: LogAxes, source: &str) -> Option<String> {
    if !calibrated(r) {
        return None;
    }
    let f = axes.body_from_internal();
    let c = &r.corrections;
    let rot = f * c.body_offset.matrix() * f;
    let t = f * (-c.lever_arm_m.raw());
    let tau = c.mocap_delay_s + c.pose_shift_s;
    let mut y = String::new();
    let _ = writeln!(y, "# flyarena identify --calibrate: {source}");
    let _ =
        writeln!(y, "# T_BS: the mocap body S (the markers' frame) in the IMU's frame B, p_B = T_BS·p_S (ASL/Kalibr),");
    let _ = writeln!(
        y,
        "# in the log's own axes; the time offset: a pose stamped t was taken at IMU time t − time_offset_s"
    );
    let _ = writeln!(y, "sensor_type: mocap");
    let _ = writeln!(y, "T_BS:");
    let _ = writeln!(y, "  cols: 4");
    let _ = writeln!(y, "  rows: 4");
    let rows: Vec<String> = (0..4)
        .map(|i| {
            let cells: Vec<f64> =
                if i < 3 { vec![rot[(i, 0)], rot[(i, 1)], rot[(i, 2)], t[i]] } else { vec![0.0, 0.0, 0.0, 1.0] };
            cells.iter().map(|x| format!("{x:.12}")).collect::<Vec<_>>().join(", ")
        })
        .collect();
    let _ = writeln!(y, "  data: [{}]", rows.join(",\n         "));
    let _ = writeln!(y, "time_offset_s: {tau:.9}");
    let _ = writeln!(y, "timeshift_mocap_imu: {:.9}", -tau);
    let _ = writeln!(y, "ci95:");
    let rot_ci = ci95(r, Effect::BodyOffset);
    let _ = writeln!(y, "  # the rotation: a small rotation about the IMU's x, y, z (deg)");
    let _ = writeln!(y, "  rotation_deg: {}", list(&rot_ci));
    let lever_ci: Vec<f64> = ci95(r, Effect::LeverArm).iter().map(|x| x * 1e-3).collect();
    let _ = writeln!(y, "  translation_m: {}", list(&lever_ci));
    let _ = writeln!(y, "  time_offset_s: {:.9}", ci95(r, Effect::MocapDelay).first().map_or(f64::NAN, |x| x * 1e-3));
    // what else the calibration found, in the log's axes
    if let Some(b) = r.effect(Effect::AccelBias) {
        let v = f * Vector3::from_iterator(b.params.iter().map(|p| p.value));
        let _ = writeln!(y, "accel_bias_m_s2: {}", list(v.as_slice()));
    }
    if let Some(b) = r.effect(Effect::GyroBias) {
        let v = f * Vector3::from_iterator(b.params.iter().map(|p| p.value.to_radians()));
        let _ = writeln!(y, "gyro_bias_rad_s: {}", list(v.as_slice()));
    }
    if r.effect(Effect::WorldTilt).is_some() {
        // gravity's direction in the mocap world as the log writes it
        let down = axes.world.to_z_down().inverse() * (c.world_tilt.quaternion() * Vector3::z());
        let _ = writeln!(y, "# gravity's direction (unit) in the mocap's world, in the log's axes");
        let _ = writeln!(y, "gravity_direction: {}", list(down.as_slice()));
    }
    Some(y)
}

/// The IMU frame's trajectory in the TUM format (see the module doc); `None` when the report
/// holds no calibration to write.
pub fn imu_trajectory_tum(s: &Series, r: &Report, axes: LogAxes) -> Option<String> {
    if !calibrated(r) {
        return None;
    }
    let c = &r.corrections;
    // the mocap's world kept (no tilt taken out): the corrections of the IMU's frame alone
    let corr = Corrections { world_tilt: crate::frames::Rot::identity(), ..*c };
    let k = correct(s, &corr);
    let f = axes.body_from_internal();
    let w_inv = axes.world.to_z_down().inverse();
    let f_q = UnitQuaternion::from_rotation_matrix(&nalgebra::Rotation3::from_matrix_unchecked(f));
    let mut out = String::from(
        "# t x y z qx qy qz qw: the IMU's frame in the mocap's world, on the IMU's clock (flyarena identify --calibrate)\n",
    );
    for i in (0..s.len()).filter(|&i| k.ok[i]) {
        let q = w_inv * k.att_body[i].quaternion() * f_q;
        let p = w_inv * k.pos_nav[i].raw();
        let ns = s.clocks.imu_origin_ns + (s.t_s[i] * 1e9).round() as i128;
        let (sec, frac) = (ns.div_euclid(1_000_000_000), ns.rem_euclid(1_000_000_000));
        let _ = writeln!(
            out,
            "{sec}.{frac:09} {:.9} {:.9} {:.9} {:.12} {:.12} {:.12} {:.12}",
            p.x, p.y, p.z, q.i, q.j, q.k, q.w
        );
    }
    Some(out)
}

//! An independent check of the roll/pitch misalignment: the vehicle resting on the floor before
//! take-off. There the accelerometer reads f = −g·C_n^b·e_D in the IMU frame and the mocap
//! predicts f̂ = −g·R_mᵀ·e_D in the marker frame; the rotation from f̂ to f is the marker
//! offset's roll and pitch, δ = f̂ × f / |f̂|² (small angles; its yaw is unobservable at rest).
//!
//! It assumes no accelerometer bias: a bias b reads as a tilt of b/g rad (0.1 m/s² ≈ 0.58°), and
//! the check cannot tell them apart. It needs ≥ 0.5 s of rest (thrust zero, or within 1 cm of
//! the floor without a thrust column).

use super::series::Series;

#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct GroundCheck {
    pub roll_deg: f64,
    pub pitch_deg: f64,
    /// Standard error of the mean, from the sample scatter (deg).
    pub roll_se_deg: f64,
    pub pitch_se_deg: f64,
    pub samples: usize,
}

/// The ground check as the accelerometer reads it, with no bias removed.
pub fn ground_check(s: &Series) -> Option<GroundCheck> {
    tilt_at_rest(s, &nalgebra::Vector3::zeros())
}

/// The rest before take-off: rows [start, end) inside the first segment, ≥ 0.5 s.
fn rest(s: &Series) -> Option<(usize, usize)> {
    let z0 = s.pos_mocap_nav.first()?.z;
    let resting = |i: usize| match &s.thrust_n {
        Some(t) => t[i] == 0.0,
        None => (s.pos_mocap_nav[i].z - z0).abs() < 0.01,
    };
    // the rest before take-off, inside the first segment (the data-quality gate may have cut
    // its start or its end)
    let (start, seg_end) = *s.segments.first()?;
    if start > 0 && !resting(start) {
        return None;
    }
    let end = (start..seg_end).find(|&i| !resting(i) || !s.mocap_ok[i]).unwrap_or(seg_end);
    // leave the last 0.2 s before the motors start out (spin-up)
    let end = end.saturating_sub((0.2 / s.dt()) as usize).max(start);
    if ((end - start) as f64) * s.dt() < 0.5 {
        return None;
    }
    Some((start, end))
}

/// The mocap yaw at rest (rad, circular mean), where the ground check was taken: a world tilt
/// reads as a body tilt turned by it.
pub fn rest_yaw(s: &Series) -> Option<f64> {
    let (start, end) = rest(s)?;
    let (sx, sy) = (start..end).map(|i| s.att_mocap[i].euler_angles().2).fold((0.0, 0.0), |(x, y), a| (x + a.cos(), y + a.sin()));
    Some(sy.atan2(sx))
}

/// The ground check with an accelerometer bias `accel_bias_body` (IMU frame, m/s²) removed from
/// every sample first: δ = f̂ × (f − b) / |f̂|².
pub fn tilt_at_rest(s: &Series, accel_bias_body: &nalgebra::Vector3<f64>) -> Option<GroundCheck> {
    let (start, end) = rest(s)?;
    let g = s.model.gravity_m_s2;
    let mut rp: Vec<(f64, f64)> = Vec::with_capacity(end - start);
    for i in start..end {
        let f_hat = s.att_mocap[i].inverse_transform_vector(&nalgebra::Vector3::new(0.0, 0.0, -g));
        let f = s.accel_body[i] - accel_bias_body;
        let d = f_hat.cross(&f) / f_hat.norm_squared();
        rp.push((d.x, d.y));
    }
    let m = rp.len() as f64;
    let (mr, mp) = rp.iter().fold((0.0, 0.0), |a, x| (a.0 + x.0 / m, a.1 + x.1 / m));
    let (vr, vp) = rp.iter().fold((0.0, 0.0), |a, x| (a.0 + (x.0 - mr).powi(2) / (m - 1.0), a.1 + (x.1 - mp).powi(2) / (m - 1.0)));
    Some(GroundCheck {
        roll_deg: mr.to_degrees(),
        pitch_deg: mp.to_degrees(),
        roll_se_deg: (vr / m).sqrt().to_degrees(),
        pitch_se_deg: (vp / m).sqrt().to_degrees(),
        samples: rp.len(),
    })
}

/// One axis of [`GroundAgreement`] (degrees at this edge).
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct TiltAgreement {
    /// The ground check as measured.
    pub ground_deg: f64,
    /// The tilt that the fitted accelerometer bias reads as at rest (b_y/g for roll, −b_x/g for
    /// pitch; 0 when no bias was fitted).
    pub bias_tilt_deg: f64,
    /// The ground check with the fitted bias removed: the accelerometer's tilt against the markers.
    pub ground_corrected_deg: f64,
    /// The flight's frame tilt at rest: its body offset plus its world tilt as seen at the rest
    /// yaw (0 when neither was selected: the model then says "no offset").
    pub flight_deg: f64,
    /// ground_corrected − flight = ground − (offset + bias tilt).
    pub difference_deg: f64,
    /// 95 % half-width of the difference: the ground's scatter and the flight's covariance of
    /// offset + bias tilt (the combination a hover determines, far better than either part),
    /// widened where the flight cannot tell two models apart.
    pub ci95_deg: f64,
    /// |difference| ≤ ci95.
    pub covers: bool,
}

/// The ground check against the flight's model. At rest the accelerometer reads
/// f = −g·C·e_D + b, so the ground check sees the frame tilt (body offset δ, and a world tilt
/// turned by the rest yaw) *plus* the tilt b/g of a bias: the two are compared as ground − b/g
/// against the frame tilt (equivalently ground against frame tilt + b/g).
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct GroundAgreement {
    pub roll: TiltAgreement,
    pub pitch: TiltAgreement,
    /// A body offset or a world tilt was selected (or forced).
    pub frame_fitted: bool,
    pub accel_bias_fitted: bool,
}

/// Z_{0.975}
const Z: f64 = 1.959963984540054;

/// Builds the agreement from the raw ground check, the bias-corrected one, the flight's offset
/// (rad), the standard deviation of offset + bias tilt (rad) and an extra half-width (rad) from
/// models the flight cannot tell apart.
pub fn agreement(
    raw: &GroundCheck,
    corrected: &GroundCheck,
    offset_rad: [f64; 2],
    sd_rad: [f64; 2],
    widen_rad: [f64; 2],
    frame_fitted: bool,
    accel_bias_fitted: bool,
) -> GroundAgreement {
    let axis = |k: usize| {
        let (g, gc, se) = if k == 0 { (raw.roll_deg, corrected.roll_deg, raw.roll_se_deg) } else { (raw.pitch_deg, corrected.pitch_deg, raw.pitch_se_deg) };
        let flight = offset_rad[k].to_degrees();
        let difference = gc - flight;
        let ci95 = (Z * se).hypot(Z * sd_rad[k].to_degrees()) + widen_rad[k].to_degrees();
        TiltAgreement {
            ground_deg: g,
            bias_tilt_deg: g - gc,
            ground_corrected_deg: gc,
            flight_deg: flight,
            difference_deg: difference,
            ci95_deg: ci95,
            covers: difference.abs() <= ci95,
        }
    };
    GroundAgreement { roll: axis(0), pitch: axis(1), frame_fitted, accel_bias_fitted }
}

/// The report's notes on a ground agreement: a difference beyond 1° that the flight's interval
/// covers (the flight cannot pin its tilt down), or a disagreement.
pub fn agreement_notes(a: &GroundAgreement) -> Vec<String> {
    let mut notes = Vec::new();
    for (name, t) in [("roll", &a.roll), ("pitch", &a.pitch)] {
        if t.difference_deg.abs() > 1.0 && t.covers {
            notes.push(format!(
                "ground check and flight differ by {:.2}° in {name}, within what this flight determines (±{:.2}°): the flight cannot pin its tilt down to 1°",
                t.difference_deg, t.ci95_deg
            ));
        } else if !t.covers {
            notes.push(format!(
                "ground check and flight disagree in {name}: the ground reads {:.2}°{}, the flight {:.2}° (difference {:.2} ± {:.2}°): the markers or the IMU board moved between rest and flight, or the flight holds an effect the candidate library lacks",
                t.ground_deg,
                if t.bias_tilt_deg != 0.0 { format!(" ({:.2}° once the fitted accelerometer bias is removed)", t.ground_corrected_deg) } else { String::new() },
                t.flight_deg,
                t.difference_deg,
                t.ci95_deg
            ));
        }
    }
    notes
}

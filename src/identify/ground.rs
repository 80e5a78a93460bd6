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

pub fn ground_check(s: &Series) -> Option<GroundCheck> {
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
    let g = s.model.gravity_m_s2;
    let mut rp: Vec<(f64, f64)> = Vec::with_capacity(end - start);
    for i in start..end {
        let f_hat = s.att_mocap[i].inverse_transform_vector(&nalgebra::Vector3::new(0.0, 0.0, -g));
        let f = s.accel_body[i];
        let d = f_hat.cross(&f) / f_hat.norm_squared();
        rp.push((d.x, d.y));
    }
    let m = rp.len() as f64;
    let (mr, mp) = rp.iter().fold((0.0, 0.0), |a, x| (a.0 + x.0 / m, a.1 + x.1 / m));
    let (vr, vp) = rp.iter().fold((0.0, 0.0), |a, x| (a.0 + (x.0 - mr).powi(2) / (m - 1.0), a.1 + (x.1 - mp).powi(2) / (m - 1.0)));
    Some(GroundCheck { roll_deg: mr.to_degrees(), pitch_deg: mp.to_degrees(), roll_se_deg: (vr / m).sqrt().to_degrees(), pitch_se_deg: (vp / m).sqrt().to_degrees(), samples: rp.len() })
}

//! The global start as the report prints it, and the verdict on a fit that is not physically
//! possible: what makes it so, what the fit gave (claimed as nothing) and what to try.

use crate::identify::fit::select::Report;
use crate::identify::fit::select::plausible::Implausible;
use crate::identify::fit::start::{CLOCK_REACH_S, ROTATION_REACH_DEG, Start};
use std::fmt::{self, Write as _};

impl fmt::Display for Implausible {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Implausible::AccelBias { norm_m_s2, bound_m_s2 } => write!(
                f,
                "an accelerometer bias of {norm_m_s2:.2} m/s² ({:.2} g): no accelerometer has more than {bound_m_s2} m/s²",
                norm_m_s2 / crate::vehicle::params::GRAVITY
            ),
            Implausible::GyroBias { norm_deg_s, bound_deg_s } => {
                write!(f, "a gyro bias of {norm_deg_s:.1} °/s: no gyro has more than {bound_deg_s} °/s")
            }
            Implausible::LeverArm { norm_m, bound_m } => write!(
                f,
                "a lever arm of {norm_m:.2} m between the tracked point and the IMU: a rigid body holds them within {bound_m} m"
            ),
            Implausible::GyroUnexplained { fraction, motion_rad_s, floor_rad_s, bound } => write!(
                f,
                "{:.0} % of the gyro's motion ({motion_rad_s:.3} rad/s rms) is left unexplained, where the best rotation of the mocap's rates leaves {floor_rad_s:.4} rad/s: a gyro and a mocap whose frames and clocks agree leave at most {:.0} %",
                100.0 * fraction,
                100.0 * bound
            ),
        }
    }
}

/// "(x, y, z)" to `d` decimals.
fn triple(v: [f64; 3], d: usize) -> String {
    format!("({:.d$}, {:.d$}, {:.d$})", v[0], v[1], v[2])
}

/// The start's block of the report: the clock, the frames, what was applied and how far the fine
/// fit moved from it.
pub(crate) fn render_start(s: &mut String, r: &Report) {
    let st = &r.start;
    let _ = writeln!(s, "\n  global start (closed form, before the fine fit):");
    match &st.clock {
        Some(c) => {
            let runner = c
                .runner_up
                .map_or(String::new(), |p| format!("; next best {:.2} at {:.0} ms", p.correlation, p.offset_s * 1e3));
            let _ = writeln!(
                s,
                "    clock     the mocap's stamps {:.1} ms after the IMU's (‖ω‖ correlation {:.4}{runner}; searched {:.1} … {:.1} s{}){}",
                c.best.offset_s * 1e3,
                c.best.correlation,
                c.searched_s[0],
                c.searched_s[1],
                if c.widened { ", every offset where the streams overlap: the window held none" } else { "" },
                if c.determined() { "" } else { "; not determined" }
            );
        }
        None => {
            let _ = writeln!(
                s,
                "    clock     no angular speed to correlate (a stream without one, or sampled less than once a second)"
            );
        }
    }
    if let Some(f) = &st.frames {
        let q = f.body_offset.quaternion();
        let axis = q.axis().map_or([0.0; 3], |a| [a.x, a.y, a.z]);
        let _ = writeln!(
            s,
            "    rotation  mocap body → IMU {:.2}° about {} (Wahba on the rates; spread {} deg about x, y, z; gyro residual {:.3} of {:.3} rad/s)",
            q.angle().to_degrees(),
            triple(axis, 3),
            triple(f.body_offset_sd_rad.map(f64::to_degrees), 3),
            f.gyro_residual_rad_s,
            f.gyro_rms_rad_s
        );
        let _ = writeln!(
            s,
            "    gravity   {:.2} m/s², the mocap world tilted {:.2}° from its declared up; lever arm {} mm; biases {} m/s², {} deg/s",
            f.gravity_m_s2,
            f.world_tilt.angle().to_degrees(),
            triple((f.lever_arm_m * 1e3).to_array(), 1),
            triple(f.accel_bias_m_s2.to_array(), 3),
            triple(f.gyro_bias_rad_s.to_array().map(f64::to_degrees), 2)
        );
    } else {
        let _ = writeln!(s, "    frames    too few usable samples for a start");
    }
    let _ = writeln!(s, "    {}", applied(st, r));
}

/// What of the start the fine fit started from, and how far it moved.
fn applied(st: &Start, r: &Report) -> String {
    let a = st.applied;
    let mut parts = Vec::new();
    if a.clock {
        parts.push("the clock");
    }
    if a.rotation {
        parts.push("the rotation");
    }
    if a.tilt {
        parts.push("the world's tilt");
    }
    let head = if parts.is_empty() {
        format!(
            "applied: nothing, the fine fit starts at the identity (the start lies within its reach of {:.0} ms and {:.0}°)",
            CLOCK_REACH_S * 1e3,
            ROTATION_REACH_DEG
        )
    } else {
        format!(
            "applied: {} (beyond the fine fit's reach of {:.0} ms and {:.0}°), fitted untested from there",
            parts.join(", "),
            CLOCK_REACH_S * 1e3,
            ROTATION_REACH_DEG
        )
    };
    let m = &r.moved;
    let moved: Vec<String> = [
        m.clock_ms.map(|x| format!("clock {x:+.2} ms")),
        m.rotation_deg.map(|x| format!("rotation {x:.3}°")),
        m.tilt_deg.map(|x| format!("tilt {x:.3}°")),
        m.lever_arm_mm.map(|x| format!("lever arm {x:.1} mm")),
    ]
    .into_iter()
    .flatten()
    .collect();
    if moved.is_empty() { head } else { format!("{head}; the fit lies {} from the start", moved.join(", ")) }
}

/// The verdict on a fit that is not physically possible: why, what the fit gave, what to try.
pub(crate) fn render_misaligned(s: &mut String, r: &Report) {
    if r.misaligned.is_empty() {
        return;
    }
    let _ = writeln!(
        s,
        "\n  NOT ALIGNED: the frames or the clocks of this log are not what the fit can explain, so no effect is claimed:"
    );
    for m in &r.misaligned {
        let _ = writeln!(s, "    - {m}");
    }
    if !r.unclaimed.is_empty() {
        let _ = writeln!(s, "  what the fit gave (claimed as nothing):");
        for f in &r.unclaimed {
            let ps: Vec<String> =
                f.params.iter().map(|p| crate::identify::precision::param_text(p, |x| format!("{x:.3}"))).collect();
            let _ = writeln!(s, "    {:<34} {}", f.name, ps.join(", "));
        }
    }
    let _ = writeln!(s, "  what to try:");
    for t in to_try(r) {
        let _ = writeln!(s, "    - {t}");
    }
}

/// What to try, from what the start saw.
fn to_try(r: &Report) -> Vec<String> {
    let st = &r.start;
    let mut out = Vec::new();
    match &st.clock {
        Some(c) if !c.determined() => out.push(format!(
            "the clocks: no clear offset between the streams within {:.1} … {:.1} s (correlation {:.2}{}); give a known coarse offset (`--clock-offset SECONDS`) or a wider window (`--clock-offset=-30..30`)",
            c.searched_s[0],
            c.searched_s[1],
            c.best.correlation,
            c.runner_up.map_or(String::new(), |p| format!(", another peak of {:.2} at {:.2} s", p.correlation, p.offset_s)),
        )),
        None => out.push("the clocks: the log has no angular speed on one of its streams to align them by (or one sampled less than once a second)".into()),
        _ => {}
    }
    if let Some(f) = &st.frames {
        if !f.rotation_determined() {
            out.push(format!(
                "the motion: the rates fix the rotation only to {} deg about x, y, z, and leave {:.0} % of the gyro's rms unexplained; turn the rig about two axes at least",
                triple(f.body_offset_sd_rad.map(f64::to_degrees), 1),
                100.0 * f.gyro_residual_rad_s / f.gyro_rms_rad_s.max(1e-12)
            ));
        }
        let g = r.model.gravity_m_s2;
        if (f.gravity_m_s2 - g).abs() > crate::identify::fit::start::GRAVITY_TOLERANCE * g {
            out.push(format!(
                "the units: gravity comes out as {:.2} m/s² from the accelerometer against the mocap; check the mapping's accelerometer unit (g or m/s2) and position unit (m or mm)",
                f.gravity_m_s2
            ));
        }
    }
    out.push(
        "the frames: check the mapping's `world` (which axis is up), `body` and the quaternion `order`; the global start above says where the rates put the IMU"
            .into(),
    );
    out
}

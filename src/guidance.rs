//! Guidance: the flight plan as a timeline of phases, and the reference it produces.
//!
//! Each phase has a fixed duration known when it starts, so the whole plan is a pure function of
//! time (no feedback from the vehicle), and the engine can tell which phase it is in from the tick.
//! Motion profiles are trapezoidal in velocity (position, velocity and acceleration feed-forward
//! continuous in position and velocity); yaw moves at constant rate with its rate as feed-forward.
//! Positions are relative to the vehicle's home on the floor (NED, so altitude h is D = −h).

use crate::clock::Nanos;
use crate::control::{LateralMode, Reference};
use crate::frames::{MocapNav, Vec3};

/// One piece of a flight plan (the scenario's `plan:` entries). Times in s, distances in m,
/// angles in rad, positions relative to home in the mocap's NED frame.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
#[allow(missing_docs)] // the fields are named by what and in which unit; the variants say how
pub enum Phase {
    /// Motors off on the floor (a log's rest before take-off: the accelerometer reads gravity).
    Idle { duration_s: f64 },
    /// Climb from the floor to `altitude_m`.
    Takeoff { altitude_m: f64, duration_s: f64 },
    /// Hold the current point.
    Hover { duration_s: f64 },
    /// Hover `settle_s`, then average the measured roll and pitch for `average_s` (Sec. IV.A).
    CalibrateRollPitch { settle_s: f64, average_s: f64 },
    /// Turn to ψ_com = 0 and hover `settle_s`, then fly `distance_m` North with φ_com = 0 (6),
    /// trapezoidal speed `speed_m_s`, acceleration `accel_m_s2`; fit the track (8)–(9).
    CalibrateYaw { settle_s: f64, distance_m: f64, speed_m_s: f64, accel_m_s2: f64 },
    /// Hover `settle_s`, then turn on the spot by `angle_rad` in `duration_s`.
    YawSpin { settle_s: f64, angle_rad: f64, duration_s: f64 },
    /// Hover `settle_s`, then fly `turns` horizontal circles of radius `radius_m` and period
    /// `period_s` about the current point (spiralling out during the first turn and back in
    /// during the last), at constant heading. The centripetal acceleration R·(2π/P)² tilts the
    /// vehicle by atan(R·(2π/P)²/g), and the tilt turns with the circle, so the body rotates
    /// about x and y at ≈ tilt·2π/P: the excitation the gyro alignment needs ([`crate::calibrate::gyro`]).
    CalibrateGyro { settle_s: f64, radius_m: f64, period_s: f64, turns: f64 },
    /// Fly in a straight line to `pos_m` (relative to home) and hold `hold_s`.
    Waypoint { pos_m: [f64; 3], speed_m_s: f64, accel_m_s2: f64, hold_s: f64 },
    /// Descend to the floor in `duration_s`, then motors off.
    Land { duration_s: f64 },
}

/// Distance, speed and acceleration of a trapezoidal (or triangular) profile at time t.
pub fn trapezoid(dist: f64, vmax: f64, amax: f64, t: f64) -> (f64, f64, f64) {
    if dist <= 0.0 {
        return (0.0, 0.0, 0.0);
    }
    let t_acc = (vmax / amax).min((dist / amax).sqrt());
    let v_peak = amax * t_acc;
    let d_acc = 0.5 * amax * t_acc * t_acc;
    let t_cruise = (dist - 2.0 * d_acc) / v_peak;
    let total = 2.0 * t_acc + t_cruise;
    if t <= 0.0 {
        (0.0, 0.0, 0.0)
    } else if t < t_acc {
        (0.5 * amax * t * t, amax * t, amax)
    } else if t < t_acc + t_cruise {
        (d_acc + v_peak * (t - t_acc), v_peak, 0.0)
    } else if t < total {
        let r = total - t;
        (dist - 0.5 * amax * r * r, amax * r, -amax)
    } else {
        (dist, 0.0, 0.0)
    }
}

/// Duration of [`trapezoid`] (s).
fn trapezoid_duration(dist: f64, vmax: f64, amax: f64) -> f64 {
    if dist <= 0.0 {
        return 0.0;
    }
    let t_acc = (vmax / amax).min((dist / amax).sqrt());
    let v_peak = amax * t_acc;
    2.0 * t_acc + (dist - amax * t_acc * t_acc) / v_peak
}

const TAKEOFF_ACCEL: f64 = 0.5;
const LAND_OVERSHOOT_M: f64 = 0.1;

impl Phase {
    /// Its key in YAML and in the recording's timeline.
    pub fn name(&self) -> &'static str {
        match self {
            Phase::Idle { .. } => "idle",
            Phase::Takeoff { .. } => "takeoff",
            Phase::Hover { .. } => "hover",
            Phase::CalibrateRollPitch { .. } => "calibrate_roll_pitch",
            Phase::CalibrateYaw { .. } => "calibrate_yaw",
            Phase::YawSpin { .. } => "yaw_spin",
            Phase::CalibrateGyro { .. } => "calibrate_gyro",
            Phase::Waypoint { .. } => "waypoint",
            Phase::Land { .. } => "land",
        }
    }
}

/// A phase placed on the timeline, with the reference point and heading it starts from.
#[derive(Clone, Debug)]
pub struct Scheduled {
    /// The phase.
    pub phase: Phase,
    /// When it begins.
    pub start: Nanos,
    /// When it ends (the next one begins).
    pub end: Nanos,
    /// Where the reference starts (m, mocap NED).
    pub from: Vec3<MocapNav>,
    /// The heading it starts from (rad).
    pub from_yaw: f64,
    /// Where the reference ends (position and heading).
    pub to: Vec3<MocapNav>,
    /// The heading it ends at (rad).
    pub to_yaw: f64,
}

/// What part of a phase the vehicle is in: used by the station to run the calibrations.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Window {
    /// No calibration runs.
    None,
    /// Average roll and pitch (calibrate_roll_pitch after settling).
    HoverAverage,
    /// The straight flight of (6) (calibrate_yaw after settling).
    YawFlight,
    /// Turning on the spot (yaw_spin after settling).
    Spin,
    /// Circling on the spot for the gyro alignment (calibrate_gyro after settling).
    GyroExcite,
}

/// The whole plan laid out in time: a pure function of time to a reference.
#[derive(Clone, Debug)]
pub struct Plan {
    /// The phases in order, back to back.
    pub phases: Vec<Scheduled>,
    home: Vec3<MocapNav>,
}

impl Plan {
    /// Lays the phases out in time, starting on the floor at `home` with heading `yaw0`.
    pub fn schedule(phases: &[Phase], home: Vec3<MocapNav>, yaw0: f64) -> Plan {
        let mut out = Vec::with_capacity(phases.len());
        let (mut t, mut pos, mut yaw) = (0.0f64, home, yaw0);
        for ph in phases {
            let (to, to_yaw, dur) = match *ph {
                Phase::Takeoff { altitude_m, duration_s } => {
                    (Vec3::new(pos.x(), pos.y(), home.z() - altitude_m), yaw, duration_s)
                }
                Phase::CalibrateYaw { settle_s, distance_m, speed_m_s, accel_m_s2 } => (
                    pos + Vec3::new(distance_m, 0.0, 0.0),
                    0.0,
                    settle_s + trapezoid_duration(distance_m, speed_m_s, accel_m_s2),
                ),
                Phase::YawSpin { settle_s, angle_rad, duration_s } => (pos, yaw + angle_rad, settle_s + duration_s),
                Phase::Waypoint { pos_m, speed_m_s, accel_m_s2, hold_s } => {
                    let to = home + Vec3::from_array(pos_m);
                    (to, yaw, trapezoid_duration((to - pos).norm(), speed_m_s, accel_m_s2) + hold_s)
                }
                Phase::Land { duration_s } => (Vec3::new(pos.x(), pos.y(), home.z()), yaw, duration_s),
                Phase::Hover { duration_s } | Phase::Idle { duration_s } => (pos, yaw, duration_s),
                Phase::CalibrateRollPitch { settle_s, average_s } => (pos, yaw, settle_s + average_s),
                Phase::CalibrateGyro { settle_s, period_s, turns, .. } => (pos, yaw, settle_s + period_s * turns),
            };
            let start = Nanos::from_secs_f64(t);
            t += dur;
            out.push(Scheduled {
                phase: ph.clone(),
                start,
                end: Nanos::from_secs_f64(t),
                from: pos,
                from_yaw: yaw,
                to,
                to_yaw,
            });
            pos = to;
            yaw = to_yaw;
        }
        Plan { phases: out, home }
    }

    /// When the last phase ends.
    pub fn end(&self) -> Nanos {
        self.phases.last().map_or(Nanos::ZERO, |p| p.end)
    }

    /// Index of the phase active at `t` (`None` before the first or after the last).
    pub(crate) fn phase_at(&self, t: Nanos) -> Option<usize> {
        self.phases.iter().position(|p| t >= p.start && t < p.end)
    }

    /// A time until which [`Self::reference`]'s window, and in a spin its position, stay what
    /// they are at `t` (for a caller that needs only those every tick, not the whole reference).
    /// Within a phase they change only where the settling ends, (t − start) ≥ `settle_s` in
    /// seconds; the bound stops 1 µs short of that instant, so that no rounding can put it late.
    pub fn window_until(&self, t: Nanos) -> Nanos {
        let Some(i) = self.phase_at(t) else {
            return match self.phases.first() {
                Some(first) if t < first.start => first.start,
                _ => Nanos(i64::MAX),
            };
        };
        let s = &self.phases[i];
        let settle_s = match s.phase {
            Phase::CalibrateRollPitch { settle_s, .. }
            | Phase::CalibrateYaw { settle_s, .. }
            | Phase::YawSpin { settle_s, .. }
            | Phase::CalibrateGyro { settle_s, .. } => settle_s,
            _ => return s.end,
        };
        if (t - s.start).as_secs_f64() < settle_s {
            (s.start + Nanos::from_secs_f64(settle_s) - Nanos::from_micros(1)).min(s.end)
        } else {
            s.end
        }
    }

    /// The reference at time `t`, and the calibration window it is in.
    pub fn reference(&self, t: Nanos) -> (Reference, Window) {
        let hold = |p: Vec3<MocapNav>, yaw: f64, motors_off: bool| Reference {
            pos: p,
            vel: Vec3::zeros(),
            acc: Vec3::zeros(),
            yaw,
            yaw_rate: 0.0,
            lateral: LateralMode::Closed,
            motors_off,
        };
        let Some(i) = self.phase_at(t) else {
            return match self.phases.last() {
                Some(last) if t >= last.end => {
                    // on the floor after a landing, or after an idle (a rest after the landing):
                    // the motors stay off; after any other phase the vehicle holds in the air
                    let on_floor = matches!(last.phase, Phase::Land { .. } | Phase::Idle { .. });
                    (hold(last.to, last.to_yaw, on_floor), Window::None)
                }
                _ => (hold(self.home, self.phases.first().map_or(0.0, |p| p.from_yaw), true), Window::None),
            };
        };
        let s = &self.phases[i];
        let tau = (t - s.start).as_secs_f64();
        let along = |d: f64, v: f64, a: f64, dir: Vec3<MocapNav>| (s.from + dir * d, dir * v, dir * a);
        match s.phase {
            Phase::Takeoff { duration_s, .. } | Phase::Land { duration_s } if duration_s > 0.0 => {
                // vertical move from `from` to `to`; landing aims LAND_OVERSHOOT_M below the floor
                // so that the vehicle settles on it rather than hovering just above
                let landing = matches!(s.phase, Phase::Land { .. });
                let dist = (s.to.z() - s.from.z()).abs() + if landing { LAND_OVERSHOOT_M } else { 0.0 };
                let dir = Vec3::new(0.0, 0.0, if landing { 1.0 } else { -1.0 });
                // the speed that completes the profile in duration_s with TAKEOFF_ACCEL ramps
                let vmax = speed_for_duration(dist, TAKEOFF_ACCEL, duration_s);
                let (d, v, a) = trapezoid(dist, vmax, TAKEOFF_ACCEL, tau);
                let (p, v, a) = along(d, v, a, dir);
                (Reference { pos: p, vel: v, acc: a, ..hold(p, s.from_yaw, false) }, Window::None)
            }
            Phase::CalibrateRollPitch { settle_s, .. } => {
                (hold(s.from, s.from_yaw, false), if tau >= settle_s { Window::HoverAverage } else { Window::None })
            }
            Phase::CalibrateYaw { settle_s, distance_m, speed_m_s, accel_m_s2 } => {
                if tau < settle_s {
                    (hold(s.from, 0.0, false), Window::None)
                } else {
                    let (d, v, a) = trapezoid(distance_m, speed_m_s, accel_m_s2, tau - settle_s);
                    let (p, v, a) = along(d, v, a, Vec3::new(1.0, 0.0, 0.0));
                    (
                        Reference { pos: p, vel: v, acc: a, lateral: LateralMode::RollZero, ..hold(p, 0.0, false) },
                        Window::YawFlight,
                    )
                }
            }
            Phase::YawSpin { settle_s, angle_rad, duration_s } => {
                if tau < settle_s {
                    (hold(s.from, s.from_yaw, false), Window::None)
                } else {
                    let rate = angle_rad / duration_s;
                    let yaw = s.from_yaw + rate * (tau - settle_s);
                    (Reference { yaw_rate: rate, ..hold(s.from, yaw, false) }, Window::Spin)
                }
            }
            Phase::CalibrateGyro { settle_s, radius_m, period_s, turns } => {
                if tau < settle_s {
                    return (hold(s.from, s.from_yaw, false), Window::None);
                }
                let (p, v, a) = circle(radius_m, period_s, turns, tau - settle_s);
                let r = Reference { pos: s.from + p, vel: v, acc: a, ..hold(s.from, s.from_yaw, false) };
                (r, Window::GyroExcite)
            }
            Phase::Waypoint { speed_m_s, accel_m_s2, .. } => {
                let delta = s.to - s.from;
                let dist = delta.norm();
                if dist == 0.0 {
                    return (hold(s.to, s.from_yaw, false), Window::None);
                }
                let (d, v, a) = trapezoid(dist, speed_m_s, accel_m_s2, tau);
                let (p, v, a) = along(d, v, a, delta * (1.0 / dist));
                (Reference { pos: p, vel: v, acc: a, ..hold(p, s.from_yaw, false) }, Window::None)
            }
            Phase::Idle { .. } => (hold(s.from, s.from_yaw, true), Window::None),
            Phase::Hover { .. } | Phase::Takeoff { .. } | Phase::Land { .. } => {
                (hold(s.to, s.to_yaw, false), Window::None)
            }
        }
    }
}

/// Offset, velocity and acceleration of the calibrate_gyro circle at time τ into it:
/// p = R·e(τ)·u(τ) with u = (cos ωτ, sin ωτ, 0), ω = 2π/P, and the envelope e = s(τ/P)·s((T−τ)/P),
/// s(x) = 6x⁵ − 15x⁴ + 10x³ on [0, 1] (smootherstep: s', s'' vanish at 0 and 1), T = turns·P, so
/// position, velocity and acceleration are continuous everywhere. v = R(e'u + eωu⊥), a = R(e''u + 2e'ωu⊥ − eω²u), u⊥ = (−sin ωτ, cos ωτ, 0).
fn circle(radius: f64, period: f64, turns: f64, tau: f64) -> (Vec3<MocapNav>, Vec3<MocapNav>, Vec3<MocapNav>) {
    let total = period * turns;
    let smooth = |x: f64| {
        let x = x.clamp(0.0, 1.0);
        let inside = x > 0.0 && x < 1.0;
        let (x2, x3) = (x * x, x * x * x);
        let d1 = if inside { 30.0 * x2 * x2 - 60.0 * x3 + 30.0 * x2 } else { 0.0 };
        let d2 = if inside { 120.0 * x3 - 180.0 * x2 + 60.0 * x } else { 0.0 };
        (6.0 * x3 * x2 - 15.0 * x2 * x2 + 10.0 * x3, d1, d2)
    };
    let (f, f1, f2) = smooth(tau / period);
    let (g, g1, g2) = smooth((total - tau) / period);
    let (f1, f2) = (f1 / period, f2 / (period * period));
    let (g1, g2) = (-g1 / period, g2 / (period * period));
    let (e, e1, e2) = (f * g, f1 * g + f * g1, f2 * g + 2.0 * f1 * g1 + f * g2);
    let w = 2.0 * std::f64::consts::PI / period;
    let (sn, cs) = (w * tau).sin_cos();
    let u = Vec3::new(cs, sn, 0.0);
    let up = Vec3::new(-sn, cs, 0.0);
    let p = u * (radius * e);
    let v = (u * e1 + up * (e * w)) * radius;
    let a = (u * (e2 - e * w * w) + up * (2.0 * e1 * w)) * radius;
    (p, v, a)
}

/// Cruise speed that makes a trapezoid of acceleration `a` cover `dist` in `duration` (s).
/// T = d/v + v/a  ⇒  v = (a·T − √(a²T² − 4ad))/2; if the duration is too short for that
/// acceleration, the triangular profile's peak speed √(a·d) is used and the phase ends early.
fn speed_for_duration(dist: f64, a: f64, duration: f64) -> f64 {
    let disc = a * a * duration * duration - 4.0 * a * dist;
    if disc <= 0.0 { (a * dist).sqrt() } else { (a * duration - disc.sqrt()) / 2.0 }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn trapezoid_covers_the_distance_in_its_duration() {
        for &(d, v, a) in &[(6.0, 0.75, 0.5), (0.2, 1.0, 0.5), (10.0, 2.0, 1.0)] {
            let t_end = trapezoid_duration(d, v, a);
            let (s, vv, _) = trapezoid(d, v, a, t_end);
            assert!((s - d).abs() < 1e-12 && vv == 0.0);
            // integrating the velocity gives the distance
            let n = 100_000;
            let dt = t_end / n as f64;
            let integral: f64 = (0..n).map(|k| trapezoid(d, v, a, (k as f64 + 0.5) * dt).1 * dt).sum();
            assert!((integral - d).abs() < 1e-6, "{integral} vs {d}");
        }
    }

    /// The circle's velocity and acceleration are the derivatives of its position (central
    /// differences), and it starts and ends at the centre at rest.
    #[test]
    fn gyro_circle_feed_forward_is_consistent() {
        let (r, p, turns) = (0.25, 2.0, 3.0);
        let h = 1e-5;
        for k in 1..600 {
            let t = k as f64 * 0.01;
            let (x0, v0, a0) = circle(r, p, turns, t);
            let (xm, vm, _) = circle(r, p, turns, t - h);
            let (xp, vp, _) = circle(r, p, turns, t + h);
            assert!(((xp - xm) * (0.5 / h) - v0).norm() < 1e-6, "v at {t}");
            assert!(((vp - vm) * (0.5 / h) - a0).norm() < 1e-4, "a at {t}");
            assert!(x0.norm() <= r + 1e-12);
        }
        for t in [0.0, p * turns] {
            let (x, v, a) = circle(r, p, turns, t);
            assert!(x.norm() < 1e-12 && v.norm() < 1e-12 && a.norm() < 1e-9, "{t}");
        }
        // full radius in the middle turn
        assert!((circle(r, p, turns, 3.0).0.norm() - r).abs() < 1e-12);
    }

    /// Over a plan with every phase, ms by ms: from t to window_until(t) the window (and in a
    /// spin the position) is the one at t.
    #[test]
    fn window_until_never_passes_a_window_change() {
        let plan = Plan::schedule(
            &[
                Phase::Idle { duration_s: 0.5 },
                Phase::Takeoff { altitude_m: 1.0, duration_s: 2.0 },
                Phase::CalibrateRollPitch { settle_s: 1.0005, average_s: 1.0 },
                Phase::CalibrateYaw { settle_s: 0.7, distance_m: 1.0, speed_m_s: 1.0, accel_m_s2: 1.0 },
                Phase::YawSpin { settle_s: 0.3333, angle_rad: 3.0, duration_s: 1.0 },
                Phase::CalibrateGyro { settle_s: 0.25, radius_m: 0.2, period_s: 1.0, turns: 1.0 },
                Phase::Waypoint { pos_m: [1.0, 1.0, -1.0], speed_m_s: 1.0, accel_m_s2: 1.0, hold_s: 0.2 },
                Phase::Hover { duration_s: 0.1 },
                Phase::Land { duration_s: 1.0 },
            ],
            Vec3::zeros(),
            0.0,
        );
        let end = plan.phases.last().unwrap().end + Nanos::from_millis(500);
        let (mut t, mut switches) = (Nanos::ZERO, 0);
        while t < end {
            let (r0, w0) = plan.reference(t);
            let until = plan.window_until(t);
            assert!(until > t || plan.reference(t + Nanos::from_millis(1)).1 != w0, "no progress at {t}");
            let mut u = t + Nanos::from_millis(1);
            while u < until.min(end) {
                let (r, w) = plan.reference(u);
                assert_eq!(w, w0, "window changed at {u} before {until} (from {t})");
                if w == Window::Spin {
                    assert_eq!(r.pos, r0.pos);
                }
                u += Nanos::from_millis(1);
            }
            if plan.reference(u).1 != w0 {
                switches += 1;
            }
            t = u.max(t + Nanos::from_millis(1));
        }
        // None → HoverAverage → None → YawFlight → None → Spin → None → GyroExcite → None
        assert!(switches >= 8, "{switches} window switches seen");
    }

    #[test]
    fn takeoff_reaches_altitude_in_its_duration() {
        let plan = Plan::schedule(
            &[Phase::Takeoff { altitude_m: 1.0, duration_s: 4.0 }, Phase::Hover { duration_s: 1.0 }],
            Vec3::zeros(),
            0.0,
        );
        let (r, _) = plan.reference(Nanos::from_secs_f64(3.999_999));
        assert!((r.pos.z() + 1.0).abs() < 1e-6, "{:?}", r.pos);
        let (r, _) = plan.reference(Nanos::from_secs_f64(4.5));
        assert_eq!(r.pos, Vec3::new(0.0, 0.0, -1.0));
    }

    /// After the plan the motors stay off when it ends on the floor (a landing, or an idle after
    /// it: before this, an idle after the landing turned them back on when the plan ended, and
    /// the vehicle lifted off at the end of the log), and stay on when it ends in the air.
    #[test]
    fn the_motors_stay_off_after_a_plan_that_ends_on_the_floor() {
        let after = |phases: &[Phase]| {
            let plan = Plan::schedule(phases, Vec3::zeros(), 0.0);
            plan.reference(plan.phases.last().unwrap().end + Nanos::from_millis(10)).0.motors_off
        };
        let up = Phase::Takeoff { altitude_m: 1.0, duration_s: 2.0 };
        assert!(after(&[up.clone(), Phase::Land { duration_s: 1.0 }]));
        assert!(after(&[up.clone(), Phase::Land { duration_s: 1.0 }, Phase::Idle { duration_s: 1.0 }]));
        assert!(!after(&[up, Phase::Hover { duration_s: 1.0 }]));
    }
}

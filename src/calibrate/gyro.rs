//! The mocap-to-body rotation from body-rate telemetry: gyro vs mocap attitude increments
//! (Wahba's problem). Not in the paper; flyarena adds it because the paper's yaw method cannot
//! see a marker rotation about the thrust axis (README, "Findings").
//!
//! Frames: the true attitude is R_b(t) = `Rot<Body, Nav>`, the mocap's R_m(t) = R_b(t)·C with
//! C = R_off = `Rot<MocapBody, Body>`. Over a window [t_a, t_b]:
//!
//! * mocap increment  ΔR_m = R_m(t_a)ᵀ·R_m(t_b)  (`Rot<MocapBody, MocapBody>`)
//! * gyro increment   ΔR_b = Π_k exp(ω̄_k·Δt_k)   (telemetry frames in time order, body frame)
//! * and exactly      ΔR_m = Cᵀ·ΔR_b·C, so the rotation vectors obey θ_b = C·θ_m.
//!
//! With a constant gyro bias b_g, θ_b = C·θ_m + b_g·W for windows of fixed length W. Minimising
//! Σ‖θ_b,i − C·θ_m,i − β‖² over C ∈ SO(3) and β is the rigid fit of [`crate::mocap::fit`]: centre
//! both sets, H = Σ θ̃_m·θ̃_bᵀ, C = Kabsch(H), β = θ̄_b − C·θ̄_m (so b̂_g = β/W). The sums are kept
//! as running moments (constant memory, no allocation per sample).
//!
//! Observability: the rotation is determined only if θ_m varies about two axes at least — a yaw
//! spin alone reveals roll and pitch of C, not yaw; a circle on the spot (roll and pitch rates)
//! plus the spin reveals all three. The 1σ uncertainty of a small rotation error δ of C (body
//! axes) is σ²·(tr(S)·I − S)⁻¹ with S = C·(Σ θ̃_m·θ̃_mᵀ)·Cᵀ and σ² the residual variance per
//! component (Fisher information of the linearised fit; windows treated as independent).

use crate::clock::Nanos;
use crate::frames::{Body, Euler, MocapBody, MocapNav, Rot, Vec3};
use crate::mocap::fit::kabsch;
use crate::vehicle::TelemetryFrame;
use nalgebra::{Matrix3, Vector3};

/// The estimate of C = R_off from gyro telemetry.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct GyroFit {
    #[serde(skip)]
    pub rotation: Rot<MocapBody, Body>,
    /// ZYX angles of C (rad), comparable with the hover and straight-flight estimates.
    pub euler: Euler,
    /// 1σ of a small rotation error about the body x, y, z axes (rad); z ≈ the yaw uncertainty.
    pub sigma: [f64; 3],
    /// Estimated gyro bias (rad/s, body frame).
    pub gyro_bias: [f64; 3],
    /// RMS residual per component (rad per window).
    pub rms_residual: f64,
    pub windows: u64,
}

const MOCAP_RING: usize = 64;
const PENDING: usize = 8;

#[derive(Clone, Copy, Debug)]
struct GyroWindow {
    t_a: Nanos,
    t_b: Nanos,
    delta: Rot<Body, Body>,
}

/// Pairs mocap attitudes with telemetry and accumulates the moments of the fit.
#[derive(Clone, Debug)]
pub struct GyroAlignment {
    window: Nanos,
    mocap_period: Nanos,
    mocap: [Option<(Nanos, Rot<MocapBody, MocapNav>)>; MOCAP_RING],
    newest_mocap: Nanos,
    open: Option<GyroWindow>,
    pending: [Option<GyroWindow>; PENDING],
    n: u64,
    dropped: u64,
    sum_m: Vector3<f64>,
    sum_b: Vector3<f64>,
    sum_mb: Matrix3<f64>,
    sum_mm: Matrix3<f64>,
    sum_bb: f64,
}

fn gcd(a: i64, b: i64) -> i64 {
    if b == 0 { a } else { gcd(b, a % b) }
}

impl GyroAlignment {
    /// Windows are the shortest multiple of both periods that is at least `min_window`.
    pub fn new(mocap_period: Nanos, telemetry_period: Nanos, min_window: Nanos) -> Self {
        let (m, t) = (mocap_period.0.max(1), telemetry_period.0.max(1));
        let lcm = m / gcd(m, t) * t;
        let k = ((min_window.0 + lcm - 1) / lcm).max(1);
        GyroAlignment {
            window: Nanos(k * lcm),
            mocap_period: Nanos(m),
            mocap: [None; MOCAP_RING],
            newest_mocap: Nanos(i64::MIN),
            open: None,
            pending: [None; PENDING],
            n: 0,
            dropped: 0,
            sum_m: Vector3::zeros(),
            sum_b: Vector3::zeros(),
            sum_mb: Matrix3::zeros(),
            sum_mm: Matrix3::zeros(),
            sum_bb: 0.0,
        }
    }

    pub fn window(&self) -> Nanos {
        self.window
    }
    pub fn windows(&self) -> u64 {
        self.n
    }
    /// Windows lost to missing mocap frames or telemetry.
    pub fn dropped(&self) -> u64 {
        self.dropped
    }

    fn slot(&self, t: Nanos) -> usize {
        (t.0.div_euclid(self.mocap_period.0) as usize) % MOCAP_RING
    }

    /// A mocap attitude captured at `t_capture`.
    pub fn add_mocap(&mut self, t_capture: Nanos, att: Rot<MocapBody, MocapNav>) {
        let i = self.slot(t_capture);
        self.mocap[i] = Some((t_capture, att));
        self.newest_mocap = self.newest_mocap.max(t_capture);
        self.resolve();
    }

    /// A telemetry frame (frames arrive in sequence order; a gap restarts the window).
    pub fn add_telemetry(&mut self, f: &TelemetryFrame) {
        let step = Rot::from_rotation_vector(f.gyro_mean * (f.t1 - f.t0).as_secs_f64());
        let w = match self.open {
            Some(w) if w.t_b == f.t0 => GyroWindow { t_b: f.t1, delta: w.delta * step, ..w },
            Some(_) => {
                self.dropped += 1;
                GyroWindow { t_a: f.t0, t_b: f.t1, delta: step }
            }
            None => GyroWindow { t_a: f.t0, t_b: f.t1, delta: step },
        };
        if w.t_b - w.t_a >= self.window {
            self.open = None;
            if w.t_b - w.t_a == self.window {
                self.push_pending(w);
            } else {
                self.dropped += 1;
            }
        } else {
            self.open = Some(w);
        }
        self.resolve();
    }

    fn push_pending(&mut self, w: GyroWindow) {
        if let Some(slot) = self.pending.iter_mut().find(|p| p.is_none()) {
            *slot = Some(w);
        } else {
            // full: the oldest waits for a mocap frame that will not come
            let oldest = (0..PENDING).min_by_key(|&i| self.pending[i].map_or(i64::MAX, |p| p.t_a.0)).unwrap_or(0);
            self.pending[oldest] = Some(w);
            self.dropped += 1;
        }
    }

    fn mocap_at(&self, t: Nanos) -> Option<Rot<MocapBody, MocapNav>> {
        self.mocap[self.slot(t)].filter(|(tc, _)| *tc == t).map(|(_, a)| a)
    }

    fn resolve(&mut self) {
        for i in 0..PENDING {
            let Some(w) = self.pending[i] else { continue };
            match (self.mocap_at(w.t_a), self.mocap_at(w.t_b)) {
                (Some(a), Some(b)) => {
                    let theta_m = (a.inverse() * b).rotation_vector();
                    self.add_pair(theta_m, w.delta.rotation_vector());
                    self.pending[i] = None;
                }
                // the frames for this window are older than the ring or will never arrive
                _ if (self.newest_mocap - w.t_b).0 > self.mocap_period.0 * (MOCAP_RING as i64 / 2) => {
                    self.pending[i] = None;
                    self.dropped += 1;
                }
                _ => {}
            }
        }
    }

    /// Adds one pair of rotation vectors directly (θ_m in the mocap body frame, θ_b in the body
    /// frame, rad).
    pub fn add_pair(&mut self, theta_m: Vec3<MocapBody>, theta_b: Vec3<Body>) {
        let (m, b) = (*theta_m.raw(), *theta_b.raw());
        self.n += 1;
        self.sum_m += m;
        self.sum_b += b;
        self.sum_mb += m * b.transpose();
        self.sum_mm += m * m.transpose();
        self.sum_bb += b.norm_squared();
    }

    /// The fit, once at least 10 windows are in and θ_m has varied about two axes.
    pub fn estimate(&self) -> Option<GyroFit> {
        if self.n < 10 {
            return None;
        }
        let n = self.n as f64;
        let (mm, mb) = (self.sum_m / n, self.sum_b / n);
        let h = self.sum_mb - n * mm * mb.transpose();
        let s_m = self.sum_mm - n * mm * mm.transpose();
        let e = s_m.symmetric_eigenvalues();
        let mut ev = [e[0], e[1], e[2]];
        ev.sort_by(f64::total_cmp);
        if ev[1] <= 1e-12 * ev[2].max(1e-300) {
            return None;
        }
        let c = kabsch(&h)?;
        // RSS = Σ‖θ̃_b‖² + Σ‖θ̃_m‖² − 2·tr(C·H)
        let ss_b = self.sum_bb - n * mb.norm_squared();
        let rss = (ss_b + s_m.trace() - 2.0 * (c * h).trace()).max(0.0);
        let dof = (3.0 * n - 6.0).max(1.0);
        let var = rss / dof;
        let s = c * s_m * c.transpose();
        let info = Matrix3::identity() * s.trace() - s;
        let cov = info.try_inverse()? * var;
        let bias = (mb - c * mm) / self.window.as_secs_f64();
        let rotation: Rot<MocapBody, Body> = Rot::from_matrix(&c);
        Some(GyroFit {
            rotation,
            euler: rotation.euler(),
            sigma: [cov[(0, 0)].max(0.0).sqrt(), cov[(1, 1)].max(0.0).sqrt(), cov[(2, 2)].max(0.0).sqrt()],
            gyro_bias: [bias.x, bias.y, bias.z],
            rms_residual: (rss / (3.0 * n)).sqrt(),
            windows: self.n,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frames::Nav;

    /// Rotation vectors about two axes, mapped through a known C, recover C exactly and the bias.
    #[test]
    fn recovers_a_known_rotation_and_bias_from_exact_pairs() {
        let c: Rot<MocapBody, Body> = Rot::from_euler(Euler::from_degrees(1.0, -2.0, 4.0));
        let mut g = GyroAlignment::new(Nanos::from_millis(5), Nanos::from_millis(10), Nanos::from_millis(50));
        assert_eq!(g.window(), Nanos::from_millis(50));
        let bias = Vec3::<Body>::new(0.01, -0.02, 0.005);
        for k in 0..200 {
            let a = k as f64 * 0.37;
            let theta_m = Vec3::<MocapBody>::new(0.02 * a.sin(), 0.015 * (1.3 * a).cos(), 0.01 * (0.7 * a).sin());
            g.add_pair(theta_m, c.apply(theta_m) + bias * 0.05);
        }
        let fit = g.estimate().unwrap();
        assert!((fit.rotation.inverse() * c).angle() < 1e-9);
        for (e, b) in fit.gyro_bias.iter().zip(bias.to_array()) {
            assert!((e - b).abs() < 1e-9, "{e} vs {b}");
        }
        assert!(fit.rms_residual < 1e-9 && fit.sigma.iter().all(|s| *s < 1e-6));
    }

    /// A spin about one axis only leaves the rotation about that axis undetermined.
    #[test]
    fn one_axis_of_rotation_is_not_enough() {
        let mut g = GyroAlignment::new(Nanos::from_millis(5), Nanos::from_millis(10), Nanos::from_millis(50));
        for k in 0..100 {
            let theta = Vec3::<MocapBody>::new(0.0, 0.0, 0.01 * (k as f64).sin());
            g.add_pair(theta, theta.assume_same_as());
        }
        assert!(g.estimate().is_none());
    }

    /// End to end through the pairing: a vehicle rocking about x and y with a known C, mocap
    /// attitudes at 200 Hz and telemetry at 100 Hz, frames arriving late and out of step.
    #[test]
    fn pairs_telemetry_with_mocap_frames() {
        let c: Rot<MocapBody, Body> = Rot::from_euler(Euler::from_degrees(0.5, 0.3, -3.0));
        let mut g = GyroAlignment::new(Nanos::from_millis(5), Nanos::from_millis(10), Nanos::from_millis(40));
        // ω(t) = (0.6 cos 3t, 0.5 sin 2t, 0.2), integrated finely for the truth
        let omega = |t: f64| Vec3::<Body>::new(0.6 * (3.0 * t).cos(), 0.5 * (2.0 * t).sin(), 0.2);
        let mut att: Rot<Body, Nav> = Rot::identity();
        let mut seq = 0;
        let mut gyro_sum = Vec3::<Body>::zeros();
        let mut mocap_queue = Vec::new();
        let fine = 100; // substeps per ms
        for ms in 0..4000i64 {
            let t = Nanos::from_millis(ms);
            if ms % 5 == 0 {
                mocap_queue.push((t, (att * c).assume_frames::<MocapBody, MocapNav>()));
            }
            for j in 0..fine {
                let tt = (ms as f64 + (j as f64 + 0.5) / fine as f64) * 1e-3;
                let w = omega(tt);
                gyro_sum += w * (1.0 / fine as f64);
                att = att * Rot::<Body, Body>::from_rotation_vector(w * (1e-3 / fine as f64));
            }
            if (ms + 1) % 10 == 0 {
                let f = TelemetryFrame { seq, t0: Nanos::from_millis(ms - 9), t1: Nanos::from_millis(ms + 1), gyro_mean: gyro_sum * 0.1 };
                seq += 1;
                gyro_sum = Vec3::zeros();
                g.add_telemetry(&f);
            }
            // mocap frames arrive 12 ms after capture
            while let Some(&(tc, a)) = mocap_queue.first() {
                if tc + Nanos::from_millis(12) > t {
                    break;
                }
                g.add_mocap(tc, a);
                mocap_queue.remove(0);
            }
        }
        let fit = g.estimate().unwrap();
        assert!(g.windows() >= 95, "{} windows, {} dropped", g.windows(), g.dropped());
        // the mean of a window's 10 ms averages composes the rotation to second order
        assert!((fit.rotation.inverse() * c).angle().to_degrees() < 0.01, "{:?}", fit.euler.to_degrees());
    }
}

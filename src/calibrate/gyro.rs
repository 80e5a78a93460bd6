//! The mocap-to-body rotation from body-rate telemetry: gyro vs mocap attitude increments
//! (Wahba's problem). Not in the paper; flyarena adds it because the paper's yaw method cannot
//! see a marker rotation about the thrust axis (docs/findings.md).
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
//!
//! **An unsynchronised telemetry clock.** The telemetry's interval bounds are stamped by the
//! vehicle's clock, t_v = t + δ₀ + d·t (offset δ₀, drift d, against the Vicon clock t). Pairing a
//! gyro window with the mocap at t_v instead of t shifts θ_m by about δ·(ω(t_b) − ω(t_a)); while
//! the rate vector turns at Ω (a circle) that is a rotation by Ω·δ about the turning axis, which
//! C absorbs: a yaw error of Ω·δ (0.9° for 5 ms on a 2 s circle). With
//! [`GyroAlignment::estimate_clock`] the alignment fits δ₀ and d itself. The windows are then
//! fixed on the mocap's frames [t_a, t_b] (Vicon time), and for a grid of offsets δ_k (1 ms apart)
//! the gyro increment is integrated over [t_a + δ_k, t_b + δ_k] on the telemetry clock (whole
//! frames, and the covered part of a frame at either end at its mean rate). Shifting the gyro,
//! not the mocap, keeps the same mocap frames — whose noise dominates the residual — in every
//! candidate: shifting the mocap would pick other frames, and the residual would vary with their
//! noise by more than with the offset. The moments are kept per candidate and per time block
//! (5 s); for a clock model (δ₀, d) each block's are interpolated (cubic through the four nearest
//! nodes) at its own offset δ₀ + d·(t̄_block − t̄), summed, and the rotation fitted as above;
//! (δ₀, d) minimise the residual (the grid, then golden sections). The offset is observable from what a rotation cannot absorb — changes of |ω|
//! (take-off, the ramps of the circles, stops) — and its uncertainty enters C's: the 1σ of C adds
//! J·Σ_clock·Jᵀ, J = ∂C/∂(δ₀, d) by central differences, Σ_clock = 2σ²·H⁻¹ from the residual's
//! Hessian H (profile likelihood, delta method).

use crate::clock::Nanos;
use crate::frames::{Body, Euler, MocapBody, MocapNav, Rot, Vec3};
use crate::mocap::fit::kabsch;
use crate::vehicle::TelemetryFrame;
use nalgebra::{Matrix3, Vector3};

/// The estimate of C = R_off from gyro telemetry.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct GyroFit {
    /// C itself.
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
    /// Windows fitted.
    pub windows: u64,
    /// The telemetry clock fitted against the Vicon clock, when the alignment estimates it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub clock: Option<ClockFit>,
}

/// The telemetry clock against the Vicon clock: t_v = t + offset + drift·(t − t̄), t̄ the mean time
/// of the windows.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct ClockFit {
    /// δ at the windows' mean time (s) and its 1σ.
    pub offset_s: f64,
    /// 1σ of the offset (s).
    pub offset_sigma_s: f64,
    /// Drift (parts per million) and its 1σ; `None` when the windows span fewer than three time
    /// blocks (the drift is then not estimated: 0).
    pub drift_ppm: Option<f64>,
    /// 1σ of the drift (ppm).
    pub drift_sigma_ppm: Option<f64>,
    /// The windows' mean time on the Vicon clock (s).
    pub t_mean_s: f64,
}

/// The grid of candidate offsets and the time blocks of [`GyroAlignment::estimate_clock`].
#[derive(Clone, Copy, Debug)]
pub struct ClockSearch {
    /// Offsets searched: |δ| ≤ max_offset.
    pub max_offset: Nanos,
    /// Grid step of the candidate offsets (moments are interpolated between nodes).
    pub step: Nanos,
    /// Length of a time block (the drift is resolved between blocks).
    pub block: Nanos,
    /// Drifts searched: |d| ≤ max_drift_ppm.
    pub max_drift_ppm: f64,
}

impl Default for ClockSearch {
    fn default() -> Self {
        ClockSearch {
            max_offset: Nanos::from_millis(50),
            step: Nanos::from_millis(1),
            block: Nanos::from_millis(5000),
            max_drift_ppm: 500.0,
        }
    }
}

/// The moments that depend on the offset (through the gyro increment), per candidate.
#[derive(Clone, Copy, Debug, Default)]
struct GyroMoments {
    sum_b: Vector3<f64>,
    sum_mb: Matrix3<f64>,
    sum_bb: f64,
}

/// One time block: the moments of the mocap side, and one [`GyroMoments`] per candidate offset.
#[derive(Clone, Debug)]
struct Block {
    index: i64,
    n: u64,
    sum_t: f64,
    sum_m: Vector3<f64>,
    sum_mm: Matrix3<f64>,
    per_offset: Vec<GyroMoments>,
}

/// The pooled moments of a fit.
#[derive(Clone, Copy, Debug)]
struct Moments {
    n: f64,
    sum_m: Vector3<f64>,
    sum_b: Vector3<f64>,
    sum_mb: Matrix3<f64>,
    sum_mm: Matrix3<f64>,
    sum_bb: f64,
}

/// Mocap attitudes kept (a power of two; 1.28 s at 200 Hz): enough for the windows waiting on
/// frames up to the largest searched offset.
const MOCAP_RING: usize = 256;
const PENDING: usize = 16;
/// A frame may be missing: interpolation looks this many periods either side for a neighbour.
const NEIGHBOUR_PERIODS: i64 = 3;

#[derive(Clone, Copy, Debug)]
struct GyroWindow {
    t_a: Nanos,
    t_b: Nanos,
    frames: u32,
    delta: Rot<Body, Body>,
}

/// Pairs mocap attitudes with telemetry and accumulates the moments of the fit.
#[derive(Clone, Debug)]
pub struct GyroAlignment {
    window: Nanos,
    /// Telemetry frames per window.
    frames_per_window: u32,
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
    /// Set by [`GyroAlignment::estimate_clock`].
    search: Option<ClockSearch>,
    blocks: Vec<Block>,
    /// With the clock search: the telemetry frames still needed, in t0 order, the newest frame's
    /// start, and the next window (index of t_a on the window grid).
    frames: std::collections::VecDeque<TelemetryFrame>,
    newest_telemetry_start: Nanos,
    next_window: Option<i64>,
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
            frames_per_window: (k * lcm / t) as u32,
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
            search: None,
            blocks: Vec::new(),
            frames: std::collections::VecDeque::new(),
            newest_telemetry_start: Nanos(i64::MIN),
            next_window: None,
        }
    }

    /// Fits the telemetry clock (offset and drift against the Vicon clock) with the rotation,
    /// for telemetry stamped by an unsynchronised vehicle clock (module doc).
    pub fn estimate_clock(mut self, search: ClockSearch) -> Self {
        self.search = Some(search);
        self
    }

    /// The candidate offsets of the clock search: −max, −max + step, …, +max.
    fn offsets(search: &ClockSearch) -> impl Iterator<Item = Nanos> + use<> {
        let p = search.step.0.max(1);
        let k = search.max_offset.0 / p;
        (-k..=k).map(move |i| Nanos(i * p))
    }

    /// The length of one window (a multiple of both periods).
    pub fn window(&self) -> Nanos {
        self.window
    }
    /// Windows paired so far.
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
        if self.search.is_some() {
            self.next_window.get_or_insert(t_capture.0.div_euclid(self.window.0) + 1);
            self.windows_on_mocap_grid();
        } else {
            self.resolve();
        }
    }

    /// A telemetry frame (frames arrive in sequence order; a gap restarts the window).
    pub fn add_telemetry(&mut self, f: &TelemetryFrame) {
        if self.search.is_some() {
            let at = self.frames.iter().rposition(|g| g.t0 <= f.t0).map_or(0, |i| i + 1);
            self.frames.insert(at, *f);
            self.newest_telemetry_start = self.newest_telemetry_start.max(f.t0);
            self.windows_on_mocap_grid();
            return;
        }
        let step = Rot::from_rotation_vector(f.gyro_mean * (f.t1 - f.t0).as_secs_f64());
        let w = match self.open {
            Some(w) if w.t_b == f.t0 => GyroWindow { t_b: f.t1, frames: w.frames + 1, delta: w.delta * step, ..w },
            Some(_) => {
                self.dropped += 1;
                GyroWindow { t_a: f.t0, t_b: f.t1, frames: 1, delta: step }
            }
            None => GyroWindow { t_a: f.t0, t_b: f.t1, frames: 1, delta: step },
        };
        if w.frames >= self.frames_per_window {
            self.open = None;
            // a window is `window` long on the Vicon clock; a telemetry clock that drifts (and
            // that this mode takes for the Vicon's) makes it longer or shorter by its drift
            if ((w.t_b - w.t_a).0 - self.window.0).abs() <= self.window.0 / 1000 {
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

    /// The mocap attitude at `t`: the frame captured then, if `t` is a frame time; otherwise the
    /// slerp between the nearest frames before and after it (each within
    /// [`NEIGHBOUR_PERIODS`]), once every frame that could be nearer has had time to arrive.
    fn mocap_interp(&self, t: Nanos) -> Option<Rot<MocapBody, MocapNav>> {
        let p = self.mocap_period.0;
        let base = t.0.div_euclid(p) * p;
        if base == t.0 {
            return self.mocap_at(t);
        }
        if self.newest_mocap.0 < base + NEIGHBOUR_PERIODS * p {
            return None;
        }
        let (ta, a) =
            (0..NEIGHBOUR_PERIODS).find_map(|k| self.mocap_at(Nanos(base - k * p)).map(|a| (base - k * p, a)))?;
        let (tb, b) =
            (1..=NEIGHBOUR_PERIODS).find_map(|k| self.mocap_at(Nanos(base + k * p)).map(|b| (base + k * p, b)))?;
        let s = (t.0 - ta) as f64 / (tb - ta) as f64;
        Some(a * Rot::from_rotation_vector((a.inverse() * b).rotation_vector() * s))
    }

    fn resolve(&mut self) {
        for i in 0..PENDING {
            let Some(w) = self.pending[i] else { continue };
            match (self.mocap_interp(w.t_a), self.mocap_interp(w.t_b)) {
                (Some(a), Some(b)) => {
                    let theta_m = (a.inverse() * b).rotation_vector();
                    self.add_pair(theta_m, w.delta.rotation_vector());
                    self.pending[i] = None;
                }
                // the frames for this window are older than the ring or will never arrive
                // (saturating: before the first mocap frame, newest_mocap is i64::MIN and the
                // window waits)
                _ if self.newest_mocap.0.saturating_sub(w.t_b.0) > self.mocap_period.0 * (MOCAP_RING as i64 / 2) => {
                    self.pending[i] = None;
                    self.dropped += 1;
                }
                _ => {}
            }
        }
    }

    /// With the clock search: every window [t_a, t_b] of the grid whose mocap frames and whose
    /// telemetry up to t_b + max_offset can have arrived is paired at every candidate offset (or
    /// dropped, if a frame or a stretch of telemetry is missing). "Can have arrived" for the
    /// telemetry is a frame that starts at or after t_b + max_offset: a frame that covers
    /// t_b + δ in part integrates the parabola through its neighbours' means, so the frame
    /// after it must be in too (with only the frames up to t_b + max_offset in, the last one
    /// took its own mean for its missing neighbour, and the estimate depended on arrival order).
    ///
    /// Window k ends at t_b = (k + 1)·window; it is ready when t_b ≤ `ready`, the earlier of
    /// newest mocap − [`NEIGHBOUR_PERIODS`] periods and newest telemetry start − max_offset, that
    /// is for k < ⌊ready / window⌋. The windows are walked over that range, so the loop ends
    /// whatever the bookkeeping of `next_window` does.
    fn windows_on_mocap_grid(&mut self) {
        let (Some(search), Some(first)) = (self.search, self.next_window) else { return };
        // saturating: before the first telemetry frame its start is i64::MIN
        let ready = self
            .newest_mocap
            .0
            .saturating_sub(self.mocap_period.0 * NEIGHBOUR_PERIODS)
            .min(self.newest_telemetry_start.0.saturating_sub(search.max_offset.0));
        for k in first..ready.div_euclid(self.window.0) {
            let (t_a, t_b) = (Nanos(k * self.window.0), Nanos((k + 1) * self.window.0));
            self.next_window = Some(k + 1);
            // frames that no later window needs
            while self.frames.front().is_some_and(|f| f.t1 < t_a - search.max_offset) {
                self.frames.pop_front();
            }
            let (Some(a), Some(b)) = (self.mocap_at(t_a), self.mocap_at(t_b)) else {
                self.dropped += 1;
                continue;
            };
            let theta_m = *(a.inverse() * b).rotation_vector().raw();
            let thetas: Option<Vec<Vector3<f64>>> =
                Self::offsets(&search).map(|d| self.gyro_increment(t_a + d, t_b + d)).collect();
            match thetas {
                Some(thetas) => self.add_to_block(&search, t_a, t_b, theta_m, &thetas),
                None => self.dropped += 1,
            }
        }
    }

    /// The gyro increment over [u0, u1] on the telemetry clock as a rotation vector: the frames'
    /// steps in time order, or `None` where the frames leave a gap. A frame covered in part
    /// contributes the integral of the parabola through its own mean and its neighbours' means
    /// ([`partial_rate_integral`]): at a constant rate within the frame instead, the error
    /// ω̇·L·(T − L)/2 follows the angular acceleration, like the shift being fitted, and would bias
    /// the offset.
    fn gyro_increment(&self, u0: Nanos, u1: Nanos) -> Option<Vector3<f64>> {
        let mut at = u0;
        let mut delta: Rot<Body, Body> = Rot::identity();
        let first = self.frames.iter().position(|f| f.t1 > u0)?;
        for i in first..self.frames.len() {
            let f = &self.frames[i];
            if f.t0 > at {
                return None;
            }
            let end = f.t1.min(u1);
            let step = if at == f.t0 && end == f.t1 {
                f.gyro_mean * (f.t1 - f.t0).as_secs_f64()
            } else {
                // neighbours' means where the frames are contiguous, else this frame's own
                let prev = i
                    .checked_sub(1)
                    .map(|j| &self.frames[j])
                    .filter(|g| g.t1 == f.t0)
                    .map_or(f.gyro_mean, |g| g.gyro_mean);
                let next = self.frames.get(i + 1).filter(|g| g.t0 == f.t1).map_or(f.gyro_mean, |g| g.gyro_mean);
                let span = (f.t1 - f.t0).as_secs_f64();
                let x = |t: Nanos| (t - f.t0).as_secs_f64() / span;
                let integral = |x: f64| partial_rate_integral(*prev.raw(), *f.gyro_mean.raw(), *next.raw(), x);
                Vec3::from_raw((integral(x(end)) - integral(x(at))) * span)
            };
            delta = delta * Rot::from_rotation_vector(step);
            at = end;
            if at >= u1 {
                return Some(*delta.rotation_vector().raw());
            }
        }
        None
    }

    fn add_to_block(
        &mut self,
        search: &ClockSearch,
        t_a: Nanos,
        t_b: Nanos,
        theta_m: Vector3<f64>,
        thetas: &[Vector3<f64>],
    ) {
        let index = t_a.0.div_euclid(search.block.0.max(1));
        let pos = match self.blocks.iter().rposition(|b| b.index <= index) {
            Some(i) if self.blocks[i].index == index => i,
            other => {
                let at = other.map_or(0, |i| i + 1);
                let block = Block {
                    index,
                    n: 0,
                    sum_t: 0.0,
                    sum_m: Vector3::zeros(),
                    sum_mm: Matrix3::zeros(),
                    per_offset: vec![GyroMoments::default(); thetas.len()],
                };
                self.blocks.insert(at, block);
                at
            }
        };
        let block = &mut self.blocks[pos];
        block.n += 1;
        block.sum_t += 0.5 * (t_a.as_secs_f64() + t_b.as_secs_f64());
        block.sum_m += theta_m;
        block.sum_mm += theta_m * theta_m.transpose();
        for (g, b) in block.per_offset.iter_mut().zip(thetas) {
            g.sum_b += b;
            g.sum_mb += theta_m * b.transpose();
            g.sum_bb += b.norm_squared();
        }
        self.n += 1;
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

    /// The fit, once at least 10 windows are in and θ_m has varied about two axes; with the
    /// clock search, the rotation at the best clock (module doc) or `None` when the best offset
    /// lies at the edge of the searched range.
    pub fn estimate(&self) -> Option<GyroFit> {
        match &self.search {
            None => self.fit(&self.moments(), 0).map(|(fit, _, _)| fit),
            Some(search) => self.estimate_with_clock(search),
        }
    }

    /// The moments of every window paired without the clock search.
    fn moments(&self) -> Moments {
        Moments {
            n: self.n as f64,
            sum_m: self.sum_m,
            sum_b: self.sum_b,
            sum_mb: self.sum_mb,
            sum_mm: self.sum_mm,
            sum_bb: self.sum_bb,
        }
    }

    /// Kabsch on pooled moments: the fit, its residual sum of squares and the 3×3 covariance of a
    /// small rotation error of C (body axes). `extra` parameters are taken off the degrees of
    /// freedom.
    fn fit(&self, m: &Moments, extra: usize) -> Option<(GyroFit, f64, Matrix3<f64>)> {
        if m.n < 10.0 {
            return None;
        }
        let n = m.n;
        let (mm, mb) = (m.sum_m / n, m.sum_b / n);
        let h = m.sum_mb - n * mm * mb.transpose();
        let s_m = m.sum_mm - n * mm * mm.transpose();
        let e = s_m.symmetric_eigenvalues();
        let mut ev = [e[0], e[1], e[2]];
        ev.sort_by(f64::total_cmp);
        if ev[1] <= 1e-12 * ev[2].max(1e-300) {
            return None;
        }
        let c = kabsch(&h)?;
        // RSS = Σ‖θ̃_b‖² + Σ‖θ̃_m‖² − 2·tr(C·H)
        let ss_b = m.sum_bb - n * mb.norm_squared();
        let rss = (ss_b + s_m.trace() - 2.0 * (c * h).trace()).max(0.0);
        let dof = (3.0 * n - 6.0 - extra as f64).max(1.0);
        let var = rss / dof;
        let s = c * s_m * c.transpose();
        let info = Matrix3::identity() * s.trace() - s;
        let cov = info.try_inverse()? * var;
        let bias = (mb - c * mm) / self.window.as_secs_f64();
        let rotation: Rot<MocapBody, Body> = Rot::from_matrix(&c);
        let fit = GyroFit {
            rotation,
            euler: rotation.euler(),
            sigma: [cov[(0, 0)].max(0.0).sqrt(), cov[(1, 1)].max(0.0).sqrt(), cov[(2, 2)].max(0.0).sqrt()],
            gyro_bias: [bias.x, bias.y, bias.z],
            rms_residual: (rss / (3.0 * n)).sqrt(),
            windows: n as u64,
            clock: None,
        };
        Some((fit, rss, cov))
    }

    /// The blocks' moments pooled for the clock (offset at the mean time `t_mean` (s), drift):
    /// each block's interpolated at its own offset by the cubic through the four nearest nodes
    /// (exact for moments up to cubic in the offset; a linear interpolation of Σ‖θ_b‖², which is
    /// quadratic, would overestimate it between nodes and pull the minimum onto a node); `None`
    /// outside the grid.
    fn pooled(&self, search: &ClockSearch, t_mean: f64, offset_s: f64, drift: f64) -> Option<Moments> {
        let step = search.step.as_secs_f64();
        let max = (search.max_offset.0 / search.step.0.max(1)) as f64 * step;
        let mut m = Moments {
            n: 0.0,
            sum_m: Vector3::zeros(),
            sum_b: Vector3::zeros(),
            sum_mb: Matrix3::zeros(),
            sum_mm: Matrix3::zeros(),
            sum_bb: 0.0,
        };
        for b in &self.blocks {
            let d = offset_s + drift * (b.sum_t / b.n as f64 - t_mean);
            let u = (d + max) / step;
            let last = b.per_offset.len() as f64 - 1.0;
            // nodes k−1, k, k+1, k+2 around u ∈ [k, k+1]
            if !(1.0..=last - 1.0).contains(&u) {
                return None;
            }
            let k = (u.floor() as usize).min(b.per_offset.len() - 3);
            let x = u - k as f64;
            let w = [
                -x * (x - 1.0) * (x - 2.0) / 6.0,
                (x + 1.0) * (x - 1.0) * (x - 2.0) / 2.0,
                -(x + 1.0) * x * (x - 2.0) / 2.0,
                (x + 1.0) * x * (x - 1.0) / 6.0,
            ];
            m.n += b.n as f64;
            m.sum_m += b.sum_m;
            m.sum_mm += b.sum_mm;
            for (j, wj) in w.iter().enumerate() {
                let node = &b.per_offset[k + j - 1];
                m.sum_b += node.sum_b * *wj;
                m.sum_mb += node.sum_mb * *wj;
                m.sum_bb += node.sum_bb * *wj;
            }
        }
        Some(m)
    }

    fn estimate_with_clock(&self, search: &ClockSearch) -> Option<GyroFit> {
        let n: u64 = self.blocks.iter().map(|b| b.n).sum();
        if n < 10 {
            return None;
        }
        let t_mean = self.blocks.iter().map(|b| b.sum_t).sum::<f64>() / n as f64;
        let with_drift = self.blocks.len() >= 3;
        let extra = if with_drift { 2 } else { 1 };
        // the fit with the clock (offset s, drift) = x, and its residual sum of squares
        let fit_at = |x: [f64; 2]| self.pooled(search, t_mean, x[0], x[1]).and_then(|m| self.fit(&m, extra));
        let rss = |x: [f64; 2]| fit_at(x).map_or(f64::INFINITY, |f| f.1);
        let step = search.step.as_secs_f64();
        let max = (search.max_offset.0 / search.step.0.max(1)) as f64 * step;
        let drift_step = search.max_drift_ppm * 1e-6 / 10.0;
        let drifts: Vec<f64> = if with_drift { (-10..=10).map(|i| i as f64 * drift_step).collect() } else { vec![0.0] };
        // the grid, then golden sections along each coordinate in turn
        let mut best = ([0.0, 0.0], f64::INFINITY);
        for d in Self::offsets(search) {
            for &dr in &drifts {
                let x = [d.as_secs_f64(), dr];
                let r = rss(x);
                if r < best.1 {
                    best = (x, r);
                }
            }
        }
        if !best.1.is_finite() {
            return None;
        }
        let mut x = best.0;
        for _ in 0..4 {
            x[0] = golden(|v| rss([v, x[1]]), x[0] - step, x[0] + step);
            if with_drift {
                x[1] = golden(|v| rss([x[0], v]), x[1] - drift_step, x[1] + drift_step);
            }
        }
        // a minimum at the edge of the range is not a minimum
        if x[0].abs() > max - 1.5 * step || (with_drift && x[1].abs() > search.max_drift_ppm * 1e-6 - drift_step) {
            return None;
        }
        let (mut fit, r0, cov_c) = fit_at(x)?;
        // the clock's covariance 2σ²·H⁻¹ from the residual's Hessian, and C's sensitivity to it
        let var = r0 / (3.0 * n as f64 - 6.0 - extra as f64).max(1.0);
        let h = [0.25 * step, 0.25 * drift_step];
        let p = if with_drift { 2 } else { 1 };
        let hess = central_hessian(rss, x, r0, h, p);
        let cov_clock = hess.try_inverse()? * (2.0 * var);
        let jac = central_rotation_jacobian(|clock| fit_at(clock).map(|f| f.0.rotation), x, h, p)?;
        let add = &jac * &cov_clock * jac.transpose();
        for k in 0..3 {
            fit.sigma[k] = (cov_c[(k, k)] + add[(k, k)]).max(0.0).sqrt();
        }
        fit.clock = Some(ClockFit {
            offset_s: x[0],
            offset_sigma_s: cov_clock[(0, 0)].max(0.0).sqrt(),
            drift_ppm: with_drift.then_some(x[1] * 1e6),
            drift_sigma_ppm: with_drift.then(|| cov_clock[(1, 1)].max(0.0).sqrt() * 1e6),
            t_mean_s: t_mean,
        });
        Some(fit)
    }
}

/// ∫₀ˣ p(s) ds for the parabola p on a frame s ∈ [0, 1] whose means over the previous frame
/// [−1, 0], this one and the next [1, 2] are `a`, `b`, `c`:
/// p(s) = b + β·(s − ½) + γ·((s − ½)² − 1/12), β = (c − a)/2, γ = (a + c)/2 − b, so
/// ∫₀ˣ p = b·x + β·(x² − x)/2 + γ·(((x − ½)³ + ⅛)/3 − x/12); it is b at x = 1.
fn partial_rate_integral(a: Vector3<f64>, b: Vector3<f64>, c: Vector3<f64>, x: f64) -> Vector3<f64> {
    let beta = (c - a) * 0.5;
    let gamma = (a + c) * 0.5 - b;
    b * x + beta * ((x * x - x) / 2.0) + gamma * (((x - 0.5).powi(3) + 0.125) / 3.0 - x / 12.0)
}

/// The Hessian of f over its first `p` (1 or 2) coordinates at `x` by central differences
/// with steps `h`, f₀ = f(x), g(d) = f(x + d): H_ii = (g(h_i·e_i) − 2f₀ + g(−h_i·e_i))/h_i² and
/// H₀₁ = (g(h₀, h₁) − g(h₀, −h₁) − g(−h₀, h₁) + g(−h₀, −h₁))/(4h₀h₁). Exact for a quadratic.
fn central_hessian(f: impl Fn([f64; 2]) -> f64, x: [f64; 2], f0: f64, h: [f64; 2], p: usize) -> nalgebra::DMatrix<f64> {
    let f = |d: [f64; 2]| f([x[0] + d[0], x[1] + d[1]]);
    let mut hess = nalgebra::DMatrix::<f64>::zeros(p, p);
    for i in 0..p {
        let mut e = [0.0; 2];
        e[i] = h[i];
        hess[(i, i)] = (f(e) - 2.0 * f0 + f([-e[0], -e[1]])) / (h[i] * h[i]);
    }
    if p == 2 {
        hess[(0, 1)] =
            (f([h[0], h[1]]) - f([h[0], -h[1]]) - f([-h[0], h[1]]) + f([-h[0], -h[1]])) / (4.0 * h[0] * h[1]);
        hess[(1, 0)] = hess[(0, 1)];
    }
    hess
}

/// The Jacobian of a rotation-valued g over its first `p` (1 or 2) coordinates at `x` by
/// central differences with steps `h`: column i is the rotation vector (rad) of
/// g(x + h_i·e_i)·g(x − h_i·e_i)⁻¹ over 2h_i. Exact for a rotation about one fixed axis u by an
/// angle linear in x, g(x) = exp([u·(a·x)]×), whose column i is a_i·u. None where g is None.
fn central_rotation_jacobian<A: crate::frames::Frame, B: crate::frames::Frame>(
    g: impl Fn([f64; 2]) -> Option<Rot<A, B>>,
    x: [f64; 2],
    h: [f64; 2],
    p: usize,
) -> Option<nalgebra::DMatrix<f64>> {
    let g = |d: [f64; 2]| g([x[0] + d[0], x[1] + d[1]]);
    let mut jac = nalgebra::DMatrix::<f64>::zeros(3, p);
    for i in 0..p {
        let mut e = [0.0; 2];
        e[i] = h[i];
        let (plus, minus) = (g(e)?, g([-e[0], -e[1]])?);
        let d = (plus * minus.inverse()).rotation_vector().to_array();
        for k in 0..3 {
            jac[(k, i)] = d[k] / (2.0 * h[i]);
        }
    }
    Some(jac)
}

/// The minimum of `f` on [a, b] by golden sections (60 steps: the bracket shrinks by 10⁻¹²).
fn golden(f: impl Fn(f64) -> f64, mut a: f64, mut b: f64) -> f64 {
    let r = 0.5 * (5f64.sqrt() - 1.0);
    let (mut c, mut d) = (b - r * (b - a), a + r * (b - a));
    let (mut fc, mut fd) = (f(c), f(d));
    for _ in 0..60 {
        if fc < fd {
            b = d;
            d = c;
            fd = fc;
            c = b - r * (b - a);
            fc = f(c);
        } else {
            a = c;
            c = d;
            fc = fd;
            d = a + r * (b - a);
            fd = f(d);
        }
    }
    0.5 * (a + b)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frames::Nav;

    /// A window is the shortest multiple of both periods at least `min_window` long: for 4 ms mocap
    /// and 6 ms telemetry frames the multiples are 12 ms apart (lcm = 4·6/gcd(4, 6)), so 1 ms gives
    /// 12 ms and 13 ms gives 24 ms, with 2 and 4 telemetry frames (a bug it catches: gcd's `b == 0`
    /// as `!=` returned its first argument, right for 5 and 10 ms, and made the lcm 6).
    #[test]
    fn a_window_is_the_shortest_common_multiple_of_both_periods() {
        for (min_ms, want_ms, frames) in [(1, 12, 2), (12, 12, 2), (13, 24, 4)] {
            let g = GyroAlignment::new(Nanos::from_millis(4), Nanos::from_millis(6), Nanos::from_millis(min_ms));
            assert_eq!((g.window(), g.frames_per_window), (Nanos::from_millis(want_ms), frames), "min {min_ms} ms");
        }
        assert_eq!((gcd(4, 6), gcd(6, 4), gcd(7, 0)), (2, 2, 7));
    }

    /// Windows go to the time block of their start t_a (5 s blocks: t_a = 10 s and 11 s to block 2,
    /// 0.5 s to 0, 6 s to 1), one block per index, kept in index order whatever order the windows
    /// come in; each block sums its windows' centres ½(t_a + t_b), mocap rotations and per-offset
    /// telemetry rotations, and their second moments. A bug it catches: the lookup's guard as false
    /// (a second block 2), its `<=` as `>` and the insertion at i·1 (blocks out of order); mutate
    /// each sum.
    #[test]
    fn windows_are_summed_in_one_block_per_index_in_index_order() {
        let mut g = GyroAlignment::new(Nanos::from_millis(5), Nanos::from_millis(10), Nanos::from_millis(40));
        let search = ClockSearch::default();
        assert_eq!(search.block, Nanos::from_millis(5000));
        for (t_a_ms, m) in [(10_000, 1.0), (500, 2.0), (11_000, 3.0), (6_000, 4.0)] {
            let t_a = Nanos::from_millis(t_a_ms);
            g.add_to_block(
                &search,
                t_a,
                t_a + Nanos::from_millis(40),
                Vector3::new(m, 0.0, 0.0),
                &[Vector3::new(0.0, m, 0.0)],
            );
        }
        assert_eq!(g.n, 4);
        let got: Vec<(i64, u64, f64, f64)> =
            g.blocks.iter().map(|b| (b.index, b.n, b.sum_m.x, b.per_offset[0].sum_b.y)).collect();
        assert_eq!(got, [(0, 1, 2.0, 2.0), (1, 1, 4.0, 4.0), (2, 2, 4.0, 4.0)]);
        // second moments Σθ_m·θ_mᵀ, Σθ_m·θ_bᵀ and Σ|θ_b|², each Σm² (block 2: 1² + 3² = 10),
        // and nothing off their one entry
        for (b, want) in g.blocks.iter().zip([4.0, 16.0, 10.0]) {
            let o = &b.per_offset[0];
            assert_eq!((b.sum_mm[(0, 0)], o.sum_mb[(0, 1)], o.sum_bb), (want, want, want), "block {}", b.index);
            assert_eq!(
                (b.sum_mm.sum(), o.sum_mb.sum(), b.sum_m.sum(), o.sum_b.sum()),
                (want, want, b.sum_m.x, o.sum_b.y)
            );
        }
        let centres: Vec<f64> = g.blocks.iter().map(|b| b.sum_t).collect();
        for (got, want) in centres.iter().zip([0.52, 6.02, 10.02 + 11.02]) {
            assert!((got - want).abs() < 1e-12, "{centres:?}");
        }
    }

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

    /// The residual RMS is √(RSS / 3n) per component, RSS the sum of the squared residuals
    /// θ_b − Ĉ·θ_m − b̂·W of the fitted rotation and bias, computed here pair by pair: pairs
    /// with a deterministic ±1 mrad wobble on every component (n = 200 windows of 50 ms).
    #[test]
    fn the_residual_rms_is_per_component_over_all_windows() {
        let c: Rot<MocapBody, Body> = Rot::from_euler(Euler::from_degrees(1.0, -2.0, 4.0));
        let mut g = GyroAlignment::new(Nanos::from_millis(5), Nanos::from_millis(10), Nanos::from_millis(50));
        let bias = Vec3::<Body>::new(0.01, -0.02, 0.005);
        let mut pairs = Vec::new();
        for k in 0..200 {
            let a = k as f64 * 0.37;
            let theta_m = Vec3::<MocapBody>::new(0.02 * a.sin(), 0.015 * (1.3 * a).cos(), 0.01 * (0.7 * a).sin());
            let wobble = Vec3::<Body>::new(
                1e-3 * (2.9 * a).sin(),
                1e-3 * (3.7 * a).cos(),
                if k % 2 == 0 { 1e-3 } else { -1e-3 },
            );
            let theta_b = c.apply(theta_m) + bias * 0.05 + wobble;
            g.add_pair(theta_m, theta_b);
            pairs.push((theta_m, theta_b));
        }
        let fit = g.estimate().unwrap();
        let b = Vec3::<Body>::new(fit.gyro_bias[0], fit.gyro_bias[1], fit.gyro_bias[2]);
        let rss: f64 = pairs.iter().map(|(m, tb)| (*tb - fit.rotation.apply(*m) - b * 0.05).norm().powi(2)).sum();
        let want = (rss / 600.0).sqrt();
        assert!((fit.rms_residual - want).abs() < 1e-9 * want.max(1e-12) + 1e-15, "{} vs {want}", fit.rms_residual);
        assert!((0.5e-3..1.0e-3).contains(&want), "the wobble is what is left: {want}");
    }

    /// Between frames, the attitude is the slerp of the nearest frames before and after; with
    /// the frame before missing (lost on the link), the one a period earlier, at its own time.
    /// At a constant rate about z the slerp is exact: Rz(ω·t) at 12 ms from the frames at 5 and
    /// 15 ms (10 ms lost), to rounding.
    #[test]
    fn interpolates_across_a_lost_frame_at_the_true_frame_times() {
        let mut g = GyroAlignment::new(Nanos::from_millis(5), Nanos::from_millis(10), Nanos::from_millis(50));
        let omega = 2.0; // rad/s
        let at = |ms: i64| Rot::<MocapBody, MocapNav>::from_euler(Euler::new(0.0, 0.0, omega * ms as f64 * 1e-3));
        for ms in (0..=60).step_by(5).filter(|ms| *ms != 10) {
            g.add_mocap(Nanos::from_millis(ms), at(ms));
        }
        for (ms, truth) in [(12.0, 0.024), (7.5, 0.015), (17.0, 0.034)] {
            let got = g.mocap_interp(Nanos::from_secs_f64(ms * 1e-3)).expect("both neighbours arrived").euler().yaw;
            assert!((got - truth).abs() < 1e-12, "{ms} ms: {got} vs {truth}");
        }
        assert_eq!(g.mocap_interp(Nanos::from_millis(10)), None, "the lost frame's own time has no frame");
    }

    /// The cut for a motion too close to one axis is relative to the largest eigenvalue of the
    /// mocap increments' scatter S_m: no fit when λ₂ ≤ 10⁻¹²·λ₃, whatever the scale of the motion.
    /// Moments by hand (C = I, zero means, 100 windows): S_m = diag(s, r·s, 0) is no fit at r =
    /// 10⁻¹³ and a fit (C = I) at r = 10⁻¹¹, both at s = 1 and at s = 10⁴. A bug it catches: the
    /// cut 10⁻¹²/λ₃ (an absolute cut at s = 1).
    #[test]
    fn the_one_axis_cut_is_relative_to_the_largest_eigenvalue() {
        let g = GyroAlignment::new(Nanos::from_millis(5), Nanos::from_millis(10), Nanos::from_millis(50));
        let fit = |s: f64, r: f64| {
            let scatter = Matrix3::from_diagonal(&Vector3::new(s, r * s, 0.0));
            let m = Moments {
                n: 100.0,
                sum_m: Vector3::zeros(),
                sum_b: Vector3::zeros(),
                sum_mb: scatter,
                sum_mm: scatter,
                sum_bb: s + r * s,
            };
            g.fit(&m, 0).map(|(f, _, _)| f.rotation)
        };
        for s in [1.0, 1e4] {
            assert!(fit(s, 1e-13).is_none(), "scale {s}: a second axis 1e-13 of the first is fitted");
            let c = fit(s, 1e-11).unwrap_or_else(|| panic!("scale {s}: a second axis 1e-11 of the first is no fit"));
            assert!(c.angle() < 1e-9, "scale {s}: {c:?}");
        }
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
                let f = TelemetryFrame {
                    seq,
                    t0: Nanos::from_millis(ms - 9),
                    t1: Nanos::from_millis(ms + 1),
                    gyro_mean: gyro_sum * 0.1,
                };
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

    /// Flies ω(t) (about all three axes, its magnitude varying) for `seconds` with a known C,
    /// mocap attitudes at 200 Hz (arriving 12 ms late) and telemetry at 100 Hz stamped by a
    /// clock t_v = t + offset + drift·t; returns the alignment's fit.
    fn fly(
        g: GyroAlignment,
        c: Rot<MocapBody, Body>,
        offset: Nanos,
        drift_ppm: f64,
        seconds: i64,
    ) -> (GyroAlignment, Option<GyroFit>) {
        fly_with_gap(g, c, offset, drift_ppm, seconds, 0..0)
    }

    /// [`fly`] with the telemetry frames that end in `lost_ms` lost on the link.
    fn fly_with_gap(
        g: GyroAlignment,
        c: Rot<MocapBody, Body>,
        offset: Nanos,
        drift_ppm: f64,
        seconds: i64,
        lost_ms: std::ops::Range<i64>,
    ) -> (GyroAlignment, Option<GyroFit>) {
        fly_for(g, c, offset, drift_ppm, seconds * 1000, lost_ms)
    }

    /// [`fly_with_gap`] for `duration_ms` milliseconds.
    fn fly_for(
        g: GyroAlignment,
        c: Rot<MocapBody, Body>,
        offset: Nanos,
        drift_ppm: f64,
        duration_ms: i64,
        lost_ms: std::ops::Range<i64>,
    ) -> (GyroAlignment, Option<GyroFit>) {
        let mut g = g;
        for e in arrivals(c, offset, drift_ppm, duration_ms, lost_ms) {
            e.deliver(&mut g);
        }
        let fit = g.estimate();
        (g, fit)
    }

    /// What reaches the alignment, in order of arrival.
    enum Arrival {
        Mocap(Nanos, Rot<MocapBody, MocapNav>),
        Telemetry(TelemetryFrame),
    }

    impl Arrival {
        fn deliver(self, g: &mut GyroAlignment) {
            match self {
                Arrival::Mocap(t, a) => g.add_mocap(t, a),
                Arrival::Telemetry(f) => g.add_telemetry(&f),
            }
        }
    }

    /// A telemetry frame of a vehicle at rest: number `seq`, [t0, t0 + span).
    fn at_rest(seq: u32, t0: Nanos, span: Nanos) -> TelemetryFrame {
        TelemetryFrame { seq, t0, t1: t0 + span, gyro_mean: Vec3::zeros() }
    }

    /// The flight of [`fly_for`], as the frames it delivers in their order of arrival.
    fn arrivals(
        c: Rot<MocapBody, Body>,
        offset: Nanos,
        drift_ppm: f64,
        duration_ms: i64,
        lost_ms: std::ops::Range<i64>,
    ) -> Vec<Arrival> {
        let mut out = Vec::new();
        let omega = |t: f64| {
            Vec3::<Body>::new(
                0.6 * (3.0 * t).cos() * (1.0 + 0.5 * (0.7 * t).sin()),
                0.5 * (2.0 * t).sin(),
                0.2 + 0.3 * (1.3 * t).sin(),
            )
        };
        let stamp = |t: Nanos| Nanos(t.0 + offset.0 + (t.0 as f64 * drift_ppm * 1e-6).round() as i64);
        let mut att: Rot<Body, Nav> = Rot::identity();
        let (mut seq, mut gyro_sum) = (0, Vec3::<Body>::zeros());
        let mut mocap_queue = std::collections::VecDeque::new();
        let fine = 20;
        for ms in 0..duration_ms {
            let t = Nanos::from_millis(ms);
            if ms % 5 == 0 {
                mocap_queue.push_back((t, (att * c).assume_frames::<MocapBody, MocapNav>()));
            }
            for j in 0..fine {
                let w = omega((ms as f64 + (j as f64 + 0.5) / fine as f64) * 1e-3);
                gyro_sum += w * (1.0 / fine as f64);
                att = att * Rot::<Body, Body>::from_rotation_vector(w * (1e-3 / fine as f64));
            }
            if (ms + 1) % 10 == 0 {
                let (t0, t1) = (Nanos::from_millis(ms - 9), Nanos::from_millis(ms + 1));
                if !lost_ms.contains(&(ms + 1)) {
                    out.push(Arrival::Telemetry(TelemetryFrame {
                        seq,
                        t0: stamp(t0),
                        t1: stamp(t1),
                        gyro_mean: gyro_sum * 0.1,
                    }));
                }
                seq += 1;
                gyro_sum = Vec3::zeros();
            }
            while let Some(&(tc, a)) = mocap_queue.front() {
                if tc + Nanos::from_millis(12) > t {
                    break;
                }
                out.push(Arrival::Mocap(tc, a));
                mocap_queue.pop_front();
            }
        }
        out
    }

    fn gyro() -> GyroAlignment {
        GyroAlignment::new(Nanos::from_millis(5), Nanos::from_millis(10), Nanos::from_millis(40))
    }

    /// An unsynchronised clock, 13.3 ms ahead and 200 ppm fast: taken for the Vicon's it turns C
    /// (by 0.15° for this motion, whose rate vector turns slowly); fitted, the offset at the windows' mean time and the drift come
    /// out within their intervals and C within 0.01°.
    #[test]
    fn fits_an_unsynchronised_telemetry_clock() {
        let c: Rot<MocapBody, Body> = Rot::from_euler(Euler::from_degrees(0.5, 0.3, -3.0));
        let (offset, drift) = (Nanos::from_micros(13_300), 200.0);
        let (_, naive) = fly(gyro(), c, offset, drift, 20);
        let naive = naive.unwrap();
        assert!((naive.rotation.inverse() * c).angle().to_degrees() > 0.1, "{:?}", naive.euler.to_degrees());
        let (g, fit) = fly(gyro().estimate_clock(ClockSearch::default()), c, offset, drift, 20);
        let fit = fit.unwrap_or_else(|| panic!("no fit: {} windows, {} dropped", g.windows(), g.dropped()));
        let k = fit.clock.unwrap();
        let truth = offset.as_secs_f64() + drift * 1e-6 * k.t_mean_s;
        assert!(
            (k.offset_s - truth).abs() < 3.0 * k.offset_sigma_s + 1e-6,
            "offset {} vs {truth} (σ {})",
            k.offset_s,
            k.offset_sigma_s
        );
        assert!(k.offset_sigma_s < 1e-4, "{k:?}");
        let (d, sd) = (k.drift_ppm.unwrap(), k.drift_sigma_ppm.unwrap());
        assert!(
            (d - drift).abs() < 3.0 * sd + 1.0 && sd < 50.0,
            "drift {d} ± {sd}: the 200 ppm resolved at 4σ at least"
        );
        assert!((fit.rotation.inverse() * c).angle().to_degrees() < 0.01, "{:?}", fit.euler.to_degrees());
        assert!(g.windows() > 450, "{} windows, {} dropped", g.windows(), g.dropped());
    }

    /// The clock search on a synchronised clock finds offset 0 and no drift, and C as well as
    /// the plain alignment does; an offset or a drift beyond the searched range is no fit, not a
    /// wrong one.
    #[test]
    fn the_clock_search_finds_nothing_where_there_is_nothing_and_stops_at_its_range() {
        let c: Rot<MocapBody, Body> = Rot::from_euler(Euler::from_degrees(-1.0, 2.0, 5.0));
        let (_, fit) = fly(gyro().estimate_clock(ClockSearch::default()), c, Nanos::ZERO, 0.0, 16);
        let fit = fit.unwrap();
        // with a short search the telemetry is ready before the mocap (12 ms late): each window
        // waits for the frames after t_b that its interpolation needs, so none after the first is dropped
        let (g, short) = fly(
            gyro().estimate_clock(ClockSearch { max_offset: Nanos::from_millis(3), ..ClockSearch::default() }),
            c,
            Nanos::ZERO,
            0.0,
            16,
        );
        assert!(short.is_some() && g.dropped() <= 1, "{} windows, {} dropped", g.windows(), g.dropped());
        let k = fit.clock.unwrap();
        assert!(
            k.offset_s.abs() < 3.0 * k.offset_sigma_s + 1e-6
                && k.drift_ppm.unwrap().abs() < 3.0 * k.drift_sigma_ppm.unwrap() + 1.0,
            "{k:?}"
        );
        assert!((fit.rotation.inverse() * c).angle().to_degrees() < 0.01);
        let (_, beyond) = fly(
            gyro().estimate_clock(ClockSearch { max_offset: Nanos::from_millis(20), ..ClockSearch::default() }),
            c,
            Nanos::from_millis(30),
            0.0,
            16,
        );
        assert!(beyond.is_none(), "{beyond:?}");
        // likewise a drift beyond the searched range
        let (_, beyond) = fly(
            gyro().estimate_clock(ClockSearch { max_drift_ppm: 100.0, ..ClockSearch::default() }),
            c,
            Nanos::ZERO,
            300.0,
            16,
        );
        assert!(beyond.is_none(), "{beyond:?}");
    }

    /// The clock search fits from ten windows on, as the plain alignment does (`fit` needs
    /// n ≥ 10): flown until exactly 10 windows of 40 ms are paired, it gives a fit (offset 0 to
    /// 10 µs, a hundredth of the search step: noise-free, what is left is the second-order error
    /// of composing a window from 10 ms means, not the interval's 0.15 µs; C within 0.01°); one
    /// window less, none.
    #[test]
    fn the_clock_search_fits_from_ten_windows() {
        let c: Rot<MocapBody, Body> = Rot::from_euler(Euler::from_degrees(-1.0, 2.0, 5.0));
        let flown = |windows: u64| {
            (100..2000)
                .step_by(10)
                .map(|ms| fly_for(gyro().estimate_clock(ClockSearch::default()), c, Nanos::ZERO, 0.0, ms, 0..0))
                .find(|(g, _)| g.windows() == windows)
                .unwrap_or_else(|| panic!("no flight with {windows} windows"))
        };
        let (g, fit) = flown(10);
        let fit = fit.unwrap_or_else(|| panic!("no fit from {} windows ({} dropped)", g.windows(), g.dropped()));
        let k = fit.clock.unwrap();
        assert!(k.offset_s.abs() < 1e-5, "{k:?}");
        assert!((fit.rotation.inverse() * c).angle().to_degrees() < 0.01, "{:?}", fit.euler.to_degrees());
        let (_, fit) = flown(9);
        assert!(fit.is_none(), "{fit:?}");
    }

    /// A minimum within 1.5 steps of the searched range's edge is not a minimum (the clock could
    /// lie beyond it): with a 20 ms range and 1 ms steps, a clock 18.6 ms ahead is no fit, one
    /// 18.0 ms ahead is fitted (18.0 ms within its interval).
    #[test]
    fn a_clock_within_one_and_a_half_steps_of_the_range_edge_is_not_fitted() {
        let c: Rot<MocapBody, Body> = Rot::from_euler(Euler::from_degrees(-1.0, 2.0, 5.0));
        let search = ClockSearch { max_offset: Nanos::from_millis(20), ..ClockSearch::default() };
        let (_, inside) = fly(gyro().estimate_clock(search), c, Nanos::from_micros(18_000), 0.0, 16);
        let k = inside.unwrap().clock.unwrap();
        assert!((k.offset_s - 0.018).abs() < 3.0 * k.offset_sigma_s + 1e-6, "{k:?}");
        let (_, edge) = fly(gyro().estimate_clock(search), c, Nanos::from_micros(18_600), 0.0, 16);
        assert!(edge.is_none(), "{edge:?}");
    }

    /// The drift's twin of the offset edge: a drift minimum within one drift step (a tenth of the
    /// range) of the range's edge is not a minimum either. With a 1000 ppm range (steps of 100 ppm,
    /// edge at 900 ppm), a clock 960 ppm fast is no fit and one 700 ppm fast is fitted (700 ppm
    /// within its interval). A bug it catches: the edge at range + step (never reached: the golden
    /// sections stop at one step past the grid).
    #[test]
    fn a_drift_within_one_drift_step_of_the_range_edge_is_not_fitted() {
        let c: Rot<MocapBody, Body> = Rot::from_euler(Euler::from_degrees(-1.0, 2.0, 5.0));
        let search = ClockSearch { max_drift_ppm: 1000.0, ..ClockSearch::default() };
        let (_, inside) = fly(gyro().estimate_clock(search), c, Nanos::ZERO, 700.0, 16);
        let k = inside.unwrap().clock.unwrap();
        let (d, sd) = (k.drift_ppm.unwrap(), k.drift_sigma_ppm.unwrap());
        assert!((d - 700.0).abs() < 3.0 * sd + 1.0 && sd < 50.0, "drift {d} ± {sd}");
        let (_, edge) = fly(gyro().estimate_clock(search), c, Nanos::ZERO, 960.0, 16);
        assert!(edge.is_none(), "{edge:?}");
    }

    /// The pooled moments need the four grid nodes around each block's offset (the cubic through
    /// them): with a 20 ms range and 1 ms steps (nodes −20, −19, ..., 20 ms) an offset is pooled
    /// from −19 ms to 19 ms and not beyond either end (a bug it catches: the node count's `− 1` as
    /// `+ 1` extrapolated up to two steps past the last node).
    #[test]
    fn the_pooled_moments_stop_one_step_inside_the_grid() {
        let c: Rot<MocapBody, Body> = Rot::from_euler(Euler::from_degrees(-1.0, 2.0, 5.0));
        let search = ClockSearch { max_offset: Nanos::from_millis(20), ..ClockSearch::default() };
        let (g, _) = fly(gyro().estimate_clock(search), c, Nanos::ZERO, 0.0, 6);
        let n: u64 = g.blocks.iter().map(|b| b.n).sum();
        assert!(!g.blocks.is_empty() && g.blocks.iter().all(|b| b.per_offset.len() == 41), "{} blocks", g.blocks.len());
        let t_mean = g.blocks.iter().map(|b| b.sum_t).sum::<f64>() / n as f64;
        let pooled = |ms: f64| g.pooled(&search, t_mean, ms * 1e-3, 0.0).is_some();
        assert!(pooled(-18.99) && pooled(0.0) && pooled(18.99));
        assert!(!pooled(-19.01) && !pooled(19.01) && !pooled(20.5) && !pooled(-20.5));
    }

    /// Every window of the clock search's grid is either paired or dropped: with 0.1 s of
    /// telemetry lost, some windows are dropped (those whose span at some candidate offset
    /// reaches into the gap, at least 100/40 of them), and paired + dropped is the gapless
    /// flight's count.
    #[test]
    fn a_window_is_paired_or_dropped() {
        let c: Rot<MocapBody, Body> = Rot::from_euler(Euler::from_degrees(-1.0, 2.0, 5.0));
        let (whole, _) = fly(gyro().estimate_clock(ClockSearch::default()), c, Nanos::ZERO, 0.0, 8);
        let (gap, _) = fly_with_gap(gyro().estimate_clock(ClockSearch::default()), c, Nanos::ZERO, 0.0, 8, 4000..4100);
        assert!(gap.dropped() >= 3 && gap.dropped() < 20, "{} windows, {} dropped", gap.windows(), gap.dropped());
        assert_eq!(
            gap.windows() + gap.dropped(),
            whole.windows() + whole.dropped(),
            "{} + {} against {} + {}",
            gap.windows(),
            gap.dropped(),
            whole.windows(),
            whole.dropped()
        );
    }

    /// A frame that arrives after a newer one (a jittery link reorders them) is waited for: the
    /// attitude between frame times is the slerp of the *nearest* frames, so nothing is
    /// interpolated until every nearer frame has had [`NEIGHBOUR_PERIODS`] periods to arrive.
    /// Frames 0, 5, 15 ms are in and 10 ms is late: at 7 ms there is no answer yet (the slerp of
    /// 5 and 15 ms would give 14° instead of the truth); once 10 and 20 ms are in, it is the
    /// slerp of 10° and 12° at s = (7 − 5)/(10 − 5) = 0.4: 10.8°.
    #[test]
    fn interpolation_waits_for_a_frame_that_arrives_late() {
        let mut g = GyroAlignment::new(Nanos::from_millis(5), Nanos::from_millis(10), Nanos::from_millis(100));
        let yaw = |deg: f64| Rot::<MocapBody, MocapNav>::from_euler(Euler::from_degrees(0.0, 0.0, deg));
        for (ms, deg) in [(0, 0.0), (5, 10.0), (15, 30.0)] {
            g.add_mocap(Nanos::from_millis(ms), yaw(deg));
        }
        assert!(g.mocap_interp(Nanos::from_millis(7)).is_none(), "interpolated across a frame still on its way");
        for (ms, deg) in [(10, 12.0), (20, 40.0)] {
            g.add_mocap(Nanos::from_millis(ms), yaw(deg));
        }
        let a = g.mocap_interp(Nanos::from_millis(7)).expect("every nearer frame is in");
        assert!((a.euler().yaw.to_degrees() - 10.8).abs() < 1e-9, "{}°", a.euler().yaw.to_degrees());
    }

    /// Without the clock search (the paper's mode) a window whose mocap frame at an end never comes
    /// waits until the mocap is more than half the ring (128 periods, 640 ms at 5 ms) past its end,
    /// and is dropped then. Telemetry at rest over [0, 200) ms makes five 40 ms windows; the mocap
    /// frame at 120 ms is missing, so [80, 120] and [120, 160] cannot be paired: with frames to 760
    /// ms (640 ms past 120) the three others are paired and nothing is dropped yet, at 765 ms [80,
    /// 120] goes, past 800 ms [120, 160]. A bug it catches: a stale window never dropped (the guard
    /// as `false`).
    #[test]
    fn without_the_clock_search_a_window_missing_a_frame_is_dropped_half_a_ring_later() {
        let mut g = gyro();
        for seq in 0..20 {
            g.add_telemetry(&at_rest(seq, Nanos::from_millis(10 * seq as i64), Nanos::from_millis(10)));
        }
        let mocap_to = |g: &mut GyroAlignment, from: i64, to: i64| {
            for ms in (from..=to).step_by(5).filter(|ms| *ms != 120) {
                g.add_mocap(Nanos::from_millis(ms), Rot::identity());
            }
        };
        mocap_to(&mut g, 0, 760);
        assert_eq!((g.windows(), g.dropped()), (3, 0), "(paired, dropped) at 760 ms");
        mocap_to(&mut g, 765, 765);
        assert_eq!((g.windows(), g.dropped()), (3, 1), "(paired, dropped) at 765 ms");
        mocap_to(&mut g, 770, 800);
        assert_eq!(g.dropped(), 1, "[120, 160] waits to 800 ms");
        mocap_to(&mut g, 805, 805);
        assert_eq!((g.windows(), g.dropped()), (3, 2), "(paired, dropped) at 805 ms");
    }

    /// The clock search pairs a window only once the mocap is [`NEIGHBOUR_PERIODS`] periods past
    /// its end, so a window-end frame that a jittery link delivers after two newer ones still
    /// counts: the first window is [40, 80] ms, its frames arrive …, 75, 85, 90, 80, 95 ms, and it
    /// is paired (one window, none dropped). A bug it catches: the wait `period · 3` as `period +
    /// 3` (3 ns) tried it at 90 ms, before frame 80 was in, and dropped it.
    #[test]
    fn the_clock_search_waits_for_a_window_end_frame_that_arrives_late() {
        let mut g = gyro().estimate_clock(ClockSearch { max_offset: Nanos::from_millis(3), ..ClockSearch::default() });
        for seq in 0..20 {
            let t0 = Nanos::from_millis(10 * seq as i64);
            g.add_telemetry(&at_rest(seq, t0, Nanos::from_millis(10)));
        }
        let frames = (0..=75).step_by(5).chain([85, 90, 80, 95]);
        for ms in frames {
            g.add_mocap(Nanos::from_millis(ms), Rot::identity());
        }
        assert_eq!((g.windows(), g.dropped()), (1, 0), "(paired, dropped)");
    }

    /// The clock search drops a window whose mocap frame at either end is missing, and holds only
    /// the telemetry a later window can need. A 3 ms search, telemetry at rest over [0, 200) ms,
    /// mocap every 5 ms to 200 ms but for 120 ms: windows k < ⌊min(200 − 15, 190 − 3)/40⌋ = 4
    /// are ready, [40, 80] is paired and [80, 120], [120, 160] are dropped. The last window
    /// starts at 120 ms, so frames that end before 117 ms are let go: the 9 frames from
    /// [110, 120) on stay (all 20, kept forever, would be a leak on a long flight).
    #[test]
    fn the_clock_search_drops_a_window_without_its_mocap_frames_and_lets_old_telemetry_go() {
        let flown = |max_offset_ms: i64| {
            let mut g = gyro().estimate_clock(ClockSearch {
                max_offset: Nanos::from_millis(max_offset_ms),
                ..ClockSearch::default()
            });
            for seq in 0..20 {
                g.add_telemetry(&at_rest(seq, Nanos::from_millis(10 * seq as i64), Nanos::from_millis(10)));
            }
            for ms in (0..=200).step_by(5).filter(|ms| *ms != 120) {
                g.add_mocap(Nanos::from_millis(ms), Rot::identity());
            }
            g
        };
        let g = flown(3);
        assert_eq!((g.windows(), g.dropped()), (1, 2), "(paired, dropped)");
        assert_eq!(g.frames.len(), 9, "telemetry frames held");
        assert_eq!(g.frames.front().map(|f| f.t0), Some(Nanos::from_millis(110)));
        // With a 10 ms search, t_a − max_offset = 110 ms is a frame end: [100, 110) stays, since at
        // δ just above −10 ms window [120, 160] covers [110, 120) in part, and that frame's
        // parabola takes the mean of [100, 110) (a bug it catches: `<` as `<=` let it go, and the
        // frame took its own mean instead)
        let g = flown(10);
        assert_eq!(g.frames.front().map(|f| f.t0), Some(Nanos::from_millis(100)));
    }

    /// The plain alignment builds a window from consecutive telemetry frames; a frame that does not
    /// start where the open window ends restarts it, and the broken window counts as dropped.
    /// Windows of 4 frames (40 ms): frames at 0, 10 | 30, 40 | 60, 70, 80, 90 ms break two windows
    /// and complete one, [60, 100] ms, which waits for its mocap: telemetry that arrives before the
    /// first mocap frame is not lost (it was, through an overflow of `i64::MIN − t_b` that a debug
    /// build panicked on); with the frames in, it is paired. A bug it catches: the count `+= 1` as
    /// `-= 1`.
    #[test]
    fn a_telemetry_gap_drops_the_open_window() {
        let mut g = gyro();
        for (seq, ms) in [0, 10, 30, 40, 60, 70, 80, 90].into_iter().enumerate() {
            let t0 = Nanos::from_millis(ms);
            g.add_telemetry(&at_rest(seq as u32, t0, Nanos::from_millis(10)));
        }
        assert_eq!((g.windows(), g.dropped()), (0, 2), "(paired, dropped) before any mocap");
        for ms in (50..=110).step_by(5) {
            g.add_mocap(Nanos::from_millis(ms), Rot::identity());
        }
        assert_eq!((g.windows(), g.dropped()), (1, 2), "(paired, dropped) with the mocap in");
    }

    /// A window waits for its mocap frames in one of 16 slots; with all 16 taken, a new window
    /// evicts the oldest (the one whose frames are least likely to come) and counts it as dropped.
    /// 20 windows of 40 ms arrive before any mocap: windows 0–3 are evicted, 4 dropped. Mocap
    /// frames up to 200 ms then pair window 4 ([160, 200] ms) alone (had the newest been evicted,
    /// 0–4 would pair), and frames up to 800 ms the other 15. A bug it catches: the eviction's
    /// count `+= 1` as `-= 1` passed the unit tests.
    #[test]
    fn a_window_without_a_free_slot_evicts_the_oldest_and_counts_it_dropped() {
        let mut g = gyro();
        for seq in 0..80u32 {
            g.add_telemetry(&at_rest(seq, Nanos::from_millis(10 * seq as i64), Nanos::from_millis(10)));
        }
        assert_eq!((g.windows(), g.dropped()), (0, 4), "(paired, dropped) before any mocap");
        for ms in (0..=200).step_by(5) {
            g.add_mocap(Nanos::from_millis(ms), Rot::identity());
        }
        assert_eq!((g.windows(), g.dropped()), (1, 4), "(paired, dropped) with the mocap to 200 ms");
        for ms in (205..=800).step_by(5) {
            g.add_mocap(Nanos::from_millis(ms), Rot::identity());
        }
        assert_eq!((g.windows(), g.dropped()), (16, 4), "(paired, dropped) with the mocap to 800 ms");
    }

    /// A window is `window` long on the Vicon clock, to 1/1000: four telemetry frames of a clock
    /// 0.05 % fast (40.02 ms, 20 µs off) make a window that is paired, four of a clock 0.2 % fast
    /// (40.08 ms, 80 µs off, over the 40 µs bound) one that is dropped. A bug it catches: the
    /// span's difference `−` as `/` (a ratio near 1, always within the bound).
    #[test]
    fn a_window_off_its_length_by_more_than_a_thousandth_is_dropped() {
        for (period_ns, expected) in [(10_005_000, (1, 0)), (10_020_000, (0, 1))] {
            let mut g = gyro();
            for ms in (0..=100).step_by(5) {
                g.add_mocap(Nanos::from_millis(ms), Rot::identity());
            }
            for seq in 0..4 {
                let t0 = Nanos(period_ns * seq as i64);
                g.add_telemetry(&at_rest(seq, t0, Nanos(period_ns)));
            }
            assert_eq!((g.windows(), g.dropped()), expected, "(paired, dropped) with frames of {period_ns} ns");
        }
    }

    /// The clock search's estimate does not depend on the order in which telemetry and mocap
    /// arrive: the flight of [`fly`] (a clock 17 ms ahead, searched up to 20 ms) gives the same
    /// fit, to the bit, as delivered (telemetry first, mocap 12 ms late), with its telemetry 40 ms
    /// late instead, and with all its telemetry before any mocap. A window is paired only once a
    /// telemetry frame starting at or after t_b + max_offset is in, so the frame that covers t_b +
    /// δ in part (at the nodes next to the 17 ms minimum) has its next neighbour for the parabola
    /// in every order. A bug it catches: the gate's `<` as `<=`; the gate then (the newest frame's
    /// *end* at t_b + max_offset) paired a window with late telemetry while the frame after [t_b +
    /// 17, t_b + 27] ms was still on its way, and that frame's own mean stood in for its
    /// neighbour's.
    #[test]
    fn the_clock_search_does_not_depend_on_the_order_of_arrival() {
        let c: Rot<MocapBody, Body> = Rot::from_euler(Euler::from_degrees(-1.0, 2.0, 5.0));
        let (offset, search) =
            (Nanos::from_millis(17), ClockSearch { max_offset: Nanos::from_millis(20), ..ClockSearch::default() });
        let fed = |telemetry_lag: Option<Nanos>| {
            let mut order = arrivals(c, offset, 0.0, 4000, 0..0);
            // arrival times: a mocap frame 12 ms after its capture, a telemetry frame at the end
            // of its interval (on the arena's clock) plus the lag; None: all telemetry first
            let at = |e: &Arrival| match (e, telemetry_lag) {
                (Arrival::Mocap(t, _), _) => *t + Nanos::from_millis(12),
                (Arrival::Telemetry(f), Some(lag)) => f.t1 - offset + lag,
                (Arrival::Telemetry(_), None) => Nanos(i64::MIN),
            };
            order.sort_by_key(|e| at(e)); // stable: equal times keep the order of delivery
            let mut g = gyro().estimate_clock(search);
            for e in order {
                e.deliver(&mut g);
            }
            let fit = g.estimate().unwrap_or_else(|| panic!("no fit from {} windows", g.windows()));
            assert!(g.windows() > 90, "{} windows", g.windows());
            ((g.windows(), g.dropped()), format!("{fit:?}"))
        };
        let telemetry_first = fed(None);
        assert_eq!(fed(Some(Nanos::ZERO)), telemetry_first, "as delivered");
        assert_eq!(fed(Some(Nanos::from_millis(40))), telemetry_first, "telemetry 40 ms late");
    }

    /// The telemetry gate at its edge: with a 10 ms search, window [40, 80] ms needs telemetry
    /// up to 90 ms and is paired as soon as a frame starting at exactly 90 ms is in (the frames
    /// end there; all mocap is in). Window [80, 120] waits for a frame starting at 130 ms.
    #[test]
    fn a_window_is_paired_once_a_frame_starts_at_its_end_plus_the_search() {
        let mut g = gyro().estimate_clock(ClockSearch { max_offset: Nanos::from_millis(10), ..ClockSearch::default() });
        for ms in (0..=200).step_by(5) {
            g.add_mocap(Nanos::from_millis(ms), Rot::identity());
        }
        for seq in 0..10 {
            let t0 = Nanos::from_millis(10 * seq as i64);
            g.add_telemetry(&at_rest(seq, t0, Nanos::from_millis(10)));
        }
        assert_eq!((g.windows(), g.dropped()), (1, 0), "(paired, dropped) with frames up to [90, 100] ms");
    }

    /// Each extra parameter of a fit (the clock search's offset and drift) is one degree of freedom
    /// fewer: on the same moments of n windows, the variance with two extra parameters is (3n −
    /// 6)/(3n − 8) times the variance with none (n = 10: 24/22). A bug it catches: the `− extra` as
    /// `+ extra` gave (3n − 6)/(3n − 4).
    #[test]
    fn extra_parameters_take_degrees_of_freedom() {
        // a 13 ms clock offset the plain alignment ignores leaves residuals to scale
        let (g, _) = fly_for(
            gyro(),
            Rot::from_euler(Euler::from_degrees(-1.0, 2.0, 5.0)),
            Nanos::from_millis(13),
            0.0,
            600,
            0..0,
        );
        let (n, m) = (g.windows() as f64, g.moments());
        let ((_, rss, none), (_, _, two)) = (g.fit(&m, 0).unwrap(), g.fit(&m, 2).unwrap());
        assert!(rss > 0.0 && (10.0..20.0).contains(&n), "rss {rss}, {n} windows");
        let ratio = two[(0, 0)] / none[(0, 0)];
        assert!((ratio - (3.0 * n - 6.0) / (3.0 * n - 8.0)).abs() < 1e-12, "{ratio} from {n} windows");
    }

    /// The clock offset's interval is the residual's curvature: with one clock parameter (one time
    /// block, so no drift) σ_δ² = 2·σ²/(∂²RSS/∂δ²), σ² = RSS₀/(3n − 7): 3n residual components less
    /// the rotation's 3, the bias's 3 and the offset's 1 degrees of freedom. Here the curvature by
    /// a central difference of 0.1 ms about the fitted offset (the fit's own uses a quarter step,
    /// 0.25 ms) on 1 s of flight with a 13 ms offset: 21 windows, so 3n − 7 = 56 against 3n − 5 =
    /// 58 or 3n + 5 = 68 moves σ_δ² by 3.6 % or more; the two agree to 0.04 % (the tolerance is 1
    /// %). A bug it catches: the degrees of freedom as 3n + 6 − extra, 3n − 6 + extra and 3n/6 −
    /// extra (the tests bounded the clock's σ only from above).
    #[test]
    fn the_clock_offset_sigma_is_the_residual_variance_over_the_curvature() {
        let search = ClockSearch::default();
        let c: Rot<MocapBody, Body> = Rot::from_euler(Euler::from_degrees(-1.0, 2.0, 5.0));
        let (g, fit) = fly_for(gyro().estimate_clock(search), c, Nanos::from_millis(13), 0.0, 1000, 0..0);
        let k = fit.unwrap().clock.unwrap();
        let n = g.blocks.iter().map(|b| b.n).sum::<u64>() as f64;
        assert!(
            g.blocks.len() == 1 && k.drift_ppm.is_none() && (15.0..40.0).contains(&n),
            "{} blocks, {n} windows",
            g.blocks.len()
        );
        let rss = |d: f64| g.fit(&g.pooled(&search, k.t_mean_s, d, 0.0).unwrap(), 1).unwrap().1;
        let (d, h) = (k.offset_s, 1e-4);
        let (r0, curvature) = (rss(d), (rss(d + h) - 2.0 * rss(d) + rss(d - h)) / (h * h));
        let expected = 2.0 * r0 / (3.0 * n - 7.0) / curvature;
        let ratio = k.offset_sigma_s.powi(2) / expected;
        assert!(
            r0 > 0.0 && (ratio - 1.0).abs() < 0.01,
            "σ² {} s² against {expected} s² by hand ({n} windows, RSS {r0})",
            k.offset_sigma_s.powi(2)
        );
    }

    /// The partial-frame integral against closed forms: ω(s) = s (means −½, ½, 3/2) integrates
    /// to x²/2, ω(s) = s² (means 1/3, 1/3, 7/3) to x³/3; a whole frame gives its mean.
    #[test]
    fn partial_frame_integral_is_exact_for_parabolas() {
        let v = |x: f64| Vector3::new(x, 0.0, 0.0);
        for x in [0.0, 0.25, 0.5, 0.8, 1.0] {
            assert!((partial_rate_integral(v(-0.5), v(0.5), v(1.5), x).x - x * x / 2.0).abs() < 1e-15);
            assert!(
                (partial_rate_integral(v(1.0 / 3.0), v(1.0 / 3.0), v(7.0 / 3.0), x).x - x * x * x / 3.0).abs() < 1e-15
            );
        }
        assert!((partial_rate_integral(v(3.0), v(-2.0), v(7.0), 1.0).x + 2.0).abs() < 1e-15);
    }

    /// The gyro increment over a window that cuts frames, by hand: a rate along a fixed axis u
    /// growing linearly, ω(t) = (a + b·t)·u, read as 10 ms frames whose means are its values at the
    /// frames' midpoints. Over [23, 67] ms it turns by (a·(u₁ − u₀) + b·(u₁² − u₀²)/2)·u exactly:
    /// the parabola through a frame's and its contiguous neighbours' means is the line itself. A
    /// frame missing under the window gives `None`. A bug it catches: the neighbour taken only
    /// where it is *not* contiguous (`g.t1 == f.t0` as `!=`; the partial frame then leans on its
    /// own mean, of order 1e-5 rad off here), and `next` read at i − 1.
    #[test]
    fn the_gyro_increment_over_cut_frames_integrates_a_linear_rate_exactly() {
        let (a, b) = (0.3, 2.0); // rad/s, rad/s²
        let u = Vector3::new(0.6, 0.0, 0.8);
        let frame = |k: i64| {
            let mid = (10 * k) as f64 * 1e-3 + 0.005;
            TelemetryFrame {
                seq: k as u32,
                t0: Nanos::from_millis(10 * k),
                t1: Nanos::from_millis(10 * k + 10),
                gyro_mean: Vec3::from_raw(u * (a + b * mid)),
            }
        };
        let mut g = GyroAlignment::new(Nanos::from_millis(5), Nanos::from_millis(10), Nanos::from_millis(50));
        g.frames = (0..10).map(frame).collect();
        let (u0, u1) = (0.023, 0.067);
        let want = u * (a * (u1 - u0) + b * (u1 * u1 - u0 * u0) / 2.0);
        let got =
            g.gyro_increment(Nanos::from_secs_f64(u0), Nanos::from_secs_f64(u1)).expect("frames cover the window");
        assert!((got - want).amax() < 1e-15, "{got} vs {want}");
        g.frames.remove(4);
        assert_eq!(g.gyro_increment(Nanos::from_secs_f64(u0), Nanos::from_secs_f64(u1)), None, "40-50 ms missing");
    }

    /// The clock's Hessian by hand: f(x, y) = 3 + 0.7x − 1.1y + 2x² + 0.8xy + 5y² has H = [[4,
    /// 0.8], [0.8, 10]] everywhere, read off at the origin (where the slope is not 0, so a
    /// one-sided difference would be off) and at (0.3, −0.2) (a point read at x − d in one
    /// coordinate gives H₀₁ = −0.8) with steps (0.5, 0.25); over x alone, [[4]]. The unit tests'
    /// flights cannot tell: their clocks, parameterised at the windows' mean time, have H₀₁ ≈ 0 and
    /// a slope ≈ 0 at the fitted minimum (a bug it catches: a sign lost in the cross difference;
    /// the one-sided diagonal by nothing).
    #[test]
    fn the_clock_hessian_is_exact_for_a_quadratic() {
        let f = |d: [f64; 2]| 3.0 + 0.7 * d[0] - 1.1 * d[1] + 2.0 * d[0] * d[0] + 0.8 * d[0] * d[1] + 5.0 * d[1] * d[1];
        let want = nalgebra::DMatrix::from_row_slice(2, 2, &[4.0, 0.8, 0.8, 10.0]);
        for x in [[0.0; 2], [0.3, -0.2]] {
            let h = central_hessian(f, x, f(x), [0.5, 0.25], 2);
            assert!((&h - &want).amax() < 1e-12, "at {x:?}: {h}");
        }
        let h = central_hessian(f, [0.0; 2], f([0.0; 2]), [0.5, 0.25], 1);
        assert_eq!(h.shape(), (1, 1));
        assert!((h[(0, 0)] - 4.0).abs() < 1e-12, "{h}");
    }

    /// C's sensitivity to the clock by hand: g(x) = exp([u·(2x₀ − 3x₁)]×) about the unit axis u =
    /// (0.6, 0, 0.8) has Jacobian columns 2u and −3u everywhere, read at (0.3, −0.2) (a point read
    /// at x − d in one coordinate flips that column) with steps (0.5, 0.25); over x₀ alone, 2u. A bug it catches: the drift's column read at x − d.
    #[test]
    fn the_clock_jacobian_is_exact_for_a_rotation_linear_in_the_clock() {
        let u = [0.6, 0.0, 0.8];
        let g = |c: [f64; 2]| {
            Some(Rot::<Body, Body>::from_rotation_vector(Vec3::from_array(u.map(|k| k * (2.0 * c[0] - 3.0 * c[1])))))
        };
        let jac = central_rotation_jacobian(g, [0.3, -0.2], [0.5, 0.25], 2).unwrap();
        let want = nalgebra::DMatrix::from_row_slice(3, 2, &[1.2, -1.8, 0.0, 0.0, 1.6, -2.4]);
        assert!((&jac - &want).amax() < 1e-12, "{jac}");
        let jac = central_rotation_jacobian(g, [0.3, -0.2], [0.5, 0.25], 1).unwrap();
        assert!((&jac - want.columns(0, 1)).amax() < 1e-12, "{jac}");
        assert!(central_rotation_jacobian(|_| None::<Rot<Body, Body>>, [0.0; 2], [0.5, 0.25], 2).is_none());
    }

    /// Not knowing the clock can only widen C's interval: by the law of total variance, Var(Ĉ) =
    /// Var(Ĉ | clock) + Var(E[Ĉ | clock]) ≈ Σ_C + J·Σ_clock·Jᵀ, so each σ_k² is at least the fit's
    /// own at the fitted clock held fixed, and above it where C moves with the clock (the 13.3 ms
    /// offset of [`fits_an_unsynchronised_telemetry_clock`]'s flight turns C by 0.15° when it is
    /// ignored). A bug it catches: Σ_C − J·Σ_clock·Jᵀ (a narrower interval).
    #[test]
    fn not_knowing_the_clock_widens_the_rotation_interval_and_never_narrows_it() {
        let c: Rot<MocapBody, Body> = Rot::from_euler(Euler::from_degrees(0.5, 0.3, -3.0));
        let (g, fit) = fly(gyro().estimate_clock(ClockSearch::default()), c, Nanos::from_micros(13_300), 200.0, 20);
        let fit = fit.unwrap();
        let k = fit.clock.unwrap();
        let m = g.pooled(g.search.as_ref().unwrap(), k.t_mean_s, k.offset_s, k.drift_ppm.unwrap() * 1e-6).unwrap();
        let (_, _, cov_fixed) = g.fit(&m, 2).unwrap();
        let var = fit.sigma.map(|s| s * s);
        for i in 0..3 {
            assert!(
                var[i] >= cov_fixed[(i, i)] * (1.0 - 1e-9),
                "axis {i}: σ² {} below the fixed clock's {}",
                var[i],
                cov_fixed[(i, i)]
            );
        }
        // this noise-free flight pins the clock to microseconds, so J·Σ_clock·Jᵀ adds only ~0.4 %
        // (axis x) to Σ_C; the bound 10⁻⁴ is still far above their rounding (relative ~10⁻¹⁶)
        assert!(
            (0..3).any(|i| var[i] > (1.0 + 1e-4) * cov_fixed[(i, i)]),
            "σ² {var:?} against the fixed clock's {cov_fixed}"
        );
    }
}

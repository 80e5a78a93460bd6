//! The ground station of one vehicle: what runs on the arena's control computers each time a
//! Vicon packet arrives — velocity estimation, guidance, the paper's calibration, and the
//! controller of (1)–(5) fed with the offset-compensated attitude.

use crate::calibrate::{
    ClockSearch, GyroAlignment, GyroFit, HoverAverager, LineFit, OffsetEstimate, Rls, Validity, ValidityCheck, batch_ls,
};
use crate::clock::Nanos;
use crate::control::{ControlOutput, Gains, LateralMode, Reference, control, failsafe};
use crate::estimate::VelocityEstimator;
use crate::frames::{Body, Euler, MocapNav, Rot, Vec3};
use crate::guidance::{Plan, Window};
use crate::mocap::MocapFrame;
use crate::scenario::{CalibrationSettings, FailsafeSettings};
use crate::vehicle::TelemetryFrame;

/// Shortest window of the gyro alignment (attitude increments over ≥ 40 ms: long enough that
/// the mocap noise is small against the rotation, short enough that composition stays exact).
const GYRO_WINDOW_MIN: Nanos = Nanos(40_000_000);

/// What the failsafe did during a run.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct FailsafeReport {
    /// How many times the failsafe took over.
    pub episodes: u32,
    /// Time spent in failsafe (s).
    pub total_s: f64,
    /// The longest episode (s).
    pub longest_s: f64,
    /// When the first episode began (s).
    pub first_at_s: Option<f64>,
    /// Whether the run ended in failsafe.
    pub active_at_end: bool,
}

/// What the calibration found (angles in radians).
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct CalibrationReport {
    /// (φ̄_m, θ̄_m) and the number of samples averaged.
    pub roll_pitch: Option<(f64, f64, u64)>,
    /// The straight flight's batch least-squares line fit (9).
    pub yaw_ls: Option<LineFit>,
    /// The same fit by recursive least squares (R3 compares the two).
    pub yaw_rls: Option<LineFit>,
    /// The yaw offset estimate: ψ̂_off = ψ̂_off,before + ψ̄_m − course, with the course from the
    /// batch fit (9). The paper assumes the held yaw ψ̄_m is 0; here the PPM yaw-rate quantization
    /// lets it sit anywhere in a ±0.5 count/K_ψ deadband (±0.25° by default), so it is added back.
    pub yaw_offset: Option<f64>,
    /// The validity check (7) of the straight flight.
    pub validity: Option<Validity>,
    /// The full mocap-to-body rotation from gyro telemetry, at the end of calibrate_gyro.
    pub gyro: Option<GyroFit>,
    /// The offset the controller used at the end of the run.
    pub applied: Euler,
    /// The roll trim of the straight flight: the mean roll command of the hover average (rad;
    /// with `hover_trim` only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub roll_trim: Option<f64>,
}

/// The running hover average as it converged (for recording), rad.
#[derive(Clone, Copy, Debug)]
pub struct HoverSample {
    /// When.
    pub t: Nanos,
    /// The running mean of the measured roll (rad).
    pub roll: f64,
    /// The running mean of the measured pitch (rad).
    pub pitch: f64,
}

/// One RLS estimate as it converged (for recording).
#[derive(Clone, Copy, Debug)]
pub struct RlsSample {
    /// When.
    pub t: Nanos,
    /// The yaw offset estimate so far (rad).
    pub psi_offset: f64,
}

/// The ground station of one vehicle: guidance, the cascaded controller (1)–(5), the
/// calibration phases and the failsafe, fed by the mocap packets and the telemetry it receives.
#[derive(Clone, Debug)]
pub struct Station {
    plan: Plan,
    gains: Gains,
    settings: CalibrationSettings,
    estimator: VelocityEstimator,
    offset: OffsetEstimate,
    hover: HoverAverager,
    /// The commanded angles over the hover average, for the trim.
    hover_com: HoverAverager,
    north: Vec<f64>,
    east: Vec<f64>,
    rls: Rls,
    validity: ValidityCheck,
    gyro: GyroAlignment,
    window: Window,
    report: CalibrationReport,
    command: ControlOutput,
    reference: Reference,
    attitude: Option<Rot<Body, MocapNav>>,
    rls_trace: Option<Vec<RlsSample>>,
    hover_trace: Option<Vec<HoverSample>>,
    /// The guidance of the current tick (the engine and the station both need it).
    guidance: (Nanos, Reference, Window),
    fs: FailsafeSettings,
    last_pose_at: Option<Nanos>,
    /// Attitude for the failsafe: the last compensated mocap attitude, propagated with every
    /// telemetry frame since its capture; and the time it refers to.
    dead_reckoned: Option<(Rot<Body, MocapNav>, Nanos)>,
    failsafe_since: Option<Nanos>,
    failsafe_report: FailsafeReport,
}

impl Station {
    /// A station flying `plan`; `record_traces` keeps the RLS recursion's and the hover
    /// average's traces for the recording.
    pub fn new(
        plan: Plan,
        gains: Gains,
        settings: CalibrationSettings,
        fs: FailsafeSettings,
        velocity_cutoff_hz: f64,
        record_traces: bool,
    ) -> Self {
        let (reference, window0) = plan.reference(Nanos::ZERO);
        // the straight-flight samples are kept for the batch fit: reserve them once, so the loop
        // does not allocate while flying
        let yaw_samples: usize = plan
            .phases
            .iter()
            .filter(|p| matches!(p.phase, crate::guidance::Phase::CalibrateYaw { .. }))
            .map(|p| ((p.end - p.start).0 / settings.mocap_period.0.max(1)) as usize + 2)
            .max()
            .unwrap_or(0);
        let rls = Rls::new(settings.rls_min_spread_m);
        let mut gyro = GyroAlignment::new(settings.mocap_period, settings.telemetry_period, GYRO_WINDOW_MIN);
        if settings.estimate_telemetry_clock {
            gyro = gyro.estimate_clock(ClockSearch::default());
        }
        Station {
            plan,
            gains,
            settings,
            estimator: VelocityEstimator::new(velocity_cutoff_hz),
            offset: OffsetEstimate::default(),
            hover: HoverAverager::default(),
            hover_com: HoverAverager::default(),
            north: Vec::with_capacity(yaw_samples),
            east: Vec::with_capacity(yaw_samples),
            rls,
            validity: ValidityCheck::default(),
            gyro,
            window: Window::None,
            report: CalibrationReport::default(),
            command: ControlOutput {
                rates: Vec3::zeros(),
                thrust_n: 0.0,
                angles_com: Euler::ZERO,
                yaw_rate_com: 0.0,
                accel_com: Vec3::zeros(),
            },
            reference,
            attitude: None,
            rls_trace: record_traces.then(Vec::new),
            hover_trace: record_traces.then(Vec::new),
            guidance: (Nanos::ZERO, reference, window0),
            fs,
            last_pose_at: None,
            dead_reckoned: None,
            failsafe_since: None,
            failsafe_report: FailsafeReport::default(),
        }
    }

    /// The scheduled plan.
    pub fn plan(&self) -> &Plan {
        &self.plan
    }
    /// The latest command (held until the next packet).
    pub fn command(&self) -> &ControlOutput {
        &self.command
    }
    /// The latest set point.
    pub fn reference(&self) -> &Reference {
        &self.reference
    }
    /// The offset estimate the station holds.
    pub fn offset(&self) -> &OffsetEstimate {
        &self.offset
    }
    /// The attitude the controller last used (compensated).
    pub fn attitude(&self) -> Option<Rot<Body, MocapNav>> {
        self.attitude
    }
    /// The RLS estimates so far (empty unless traced).
    pub fn rls_trace(&self) -> &[RlsSample] {
        self.rls_trace.as_deref().unwrap_or(&[])
    }
    /// The hover averages so far (empty unless traced).
    pub fn hover_trace(&self) -> &[HoverSample] {
        self.hover_trace.as_deref().unwrap_or(&[])
    }

    /// The reference and calibration window at `now` (evaluated once per tick).
    pub fn guidance(&mut self, now: Nanos) -> (Reference, Window) {
        if self.guidance.0 != now {
            let (r, w) = self.plan.reference(now);
            self.guidance = (now, r, w);
        }
        (self.guidance.1, self.guidance.2)
    }

    /// Handles one body-rate telemetry frame. The failsafe's attitude is propagated with it:
    /// R ← R·exp((ω̄ − b̂_g)·(t₁ − t₀)) from the last pose on, where b̂_g is the gyro alignment's
    /// bias once it has run (and calibration is applied; 0 before), and the frame's stamps are
    /// taken to Vicon time by the alignment's fitted telemetry clock, t = t_v − δ(t_v), when it
    /// fitted one. Without b̂_g a gyro bias b tilts the dead-reckoned attitude by |b|·t.
    pub fn on_telemetry(&mut self, f: &TelemetryFrame) {
        self.gyro.add_telemetry(f);
        let fit = self.report.gyro.filter(|_| self.settings.apply);
        let bias = fit.map_or(Vec3::zeros(), |g| Vec3::from_array(g.gyro_bias));
        let clock = fit.and_then(|g| g.clock);
        let to_vicon = |t: Nanos| match &clock {
            Some(c) => {
                t - Nanos::from_secs_f64(
                    c.offset_s + c.drift_ppm.unwrap_or(0.0) * 1e-6 * (t.as_secs_f64() - c.t_mean_s),
                )
            }
            None => t,
        };
        if let Some((a, t)) = self.dead_reckoned
            && to_vicon(f.t0) >= t
        {
            self.dead_reckoned = Some((
                a * Rot::from_rotation_vector((f.gyro_mean - bias) * (f.t1 - f.t0).as_secs_f64()),
                to_vicon(f.t1),
            ));
        }
    }

    /// The failsafe's dead-reckoned attitude: the last compensated mocap attitude propagated
    /// with the telemetry since ([`Station::on_telemetry`]).
    pub fn dead_reckoned(&self) -> Option<Rot<Body, MocapNav>> {
        self.dead_reckoned.map(|(a, _)| a)
    }

    /// Once per tick: enters (or continues) the failsafe when the mocap has been silent too long.
    pub fn tick(&mut self, now: Nanos) {
        let Some(last) = self.last_pose_at else { return };
        if now - last <= self.fs.timeout {
            return;
        }
        let since = *self.failsafe_since.get_or_insert_with(|| {
            self.failsafe_report.episodes += 1;
            self.failsafe_report.first_at_s.get_or_insert(now.as_secs_f64());
            now
        });
        if let Some((att, _)) = self.dead_reckoned {
            let yaw_hold = self.reference.yaw;
            // motors that were off (on the floor before take-off or after landing) stay off
            let off = self.reference.motors_off || now - since >= self.fs.motors_off_after;
            self.command = failsafe(&self.gains, att, yaw_hold, self.fs.thrust_fraction, off);
        }
    }

    /// Whether the failsafe is active.
    pub fn in_failsafe(&self) -> bool {
        self.failsafe_since.is_some()
    }

    fn end_failsafe(&mut self, now: Nanos) {
        if let Some(since) = self.failsafe_since.take() {
            let d = (now - since).as_secs_f64();
            self.failsafe_report.total_s += d;
            self.failsafe_report.longest_s = self.failsafe_report.longest_s.max(d);
        }
    }

    /// What the failsafe did so far.
    pub fn failsafe_report(&self) -> FailsafeReport {
        self.failsafe_report
    }

    /// Handles one Vicon packet received at `now`.
    pub fn on_pose(&mut self, now: Nanos, f: &MocapFrame) {
        let vel = self.estimator.update(f.t_capture, f.pos);
        self.gyro.add_mocap(f.t_capture, f.att);
        self.last_pose_at = Some(now);
        self.end_failsafe(now);
        let (reference, window) = self.guidance(now);
        if window != self.window {
            self.close_window();
            self.window = window;
        }
        match window {
            Window::HoverAverage => {
                self.hover.add(f.att.euler());
                if let (Some(tr), Some((roll, pitch))) = (&mut self.hover_trace, self.hover.mean()) {
                    tr.push(HoverSample { t: now, roll, pitch });
                }
            }
            Window::YawFlight => {
                let comp = self.offset.compensate(f.att, self.settings.compensation);
                self.validity.add(comp.euler());
                self.north.push(f.pos.x());
                self.east.push(f.pos.y());
                self.rls.update(f.pos.x(), f.pos.y());
                if let (Some(tr), Some(est)) = (&mut self.rls_trace, self.rls.estimate()) {
                    tr.push(RlsSample { t: now, psi_offset: est.psi_offset });
                }
            }
            Window::None | Window::Spin | Window::GyroExcite => {}
        }
        let att = self.offset.compensate(f.att, self.settings.compensation);
        self.attitude = Some(att);
        self.dead_reckoned = Some((att, f.t_capture));
        self.reference = reference;
        self.command = control(&self.gains, &reference, f.pos, vel, att);
        if self.settings.hover_trim {
            match window {
                Window::HoverAverage => self.hover_com.add(self.command.angles_com),
                _ if reference.lateral == LateralMode::RollZero => {
                    self.command.angles_com.roll = self.report.roll_trim.unwrap_or(0.0)
                }
                _ => {}
            }
        }
    }

    /// Ends a calibration window: computes its result and, if enabled, applies it.
    fn close_window(&mut self) {
        match self.window {
            Window::HoverAverage => {
                if let Some((roll, pitch)) = self.hover.mean() {
                    self.report.roll_pitch = Some((roll, pitch, self.hover.samples()));
                    if self.settings.apply {
                        let yaw = self.offset.euler.yaw;
                        self.offset = OffsetEstimate::from_euler(Euler::new(roll, pitch, yaw));
                    }
                }
                self.hover = HoverAverager::default();
                if let Some((roll, _)) = self.hover_com.mean() {
                    self.report.roll_trim = Some(roll);
                }
                self.hover_com = HoverAverager::default();
            }
            Window::YawFlight => {
                let validity = self.validity.verdict(self.settings.eps_yaw, self.settings.eps_roll);
                let ls = batch_ls(&self.north, &self.east);
                self.report.yaw_ls = ls;
                self.report.yaw_rls = self.rls.estimate();
                self.report.validity = Some(validity);
                let e = self.offset.euler;
                let yaw_offset = ls.map(|ls| crate::frames::wrap_pi(e.yaw + validity.mean_yaw + ls.psi_offset));
                self.report.yaw_offset = yaw_offset;
                if let (true, true, Some(y)) = (self.settings.apply, validity.accepted, yaw_offset) {
                    self.offset = OffsetEstimate::from_euler(Euler::new(e.roll, e.pitch, y));
                }
                self.north.clear();
                self.east.clear();
                self.rls = Rls::new(self.settings.rls_min_spread_m);
                self.validity = ValidityCheck::default();
            }
            Window::GyroExcite => {
                // the fit uses every window since the start (the floor, where nothing turns,
                // helps to pin the gyro bias; hover, flights, spins), not only the circle; the gyro gives the absolute rotation, so only its yaw replaces the
                // current estimate (roll and pitch stay the paper's hover averages)
                self.report.gyro = self.gyro.estimate();
                if let (true, Some(g)) = (self.settings.apply, self.report.gyro) {
                    let e = self.offset.euler;
                    self.offset = OffsetEstimate::from_euler(Euler::new(e.roll, e.pitch, g.euler.yaw));
                }
            }
            Window::None | Window::Spin => {}
        }
    }

    /// Closes any open calibration window and returns the report; `last_tick` is the time of
    /// the run's last tick (a failsafe still active is counted up to it).
    pub fn finish(&mut self, last_tick: Nanos) -> CalibrationReport {
        if self.failsafe_since.is_some() {
            self.failsafe_report.active_at_end = true;
            self.end_failsafe(last_tick);
        }
        self.close_window();
        self.window = Window::None;
        self.report.applied = self.offset.euler;
        self.report.clone()
    }
}

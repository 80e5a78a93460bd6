//! The engine: one integer clock at the physics rate (1 kHz) drives every component at its own
//! rate, for every vehicle of the fleet.
//!
//! Per physics tick k (t = k·1 ms), for each vehicle in fleet order:
//! 1. every 5th tick (200 Hz): the Vicon system captures the true state; the frame is handed to the
//!    link `mocap.latency` later (processing), and arrives after the link's own latency/jitter, or never;
//! 2. every packet that has arrived by t goes to the vehicle's [`Station`] (estimation, guidance,
//!    calibration, control), in arrival order, then every telemetry frame that has arrived;
//! 3. every 20th tick (50 Hz): the PPM radio samples the station's latest command (for a vehicle
//!    with `station: external`, the frame its external controller gave last,
//!    [`Arena::set_command`]);
//! 4. the vehicle's receiver holds the last decoded frame; the IMU is sampled; in attitude mode
//!    the onboard attitude loop turns the held angles into body rates; the onboard rate loop
//!    computes rotor commands; every 10th tick (100 Hz) the mean gyro reading goes back over
//!    the telemetry link; the rigid body is integrated over 1 ms (RK4).
//!
//! Steps 1–2 are [`Arena::sense`], 3–4 [`Arena::act`]: a bridge to an external controller
//! (`flyarena serve --lockstep`) asks for the radio frame in between, after the controller has
//! seen every pose that arrived by t, as the built-in station has.
//!
//! Random draws come from one stream per component and vehicle ([`crate::rng`]), so a run is a
//! pure function of the scenario and its seed: bit-identical trajectories whatever the thread
//! count (the engine is single-threaded per run; fleets and sweeps never share a stream).

pub mod station;

pub use station::{CalibrationReport, FailsafeReport, HoverSample, RlsSample, Station};

use crate::clock::{Clock, Every, Nanos};
use crate::frames::{Body, Euler, MocapBody, MocapNav, Nav, Rot, Vec3};
use crate::guidance::{Plan, Window};
use crate::link::{Link, LinkStats};
use crate::mocap::{CameraError, MarkerSet, Mocap, MocapFrame, TrueOffset};
use crate::radio::{PpmFrame, Radio, Received};
use crate::rng::{Component, Stream};
use crate::scenario::{ArenaSpec, CalibrationSettings, StationKind, VehicleSpec};
use crate::vehicle::battery;
use crate::vehicle::{AttitudeLoop, Battery, Downlink, Imu, ImuSample, RateLoop, TelemetryFrame, VehicleParams, X3d};
use std::collections::VecDeque;

/// Options that are not part of the scenario.
#[derive(Clone, Copy, Debug)]
pub struct RunOptions {
    /// Keep a trajectory sample per Vicon frame (needed for recording and determinism checks).
    pub trace: bool,
    /// Override `calibration.apply` (the engine runs the scenario uncompensated for R2).
    pub apply_calibration: Option<bool>,
}

impl Default for RunOptions {
    fn default() -> Self {
        RunOptions { trace: true, apply_calibration: None }
    }
}

/// One trajectory sample (taken at each Vicon tick).
#[derive(Clone, Copy, Debug)]
pub struct TraceSample {
    /// Simulation time of the tick.
    pub t: Nanos,
    /// True position of the body origin (m, true NED).
    pub pos: Vec3<Nav>,
    /// True velocity (m/s, true NED).
    pub vel: Vec3<Nav>,
    /// True attitude as Z-Y-X Euler angles (rad).
    pub att_true: Euler,
    /// Raw mocap pose of the last received packet.
    pub pos_measured: Option<Vec3<MocapNav>>,
    /// Raw mocap attitude of the last received packet (the markers' frame, not the body's).
    pub att_measured: Option<Rot<MocapBody, MocapNav>>,
    /// True attitude (body → true NED).
    pub att_true_rot: Rot<Body, Nav>,
    /// Attitude the controller used (offset removed).
    pub att_compensated: Option<Euler>,
    /// The failsafe's attitude: the last compensated pose propagated with the telemetry gyro.
    pub att_dead_reckoned: Option<Rot<Body, MocapNav>>,
    /// True body rates (rad/s).
    pub omega: Vec3<Body>,
    /// The Vicon frame captured at this tick (before the link), if the vehicle was seen.
    pub captured: Option<MocapFrame>,
    /// The IMU sample of this tick (gyro, specific force; body frame).
    pub imu: ImuSample,
    /// The guidance's position set point (m, mocap NED).
    pub reference: Vec3<MocapNav>,
    /// The guidance's yaw set point (rad).
    pub reference_yaw: f64,
    /// Last PPM frame sent.
    pub ppm: Option<PpmFrame>,
    /// The collective thrust the receiver holds (decoded command, N).
    pub thrust_n: f64,
    /// Battery terminal voltage over this tick (V).
    pub vbat_v: f64,
    /// The mocap link's counts so far.
    pub link: LinkStats,
    /// The plan phase flown (index into the scenario's `plan`), if any.
    pub phase: Option<usize>,
}

/// Everything a run produced for one vehicle.
#[derive(Clone, Debug)]
pub struct VehicleRun {
    /// The vehicle's name in the scenario.
    pub name: String,
    /// Its physical parameters (preset with the scenario's overrides).
    pub params: VehicleParams,
    /// The true mocap → body offset the markers make (the calibration's truth).
    pub truth: TrueOffset,
    /// The mounted markers and their template.
    pub markers: MarkerSet,
    /// The camera system's own error (world tilt, scale), if declared.
    pub camera: CameraError,
    /// What the calibration phases estimated.
    pub calibration: CalibrationReport,
    /// The mocap link's counts (delivered, lost, late) over the run.
    pub link: LinkStats,
    /// The body-rate telemetry link (vehicle → station).
    pub telemetry: LinkStats,
    /// The mocap-outage failsafe.
    pub failsafe: FailsafeReport,
    /// Max horizontal distance from the commanded point while spinning on the spot (m).
    pub spin_max_deviation_m: Option<f64>,
    /// Mean commanded (decoded) thrust while hovering in calibrate_roll_pitch (N).
    pub hover_thrust_mean_n: Option<f64>,
    /// One sample per Vicon tick, when [`RunOptions::trace`] is set.
    pub trace: Vec<TraceSample>,
    /// The recursive least squares of the straight-flight yaw, sample by sample.
    pub rls_trace: Vec<RlsSample>,
    /// The running hover average (recording only).
    pub hover_trace: Vec<HoverSample>,
    /// When each plan phase began, and its kind.
    pub phases: Vec<(Nanos, &'static str)>,
    /// Undeclared mocap delay in frames: the flight log stamps poses this many frames late.
    pub log_delay_frames: usize,
    /// Undeclared gyro delay in frames: the flight log stamps gyro samples this many frames late.
    pub gyro_log_delay_frames: usize,
    /// True position at the end of the run (m, true NED).
    pub final_pos: Vec3<Nav>,
    /// Whether the state ever stopped being finite (the run is then void).
    pub any_nan: bool,
    /// Flown by an external controller (`station: external`): the calibration above is then
    /// what the controller reported ([`crate::serve::command`]'s offset message), not the
    /// built-in station's.
    pub external: bool,
}

/// Everything a run produced.
#[derive(Clone, Debug)]
pub struct RunOutput {
    /// The scenario's name.
    pub scenario: String,
    /// The seed the run drew every random stream from.
    pub seed: u64,
    /// Simulated time at the end.
    pub duration: Nanos,
    /// Per vehicle, in the scenario's order.
    pub vehicles: Vec<VehicleRun>,
}

/// One vehicle in the arena: the simulated airframe and everything between it and its ground
/// station (links, radio, IMU, battery, onboard loops). `crate::vehicle` holds the models;
/// this is their wiring for one run.
struct VehicleLoop {
    name: String,
    x3d: X3d,
    battery: Battery,
    rate_loop: RateLoop,
    /// Used in attitude mode only.
    attitude_loop: AttitudeLoop,
    imu: Imu,
    mocap: Mocap,
    /// With `mocap.noise_in_loop: false`, the same cameras without the marker noise: their
    /// frames go to the station while `mocap`'s noisy ones are only recorded.
    loop_mocap: Option<Mocap>,
    mocap_latency: Nanos,
    /// The scenario's `mocap.latency_ms`: what the mocap system itself knows of its latency.
    declared_mocap_latency: Nanos,
    log_delay_frames: usize,
    gyro_log_delay_frames: usize,
    link: Link<MocapFrame>,
    downlink: Downlink,
    telemetry: Link<TelemetryFrame>,
    radio: Radio,
    station: Station,
    truth: TrueOffset,
    last_frame: Option<MocapFrame>,
    spin_max: Option<f64>,
    thrust_sum: f64,
    thrust_n: u64,
    window: WindowCache,
    trace: Vec<TraceSample>,
    any_nan: bool,
    /// The frames that reached the station in the current tick, kept only when tapped
    /// ([`Arena::tap_delivered`]).
    delivered: Option<Vec<MocapFrame>>,
    /// The telemetry frames that reached the station in the current tick (tapped likewise).
    telemetry_delivered: Option<Vec<TelemetryFrame>>,
    /// The frames the mocap lost this vehicle in (fewer than three markers seen), with the time
    /// a tracked frame would have reached the station (capture + mocap latency + the link's
    /// fixed delay) and the capture time; kept only when tapped.
    lost: Option<VecDeque<(Nanos, u32, Nanos)>>,
    /// The lost frames due in the current tick: (frame number, capture time).
    lost_due: Vec<(u32, Nanos)>,
    /// An external controller's frame, held until the next one (`None`: the built-in station
    /// commands).
    external: Option<PpmFrame>,
    /// Set by [`VehicleLoop::sense`] for [`VehicleLoop::act`] in the same tick.
    captured: Option<MocapFrame>,
}

/// The plan's window at the last evaluation, the reference position then, and until when both
/// hold ([`crate::guidance::Plan::window_until`]).
#[derive(Clone, Copy)]
struct WindowCache {
    window: Window,
    pos: Vec3<MocapNav>,
    until: Nanos,
}

/// A built arena, ready to run.
pub struct Arena {
    clock: Clock,
    end_tick: u64,
    mocap_every: Every,
    radio_every: Every,
    dt: Nanos,
    trace: bool,
    vehicles: Vec<VehicleLoop>,
    name: String,
    seed: u64,
    /// Between [`Arena::sense`] and [`Arena::act`]: whether this tick captures and transmits.
    pending: Option<(bool, bool)>,
}

impl Arena {
    /// Builds the arena of a validated scenario ([`Scenario::spec`](crate::Scenario::spec)).
    pub fn new(spec: &ArenaSpec, opts: RunOptions) -> Arena {
        let physics = spec.physics;
        let vehicles = spec.vehicles.iter().enumerate().map(|(i, v)| VehicleLoop::build(spec, v, i, &opts)).collect();
        Arena {
            clock: Clock::new(physics),
            end_tick: (spec.run_time.0 / physics.period().0) as u64,
            mocap_every: Every::new(spec.mocap.every),
            radio_every: Every::new(spec.radio_every),
            dt: physics.period(),
            trace: opts.trace,
            vehicles,
            name: spec.name.clone(),
            seed: spec.seed,
            pending: None,
        }
    }

    /// The simulation time of the next tick.
    pub fn now(&self) -> Nanos {
        self.clock.now()
    }

    /// Whether the scenario's run time is over.
    pub fn done(&self) -> bool {
        self.clock.tick() >= self.end_tick
    }

    /// From now on, keep the mocap and telemetry frames that reach each vehicle's station in a
    /// tick, and the frames the mocap lost it in, for [`Arena::delivered`],
    /// [`Arena::telemetry_delivered`] and [`Arena::lost`] (a bridge streams them,
    /// e.g. `flyarena serve`). Changes nothing in the run.
    pub fn tap_delivered(&mut self) {
        for v in &mut self.vehicles {
            v.delivered.get_or_insert_with(Vec::new);
            v.telemetry_delivered.get_or_insert_with(Vec::new);
            v.lost.get_or_insert_with(VecDeque::new);
        }
    }

    /// The telemetry frames (body-rate downlink) that reached vehicle `i`'s station during the
    /// last [`Arena::sense`]. Empty unless [`Arena::tap_delivered`] was called.
    pub fn telemetry_delivered(&self, i: usize) -> &[TelemetryFrame] {
        self.vehicles.get(i).and_then(|v| v.telemetry_delivered.as_deref()).unwrap_or(&[])
    }

    /// Whether vehicle `i` is flown by an external controller (`station: external`).
    pub fn is_external(&self, i: usize) -> bool {
        self.vehicles.get(i).is_some_and(|v| v.external.is_some())
    }

    /// The idle frame of vehicle `i`'s radio (zero rates or level, zero thrust): what its
    /// receiver's failsafe sends.
    pub fn idle_frame(&self, i: usize) -> PpmFrame {
        self.vehicles[i].radio.idle_frame()
    }

    /// Gives an externally flown vehicle the frame its transmitter sends from the next radio
    /// tick on (held until the next call, as a PPM transmitter holds its channels). Ignored for a
    /// vehicle the built-in station flies.
    pub fn set_command(&mut self, i: usize, frame: PpmFrame) {
        if let Some(held) = self.vehicles.get_mut(i).and_then(|v| v.external.as_mut()) {
            *held = frame;
        }
    }

    /// The mocap frames that reached vehicle `i`'s station during the last [`Arena::step`], in
    /// arrival order (after the link's latency, jitter, loss and outages): what the station
    /// received. Empty unless [`Arena::tap_delivered`] was called.
    pub fn delivered(&self, i: usize) -> &[MocapFrame] {
        self.vehicles.get(i).and_then(|v| v.delivered.as_deref()).unwrap_or(&[])
    }

    /// The frames whose capture lost vehicle `i` (fewer than three markers seen) and that would
    /// have reached its station during the last [`Arena::step`] had it been tracked (capture +
    /// mocap latency + the link's fixed delay): (frame number, capture time). Empty unless
    /// [`Arena::tap_delivered`] was called.
    pub fn lost(&self, i: usize) -> &[(u32, Nanos)] {
        self.vehicles.get(i).map(|v| v.lost_due.as_slice()).unwrap_or(&[])
    }

    /// The number of vehicles.
    pub fn vehicle_count(&self) -> usize {
        self.vehicles.len()
    }

    /// The latency vehicle `i`'s mocap reports of itself: the scenario's declared
    /// `mocap.latency_ms`, without an undeclared delay (which no mocap system knows of).
    pub fn declared_mocap_latency(&self, i: usize) -> Nanos {
        self.vehicles[i].declared_mocap_latency
    }

    /// Advances every vehicle by one physics tick: [`Arena::sense`], then [`Arena::act`].
    pub fn step(&mut self) {
        self.sense();
        self.act();
    }

    /// The first half of the next tick: the mocap captures (on a Vicon tick), the frames and
    /// telemetry that have arrived go to the stations, the stations tick. Returns whether the
    /// radio transmits in this tick ([`Arena::act`]), so that an external controller can be
    /// asked for its frame in between (lockstep). Calling it twice without `act` does nothing.
    pub fn sense(&mut self) -> bool {
        if let Some((_, radio_tick)) = self.pending {
            return radio_tick;
        }
        let t = self.clock.now();
        let mocap_tick = self.mocap_every.fires();
        let radio_tick = self.radio_every.fires();
        for v in &mut self.vehicles {
            v.sense(t, mocap_tick);
        }
        self.pending = Some((mocap_tick, radio_tick));
        radio_tick
    }

    /// The second half: the radio transmits (on a radio tick), the onboard loops and the physics
    /// advance by one tick, the clock moves on. Runs [`Arena::sense`] first if it was not.
    pub fn act(&mut self) {
        self.sense();
        let (mocap_tick, radio_tick) = self.pending.take().expect("sensed");
        let t = self.clock.now();
        for v in &mut self.vehicles {
            v.act(t, mocap_tick, radio_tick, self.dt, self.trace);
        }
        self.clock.advance();
    }

    /// Runs to the end and collects the results.
    pub fn run(mut self) -> RunOutput {
        while !self.done() {
            self.step();
        }
        self.finish()
    }

    /// Collects the results of the ticks run so far.
    pub fn finish(self) -> RunOutput {
        let duration = self.clock.now();
        // the clock has advanced past the last tick that ran
        let last_tick = if self.clock.tick() > 0 { duration - self.clock.period() } else { duration };
        let vehicles = self
            .vehicles
            .into_iter()
            .map(|mut v| {
                let calibration = v.station.finish(last_tick);
                let phases = v.station.plan().phases.iter().map(|p| (p.start, p.phase.name())).collect();
                VehicleRun {
                    name: v.name,
                    params: v.x3d.params().clone(),
                    truth: v.truth,
                    markers: v.mocap.markers().clone(),
                    camera: *v.mocap.camera(),
                    calibration,
                    link: *v.link.stats(),
                    telemetry: *v.telemetry.stats(),
                    failsafe: v.station.failsafe_report(),
                    spin_max_deviation_m: v.spin_max,
                    hover_thrust_mean_n: (v.thrust_n > 0).then(|| v.thrust_sum / v.thrust_n as f64),
                    rls_trace: v.station.rls_trace().to_vec(),
                    hover_trace: v.station.hover_trace().to_vec(),
                    trace: v.trace,
                    phases,
                    log_delay_frames: v.log_delay_frames,
                    gyro_log_delay_frames: v.gyro_log_delay_frames,
                    final_pos: v.x3d.state().pos,
                    any_nan: v.any_nan,
                    external: v.external.is_some(),
                }
            })
            .collect();
        RunOutput { scenario: self.name, seed: self.seed, duration, vehicles }
    }
}

impl VehicleLoop {
    /// Vehicle `v` (number `i`, which picks its random streams) of `spec`, wired: its true
    /// model, markers and cameras, links, radio, onboard loops and ground station.
    fn build(spec: &ArenaSpec, v: &VehicleSpec, i: usize, opts: &RunOptions) -> VehicleLoop {
        let (physics, seed) = (spec.physics, spec.seed);
        let mocap = Mocap::new(
            v.markers.clone(),
            v.occlusions.clone(),
            spec.mocap.camera,
            spec.mocap.noise_m,
            Stream::new(seed, Component::MocapNoise, i),
        );
        let loop_mocap = (!spec.mocap.noise_in_loop).then(|| {
            Mocap::new(
                v.markers.clone(),
                v.occlusions.clone(),
                spec.mocap.camera,
                0.0,
                Stream::new(seed, Component::MocapNoise, i),
            )
        });
        let radio = Radio::new(v.radio);
        let plan = Plan::schedule(&spec.phases, v.home, v.yaw0_rad);
        let settings = CalibrationSettings {
            apply: opts.apply_calibration.unwrap_or(v.calibration.apply),
            ..v.calibration.clone()
        };
        let station = Station::new(plan, v.gains.clone(), settings, v.failsafe, v.velocity_cutoff_hz, opts.trace);
        let true_params = v.true_params.clone();
        let home_nav = spec.mocap.camera.to_nav(v.home);
        let tm = &spec.telemetry;
        VehicleLoop {
            name: v.name.clone(),
            battery: Battery::new(true_params.battery),
            x3d: X3d::on_floor(true_params, v.disturbance, home_nav, v.yaw0_rad),
            rate_loop: RateLoop::new(&v.params, physics.period().as_secs_f64()),
            attitude_loop: AttitudeLoop::new(
                v.params.attitude_loop_gain_per_s,
                physics.period().as_secs_f64(),
                v.yaw0_rad,
            ),
            imu: Imu::new(v.imu.clone(), Stream::new(seed, Component::ImuNoise, i)),
            mocap,
            loop_mocap,
            mocap_latency: v.mocap_latency,
            declared_mocap_latency: spec.mocap.latency,
            log_delay_frames: v.log_delay_frames,
            gyro_log_delay_frames: v.gyro_log_delay_frames,
            link: Link::new(
                spec.link,
                Stream::new(seed, Component::LinkLoss, i),
                Stream::new(seed, Component::LinkJitter, i),
            )
            .with_outages(spec.outages.clone()),
            downlink: Downlink::new(tm.every).with_clock(tm.clock_offset, tm.clock_drift_ppm),
            telemetry: Link::new(
                tm.link,
                Stream::new(seed, Component::TelemetryLoss, i),
                Stream::new(seed, Component::TelemetryJitter, i),
            ),
            station,
            truth: v.truth,
            last_frame: None,
            spin_max: None,
            thrust_sum: 0.0,
            window: WindowCache { window: Window::None, pos: Vec3::zeros(), until: Nanos::ZERO },
            thrust_n: 0,
            trace: Vec::new(),
            any_nan: false,
            delivered: None,
            telemetry_delivered: None,
            lost: None,
            lost_due: Vec::new(),
            external: (v.station == StationKind::External).then(|| radio.idle_frame()),
            captured: None,
            radio,
        }
    }
}

impl VehicleLoop {
    fn sense(&mut self, t: Nanos, mocap_tick: bool) {
        self.captured = None;
        if mocap_tick {
            let seq = self.mocap.next_seq();
            let state = *self.x3d.state();
            match self.mocap.capture(t, &state) {
                Some(f) => {
                    let sent = self.loop_mocap.as_mut().and_then(|m| m.capture(t, &state)).unwrap_or(f);
                    self.link.send(t + self.mocap_latency, sent.seq, sent);
                    self.captured = Some(f);
                }
                None => {
                    if let Some(l) = &mut self.lost {
                        l.push_back((t + self.mocap_latency + self.link.latency(), seq, t));
                    }
                }
            }
        }
        self.lost_due.clear();
        if let Some(l) = &mut self.lost {
            while let Some(&(_, seq, at)) = l.front().filter(|(due, _, _)| *due <= t) {
                self.lost_due.push((seq, at));
                l.pop_front();
            }
        }
        if let Some(d) = &mut self.delivered {
            d.clear();
        }
        while let Some(f) = self.link.receive(t) {
            if let Some(d) = &mut self.delivered {
                d.push(f);
            }
            self.station.on_pose(t, &f);
            self.last_frame = Some(f);
        }
        if let Some(d) = &mut self.telemetry_delivered {
            d.clear();
        }
        while let Some(f) = self.telemetry.receive(t) {
            if let Some(d) = &mut self.telemetry_delivered {
                d.push(f);
            }
            self.station.on_telemetry(&f);
        }
        self.station.tick(t);
    }

    fn act(&mut self, t: Nanos, mocap_tick: bool, radio_tick: bool, dt: Nanos, trace: bool) {
        let captured = self.captured;
        if radio_tick {
            match self.external {
                Some(f) => self.radio.transmit_frame(t, f),
                None => {
                    let cmd = *self.station.command();
                    self.radio.transmit(t, &cmd);
                }
            }
        }
        let held = self.radio.receiver(t);
        // the engine's own measurements need the window (and in a spin the reference position)
        // every tick: evaluate the plan only where they can change
        if t >= self.window.until {
            let (r, w) = self.station.guidance(t);
            self.window = WindowCache { window: w, pos: r.pos, until: self.station.plan().window_until(t) };
        }
        if self.window.window == Window::HoverAverage {
            self.thrust_sum += held.thrust_n();
            self.thrust_n += 1;
        }
        if self.window.window == Window::Spin {
            let dev = (self.x3d.state().pos - self.mocap.camera().to_nav(self.window.pos)).horizontal_norm();
            self.spin_max = Some(self.spin_max.map_or(dev, |m: f64| m.max(dev)));
        }
        let s = *self.x3d.state();
        let mut f = self.x3d.specific_force();
        if let Some(r) = self.imu.position() {
            f += crate::vehicle::imu::lever_arm_specific_force(s.omega, self.x3d.angular_acceleration(), r);
        }
        let imu = self.imu.sample(s.omega, f);
        let rates = match held {
            Received::Rates(c) => c,
            Received::Attitude(a) => self.attitude_loop.rate_command(&a, &imu),
        };
        let gyro = match held {
            Received::Rates(_) => imu.gyro,
            Received::Attitude(_) => self.attitude_loop.calibrated(imu.gyro),
        };
        let mut rotor_cmd = self.rate_loop.rotor_speed_commands(&rates, gyro);
        if let Some(f) = self.downlink.sample(t, imu.gyro) {
            self.telemetry.send(t, f.seq, f);
        }
        // the battery matters only where something reads its voltage: the motors (a thrust
        // against voltage) or the log (a trace); otherwise it is skipped, which changes nothing
        // observable and keeps the loop at its speed
        let p = self.x3d.params();
        let mut vbat = f64::NAN;
        if trace || p.thrust_voltage_per_v != 0.0 {
            vbat = self.battery.step(p.rotor_power_w(&s.rotor_speed), dt.as_secs_f64());
            let speed = battery::speed_factor(p.thrust_voltage_per_v, vbat, p.battery.v_ref);
            if speed != 1.0 {
                rotor_cmd = rotor_cmd.map(|w| w * speed);
            }
        }
        self.x3d.step(&rotor_cmd, dt.as_secs_f64());
        let s = self.x3d.state();
        if !(s.pos.is_finite() && s.vel.is_finite() && s.omega.is_finite()) {
            self.any_nan = true;
        }
        if trace && mocap_tick {
            let (reference, _) = self.station.guidance(t);
            self.trace.push(TraceSample {
                t,
                pos: s.pos,
                vel: s.vel,
                att_true: s.att.euler(),
                att_true_rot: s.att,
                omega: s.omega,
                captured,
                imu,
                pos_measured: self.last_frame.map(|f| f.pos),
                att_measured: self.last_frame.map(|f| f.att),
                att_compensated: self.station.attitude().map(|a| a.euler()),
                att_dead_reckoned: self.station.dead_reckoned(),
                reference: reference.pos,
                reference_yaw: reference.yaw,
                ppm: self.radio.last_sent().copied(),
                thrust_n: held.thrust_n(),
                vbat_v: vbat,
                link: *self.link.stats(),
                phase: self.station.plan().phase_at(t),
            });
        }
    }
}

/// Builds the arena of `spec` and runs it to the end.
pub fn run(spec: &ArenaSpec, opts: RunOptions) -> RunOutput {
    Arena::new(spec, opts).run()
}

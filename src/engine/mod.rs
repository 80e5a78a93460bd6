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

pub use station::{CalibrationReport, CalibrationSettings, FailsafeReport, FailsafeSettings, HoverSample, RlsSample, Station};

use crate::clock::{Clock, Every, Nanos, Rate};
use crate::control::Gains;
use crate::frames::{Body, Euler, MocapBody, MocapNav, Nav, Rot, Vec3};
use crate::guidance::{Phase, Plan, Window};
use crate::link::{Link, LinkParams, LinkStats};
use crate::mocap::{CameraError, MarkerSet, Mocap, MocapFrame, Occlusion, TrueOffset};
use crate::radio::{PpmFrame, Radio, RadioParams, Received};
use crate::rng::{Component, Stream};
use crate::scenario::{PHYSICS_HZ, Scenario, StationKind};
use crate::vehicle::battery;
use crate::vehicle::{AttitudeLoop, Battery, Disturbance, Downlink, Imu, ImuParams, ImuSample, RateLoop, TelemetryFrame, VehicleParams, X3d};
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

fn rate(hz: u32) -> Rate {
    Rate::from_hz(hz).expect("validated by the scenario")
}

impl Arena {
    /// Builds the arena of a validated scenario.
    pub fn new(s: &Scenario, opts: RunOptions) -> Arena {
        let physics = rate(PHYSICS_HZ);
        let mocap_every = rate(s.mocap.rate_hz()).ticks_of(physics).expect("validated");
        let radio_every = rate(s.radio.rate_hz()).ticks_of(physics).expect("validated");
        let ms = |x: f64| Nanos::from_secs_f64(x * 1e-3);
        let cam = &s.mocap.camera_error;
        let camera = CameraError {
            rotation: Rot::from_euler(Euler::from_degrees(cam.rotation_deg[0], cam.rotation_deg[1], cam.rotation_deg[2])),
            translation: Vec3::from_array(cam.translation_mm.map(|x| x * 1e-3)),
        };
        let link = LinkParams { latency: ms(s.link.latency_ms), jitter: ms(s.link.jitter_ms), loss: s.link.loss.model() };
        let outages: Vec<(Nanos, Option<Nanos>)> = s.link.outages().map(|o| (Nanos::from_secs_f64(o.from_s), o.to_s.map(Nanos::from_secs_f64))).collect();
        let tm = &s.telemetry;
        let telemetry = LinkParams { latency: ms(tm.latency_ms), jitter: ms(tm.jitter_ms), loss: tm.loss.model() };
        let telemetry_every = rate(tm.rate_hz()).ticks_of(physics).expect("validated") as u32;
        let phases: Vec<Phase> = s.plan().iter().map(|p| p.to_phase()).collect();
        let fleet = Fleet { physics, camera, link, outages, telemetry, telemetry_every, phases };
        let vehicles = (0..s.vehicle_cfgs().len()).map(|i| VehicleLoop::build(s, i, &opts, &fleet)).collect();
        let end = Nanos::from_secs_f64(s.run_time_s());
        Arena {
            clock: Clock::new(physics),
            end_tick: (end.0 / physics.period().0) as u64,
            mocap_every: Every::new(mocap_every),
            radio_every: Every::new(radio_every),
            dt: physics.period(),
            trace: opts.trace,
            vehicles,
            name: s.name.clone(),
            seed: s.seed,
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

/// What every vehicle of a scenario shares: the clocks, the camera system, the links' models, the
/// plan.
struct Fleet {
    physics: Rate,
    camera: CameraError,
    link: LinkParams,
    outages: Vec<(Nanos, Option<Nanos>)>,
    telemetry: LinkParams,
    telemetry_every: u32,
    phases: Vec<Phase>,
}

impl VehicleLoop {
    /// Vehicle `i` of `s`, wired: its model with the undeclared effects, markers and cameras,
    /// links, radio, onboard loops and ground station.
    fn build(s: &Scenario, i: usize, opts: &RunOptions, fleet: &Fleet) -> VehicleLoop {
        let Fleet { physics, camera, link, outages, telemetry, telemetry_every, phases } = fleet;
        let (physics, camera, link, telemetry, telemetry_every) = (*physics, *camera, *link, *telemetry, *telemetry_every);
        let v = s.vehicle(i);
        let (c, cal, tm) = (&s.controller, &s.calibration, &s.telemetry);
        let ms = |x: f64| Nanos::from_secs_f64(x * 1e-3);
        let params = s.vehicle_params(i);
        let template = s.template(i);
        let n = template.len();
        let disp: Vec<Vec3<_>> = match v.markers.displacement_mm() {
            Some(d) => d.iter().map(|a| Vec3::from_array(a.map(|x| x * 1e-3))).collect(),
            None => vec![Vec3::zeros(); n],
        };
        let r = v.markers.rotation_deg;
        let markers = MarkerSet::displaced(template, Euler::from_degrees(r[0], r[1], r[2]), &disp);
        let truth = markers.true_offset().expect("validated");
        let occlusions = v.markers.occlusions().map(|o| Occlusion { marker: o.marker as usize, from: Nanos::from_secs_f64(o.from_s), to: Nanos::from_secs_f64(o.to_s) }).collect();
        let mocap = Mocap::new(markers, occlusions, camera, s.mocap.noise_mm * 1e-3, Stream::new(s.seed, Component::MocapNoise, i));
        let thrust_max = s.radio.thrust_max_n.unwrap_or(params.thrust_max());
        let radio = Radio::new(RadioParams {
            channels: s.radio.channels() as usize,
            latency: ms(s.radio.latency_ms),
            rate_scale_rad_s: s.radio.rate_scale_deg_s.to_radians(),
            angle_scale_rad: s.radio.angle_scale_deg.to_radians(),
            thrust_max_n: thrust_max,
            mode: params.onboard_mode,
        });
        let gains = Gains { k_x: c.k_x, k_v: c.k_v, k_att: c.k_att, max_tilt: [c.max_tilt_deg.to_radians(); 2], thrust_max_n: thrust_max, mass_kg: params.mass_kg };
        let home = Vec3::<MocapNav>::new(v.home_m[0], v.home_m[1], 0.0);
        let yaw0 = v.yaw0_deg.to_radians();
        let plan = Plan::schedule(phases, home, yaw0);
        let settings = CalibrationSettings {
            apply: opts.apply_calibration.unwrap_or(cal.apply),
            compensation: c.compensation,
            eps_yaw: cal.validity_max_mean_yaw_deg.to_radians(),
            eps_roll: cal.validity_max_mean_roll_deg.to_radians(),
            rls_min_spread_m: cal.rls_min_spread_m,
            mocap_period: rate(s.mocap.rate_hz()).period(),
            telemetry_period: rate(tm.rate_hz()).period(),
            estimate_telemetry_clock: tm.clock.estimate,
            hover_trim: cal.hover_trim && params.onboard_mode == crate::vehicle::OnboardMode::Attitude,
        };
        let fs =
            FailsafeSettings { timeout: ms(c.failsafe_timeout_ms), thrust_fraction: c.failsafe_thrust_fraction, motors_off_after: Nanos::from_secs_f64(c.failsafe_motors_off_s) };
        let station = Station::new(plan, gains, settings, fs, c.velocity_cutoff_hz, opts.trace);
        let imu = ImuParams {
            gyro_noise_rad_s: v.imu.gyro_noise_deg_s.to_radians(),
            accel_noise_m_s2: v.imu.accel_noise_m_s2,
            gyro_bias_rad_s: v.imu.gyro_bias_deg_s.map(f64::to_radians),
            accel_bias_m_s2: v.imu.accel_bias_m_s2,
            position_m: v.imu.position_mm.map(|x| x * 1e-3),
        };
        // the truth: the declared parameters with the undeclared effects added
        let u = &v.undeclared;
        let mut true_params = params.clone();
        true_params.k_thrust *= u.thrust_scale;
        true_params.ground_effect += u.ground_effect;
        true_params.thrust_voltage_per_v += u.thrust_voltage_per_v;
        true_params.rotor_drag_per_s = [params.rotor_drag_per_s[0] + u.rotor_drag_per_s[0], params.rotor_drag_per_s[1] + u.rotor_drag_per_s[1]];
        let dist = Disturbance { force_nav_n: v.disturbance.force_n, torque_body_nm: v.disturbance.torque_nm };
        let home_nav = camera.to_nav(home);
        VehicleLoop {
            name: v.name.clone(),
            battery: Battery::new(true_params.battery),
            x3d: X3d::on_floor(true_params, dist, home_nav, yaw0),
            rate_loop: RateLoop::new(&params, physics.period().as_secs_f64()),
            attitude_loop: AttitudeLoop::new(params.attitude_loop_gain_per_s, physics.period().as_secs_f64(), yaw0),
            imu: Imu::new(imu, Stream::new(s.seed, Component::ImuNoise, i)),
            mocap,
            mocap_latency: ms(s.mocap.latency_ms + u.mocap_delay_ms),
            declared_mocap_latency: ms(s.mocap.latency_ms),
            log_delay_frames: (u.mocap_delay_ms * s.mocap.rate_hz() as f64 / 1000.0).round() as usize,
            gyro_log_delay_frames: (u.gyro_delay_ms * s.mocap.rate_hz() as f64 / 1000.0).round() as usize,
            link: Link::new(link, Stream::new(s.seed, Component::LinkLoss, i), Stream::new(s.seed, Component::LinkJitter, i)).with_outages(outages.clone()),
            downlink: Downlink::new(telemetry_every).with_clock(ms(tm.clock.offset_ms), tm.clock.drift_ppm),
            telemetry: Link::new(telemetry, Stream::new(s.seed, Component::TelemetryLoss, i), Stream::new(s.seed, Component::TelemetryJitter, i)),
            station,
            truth,
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
            match self.mocap.capture(t, self.x3d.state()) {
                Some(f) => {
                    self.link.send(t + self.mocap_latency, f.seq, f);
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

/// Convenience: build and run.
pub fn run(s: &Scenario, opts: RunOptions) -> RunOutput {
    Arena::new(s, opts).run()
}

//! The arena over the network: a scenario's mocap streamed as OptiTrack NatNet, so that a lab's
//! own mocap client (libmotioncapture / Crazyswarm2, the `natnet` Python client, anything that
//! reads Motive) receives flyarena's poses as if from the cameras.
//!
//! [`serve`] flies the scenario as `run` does (the same [`Arena`], bit for bit) paced by the
//! wall clock, and sends every mocap frame at the moment it reaches the vehicle's station: after
//! the mocap's processing latency, the link's latency and jitter, and only if the link did not
//! lose it (loss, outages), with the scenario's noise, occlusions and marker misalignment in the
//! pose. What a client receives is what flyarena's own ground station receives.
//!
//! **Frames.** flyarena's mocap world is NED (x north, y east, z down) and the rigid body's
//! frame is the markers' frame (x forward, y right, z down). NatNet streams are usually Z-up or
//! Y-up; [`Up`] chooses the convention, applied to the world and to the body alike:
//!
//! | `Up` | world (x, y, z) from NED (n, e, d) | quaternion (x, y, z, w) from NED's (x, y, z, w) |
//! |---|---|---|
//! | `Z` (default; Crazyswarm2, ROS) | (n, −e, −d): x forward, y left, z up | (x, −y, −z, w) |
//! | `Y` (Motive's default) | (n, −d, e): y up | (x, −z, y, w) |
//! | `Ned` | (n, e, d) | (x, y, z, w) |
//!
//! Each is a proper rotation C (det +1) applied as C·R·Cᵀ to the attitude R (body → world), so
//! the quaternion's axis turns with C and its angle stays.
//!
//! **Timestamps** are simulated time in nanoseconds ([`natnet::CLOCK_HZ`]): the frame's
//! `timestamp` and mid-exposure stamp are the exposure time, the data-received and transmit
//! stamps are exposure + the mocap's declared processing latency (so a client's "camera latency"
//! reads the scenario's `mocap.latency_ms`, and not an undeclared `mocap_delay_ms`, which no mocap
//! system knows of; the link's network latency comes after the transmit stamp, as on a real
//! network). Frame numbers are the mocap's (+1 per camera frame, also for frames
//! that were lost), so a client sees gaps where the link lost frames. Bodies the cameras did not
//! see, or whose frame the link lost, are absent from that packet. The mean marker error is not
//! modelled (0).
//!
//! **Clients.** Unicast: a client is registered by its connect (or keep-alive) packet and
//! receives each frame at the address it sent from (the `natnet` client's command socket) and at
//! its host's data port (libmotioncapture binds the data port from the server info). Multicast:
//! frames go to the group and data port once. The model definition names each rigid body after
//! its vehicle, with id = 1 + its index in the fleet, and lists its marker template.

pub mod command;
pub mod natnet;

use crate::clock::Nanos;
use crate::engine::{Arena, RunOptions, RunOutput};
use crate::frames::{MocapBody, MocapNav, Rot, Vec3};
use crate::radio::PpmFrame;
use crate::scenario::Scenario;
use command::{CommandStats, Receiver};
use std::net::{Ipv4Addr, SocketAddr, SocketAddrV4, UdpSocket};
use std::time::{Duration, Instant};

/// The stream's axis convention (module doc).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Up {
    /// x forward, y left, z up.
    #[default]
    Z,
    /// Motive's default: y up, z = east.
    Y,
    /// flyarena's own: north, east, down.
    Ned,
}

impl Up {
    /// A mocap-world position in this convention (m).
    pub fn position(self, p: Vec3<MocapNav>) -> [f32; 3] {
        self.vector(p.to_array())
    }

    /// A vector of the rigid body's (marker) frame in this convention (m).
    fn body_vector(self, p: Vec3<MocapBody>) -> [f32; 3] {
        self.vector(p.to_array())
    }

    fn vector(self, [n, e, d]: [f64; 3]) -> [f32; 3] {
        let v = match self {
            Up::Z => [n, -e, -d],
            Up::Y => [n, -d, e],
            Up::Ned => [n, e, d],
        };
        v.map(|x| x as f32)
    }

    /// The attitude (body → world) as the quaternion (x, y, z, w) of this convention.
    pub fn quaternion(self, r: &Rot<MocapBody, MocapNav>) -> [f32; 4] {
        let q = r.quaternion();
        let (w, x, y, z) = (q.w, q.i, q.j, q.k);
        let v = match self {
            Up::Z => [x, -y, -z, w],
            Up::Y => [x, -z, y, w],
            Up::Ned => [x, y, z, w],
        };
        v.map(|a| a as f32)
    }
}

/// Where and how to serve.
#[derive(Clone, Debug)]
pub struct ServeOptions {
    /// The address to listen on (127.0.0.1: this machine only; 0.0.0.0: every interface).
    pub bind: Ipv4Addr,
    /// NatNet's command port (Motive: 1510).
    pub command_port: u16,
    /// NatNet's data port, announced in the server info (Motive: 1511).
    pub data_port: u16,
    /// Send frames to this multicast group instead of to each client (Motive: 239.255.42.99).
    pub multicast: Option<Ipv4Addr>,
    /// The axis convention of the stream.
    pub up: Up,
    /// Simulated seconds per wall-clock second (1: real time).
    pub speed: f64,
    /// Wait this long for a first client before the flight starts (zero: start at once); with
    /// externally flown vehicles, for a first command of each.
    pub wait_for_client: Duration,
    /// Lockstep: each radio tick of an externally flown vehicle waits for its controller's
    /// command, at most this long; a tick that waited in vain goes on without it (the held
    /// frame, then after `radio.failsafe_ms` of such ticks the receiver's failsafe), and the
    /// next tick waits again, so a controller that answers again is back at once. A controller
    /// that never answers costs this long per radio tick. Requests are answered while a tick waits, so with no
    /// externally flown vehicle a lockstep run goes as fast as it can and answers nothing until
    /// it ends. `None`: real time, paced by the wall clock.
    pub lockstep: Option<Duration>,
}

impl Default for ServeOptions {
    fn default() -> Self {
        ServeOptions {
            bind: Ipv4Addr::LOCALHOST,
            command_port: 1510,
            data_port: 1511,
            multicast: None,
            up: Up::Z,
            speed: 1.0,
            wait_for_client: Duration::from_secs(30),
            lockstep: None,
        }
    }
}

/// What a served run did on the network.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct ServeReport {
    /// The clients that connected (address they sent from).
    pub clients: Vec<String>,
    /// NatNet frames sent (one per frame number and arrival tick; each to every client).
    pub frames: u64,
    /// Tracked rigid-body poses in those frames.
    pub poses: u64,
    /// Datagrams that could not be sent (e.g. a client's port closed).
    pub send_errors: u64,
    /// Requests answered (connect, model definition, frame, commands).
    pub requests: u64,
    /// Wall-clock time spent waiting for the first client (s).
    pub waited_s: f64,
    /// The largest delay of a physics tick behind its wall-clock time (ms): frames were sent at
    /// most this late (real time only).
    pub max_lag_ms: f64,
    /// Connects and keep-alives from a new address refused because 32 clients were registered.
    pub clients_refused: u64,
    /// Real time: physics ticks run, and those that began more than one physics period after
    /// their wall-clock time (their frames and commands went out late).
    pub ticks: u64,
    /// See [`ServeReport::ticks`].
    pub late_ticks: u64,
    /// Per externally flown vehicle, what its commands did.
    pub commands: Vec<VehicleCommands>,
    /// Packets refused: neither a NatNet request flyarena knows nor a command or offset report
    /// for an externally flown vehicle (malformed, another version, an unknown vehicle id, a
    /// NatNet message id the server does not know: that one is answered as Motive does).
    pub rejected: u64,
}

/// The command counts of one externally flown vehicle.
#[derive(Clone, Debug, serde::Serialize)]
pub struct VehicleCommands {
    /// The vehicle's name.
    pub vehicle: String,
    /// The counts.
    pub stats: CommandStats,
}

impl ServeReport {
    /// A physics tick that began `lag` after its wall-clock time: late if more than `period`.
    fn count_tick(&mut self, lag: Duration, period: Duration) {
        self.max_lag_ms = self.max_lag_ms.max(lag.as_secs_f64() * 1e3);
        self.ticks += 1;
        self.late_ticks += u64::from(lag > period);
    }

    /// One requirement row per externally flown vehicle, R0: its controller flew it (at least one
    /// of its commands applied). A vehicle whose controller never connected, or sent nothing the
    /// receiver applied, stays on the ground holding its first frame; the other requirements
    /// may then hold of a flight nobody flew (no drift while yawing, when nothing yawed), so the
    /// run fails here instead.
    pub fn controller_rows(&self) -> Vec<crate::requirements::Row> {
        self.commands
            .iter()
            .map(|c| crate::requirements::Row {
                vehicle: c.vehicle.clone(),
                id: "R0",
                what: format!(
                    "flown by its external controller (commands received {}, radio ticks held {})",
                    c.stats.received, c.stats.held
                ),
                measured: format!("{} applied", c.stats.applied),
                limit: "≥ 1".into(),
                pass: c.stats.applied >= 1,
                asserted: true,
            })
            .collect()
    }
}

/// Why serving failed.
#[derive(Debug, thiserror::Error)]
pub enum ServeError {
    /// The command port could not be opened.
    #[error("cannot listen on {addr}: {source} (is another server on that port? choose another with --command-port)")]
    Bind {
        /// The address.
        addr: SocketAddr,
        /// The system's reason.
        source: std::io::Error,
    },
    /// The speed is not a positive finite number.
    #[error("speed {0} must be a positive number of simulated seconds per second")]
    Speed(f64),
    /// A socket operation failed.
    #[error("network: {0}")]
    Io(#[from] std::io::Error),
}

/// The sockets and the clients.
struct Server {
    socket: UdpSocket,
    opts: ServeOptions,
    clients: Vec<SocketAddr>,
    model_def: Vec<u8>,
    server_info: Vec<u8>,
    last_frame: Option<Vec<u8>>,
    report: ServeReport,
    /// Per vehicle: whether it is flown from outside, its controller's address, its receiver,
    /// the newest frame to apply.
    external: Vec<bool>,
    controllers: Vec<Option<SocketAddr>>,
    receivers: Vec<Receiver>,
    incoming: Vec<Option<PpmFrame>>,
    /// The offset each external controller reported last (rad).
    offsets: Vec<Option<[f64; 3]>>,
}

/// The longest sleep between two reads of the command port: a request waits at most this long.
const POLL: Duration = Duration::from_micros(100);

/// The command port's receive buffer asked of the kernel (bytes): a flood's burst that arrives
/// while the host is busy waits there instead of pushing the controllers' commands out.
const RECV_BUFFER: usize = 1 << 20;

/// At most this many waiting datagrams are read at the start of a physics tick.
const DRAIN: usize = 256;

/// At most this many unicast clients (each costs two datagrams per frame).
const MAX_CLIENTS: usize = 32;

impl Server {
    fn bind(opts: &ServeOptions, model_def: Vec<u8>, external: Vec<bool>) -> Result<Server, ServeError> {
        let addr = SocketAddr::V4(SocketAddrV4::new(opts.bind, opts.command_port));
        let socket = UdpSocket::bind(addr).map_err(|source| ServeError::Bind { addr, source })?;
        socket.set_nonblocking(true)?;
        // room for a burst while the host is busy (the kernel caps it at net.core.rmem_max)
        let _ = socket2::SockRef::from(&socket).set_recv_buffer_size(RECV_BUFFER);
        if opts.multicast.is_some() {
            // one hop, looped back to this host's listeners, out of the interface we listen on
            socket.set_multicast_ttl_v4(1)?;
            socket.set_multicast_loop_v4(true)?;
            if !opts.bind.is_unspecified() {
                socket2::SockRef::from(&socket).set_multicast_if_v4(&opts.bind)?;
            }
        }
        let server_info = natnet::server_info("flyarena", [0, 1, 0, 0], opts.data_port, opts.multicast);
        let n = external.len();
        Ok(Server {
            socket,
            opts: opts.clone(),
            clients: Vec::new(),
            model_def,
            server_info,
            last_frame: None,
            report: ServeReport::default(),
            external,
            controllers: vec![None; n],
            receivers: vec![Receiver::default(); n],
            incoming: vec![None; n],
            offsets: vec![None; n],
        })
    }

    /// Answers what is waiting on the command port, then requests until `until` (wall clock).
    /// A tick that began late (the host was busy) still reads what queued meanwhile: a socket
    /// left unread while a flood arrives overflows, and the kernel drops the controllers'
    /// commands with the flood's datagrams.
    fn listen_until(&mut self, until: Instant) -> Result<(), ServeError> {
        self.drain()?;
        while Instant::now() < until {
            self.listen_once(until)?;
        }
        Ok(())
    }

    /// Answers the datagrams already waiting, at most [`DRAIN`] of them (a flood faster than
    /// they are read cannot hold the physics tick).
    fn drain(&mut self) -> Result<(), ServeError> {
        for _ in 0..DRAIN {
            if !self.answer_waiting()? {
                break;
            }
        }
        Ok(())
    }

    /// Answers the next datagram waiting on the command port; false when none waits. An earlier
    /// datagram to a closed port that came back as refused is not one: the read goes on past it.
    fn answer_waiting(&mut self) -> Result<bool, ServeError> {
        let mut buf = [0u8; 2048];
        loop {
            match self.socket.recv_from(&mut buf) {
                Ok((n, from)) => {
                    self.answer(&buf[..n], from);
                    return Ok(true);
                }
                Err(e) if e.kind() == std::io::ErrorKind::ConnectionRefused => {}
                Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => return Ok(false),
                Err(e) => return Err(e.into()),
            }
        }
    }

    /// Answers the next request, waiting for it until `until` at most. The socket does not
    /// block: a receive timeout counts in the kernel's ticks (a 200 µs timeout waited 8 ms on
    /// the CI's kernel), which would send the frames of a quiet tick that late, so the wait is
    /// sleeps of at most [`POLL`] (high-resolution timers) between reads.
    fn listen_once(&mut self, until: Instant) -> Result<(), ServeError> {
        loop {
            if self.answer_waiting()? {
                return Ok(());
            }
            let now = Instant::now();
            if now >= until {
                return Ok(());
            }
            std::thread::sleep((until - now).min(POLL));
        }
    }

    fn send(&mut self, bytes: &[u8], to: SocketAddr) {
        if self.socket.send_to(bytes, to).is_err() {
            self.report.send_errors += 1;
        }
    }

    fn register(&mut self, from: SocketAddr) {
        if self.clients.contains(&from) {
            return;
        }
        if self.clients.len() < MAX_CLIENTS {
            self.clients.push(from);
            self.report.clients.push(from.to_string());
        } else {
            self.report.clients_refused += 1;
        }
    }

    fn answer(&mut self, packet: &[u8], from: SocketAddr) {
        let ours = |id: u8| (1..=self.external.len()).contains(&(id as usize)) && self.external[id as usize - 1];
        let req = match classify(packet) {
            Incoming::Offset { vehicle_id, roll_pitch_yaw } if ours(vehicle_id) => {
                self.offsets[vehicle_id as usize - 1] = Some(roll_pitch_yaw);
                return;
            }
            Incoming::Command(c) if ours(c.vehicle_id) => {
                let i = c.vehicle_id as usize - 1;
                // only a command the receiver applies (or the first) points the requests at its
                // sender: a replayed or stale one, from anywhere, changes nothing
                if self.receivers[i].accept(c.seq) {
                    self.incoming[i] = Some(c.frame);
                    self.controllers[i] = Some(from);
                } else if self.controllers[i].is_none() {
                    self.controllers[i] = Some(from);
                }
                return;
            }
            Incoming::Request(natnet::Request::Unknown(_)) => {
                // answered as Motive answers a message it does not know, and refused
                self.report.rejected += 1;
                self.send(&natnet::response(None), from);
                return;
            }
            Incoming::Request(req) => req,
            Incoming::Offset { .. } | Incoming::Command(_) | Incoming::Rejected => {
                self.report.rejected += 1;
                return;
            }
        };
        self.report.requests += 1;
        match req {
            natnet::Request::Connect => {
                self.register(from);
                let info = self.server_info.clone();
                self.send(&info, from);
            }
            natnet::Request::ModelDef => {
                let def = self.model_def.clone();
                self.send(&def, from);
            }
            natnet::Request::FrameOfData => {
                if let Some(f) = self.last_frame.clone() {
                    self.send(&f, from);
                }
            }
            natnet::Request::KeepAlive => self.register(from),
            natnet::Request::Disconnect => self.clients.retain(|c| *c != from),
            // no Motive commands (recording, bitstream version) are supported: -1
            natnet::Request::Command(_) => self.send(&natnet::response(Some(-1)), from),
            // refused and answered above
            natnet::Request::Unknown(_) => {}
        }
    }

    /// Lockstep: waits at most `timeout` for every registered external controller to answer
    /// request `period` (a command with that sequence number or later); each one that has not by
    /// then misses the deadline (counted) and the tick goes on without it.
    fn wait_for_answers(&mut self, period: u32, timeout: Duration) -> Result<(), ServeError> {
        let give_up = Instant::now() + timeout;
        loop {
            let left: Vec<usize> = (0..self.external.len())
                .filter(|&i| {
                    self.external[i]
                        && self.controllers[i].is_some()
                        && self.receivers[i].last().is_none_or(|l| l < period)
                })
                .collect();
            if left.is_empty() {
                return Ok(());
            }
            if Instant::now() >= give_up {
                for i in left {
                    self.receivers[i].stats.timeouts += 1;
                }
                return Ok(());
            }
            self.listen_once(give_up)?;
        }
    }

    fn broadcast(&mut self, bytes: Vec<u8>, poses: usize) {
        self.report.frames += 1;
        self.report.poses += poses as u64;
        if let Some(group) = self.opts.multicast {
            self.send(&bytes, SocketAddr::V4(SocketAddrV4::new(group, self.opts.data_port)));
        } else {
            for c in self.clients.clone() {
                self.send(&bytes, c);
                let data = SocketAddr::new(c.ip(), self.opts.data_port);
                if data != c {
                    self.send(&bytes, data);
                }
            }
        }
        self.last_frame = Some(bytes);
    }
}

/// What a datagram on the command port is. NatNet requests and flyarena's own packets share
/// the port; the magic tells them apart ([`command`], [`natnet`]).
#[derive(Clone, Debug, PartialEq)]
pub enum Incoming {
    /// A well-formed offset report ([`command::OFFSET`]).
    Offset {
        /// The rigid body's id (1 + fleet index).
        vehicle_id: u8,
        /// The controller's estimate of the marker offset (rad; yaw NaN when it has none).
        roll_pitch_yaw: [f64; 3],
    },
    /// A well-formed command.
    Command(command::Command),
    /// A NatNet request whose header and payload are all there.
    Request(natnet::Request),
    /// Anything else: a malformed offset report or command, or fewer bytes than a NatNet
    /// header and its payload announce.
    Rejected,
}

/// Classifies a datagram received on the command port as `serve` does before acting on it.
/// Never panics, whatever the bytes; whether the vehicle id names an externally flown vehicle
/// is the server's question, not this one's.
pub fn classify(packet: &[u8]) -> Incoming {
    if packet.starts_with(&command::OFFSET) {
        return command::parse_offset(packet).map_or(Incoming::Rejected, |(vehicle_id, roll_pitch_yaw)| {
            Incoming::Offset { vehicle_id, roll_pitch_yaw }
        });
    }
    if packet.starts_with(&command::COMMAND) {
        return command::parse_command(packet).map_or(Incoming::Rejected, Incoming::Command);
    }
    natnet::parse_request(packet).map_or(Incoming::Rejected, Incoming::Request)
}

/// The rigid-body definitions of a scenario's fleet in the convention `up`.
fn rigid_bodies(s: &Scenario, up: Up) -> Vec<natnet::RigidBodyDef> {
    s.spec()
        .vehicles
        .iter()
        .enumerate()
        .map(|(i, v)| natnet::RigidBodyDef {
            name: v.name.clone(),
            id: i as i32 + 1,
            markers_m: v.template.iter().map(|m| up.body_vector(*m)).collect(),
        })
        .collect()
}

/// Flies `s` and streams its mocap as NatNet (module doc); vehicles with `station: external`
/// are flown by the commands that arrive ([`command`]). Paced by the wall clock, or in lockstep
/// with the external controllers. Returns the run, identical to [`crate::engine::run`] with the
/// same options when every external vehicle receives the frames the built-in station would
/// send, and what happened on the network.
pub fn serve(s: &Scenario, opts: &ServeOptions, run: RunOptions) -> Result<(RunOutput, ServeReport), ServeError> {
    if !(opts.speed.is_finite() && opts.speed > 0.0) {
        return Err(ServeError::Speed(opts.speed));
    }
    let mut arena = Arena::new(s.spec(), run);
    arena.tap_delivered();
    let n = arena.vehicle_count();
    let external: Vec<bool> = (0..n).map(|i| arena.is_external(i)).collect();
    let mut server = Server::bind(opts, natnet::model_def(&rigid_bodies(s, opts.up)), external.clone())?;
    wait_for_participants(&mut server, opts.wait_for_client)?;
    // what came before the flight registered the controllers and answers no request: the
    // receivers start afresh, whatever sequence number the registration carried
    for i in 0..n {
        server.receivers[i] = Receiver::default();
        server.incoming[i] = None;
    }
    let failsafe_after = Nanos::from_secs_f64(s.radio.failsafe_ms * 1e-3);
    let mut last_applied: Vec<Option<Nanos>> = vec![None; n];
    let latency: Vec<Nanos> = (0..n).map(|i| arena.declared_mocap_latency(i)).collect();
    let start = Instant::now();
    let mut stream = StreamState::default();
    let mut period: u32 = 0;
    let physics_period = Duration::from_secs_f64(s.spec().physics.period().as_secs_f64() / opts.speed);
    while !arena.done() {
        if opts.lockstep.is_none() {
            let due = start + Duration::from_secs_f64(arena.now().as_secs_f64() / opts.speed);
            server.listen_until(due)?;
            server.report.count_tick(Instant::now().saturating_duration_since(due), physics_period);
        } else {
            server.listen_until(Instant::now())?;
        }
        let t = arena.now();
        let radio_tick = arena.sense();
        stream_frames(&mut server, &arena, opts.up, &latency, &mut stream);
        for i in (0..n).filter(|i| external[*i]) {
            if let Some(to) = server.controllers[i] {
                for f in arena.telemetry_delivered(i) {
                    server.send(&command::telemetry(i as u8 + 1, f), to);
                }
            }
        }
        if radio_tick {
            for i in (0..n).filter(|i| external[*i]) {
                if let Some(to) = server.controllers[i] {
                    server.send(&command::request(i as u8 + 1, period, t.as_nanos()), to);
                }
            }
            if let Some(timeout) = opts.lockstep {
                server.wait_for_answers(period, timeout)?;
            }
        }
        for i in 0..n {
            if let Some(f) = server.incoming[i].take() {
                arena.set_command(i, f);
                last_applied[i] = Some(t);
            }
        }
        if radio_tick {
            for i in (0..n).filter(|i| external[*i]) {
                server.receivers[i].radio_tick();
                // the receiver's failsafe: silent for failsafe_ms, the idle frame goes out
                if last_applied[i].is_some_and(|t0| t - t0 >= failsafe_after) {
                    arena.set_command(i, arena.idle_frame(i));
                    server.receivers[i].stats.failsafe += 1;
                }
            }
            period += 1;
        }
        arena.act();
    }
    server.report.commands = (0..n)
        .filter(|i| external[*i])
        .map(|i| VehicleCommands { vehicle: s.vehicle(i).name.clone(), stats: server.receivers[i].stats })
        .collect();
    let mut out = arena.finish();
    adopt_reported_calibrations(&mut out, &server.offsets);
    Ok((out, server.report))
}

/// Before the flight: listen until a NatNet client has asked (no external controller), or every
/// external controller has sent its first command, or `wait` has passed.
fn wait_for_participants(server: &mut Server, wait: Duration) -> Result<(), ServeError> {
    let waiting = Instant::now();
    let deadline = waiting + wait;
    let ready = |sv: &Server| {
        if sv.external.iter().any(|e| *e) {
            sv.external.iter().zip(&sv.controllers).all(|(e, c)| !e || c.is_some())
        } else {
            !sv.clients.is_empty()
        }
    };
    while !ready(server) && Instant::now() < deadline {
        server.listen_until((Instant::now() + Duration::from_millis(20)).min(deadline))?;
    }
    server.report.waited_s = waiting.elapsed().as_secs_f64();
    Ok(())
}

/// An external vehicle's calibration is what its controller reported, not what the built-in
/// station (which ran alongside on the same poses) estimated: R1 reads the report, R3 and R4
/// (the station's own straight-flight fits) do not apply.
fn adopt_reported_calibrations(out: &mut RunOutput, offsets: &[Option<[f64; 3]>]) {
    for (v, o) in out.vehicles.iter_mut().zip(offsets).filter(|(v, _)| v.external) {
        v.calibration.roll_pitch = o.map(|o| (o[0], o[1], 0));
        v.calibration.yaw_offset = o.and_then(|o| o[2].is_finite().then_some(o[2]));
        v.calibration.gyro = None;
        v.calibration.yaw_ls = None;
        v.calibration.yaw_rls = None;
        v.calibration.validity = None;
    }
}

/// What the stream last said of each body, for the frames that lose it.
#[derive(Default)]
struct StreamState {
    /// The ids of the last frame's bodies.
    ids: Vec<i32>,
    /// Each vehicle's last tracked pose as streamed (position, quaternion).
    last_pose: Vec<Option<([f32; 3], [f32; 4])>>,
}

/// Sends the mocap frames that reached the stations in this tick: one NatNet frame per frame
/// number, with every body that came with it, tracked, and every body the mocap lost in that
/// frame with its tracking flag cleared and its last tracked pose (as Motive sends a rigid body
/// out of view; the origin and no rotation before it was ever seen). A body missing because its
/// link lost the packet is not in the frame.
fn stream_frames(server: &mut Server, arena: &Arena, up: Up, latency: &[Nanos], state: &mut StreamState) {
    let n = arena.vehicle_count();
    state.last_pose.resize(n, None);
    // (frame number, vehicle, capture time, the pose if tracked)
    let mut arrived: Vec<(u32, usize, Nanos, Option<crate::mocap::MocapFrame>)> = Vec::new();
    for i in 0..n {
        arrived.extend(arena.delivered(i).iter().map(|f| (f.seq, i, f.t_capture, Some(*f))));
        arrived.extend(arena.lost(i).iter().map(|&(seq, at)| (seq, i, at, None)));
    }
    arrived.sort_by_key(|(seq, i, _, _)| (*seq, *i));
    for group in arrived.chunk_by(|a, b| a.0 == b.0) {
        let (seq, first, at, _) = group[0];
        let bodies: Vec<natnet::RigidBody> = group
            .iter()
            .map(|(_, i, _, f)| {
                let id = *i as i32 + 1;
                match f {
                    Some(f) => {
                        let (pos_m, quat_xyzw) = (up.position(f.pos), up.quaternion(&f.att));
                        state.last_pose[*i] = Some((pos_m, quat_xyzw));
                        natnet::RigidBody { id, pos_m, quat_xyzw, mean_error_m: 0.0, tracked: true }
                    }
                    None => {
                        let (pos_m, quat_xyzw) = state.last_pose[*i].unwrap_or(([0.0; 3], [0.0, 0.0, 0.0, 1.0]));
                        natnet::RigidBody { id, pos_m, quat_xyzw, mean_error_m: 0.0, tracked: false }
                    }
                }
            })
            .collect();
        let ids: Vec<i32> = bodies.iter().map(|b| b.id).collect();
        let exposed = at.as_nanos().max(0) as u64;
        let processed = (at + latency[first]).as_nanos().max(0) as u64;
        let frame = natnet::Frame {
            number: seq,
            bodies,
            timestamp_s: at.as_secs_f64(),
            mid_exposure: exposed,
            data_received: processed,
            transmit: processed,
            models_changed: ids != state.ids,
        };
        state.ids = ids;
        let tracked = frame.bodies.iter().filter(|b| b.tracked).count();
        server.broadcast(natnet::frame(&frame), tracked);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frames::Euler;
    use nalgebra::{Matrix3, UnitQuaternion, Vector3};

    fn c(up: Up) -> Matrix3<f64> {
        match up {
            Up::Z => Matrix3::new(1.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, -1.0),
            Up::Y => Matrix3::new(1.0, 0.0, 0.0, 0.0, 0.0, -1.0, 0.0, 1.0, 0.0),
            Up::Ned => Matrix3::identity(),
        }
    }

    /// The quaternion formulas of the table against C·R·Cᵀ computed as matrices, and the
    /// position formulas against C·p, for attitudes that are not symmetric in any axis.
    #[test]
    fn conventions_are_the_rotation_c_applied_to_world_and_body() {
        for up in [Up::Z, Up::Y, Up::Ned] {
            let cm = c(up);
            assert!((cm.determinant() - 1.0).abs() < 1e-12, "{up:?} is a proper rotation");
            for (r, p, y) in [(0.3, -0.2, 1.1), (-1.0, 0.7, -2.5), (0.05, 0.0, 0.0)] {
                let rot = Rot::<MocapBody, MocapNav>::from_euler(Euler::new(r, p, y));
                let expected = cm * rot.matrix() * cm.transpose();
                let [x, yq, z, w] = up.quaternion(&rot).map(|a| a as f64);
                let got = UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(w, x, yq, z))
                    .to_rotation_matrix()
                    .into_inner();
                assert!((got - expected).abs().max() < 1e-6, "{up:?}: {got} vs {expected}");
            }
            let v = Vector3::new(1.0, 2.0, 3.0);
            let expected = cm * v;
            let got = up.position(Vec3::from_array([1.0, 2.0, 3.0]));
            assert_eq!(got, [expected.x as f32, expected.y as f32, expected.z as f32], "{up:?}");
        }
        // the cases in words: 1 m up is +z in Z-up and +y in Y-up
        assert_eq!(Up::Z.position(Vec3::from_array([0.0, 0.0, -1.0])), [0.0, 0.0, 1.0]);
        assert_eq!(Up::Y.position(Vec3::from_array([0.0, 0.0, -1.0])), [0.0, 1.0, 0.0]);
    }

    /// The command port stays in the vehicle's own axes (body FRD, NED), and docs/serve.md gives
    /// the conversion from a stream convention, checked here against C: a body vector (the
    /// body rates p, q, r of a rate command, the telemetry's mean gyro) is v' = C·v, so in z-up
    /// (p, −q, −r) and in y-up (p, −r, q); a rotation (an attitude, the marker offset of a
    /// report) is R' = C·R·Cᵀ, whose Z-Y-X angles in z-up are (φ, −θ, −ψ) (so an attitude-mode
    /// command's roll, pitch and heading rate are (φ, −θ, −ψ̇) there); in y-up no sign rule
    /// gives them, and R = Cᵀ·R'·C is what to report.
    #[test]
    fn the_command_ports_conversions_in_the_guide_are_c() {
        let w = Vector3::new(0.3, -0.7, 1.1);
        assert_eq!(c(Up::Z) * w, Vector3::new(0.3, 0.7, -1.1), "z-up: (p, −q, −r)");
        assert_eq!(c(Up::Y) * w, Vector3::new(0.3, -1.1, -0.7), "y-up: (p, −r, q)");
        for (r, p, y) in [(0.05, -0.03, 0.2), (0.4, 0.3, -2.0), (-0.2, 0.1, 3.0)] {
            let frd = Rot::<MocapBody, MocapNav>::from_euler(Euler::new(r, p, y)).matrix();
            let z = c(Up::Z) * frd * c(Up::Z).transpose();
            let e = Rot::<MocapBody, MocapNav>::from_matrix(&z).euler();
            assert!(
                (e.roll - r).abs() < 1e-12
                    && (e.pitch + p).abs() < 1e-12
                    && crate::frames::wrap_pi(e.yaw + y).abs() < 1e-12,
                "z-up angles {e:?}"
            );
            let yup = c(Up::Y) * frd * c(Up::Y).transpose();
            let back = c(Up::Y).transpose() * yup * c(Up::Y);
            assert!((back - frd).abs().max() < 1e-12);
            let ey = Rot::<MocapBody, MocapNav>::from_matrix(&yup).euler();
            assert!(
                (ey.roll - r).abs() > 1e-3
                    || (ey.pitch.abs() - p.abs()).abs() > 1e-3
                    || (ey.yaw.abs() - y.abs()).abs() > 1e-3,
                "y-up has no sign rule: {ey:?}"
            );
        }
    }

    /// A tick that began late still reads what queued on the command port meanwhile (up to
    /// [`DRAIN`]): a server that only listened until a deadline already past read nothing while
    /// it was behind, its socket overflowed under a flood, and the kernel dropped the
    /// controllers' commands with it (every flown vehicle failed safe on a busy host).
    #[test]
    fn a_late_tick_reads_what_queued_meanwhile() {
        let opts = ServeOptions { command_port: 0, ..ServeOptions::default() };
        let mut server = Server::bind(&opts, Vec::new(), vec![true]).unwrap();
        let to = server.socket.local_addr().unwrap();
        let sender = UdpSocket::bind("127.0.0.1:0").unwrap();
        for _ in 0..DRAIN + 10 {
            sender.send_to(&[0xff; 3], to).unwrap();
        }
        // loopback delivers at once; give the kernel a moment all the same
        std::thread::sleep(Duration::from_millis(50));
        let past = Instant::now().checked_sub(Duration::from_millis(10)).unwrap();
        server.listen_until(past).unwrap();
        assert_eq!(server.report.rejected, DRAIN as u64, "one tick reads at most DRAIN datagrams");
        server.listen_until(past).unwrap();
        assert_eq!(server.report.rejected, DRAIN as u64 + 10, "the next tick reads the rest");
    }
}

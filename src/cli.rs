//! The command line, declared with clap: `flyarena run|serve|check|sweep|merge|identify|trials|completions`.
//! A thin shell over the library: it parses, calls `flyarena::…`, writes the outputs and turns
//! results into exit codes.
//!
//! Exit codes: 0 every requirement passed · 1 a requirement failed · 2 bad input (unreadable or
//! invalid scenario, bad arguments, an output that cannot be written) · 130 interrupted.

use clap::{Args, CommandFactory, Parser, Subcommand};
use flyarena::Error;
use flyarena::output::{install_interrupt_handler, write_atomic};
use flyarena::run::{Outcome, run_scenario};
use flyarena::scenario::Scenario;
use std::io::Write as _;
use std::path::{Path, PathBuf};

/// flyarena — quadrotor flight under motion capture with misaligned frames
#[derive(Parser)]
#[command(
    name = "flyarena",
    version,
    about,
    after_help = "EXIT CODES: 0 pass · 1 a requirement failed · 2 bad input · 130 interrupted"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Simulate the scenario, print the requirements table, write the JSON summary and the Rerun
    /// recording (open it with `rerun out/<scenario>.rrd`)
    Run(RunArgs),
    /// Fly the scenario in real time and stream its mocap as OptiTrack NatNet (UDP), so that a
    /// lab's own mocap client receives the poses flyarena's station receives; then write what
    /// `run` writes
    Serve(ServeArgs),
    /// Validate scenarios without running them
    Check {
        /// Scenario files
        #[arg(required = true, value_name = "SCENARIO.yaml")]
        scenarios: Vec<PathBuf>,
    },
    /// Run the scenario's `sweep:` variations in parallel: per-run metrics (CSV, JSON) and a
    /// summary per grid point (mean, p95, p99, pass rates)
    Sweep(SweepArgs),
    /// Combine shard outputs into the summary one unsharded sweep would give
    Merge {
        /// Shard files of one sweep (`<scenario>.sweep.shard-K-of-N.json`) or of one batch of
        /// trials (`trials-<seed>-<N>.shard-K-of-N.json`)
        #[arg(required = true, value_name = "SHARD.json")]
        shards: Vec<PathBuf>,
        /// Output folder
        #[arg(long, default_value = "out", value_name = "DIR")]
        out: PathBuf,
    },
    /// Find what the model lacks: residuals of the nominal model against a flight (run from a
    /// scenario, or a log: flyarena's CSV, another tool's CSV, a PX4 .ulg, a ROS 2 .mcap, an
    /// ASL/EuRoC folder, an IMU CSV beside TUM poses), the effects that explain them, 95 %
    /// intervals, and a scenario fragment
    Identify(IdentifyArgs),
    /// Does identify generalise? N random flights with hidden effects flown and identified:
    /// recall, precision and 95 % coverage per effect (DIR/trials-<seed>-<N>.json)
    Trials {
        /// Number of flights
        #[arg(long, default_value_t = 300, value_parser = clap::value_parser!(u64).range(1..=100_000))]
        flights: u64,
        /// Master seed (flight i of seed S is a pure function of (S, i))
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Fly only shard K of N (flights i with i mod N = K − 1), into
        /// DIR/trials-<seed>-<N>.shard-K-of-N.json; `flyarena merge` combines the shards
        #[arg(long, value_name = "K/N", value_parser = parse_shard)]
        shard: Option<(u64, u64)>,
        /// Hand-held mocap + IMU rigs at MoCap2GT's simulated setting instead of flights, each
        /// calibrated by `identify --calibrate`: the error and 95 % coverage of the rotation,
        /// world tilt, lever arm and time offset (DIR/handheld[-<setting>][-<MS>ms]-<seed>-<N>.json; docs/calibration.md)
        #[arg(long, conflicts_with = "shard")]
        handheld: bool,
        /// With --handheld: also write each rig's log (DIR/handheld-<seed>-<N>/flight-<i>.csv,
        /// read by mappings/handheld.yaml)
        #[arg(long, requires = "handheld")]
        logs: bool,
        /// With --handheld: σ of the selection's smoothing kernel (ms; default the mapping's 50;
        /// the calibration's final fit takes the narrower of it and 20 ms)
        #[arg(long, value_name = "MS", value_parser = parse_smoothing, requires = "handheld")]
        smoothing_ms: Option<f64>,
        /// With --handheld: the rig's rates, noise densities, length and bias drift from a YAML
        /// file of SI fields (`imu_hz: 200`, `accel_noise_density: 2e-3`, …); a field left out
        /// keeps MoCap2GT's value (docs/calibration.md)
        #[arg(long, value_name = "FILE", requires = "handheld")]
        setting: Option<PathBuf>,
        /// A real log with N mounts and clock offsets injected instead of flights (an ASL folder
        /// or any two-stream log, read through --mapping), each calibrated and compared with the
        /// plain log's calibration composed with its injection (DIR/injected-<log>-<seed>-<N>.json;
        /// docs/calibration.md)
        #[arg(long, value_name = "LOG", conflicts_with_all = ["shard", "handheld"], requires = "mapping")]
        injected: Option<PathBuf>,
        /// With --injected: the mapping that reads the log
        #[arg(long, value_name = "MAPPING.yaml", requires = "injected")]
        mapping: Option<PathBuf>,
        /// Output folder
        #[arg(long, default_value = "out", value_name = "DIR")]
        out: PathBuf,
    },
    /// Write Slurm job scripts: a job array of shards and the merge that waits for it
    /// (DIR/<name>.array.sbatch, .merge.sbatch, .submit.sh; run the last on a login node)
    Slurm {
        #[command(subcommand)]
        job: SlurmJob,
    },
    /// Print a shell completion script (e.g. `flyarena completions bash > ~/.local/share/bash-completion/completions/flyarena`)
    Completions {
        #[arg(value_enum)]
        shell: clap_complete::Shell,
    },
}

#[derive(Args)]
struct RunArgs {
    /// The scenario
    #[arg(value_name = "SCENARIO.yaml")]
    scenario: PathBuf,
    /// Output folder
    #[arg(long, default_value = "out", value_name = "DIR")]
    out: PathBuf,
    /// Summary path (default: DIR/<scenario name>.json; `serve`: DIR/<scenario name>.serve.json)
    #[arg(long, value_name = "PATH")]
    json: Option<PathBuf>,
    /// Rerun recording path (default: DIR/<scenario name>.rrd; `serve`: DIR/<scenario name>.serve.rrd)
    #[arg(long, value_name = "PATH", conflicts_with = "no_rrd")]
    rrd: Option<PathBuf>,
    /// Do not record
    #[arg(long)]
    no_rrd: bool,
    /// Record every N-th Vicon frame (4: 50 Hz at 200 Hz)
    #[arg(long, default_value_t = 4, value_name = "N", value_parser = clap::value_parser!(u64).range(1..=1000))]
    rrd_every: u64,
    /// Write the flight log (CSV: mocap, IMU, commands); with several vehicles one file each,
    /// PATH-<vehicle>.csv
    #[arg(long, value_name = "PATH.csv")]
    log: Option<PathBuf>,
    /// Apply an `identify` fragment (scenario fields by path) before validating
    #[arg(long, value_name = "FRAGMENT.yaml")]
    effects: Option<PathBuf>,
    /// Override the scenario's seed
    #[arg(long)]
    seed: Option<u64>,
    /// Print only the verdict line
    #[arg(long, short)]
    quiet: bool,
}

#[derive(Args)]
struct ServeArgs {
    #[command(flatten)]
    run: RunArgs,
    /// Address to listen on (0.0.0.0: every interface)
    #[arg(long, default_value = "127.0.0.1", value_name = "IPv4")]
    bind: std::net::Ipv4Addr,
    /// NatNet command port (Motive's: 1510)
    #[arg(long, default_value_t = 1510, value_name = "PORT")]
    command_port: u16,
    /// NatNet data port announced to clients (Motive's: 1511)
    #[arg(long, default_value_t = 1511, value_name = "PORT")]
    data_port: u16,
    /// Send frames to this multicast group (e.g. 239.255.42.99) instead of to each client
    #[arg(long, value_name = "IPv4")]
    multicast: Option<std::net::Ipv4Addr>,
    /// Axis convention of the stream: z (x forward, y left, z up), y (Motive's y up) or ned
    #[arg(long, value_enum, default_value_t = UpArg::Z)]
    up: UpArg,
    /// Simulated seconds per wall-clock second (1: real time)
    #[arg(long, default_value_t = 1.0, value_parser = parse_speed)]
    speed: f64,
    /// Seconds to wait for a first client before the flight starts (0: start at once); with
    /// `station: external` vehicles, for a first command of each
    #[arg(long, default_value_t = 30.0, value_name = "S", value_parser = parse_wait)]
    wait_s: f64,
    /// Lockstep: every radio tick of an external vehicle waits for its controller's command (no
    /// wall clock); otherwise real time
    #[arg(long)]
    lockstep: bool,
    /// Lockstep: how long a radio tick waits for the controller's command before going on without it
    #[arg(long, default_value_t = 1000, value_name = "MS", value_parser = clap::value_parser!(u64).range(1..=600_000), requires = "lockstep")]
    lockstep_timeout_ms: u64,
}

/// What a Slurm job array flies.
#[derive(Subcommand)]
enum SlurmJob {
    /// `flyarena sweep SCENARIO`, one shard per array task
    Sweep {
        /// The scenario (with a `sweep:` section)
        #[arg(value_name = "SCENARIO.yaml")]
        scenario: PathBuf,
        /// Number of runs (default: the scenario's)
        #[arg(long, value_parser = clap::value_parser!(u64).range(1..=10_000_000))]
        runs: Option<u64>,
        #[command(flatten)]
        cluster: ClusterArgs,
    },
    /// `flyarena trials`, one shard per array task
    Trials {
        /// Number of flights
        #[arg(long, default_value_t = 300, value_parser = clap::value_parser!(u64).range(1..=100_000))]
        flights: u64,
        /// Master seed
        #[arg(long, default_value_t = 1)]
        seed: u64,
        #[command(flatten)]
        cluster: ClusterArgs,
    },
}

/// The array's size, the cluster's options and the output folder.
#[derive(Args)]
struct ClusterArgs {
    /// Array tasks (shards)
    #[arg(long, value_parser = clap::value_parser!(u64).range(1..=100_000))]
    tasks: u64,
    /// `#SBATCH --partition`
    #[arg(long)]
    partition: Option<String>,
    /// `#SBATCH --time` (e.g. 01:00:00)
    #[arg(long)]
    time: Option<String>,
    /// `#SBATCH --cpus-per-task` (also each task's threads)
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=4096))]
    cpus_per_task: Option<u32>,
    /// `#SBATCH --account`
    #[arg(long)]
    account: Option<String>,
    /// Output folder: the scripts, and where the jobs write (shards/, logs/, the merged output)
    #[arg(long, default_value = "out", value_name = "DIR")]
    out: PathBuf,
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum UpArg {
    Z,
    Y,
    Ned,
}

fn parse_speed(v: &str) -> Result<f64, String> {
    v.parse()
        .ok()
        .filter(|x: &f64| (0.01..=1000.0).contains(x))
        .ok_or_else(|| format!("takes a number from 0.01 to 1000 (simulated seconds per second), not `{v}`"))
}

fn parse_wait(v: &str) -> Result<f64, String> {
    v.parse()
        .ok()
        .filter(|x: &f64| (0.0..=3600.0).contains(x))
        .ok_or_else(|| format!("takes seconds from 0 to 3600, not `{v}`"))
}

#[derive(Args)]
struct SweepArgs {
    /// The scenario (with a `sweep:` section)
    #[arg(value_name = "SCENARIO.yaml")]
    scenario: PathBuf,
    /// Number of runs (default: the scenario's)
    #[arg(long, value_parser = clap::value_parser!(u64).range(1..=10_000_000))]
    runs: Option<u64>,
    /// Run one slice of the runs: K/N with 1 ≤ K ≤ N (e.g. 2/8)
    #[arg(long, value_name = "K/N", value_parser = parse_shard)]
    shard: Option<(u64, u64)>,
    /// Output folder
    #[arg(long, default_value = "out", value_name = "DIR")]
    out: PathBuf,
    /// Print only the verdict line
    #[arg(long, short)]
    quiet: bool,
}

#[derive(Args)]
struct IdentifyArgs {
    /// A scenario (run, then identified), a flyarena log (with --scenario), or logs of another
    /// tool (with --mapping: a CSV, a PX4 .ulg, a ROS 2 .mcap, an ASL/EuRoC folder, an IMU CSV
    /// with --poses; several give a cross-validation)
    #[arg(required = true, value_name = "INPUT")]
    inputs: Vec<PathBuf>,
    /// The scenario that wrote a flyarena log
    #[arg(long, value_name = "SCENARIO.yaml", conflicts_with = "mapping")]
    scenario: Option<PathBuf>,
    /// Read another tool's log through a mapping (mappings/*.yaml): a CSV, a ROS 2 bag (.mcap),
    /// a PX4 log (.ulg), an ASL/EuRoC folder, or an IMU CSV beside a pose file (--poses)
    #[arg(long, value_name = "MAPPING.yaml")]
    mapping: Option<PathBuf>,
    /// The poses in a file of their own, on their own clock, beside the IMU log INPUT: a TUM
    /// trajectory (t x y z qx qy qz qw) or an ASL pose CSV, as the mapping's `poses:` says
    #[arg(long, value_name = "FILE", requires = "mapping")]
    poses: Option<PathBuf>,
    /// Where the clock offset between the IMU and the mocap is searched (s, the mocap's stamps
    /// later than the IMU's): a known coarse offset (searched ±5 s around it) or a window A..B;
    /// default ±5 s, and every offset when the two streams' times do not overlap
    #[arg(long, value_name = "S|A..B", allow_hyphen_values = true, value_parser = parse_clock_offset)]
    clock_offset: Option<flyarena::identify::start::ClockWindow>,
    /// Fit these effects without testing them (e.g. body_offset), select the rest. The hypotheses
    /// gyro_delay, accel_misalignment, accel_scale, thrust_tilt, clock_drift and imu_offset are not searched:
    /// they are fitted only when named here
    #[arg(long = "with", value_name = "EFFECT,...", value_delimiter = ',', value_parser = parse_effect)]
    forced: Vec<flyarena::identify::Effect>,
    /// Fit the mocap–IMU calibration without testing it (body_offset, world_tilt, mocap_delay,
    /// accel_bias, gyro_bias, lever_arm; added to --with) and select any other effect on top:
    /// a calibration of a rig estimates those whatever their size (docs/calibration.md)
    #[arg(long)]
    calibrate: bool,
    /// The vehicle to identify (a scenario with several)
    #[arg(long)]
    vehicle: Option<String>,
    /// Output folder
    #[arg(long, default_value = "out", value_name = "DIR")]
    out: PathBuf,
    /// Report path (default: DIR/<input>.identify.json)
    #[arg(long, value_name = "PATH")]
    json: Option<PathBuf>,
    /// Scenario fragment path (default: DIR/<input>.effects.yaml)
    #[arg(long, value_name = "PATH")]
    fragment: Option<PathBuf>,
    /// Residual recording path (default: DIR/<input>.identify.rrd)
    #[arg(long, value_name = "PATH", conflicts_with = "no_rrd")]
    rrd: Option<PathBuf>,
    /// Do not record the residuals
    #[arg(long)]
    no_rrd: bool,
    /// Replace a report in DIR that another input made (by default `identify` refuses: the files
    /// are named by the input's stem, and `a/flight.csv` and `b/flight.csv` share one)
    #[arg(long)]
    overwrite: bool,
    /// σ of the Gaussian smoothing before differentiating (ms; default 20, or the mapping's;
    /// with --calibrate the final fit takes the narrower of it and 20 ms)
    #[arg(long, value_name = "MS", value_parser = parse_smoothing)]
    smoothing_ms: Option<f64>,
    /// The seed (a scenario input: override; a log: the seed it was run with)
    #[arg(long)]
    seed: Option<u64>,
    /// Print only the verdict line
    #[arg(long, short)]
    quiet: bool,
    /// Also give the PX4 parameters the flight supports (EKF2_EV_DELAY, EKF2_EV_POS_*,
    /// EKF2_IMU_POS_*) with their intervals, and write them as a QGroundControl parameter file
    /// (DIR/<input>.px4.params); the mocap delay is always fitted
    #[arg(long)]
    px4: bool,
    /// The QGroundControl parameter file's path (with --px4)
    #[arg(long, value_name = "PATH", requires = "px4")]
    px4_params: Option<PathBuf>,
    /// With --px4: the rigid body's axes in the mocap software, for the body offset's fix: z (x
    /// forward, y left, z up: Vicon, Qualisys), y (Motive's y up: x forward, y up, z right) or
    /// ned (FRD)
    #[arg(long, value_enum, default_value_t = UpArg::Z, requires = "px4")]
    up: UpArg,
}

fn parse_shard(v: &str) -> Result<(u64, u64), String> {
    match v.split_once('/').and_then(|(k, n)| Some((k.parse::<u64>().ok()?, n.parse::<u64>().ok()?))) {
        Some((k, n)) if n >= 1 && (1..=n).contains(&k) => Ok((k - 1, n)),
        _ => Err(format!("takes K/N with 1 ≤ K ≤ N (e.g. 2/8), not `{v}`")),
    }
}

fn parse_effect(name: &str) -> Result<flyarena::identify::Effect, String> {
    flyarena::identify::Effect::ALL.iter().find(|e| e.key() == name.trim()).copied().ok_or_else(|| {
        format!(
            "`{name}` is not an effect; the effects are {}",
            flyarena::identify::Effect::ALL.iter().map(|e| e.key()).collect::<Vec<_>>().join(", ")
        )
    })
}

fn parse_clock_offset(v: &str) -> Result<flyarena::identify::start::ClockWindow, String> {
    use flyarena::identify::start::{ClockWindow, DEFAULT_HALF_WIDTH_S};
    let num = |x: &str| x.trim().parse::<f64>().ok().filter(|x| x.is_finite());
    let bad = || {
        format!(
            "takes a coarse offset in seconds (e.g. 0.2, -3, 1e6) or a window A..B with A < B (e.g. -30..30), not `{v}`"
        )
    };
    match v.split_once("..") {
        Some((a, b)) => match (num(a), num(b)) {
            (Some(a), Some(b)) if a < b => Ok(ClockWindow { centre_s: 0.5 * (a + b), half_width_s: 0.5 * (b - a) }),
            _ => Err(bad()),
        },
        None => num(v).map(|c| ClockWindow { centre_s: c, half_width_s: DEFAULT_HALF_WIDTH_S }).ok_or_else(bad),
    }
}

fn parse_smoothing(v: &str) -> Result<f64, String> {
    v.parse()
        .ok()
        .filter(|x: &f64| (2.0..=500.0).contains(x))
        .ok_or_else(|| format!("takes a number of milliseconds from 2 to 500, not `{v}`"))
}

/// Exit codes.
pub const PASS: i32 = 0;
pub const FAIL: i32 = 1;
pub const BAD_INPUT: i32 = 2;
/// Interrupted by SIGINT or SIGTERM (128 + 2, the shell's convention).
pub const INTERRUPTED: i32 = 130;

/// [`write_atomic`], its failure an [`Error::Write`].
fn write_output(path: &Path, bytes: &[u8]) -> Result<(), Error> {
    write_atomic(path, bytes).map_err(|source| Error::Write { path: path.to_path_buf(), source })
}

/// The scenario `run` and `serve` fly: the file, an `identify` fragment applied, the seed.
fn load_for_run(a: &RunArgs) -> Result<Scenario, Error> {
    let s = match &a.effects {
        Some(f) => flyarena::identify::load_with_effects(&a.scenario, f)?,
        None => Scenario::load(&a.scenario)?,
    };
    Ok(match a.seed {
        Some(seed) => s.with_seed(seed),
        None => s,
    })
}

fn cmd_run(a: RunArgs) -> Result<i32, Error> {
    let s = load_for_run(&a)?;
    if let Some(v) = s.vehicle_cfgs().find(|v| v.station == flyarena::scenario::StationKind::External) {
        return Err(Error::Usage(format!(
            "{}: vehicle `{}` has `station: external`: an external controller flies it, so fly the scenario with `flyarena serve {}`",
            a.scenario.display(),
            v.name,
            a.scenario.display()
        )));
    }
    let record = cfg!(feature = "record") && !a.no_rrd;
    let started = std::time::Instant::now();
    let outcome = run_scenario(&s, record);
    write_run(a, &s, outcome, started.elapsed(), "", None)
}

fn cmd_serve(a: ServeArgs) -> Result<i32, Error> {
    use flyarena::serve::{ServeOptions, Up, serve};
    let s = load_for_run(&a.run)?;
    let record = cfg!(feature = "record") && !a.run.no_rrd;
    let opts = ServeOptions {
        bind: a.bind,
        command_port: a.command_port,
        data_port: a.data_port,
        multicast: a.multicast,
        up: match a.up {
            UpArg::Z => Up::Z,
            UpArg::Y => Up::Y,
            UpArg::Ned => Up::Ned,
        },
        speed: a.speed,
        wait_for_client: std::time::Duration::from_secs_f64(a.wait_s),
        lockstep: a.lockstep.then(|| std::time::Duration::from_millis(a.lockstep_timeout_ms)),
    };
    let to = a.multicast.map_or_else(|| "each client".to_string(), |g| format!("multicast {g}:{}", a.data_port));
    eprintln!(
        "serving {} as NatNet 3.1 on {}:{} (data port {}, {to}, {:?}-up, {}); waiting up to {} s for a client",
        s.name(),
        a.bind,
        a.command_port,
        a.data_port,
        opts.up,
        if a.lockstep { "lockstep" } else { "real time" },
        a.wait_s
    );
    let started = std::time::Instant::now();
    // the trajectory is kept for what writes it (the recording, the log) and for nothing else:
    // without them a served flight's memory stays flat however long it runs
    let keep = flyarena::engine::RunOptions { trace: record || a.run.log.is_some(), ..Default::default() };
    let (main, net) = serve(&s, &opts, keep)?;
    let elapsed = started.elapsed();
    if !a.run.quiet {
        print_served(&net, a.lockstep);
    }
    // the uncompensated counterpart R2 compares with is flown by flyarena's own station: an
    // external controller's uncompensated flight is not at hand
    let twin = load_for_run(&a.run)?.with_builtin_stations();
    let mut outcome = flyarena::run::evaluate(&twin, main, record);
    // a flight no controller flew fails, whatever the other rows say of it
    outcome.report.rows.splice(0..0, net.controller_rows());
    // a served flight is another flight than `run`'s of the same scenario: its files say so
    write_run(a.run, &s, outcome, elapsed, ".serve", Some(&net))
}

/// What `serve` served: frames, poses and clients, and per external vehicle what its controller
/// sent and what the receiver made of it.
fn print_served(net: &flyarena::serve::ServeReport, lockstep: bool) {
    println!(
        "served {} NatNet frames ({} poses) to {} client(s){}{}{}",
        net.frames,
        net.poses,
        net.clients.len(),
        if net.clients.is_empty() { "" } else { " " }.to_string() + &net.clients.join(", "),
        if lockstep {
            String::new()
        } else {
            format!(
                "; the latest tick was sent {:.1} ms late at most, {} of {} ticks more than a physics period late",
                net.max_lag_ms, net.late_ticks, net.ticks
            )
        },
        if net.send_errors > 0 { format!("; {} datagrams could not be sent", net.send_errors) } else { String::new() }
    );
    for c in &net.commands {
        let k = &c.stats;
        println!(
            "{}: {} commands received, {} applied, {} duplicate, {} out of order, {} missing; {} radio ticks held the last frame{}{}",
            c.vehicle,
            k.received,
            k.applied,
            k.duplicates,
            k.out_of_order,
            k.missing,
            k.held,
            if k.failsafe > 0 { format!(", {} sent the failsafe's idle frame", k.failsafe) } else { String::new() },
            if k.timeouts > 0 {
                format!("; the controller missed {} lockstep deadline(s)", k.timeouts)
            } else {
                String::new()
            }
        );
    }
    if net.rejected > 0 {
        println!("{} packets refused (malformed, another version, an unknown vehicle or NatNet message)", net.rejected);
    }
    if net.clients_refused > 0 {
        println!("{} connects from new addresses refused: 32 clients were registered", net.clients_refused);
    }
}

/// `serve`'s summary: `run`'s, then what happened on the network.
#[derive(serde::Serialize)]
struct Served<'a> {
    #[serde(flatten)]
    summary: flyarena::run::Summary,
    serve: &'a flyarena::serve::ServeReport,
}

/// The summary JSON of a run, with the network report of a served one.
fn summary_json(outcome: &Outcome, s: &Scenario, served: Option<&flyarena::serve::ServeReport>) -> Vec<u8> {
    match served {
        None => serde_json::to_vec_pretty(&outcome.summary(s)),
        Some(serve) => serde_json::to_vec_pretty(&Served { summary: outcome.summary(s), serve }),
    }
    .expect("summary serialises")
}

/// Writes what `run` writes (summary, log, recording) and prints the table; `made_by` marks
/// the default names of a flight not flown by `run` (`.serve`).
fn write_run(
    a: RunArgs,
    s: &Scenario,
    outcome: Outcome,
    elapsed: std::time::Duration,
    made_by: &str,
    served: Option<&flyarena::serve::ServeReport>,
) -> Result<i32, Error> {
    let json_path = a.json.unwrap_or_else(|| a.out.join(format!("{}{made_by}.json", s.name())));
    let json = summary_json(&outcome, s, served);
    // the uncompensated twin is only recorded (`record` feature)
    #[cfg_attr(not(feature = "record"), allow(unused_variables))]
    let Outcome { main, uncompensated: unc, report } = outcome;
    write_output(&json_path, &json)?;
    let mut log_paths = Vec::new();
    if let Some(base) = &a.log {
        let period = 1.0 / s.mocap().rate_hz() as f64;
        for v in &main.vehicles {
            let path = if main.vehicles.len() == 1 {
                base.clone()
            } else {
                let stem = base.file_stem().map(|x| x.to_string_lossy().into_owned()).unwrap_or_default();
                base.with_file_name(format!("{stem}-{}.csv", v.name))
            };
            write_output(&path, flyarena::log::write_csv(v, period).as_bytes())?;
            log_paths.push(path);
        }
    }
    let record = cfg!(feature = "record") && !a.no_rrd;
    let rrd_path = record.then(|| a.rrd.unwrap_or_else(|| a.out.join(format!("{}{made_by}.rrd", s.name()))));
    #[cfg(feature = "record")]
    if let Some(path) = &rrd_path {
        let opts = flyarena::record::RecordOptions { every: a.rrd_every as usize };
        let bytes = flyarena::record::encode(&main, unc.as_ref(), &report, opts)?;
        write_output(path, &bytes)?;
    }
    let verdict = if report.passed() { "PASS" } else { "FAIL" };
    if !a.quiet {
        println!(
            "{} (seed {}): {:.1} s simulated in {:.2} s wall\n",
            s.name(),
            s.seed(),
            main.duration.as_secs_f64(),
            elapsed.as_secs_f64()
        );
        if report.rows.is_empty() && s.requirements().identify.is_some() {
            println!("(R5 is checked by `flyarena identify {}`)\n", a.scenario.display());
        } else if report.rows.is_empty() {
            println!("(the scenario declares no requirements)\n");
        } else {
            print!("{}", report.table());
            println!();
        }
        for v in main.vehicles.iter().filter(|v| v.failsafe.episodes > 0) {
            let f = &v.failsafe;
            println!(
                "{}: mocap-outage failsafe entered {} time(s), first at {:.2} s, {:.2} s in total (longest {:.2} s){}",
                v.name,
                f.episodes,
                f.first_at_s.unwrap_or(0.0),
                f.total_s,
                f.longest_s,
                if f.active_at_end { ", still active at the end" } else { ", recovered" }
            );
        }
        println!("summary: {}", json_path.display());
        for p in &log_paths {
            println!("flight log: {}", p.display());
        }
        if let Some(p) = &rrd_path {
            println!("recording: {} (open with `rerun {}`)", p.display(), p.display());
        }
    }
    println!(
        "{verdict}: {} of {} requirement checks passed",
        report.rows.iter().filter(|r| r.pass).count(),
        report.rows.len()
    );
    Ok(if report.passed() { PASS } else { FAIL })
}

fn cmd_check(args: &[PathBuf]) -> i32 {
    let mut code = PASS;
    for p in args {
        match Scenario::load(p) {
            Ok(s) => println!(
                "{}: ok ({} vehicle(s), {} phase(s), {:.1} s)",
                p.display(),
                s.vehicle_cfgs().len(),
                s.plan().len(),
                s.spec().run_time.as_secs_f64()
            ),
            Err(e) => {
                eprintln!("error: {e}");
                code = BAD_INPUT;
            }
        }
    }
    code
}

fn sweep_files(out: &Path, name: &str) -> (PathBuf, PathBuf) {
    (out.join(format!("{name}.sweep.json")), out.join(format!("{name}.sweep.csv")))
}

/// Writes a whole sweep's outputs and prints its summary; returns the exit code.
fn finish_sweep(o: &flyarena::sweep::SweepOutput, out_dir: &Path, quiet: bool) -> Result<i32, Error> {
    let summary = flyarena::sweep::summary(o);
    let (json_path, csv_path) = sweep_files(out_dir, &o.scenario);
    let json = serde_json::to_vec_pretty(&serde_json::json!({ "summary": summary, "output": o })).expect("serialises");
    for (path, bytes) in [(&json_path, json), (&csv_path, flyarena::sweep::csv(o).into_bytes())] {
        write_output(path, &bytes)?;
    }
    let failed = o.rows.iter().filter(|r| !r.passed).count();
    if !quiet {
        println!("{}: {} runs, {} rows\n", o.scenario, o.runs, o.rows.len());
        print!("{}", summary.text());
        println!("\nrows: {}\nsummary: {}", csv_path.display(), json_path.display());
    }
    println!(
        "{}: {} of {} rows passed every requirement",
        if failed == 0 { "PASS" } else { "FAIL" },
        o.rows.len() - failed,
        o.rows.len()
    );
    Ok(if failed == 0 { PASS } else { FAIL })
}

fn cmd_sweep(a: SweepArgs) -> Result<i32, Error> {
    let SweepArgs { scenario: file, runs, shard, out, quiet } = a;
    let sweep = flyarena::sweep::Sweep::load(&file)?;
    let runs = runs.unwrap_or(sweep.default_runs());
    let mine = flyarena::sweep::shard_runs(runs, shard).count() as u64;
    use std::io::IsTerminal;
    let bar = if !quiet && std::io::stderr().is_terminal() {
        let b = indicatif::ProgressBar::new(mine);
        b.set_style(
            indicatif::ProgressStyle::with_template("{bar:40} {pos}/{len} runs  {elapsed} elapsed, ETA {eta}")
                .expect("template"),
        );
        b
    } else {
        indicatif::ProgressBar::hidden()
    };
    let journal = flyarena::sweep::Journal::open(&sweep, runs, shard, &out)?;
    let done_mine = flyarena::sweep::shard_runs(runs, shard).filter(|i| journal.done().contains_key(i)).count() as u64;
    if done_mine > 0 && !quiet {
        eprintln!("resuming: {done_mine} of {mine} runs already done ({})", journal.path().display());
    }
    bar.inc(done_mine);
    let result = sweep.run_resumable(runs, shard, journal.done(), &|_, rows| {
        journal.record(rows);
        bar.inc(1);
    });
    bar.finish_and_clear();
    let o = result?;
    let code = match shard {
        None => finish_sweep(&o, &out, quiet)?,
        Some((k, n)) => {
            let path = out.join(format!("{}.sweep.shard-{}-of-{n}.json", o.scenario, k + 1));
            write_output(&path, &serde_json::to_vec(&o).expect("serialises"))?;
            println!("shard {}/{n}: {} runs → {} (combine with `flyarena merge`)", k + 1, mine, path.display());
            PASS
        }
    };
    // on an error above the journal stays, and a rerun resumes from it
    journal.finish();
    Ok(code)
}

fn cmd_merge(files: &[PathBuf], out: &Path) -> Result<i32, Error> {
    let mut sweeps = Vec::new();
    let mut trials = Vec::new();
    for f in files {
        let bytes = std::fs::read(f).map_err(|e| Error::Usage(format!("{}: {e}", f.display())))?;
        let not_a_shard = |e: serde_json::Error| Error::Usage(format!("{}: not a shard file: {e}", f.display()));
        // a trials shard holds `outcomes`, a sweep shard `rows`
        let value: serde_json::Value = serde_json::from_slice(&bytes).map_err(not_a_shard)?;
        if value.get("outcomes").is_some() {
            trials.push(serde_json::from_value::<flyarena::identify::trials::TrialsShard>(value).map_err(not_a_shard)?);
        } else {
            sweeps.push(serde_json::from_slice::<flyarena::sweep::SweepOutput>(&bytes).map_err(not_a_shard)?);
        }
    }
    match (sweeps.is_empty(), trials.is_empty()) {
        (false, true) => finish_sweep(&flyarena::sweep::merge(sweeps)?, out, false),
        (true, false) => {
            let (seed, flights, outcomes) = flyarena::identify::trials::merge(trials).map_err(Error::Usage)?;
            finish_trials(seed, flights, &outcomes, out)
        }
        _ => Err(Error::Usage("the shard files mix a sweep's and a batch of trials'".into())),
    }
}

/// The combinations of inputs and options clap cannot declare.
fn check_identify(a: &IdentifyArgs) -> Result<(), Error> {
    let usage = |m: &str| Error::Usage(m.to_string());
    let first = a.inputs.first().ok_or_else(|| {
        usage("what to identify? `flyarena identify scenarios/<x>.yaml`, or a log with --scenario or --mapping")
    })?;
    let is_yaml = first.extension().is_some_and(|e| e == "yaml" || e == "yml");
    if a.inputs.len() > 1 && a.px4 {
        return Err(usage("--px4 takes one flight: the parameters are the vehicle's as that flight shows them"));
    }
    if a.inputs.len() > 1 && a.poses.is_some() {
        return Err(usage(
            "--poses goes with one IMU log: several inputs are a cross-validation of logs that hold their poses",
        ));
    }
    if a.inputs.len() > 1 && a.mapping.is_none() {
        return Err(usage("several inputs (cross-validation) need --mapping: they are logs of other tools"));
    }
    match (is_yaml, &a.scenario, &a.mapping) {
        (true, None, None) => {}
        (true, _, _) => {
            return Err(usage(
                "a scenario input is run and identified by itself: --scenario and --mapping are for logs",
            ));
        }
        (false, Some(_), Some(_)) => {
            return Err(usage("--scenario (a flyarena log) and --mapping (another tool's log) exclude each other"));
        }
        (false, None, None) => {
            return Err(usage(&format!(
                "{}: a log needs --scenario SCENARIO.yaml (flyarena's own log) or --mapping MAPPING.yaml (another tool's); {}",
                first.display(),
                mapping_hint(first)
            )));
        }
        _ => {}
    }
    Ok(())
}

/// Which of the mappings in the checkout's `mappings/` reads a log like `input` (by its
/// extension, or an ASL folder's `mav0/`), and where the others and the format are described.
fn mapping_hint(input: &Path) -> String {
    let ext = input.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
    let fits = match ext.as_str() {
        "ulg" => "for a PX4 log, `--mapping mappings/px4.yaml` (or px4-crazyflie.yaml, with motors)",
        "mcap" => "for a ROS 2 bag, a mapping of its topics such as `mappings/ros2-crazyflie.yaml`",
        _ if input.join("mav0").is_dir() => "for an ASL (EuRoC) folder, `--mapping mappings/euroc.yaml`",
        "tum" | "txt" => {
            "for a TUM pose file, `--mapping mappings/imu-tum.yaml` with the IMU CSV as input and `--poses` this file"
        }
        _ => {
            "for a CSV, a mapping of its columns, like `mappings/nanobench.yaml` (a CSV with poses and IMU) or `mappings/imu-tum.yaml` (an IMU CSV, with --poses a TUM file)"
        }
    };
    format!("{fits} (the checkout's mappings/ has one for each format docs/identify.md names)")
}

fn cmd_identify(mut a: IdentifyArgs) -> Result<i32, Error> {
    check_identify(&a)?;
    if a.calibrate {
        let extra: Vec<_> =
            flyarena::identify::Effect::CALIBRATION.into_iter().filter(|e| !a.forced.contains(e)).collect();
        a.forced.extend(extra);
    }
    if a.inputs.len() > 1 {
        return cmd_identify_many(&a);
    }
    let input = &a.inputs[0];
    use flyarena::identify::{Request, Source};
    let source = match (&a.scenario, &a.mapping) {
        (Some(scenario), _) => Source::FlyarenaLog { log: input, scenario },
        (None, Some(mapping)) => Source::Mapped { log: input, mapping, poses: a.poses.as_deref() },
        (None, None) => Source::Scenario(input),
    };
    let mut forced = a.forced.clone();
    if a.px4 && !forced.contains(&flyarena::identify::Effect::MocapDelay) {
        // EKF2_EV_DELAY matters most and is the hardest to see: it is estimated as a tested
        // hypothesis, with its interval, whether or not the selection would add it
        forced.push(flyarena::identify::Effect::MocapDelay);
    }
    let req = Request {
        vehicle: a.vehicle.as_deref(),
        seed: a.seed,
        smoothing_ms: a.smoothing_ms,
        calibrate: a.calibrate,
        forced,
        clock: a.clock_offset,
        ..Request::new(source)
    };
    let stem = input.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "identify".into());
    let json_path = a.json.clone().unwrap_or_else(|| a.out.join(format!("{stem}.identify.json")));
    let guard = a.json.is_none() && !a.overwrite;
    if guard {
        refuse_another_input(&json_path, input, None)?;
    }
    let done = flyarena::identify::run(&req)?;
    if guard {
        refuse_another_input(&json_path, input, Some(&done.report.source))?;
    }
    let json = serde_json::to_vec_pretty(&flyarena::identify::identified_json(&done)).expect("report serialises");
    write_output(&json_path, &json)?;
    let frag_path = a.fragment.unwrap_or_else(|| a.out.join(format!("{stem}.effects.yaml")));
    write_output(&frag_path, done.fragment.as_bytes())?;
    let rrd_path = (cfg!(feature = "record") && !a.no_rrd)
        .then(|| a.rrd.clone().unwrap_or_else(|| a.out.join(format!("{stem}.identify.rrd"))));
    #[cfg(feature = "record")]
    if let Some(path) = &rrd_path {
        write_output(path, &flyarena::record::encode_identify(&stem, &done.report, &done.residuals)?)?;
    }
    let axes = match a.up {
        UpArg::Z => flyarena::identify::px4::MocapAxes::ZUp,
        UpArg::Y => flyarena::identify::px4::MocapAxes::YUp,
        UpArg::Ned => flyarena::identify::px4::MocapAxes::Frd,
    };
    let calibration_paths = [
        (done.t_bs_yaml.as_ref(), a.out.join(format!("{stem}.T_BS.yaml"))),
        (done.imu_trajectory.as_ref(), a.out.join(format!("{stem}.imu.tum"))),
    ];
    for (text, path) in &calibration_paths {
        if let Some(t) = text {
            write_output(path, t.as_bytes())?;
        }
    }
    let px4 = a.px4.then(|| flyarena::identify::px4::parameters(&done.report, axes));
    let px4_path = a.px4_params.clone().unwrap_or_else(|| a.out.join(format!("{stem}.px4.params")));
    if let Some(p) = &px4 {
        write_output(&px4_path, flyarena::identify::px4::qgc_file(p, &input.display().to_string()).as_bytes())?;
    }
    if !a.quiet {
        print!("{}", flyarena::identify::identified_text(&done));
        if let Some(p) = &px4 {
            print!("\n{}", flyarena::identify::px4::render(p));
        }
        let fly = fragment_hint(a.scenario.as_deref().or(a.mapping.is_none().then_some(input)), &frag_path);
        println!("\nreport: {}\nscenario fragment: {} ({fly})", json_path.display(), frag_path.display());
        if let Some(p) = &rrd_path {
            println!("residuals: {} (open with `rerun {}`)", p.display(), p.display());
        }
        if px4.is_some() {
            println!("PX4 parameters: {} (QGroundControl: Parameters → Tools → Load from file)", px4_path.display());
        }
        if let [(Some(_), t_bs), (Some(_), tum)] = &calibration_paths {
            println!(
                "calibration: {} (T_BS, ASL/Kalibr) and {} (the IMU's trajectory, TUM)",
                t_bs.display(),
                tum.display()
            );
        }
    }
    Ok(identify_verdict(&done, a.quiet, input))
}

/// How to fly a fragment back: into the scenario flown (`scenario`), or, for another tool's log,
/// into a scenario of the user's that models the vehicle.
fn fragment_hint(scenario: Option<&Path>, fragment: &Path) -> String {
    match scenario {
        Some(s) => format!("`flyarena run {} --effects {}`", s.display(), fragment.display()),
        None => format!(
            "for a scenario of your own that models this vehicle: `flyarena run YOURS.yaml --effects {}`",
            fragment.display()
        ),
    }
}

/// `identify`'s guard of its report at the default `path`: before the work (`source` `None`),
/// a report whose source names another file than `input`; after it, a report of another
/// source (the same file read with another pose file, seed or vehicle).
fn refuse_another_input(path: &Path, input: &Path, source: Option<&str>) -> Result<(), Error> {
    let named = input.display().to_string();
    let old_source = |v: &serde_json::Value| v["report"]["source"].as_str().map(str::to_owned);
    match source {
        None => {
            let other =
                |v: &serde_json::Value| old_source(v).filter(|s| !s.starts_with(&named)).map(|s| format!("`{s}`"));
            refuse_another_makers(path, &other, &format!("`{named}`"))
        }
        Some(this) => refuse_another_makers(path, &|v| old_source(v).map(|s| format!("`{s}`")), &format!("`{this}`")),
    }
}

/// Refuses to replace the report at a default `path` that another input made: the names are
/// the input's stem, which two folders may share. `maker` reads a report's maker (`None`: not
/// such a report, which is replaced); `this` is the new report's.
fn refuse_another_makers(
    path: &Path,
    maker: &dyn Fn(&serde_json::Value) -> Option<String>,
    this: &str,
) -> Result<(), Error> {
    let old = std::fs::read(path).ok().and_then(|b| serde_json::from_slice::<serde_json::Value>(&b).ok());
    match old.as_ref().and_then(maker) {
        Some(made_by) if made_by != this => Err(Error::Usage(format!(
            "{} holds the report of {made_by}, not of {this}: name another folder (--out DIR) or report (--json PATH), or replace it with --overwrite",
            path.display()
        ))),
        _ => Ok(()),
    }
}

/// `identify` over several flights: one cross-validated report.
fn cmd_identify_many(a: &IdentifyArgs) -> Result<i32, Error> {
    let inputs: Vec<&Path> = a.inputs.iter().map(PathBuf::as_path).collect();
    let m = flyarena::identify::run_many(
        &inputs,
        a.mapping.as_deref().expect("checked"),
        a.smoothing_ms,
        a.calibrate,
        &a.forced,
    )?;
    let json_path = a.json.clone().unwrap_or_else(|| a.out.join("cross-validation.identify.json"));
    let json = flyarena::identify::cross_validated_json(&m);
    if a.json.is_none() && !a.overwrite {
        // every flight read, those left out too
        let maker = |v: &serde_json::Value| {
            let mut n: Vec<&str> = ["reports", "excluded"]
                .iter()
                .flat_map(|k| v[k].as_array().into_iter().flatten().filter_map(|f| f["flight"].as_str()))
                .collect();
            n.sort_unstable();
            v["cross_validation"].is_object().then(|| format!("the flights {}", n.join(", ")))
        };
        let this = maker(&json).expect("a cross-validation");
        refuse_another_makers(&json_path, &maker, &this)?;
    }
    write_output(&json_path, &serde_json::to_vec_pretty(&json).expect("serialises"))?;
    if !a.quiet {
        print!("{}", flyarena::identify::cross_validated_text(&m));
    }
    println!("\nreport: {}", json_path.display());
    Ok(PASS)
}

/// The last lines of `identify` and its exit code: R5's table and verdict when the scenario
/// declares it (1 when it fails); else 1 with what makes the fit impossible when the frames or
/// the clocks are not aligned, or the one-line verdict under `--quiet`.
fn identify_verdict(done: &flyarena::identify::Identified, quiet: bool, input: &Path) -> i32 {
    match &done.requirements {
        Some(req) => {
            if !quiet {
                println!();
                print!("{}", req.table());
                println!();
            }
            let verdict = if req.passed() { "PASS" } else { "FAIL" };
            println!(
                "{verdict}: {} of {} requirement checks passed",
                req.rows.iter().filter(|r| r.pass).count(),
                req.rows.len()
            );
            if req.passed() { PASS } else { FAIL }
        }
        None if !done.report.misaligned.is_empty() => {
            println!(
                "{}FAIL: the frames or the clocks are not aligned, so no effect is claimed ({})",
                if quiet { format!("{}: ", input.display()) } else { "\n".to_string() },
                done.report.misaligned.iter().map(ToString::to_string).collect::<Vec<_>>().join("; ")
            );
            FAIL
        }
        None => {
            if quiet {
                println!("{}: {}", input.display(), flyarena::identify::report::verdict(&done.report));
            }
            PASS
        }
    }
}

fn cmd_trials(flights: u64, seed: u64, shard: Option<(u64, u64)>, out: &Path) -> Result<i32, Error> {
    let outcomes = flyarena::identify::trials::run_shard(seed, flights, shard, &flyarena::identify::Options::default());
    if let Some((k, n)) = shard {
        let part = flyarena::identify::trials::TrialsShard { seed, flights, shard: [k + 1, n], outcomes };
        let path = out.join(format!("trials-{seed}-{flights}.shard-{}-of-{n}.json", k + 1));
        write_output(&path, &serde_json::to_vec_pretty(&part).expect("serialises"))?;
        println!(
            "shard {}/{n}: {} flights → {} (combine with `flyarena merge`)",
            k + 1,
            part.outcomes.len(),
            path.display()
        );
        return Ok(PASS);
    }
    finish_trials(seed, flights, &outcomes, out)
}

/// Hand-held rigs calibrated (DIR/handheld[-<setting>][-<smoothing>ms]-<seed>-<N>.json), and
/// with `logs` their logs.
fn cmd_handheld(
    flights: u64,
    seed: u64,
    logs: bool,
    smoothing_ms: Option<f64>,
    setting: Option<&Path>,
    out: &Path,
) -> Result<i32, Error> {
    use flyarena::identify::handheld;
    let set = match setting {
        Some(path) => handheld::Setting::read(path)?,
        None => handheld::Setting::default(),
    };
    // the name says what made the batch: a setting file and a smoothing of one's own each
    // write their own, so that no batch overwrites another's
    let mut name = "handheld".to_string();
    if let Some(stem) = setting.and_then(Path::file_stem) {
        name += &format!("-{}", stem.to_string_lossy());
    }
    if let Some(ms) = smoothing_ms {
        name += &format!("-{ms}ms");
    }
    name += &format!("-{seed}-{flights}");
    if logs {
        for i in 0..flights {
            write_output(
                &out.join(&name).join(format!("flight-{i}.csv")),
                handheld::draw_for(seed, i, &set).log(&set).as_bytes(),
            )?;
        }
    }
    let mut options = handheld::options();
    if let Some(ms) = smoothing_ms {
        options.design.smoothing_s = ms * 1e-3;
    }
    let outcomes = handheld::run_many(seed, flights, &set, &options);
    let table = flyarena::identify::render_handheld(&outcomes, &set);
    let json =
        serde_json::json!({ "seed": seed, "flights": flights, "setting": set, "table": table, "outcomes": outcomes });
    let path = out.join(format!("{name}.json"));
    write_output(&path, &serde_json::to_vec_pretty(&json).expect("serialises"))?;
    print!("{table}");
    if logs {
        println!(
            "\nlogs: {} (`flyarena identify FLIGHT.csv --mapping mappings/handheld.yaml --calibrate`)",
            out.join(&name).display()
        );
    }
    println!("\nreport: {}", path.display());
    Ok(PASS)
}

/// A real log with mounts and clock offsets injected, each case calibrated and scored against
/// the plain log's calibration composed with its injection (DIR/injected-<log>-<seed>-<N>.json).
fn cmd_injected(log: &Path, mapping: &Path, cases: u64, seed: u64, out: &Path) -> Result<i32, Error> {
    use flyarena::identify::{Mapping, Options, injected};
    let map = Mapping::load(mapping)?;
    let streams = injected::streams(&map, log)?;
    let mut o = Options::calibration();
    if let Some(ms) = map.smoothing_ms {
        o.design.smoothing_s = ms * 1e-3;
    }
    let stem = log.file_name().map_or_else(|| "log".to_string(), |s| s.to_string_lossy().into_owned());
    let (plain, outcomes) = injected::run_many(&map, &streams, &log.display().to_string(), seed, cases, &o)?;
    let table = injected::render(&log.display().to_string(), &outcomes);
    let json = serde_json::json!({
        "log": log.display().to_string(), "seed": seed, "cases": cases, "table": table,
        "plain": plain.effects, "outcomes": outcomes,
    });
    let path = out.join(format!("injected-{stem}-{seed}-{cases}.json"));
    write_output(&path, &serde_json::to_vec_pretty(&json).expect("serialises"))?;
    print!("{table}");
    println!(
        "
report: {}",
        path.display()
    );
    Ok(PASS)
}

/// The batch's table and report (DIR/trials-<seed>-<N>.json), from all its outcomes.
fn finish_trials(
    seed: u64,
    flights: u64,
    outcomes: &[flyarena::identify::trials::Outcome],
    out: &Path,
) -> Result<i32, Error> {
    let table = flyarena::identify::trials::render(outcomes);
    let (by, total) = flyarena::identify::trials::score(outcomes);
    let json = serde_json::json!({ "seed": seed, "flights": flights, "scores": by.iter().map(|(e, s)| serde_json::json!({"effect": e, "score": s})).collect::<Vec<_>>(), "total": total, "outcomes": outcomes });
    let path = out.join(format!("trials-{seed}-{flights}.json"));
    write_output(&path, &serde_json::to_vec_pretty(&json).expect("serialises"))?;
    print!("{table}");
    println!("\nreport: {}", path.display());
    Ok(PASS)
}

fn cmd_slurm(job: SlurmJob) -> Result<i32, Error> {
    use flyarena::slurm::{Cluster, Job, scripts};
    let absolute = |p: &Path| std::path::absolute(p).map_err(|e| Error::Usage(format!("{}: {e}", p.display())));
    let (job, name, c) = match job {
        SlurmJob::Sweep { scenario, runs, cluster } => {
            // the scenario is checked here, on the login node, not by every task
            let s = Scenario::load(&scenario)?;
            if s.sweep().is_none() {
                return Err(Error::Usage(format!("{}: has no `sweep:` section", scenario.display())));
            }
            (Job::Sweep { scenario: absolute(&scenario)?, runs }, s.name().to_string(), cluster)
        }
        SlurmJob::Trials { flights, seed, cluster } => {
            (Job::Trials { flights, seed }, format!("trials-{seed}-{flights}"), cluster)
        }
    };
    let cluster = Cluster { partition: c.partition, time: c.time, cpus_per_task: c.cpus_per_task, account: c.account };
    let bin = std::env::current_exe().map_err(|e| Error::Usage(format!("the flyarena binary's path: {e}")))?;
    let out = absolute(&c.out)?;
    let s = scripts(&job, c.tasks, &cluster, &bin, &out, &name).map_err(Error::Usage)?;
    for (file, text) in [&s.array, &s.merge, &s.submit] {
        write_output(&out.join(file), text.as_bytes())?;
    }
    let submit = out.join(&s.submit.0);
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        std::fs::set_permissions(&submit, std::fs::Permissions::from_mode(0o755))
            .map_err(|source| Error::Write { path: submit.clone(), source })?;
    }
    println!(
        "{} array tasks → {}; submit on a login node with: {}",
        c.tasks,
        out.join(&s.array.0).display(),
        submit.display()
    );
    Ok(PASS)
}

/// The process's exit code for the command line it was given (clap's own errors exit 2,
/// `--help` and `--version` 0).
pub fn main() -> std::process::ExitCode {
    // every code is 0 (pass), 1 (a requirement failed), 2 (bad input) or 130 (interrupted)
    std::process::ExitCode::from(u8::try_from(run()).unwrap_or(BAD_INPUT as u8))
}

/// Parses the command line, runs the command, and gives its exit code; an error is printed
/// to stderr here, the one place every command's error reaches.
fn run() -> i32 {
    let cli = match Cli::try_parse() {
        Ok(c) => c,
        Err(e) => {
            let code = if e.use_stderr() { BAD_INPUT } else { PASS };
            let _ = e.print();
            return code;
        }
    };
    install_interrupt_handler(|_| {
        // not eprintln!: with stderr gone (the parent that read it was killed) it would panic
        // the handler's thread, and the process, deaf to every later signal, would fly on
        let _ = writeln!(
            std::io::stderr(),
            "interrupted: finished outputs are complete, unfinished ones untouched (a sweep resumes from its journal)"
        );
        std::process::exit(INTERRUPTED);
    });
    let done = match cli.command {
        Command::Run(a) => cmd_run(a),
        Command::Serve(a) => cmd_serve(a),
        Command::Check { scenarios } => Ok(cmd_check(&scenarios)),
        Command::Sweep(a) => cmd_sweep(a),
        Command::Merge { shards, out } => cmd_merge(&shards, &out),
        Command::Identify(a) => cmd_identify(a),
        Command::Trials { flights, seed, handheld: true, logs, smoothing_ms, setting, out, .. } => {
            cmd_handheld(flights, seed, logs, smoothing_ms, setting.as_deref(), &out)
        }
        Command::Trials { flights, seed, injected: Some(log), mapping: Some(mapping), out, .. } => {
            cmd_injected(&log, &mapping, flights, seed, &out)
        }
        Command::Trials { flights, seed, shard, out, .. } => cmd_trials(flights, seed, shard, &out),
        Command::Slurm { job } => cmd_slurm(job),
        Command::Completions { shell } => {
            clap_complete::generate(shell, &mut Cli::command(), "flyarena", &mut std::io::stdout());
            Ok(PASS)
        }
    };
    done.unwrap_or_else(|e| {
        eprintln!("error: {e}");
        e.exit_code()
    })
}

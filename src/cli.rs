//! The command line: `flyarena run SCENARIO.yaml`, `flyarena check SCENARIO.yaml`.
//!
//! Exit codes: 0 every requirement passed · 1 a requirement failed · 2 bad input (unreadable or
//! invalid scenario, bad arguments, an output that cannot be written).

use crate::engine::{RunOptions, run};
use crate::requirements::{self, Report};
use crate::scenario::Scenario;
use std::io::Write;
use std::path::{Path, PathBuf};

pub const USAGE: &str = "\
flyarena — quadrotor flight under motion capture with misaligned frames

USAGE:
    flyarena run SCENARIO.yaml [--out DIR] [--json PATH] [--rrd PATH | --no-rrd] [--rrd-every N]
                               [--log PATH.csv] [--effects FRAGMENT.yaml] [--seed N] [--quiet]
    flyarena check SCENARIO.yaml...
    flyarena sweep SCENARIO.yaml [--runs N] [--shard K/N] [--out DIR] [--quiet]
    flyarena merge SHARD.json... [--out DIR]
    flyarena identify SCENARIO.yaml [--vehicle NAME] [--seed N] [--out DIR] [--json PATH] [--fragment PATH]
    flyarena identify LOG.csv (--scenario SCENARIO.yaml | --mapping MAPPING.yaml) [...]
    flyarena identify LOG.csv LOG.csv... --mapping MAPPING.yaml [--with EFFECT,...]   (cross-validation)
    flyarena trials [--flights N] [--seed S] [--out DIR]

COMMANDS:
    run     simulate the scenario, print the requirements table, write the JSON summary and
            the Rerun recording (open it with `rerun out/<scenario>.rrd`)
    check   validate scenarios without running them
    sweep   run the scenario's `sweep:` variations in parallel: per-run metrics (CSV, JSON) and a
            summary per grid point (mean, p95, p99, pass rates); --shard K/N runs one slice
    merge   combine shard outputs into the summary one unsharded sweep would give
    identify  find what the model lacks: residuals of the nominal model against a flight (run
            from a scenario, or a log), the effects that explain them (prewhitened forward
            selection, held-out errors, 95 % intervals), and a scenario fragment with them
    trials  does identify generalise? N random flights (plans, presets, seeds, 0–3 hidden
            effects) flown and identified: recall, precision and 95 % coverage per effect
            (default 300 flights, seed 1; DIR/trials-<seed>-<N>.json)

OPTIONS:
    --out DIR     output folder (default: out)
    --json PATH   summary path (default: DIR/<scenario name>.json)
    --rrd PATH    Rerun recording path (default: DIR/<scenario name>.rrd)
    --no-rrd      do not record
    --rrd-every N record every N-th Vicon frame (default 4: 50 Hz at 200 Hz)
    --log PATH    write the flight log (CSV: mocap, IMU, commands; README, Flight logs);
                  with several vehicles, one file each, named PATH-<vehicle>.csv
    --effects F   apply an `identify` fragment (scenario fields by path) before validating
    --mapping M   identify: read another tool's CSV log through a column mapping
    --scenario S  identify: the scenario that wrote a flyarena log
    --smoothing-ms X  identify: σ of the Gaussian smoothing before differentiating (default 20)
    --with E,...  identify: fit these effects without testing them (e.g. body_offset), select the rest
    --seed N      override the scenario's seed (identify LOG --scenario: the seed the log was run
                  with, for the closed-loop comparison)
    --quiet       print only the verdict line

EXIT CODES: 0 pass · 1 a requirement failed · 2 bad input · 130 interrupted";

/// Exit codes.
pub const PASS: i32 = 0;
pub const FAIL: i32 = 1;
pub const BAD_INPUT: i32 = 2;
/// Interrupted by SIGINT or SIGTERM (128 + 2, the shell's convention).
pub const INTERRUPTED: i32 = 130;

/// Temporary files being written right now: an interrupt removes them, so a killed run leaves
/// each output either as it was or complete (the rename is atomic), and no debris.
static IN_FLIGHT: std::sync::Mutex<Vec<PathBuf>> = std::sync::Mutex::new(Vec::new());

/// Installs the SIGINT/SIGTERM handler (once per process; later calls are no-ops).
pub fn install_interrupt_handler() {
    let _ = ctrlc::set_handler(|| {
        if let Ok(files) = IN_FLIGHT.lock() {
            for f in files.iter() {
                let _ = std::fs::remove_file(f);
            }
        }
        eprintln!("interrupted: finished outputs are complete, unfinished ones untouched (a sweep resumes from its journal)");
        std::process::exit(INTERRUPTED);
    });
}

/// Writes `bytes` to `path` through a temporary file in the same folder and a rename, so the
/// path holds either its previous content or the complete new one, never half a file.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let dir = path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    std::fs::create_dir_all(dir)?;
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let tmp = dir.join(format!(".{name}.tmp-{}", std::process::id()));
    if let Ok(mut f) = IN_FLIGHT.lock() {
        f.push(tmp.clone());
    }
    let result = (|| {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    if let Ok(mut f) = IN_FLIGHT.lock() {
        f.retain(|p| *p != tmp);
    }
    result
}

/// [`write_atomic`], with the error reported to the user as bad output (exit code 2).
fn write_output(path: &Path, bytes: &[u8]) -> Result<(), i32> {
    write_atomic(path, bytes).map_err(|e| {
        eprintln!("error: cannot write {}: {e}", path.display());
        BAD_INPUT
    })
}

struct RunArgs {
    scenario: PathBuf,
    out: PathBuf,
    json: Option<PathBuf>,
    rrd: Option<PathBuf>,
    no_rrd: bool,
    rrd_every: usize,
    log: Option<PathBuf>,
    effects: Option<PathBuf>,
    seed: Option<u64>,
    quiet: bool,
}

fn parse_run(args: &[String]) -> Result<RunArgs, String> {
    let mut it = args.iter();
    let mut a = RunArgs { scenario: PathBuf::new(), out: PathBuf::from("out"), json: None, rrd: None, no_rrd: false, rrd_every: 4, log: None, effects: None, seed: None, quiet: false };
    let mut scenario = None;
    while let Some(x) = it.next() {
        let mut value = |flag: &str| it.next().cloned().ok_or_else(|| format!("{flag} needs a value"));
        match x.as_str() {
            "--out" => a.out = PathBuf::from(value("--out")?),
            "--json" => a.json = Some(PathBuf::from(value("--json")?)),
            "--rrd" => a.rrd = Some(PathBuf::from(value("--rrd")?)),
            "--no-rrd" => a.no_rrd = true,
            "--log" => a.log = Some(PathBuf::from(value("--log")?)),
            "--effects" => a.effects = Some(PathBuf::from(value("--effects")?)),
            "--rrd-every" => {
                let v = value("--rrd-every")?;
                a.rrd_every = v.parse().ok().filter(|n| (1..=1000).contains(n)).ok_or_else(|| format!("--rrd-every takes a whole number from 1 to 1000, not `{v}`"))?;
            }
            "--seed" => {
                let v = value("--seed")?;
                a.seed = Some(v.parse().map_err(|_| format!("--seed takes a whole number from 0 to {}, not `{v}`", u64::MAX))?);
            }
            "--quiet" | "-q" => a.quiet = true,
            s if s.starts_with('-') => return Err(format!("unknown option `{s}`")),
            s if scenario.is_none() => scenario = Some(PathBuf::from(s)),
            s => return Err(format!("one scenario per run; unexpected `{s}`")),
        }
    }
    a.scenario = scenario.ok_or("which scenario? `flyarena run scenarios/<x>.yaml`")?;
    if a.no_rrd && a.rrd.is_some() {
        return Err("--rrd and --no-rrd contradict each other".into());
    }
    if a.rrd.is_some() && !cfg!(feature = "record") {
        return Err("--rrd: this flyarena was built without the `record` feature".into());
    }
    Ok(a)
}

/// Runs a scenario (and its uncompensated counterpart when R2 asks for it) and evaluates it.
/// `trace_uncompensated` keeps the counterpart's trajectory (for the recording).
pub fn run_scenario(s: &Scenario, trace_uncompensated: bool) -> (crate::engine::RunOutput, Option<crate::engine::RunOutput>, Report) {
    let main = run(s, RunOptions::default());
    let unc = requirements::needs_uncompensated(&s.requirements)
        .then(|| run(s, RunOptions { trace: trace_uncompensated, apply_calibration: Some(false) }));
    let report = requirements::evaluate(&s.requirements, &main, unc.as_ref());
    (main, unc, report)
}

/// The JSON summary of a run.
pub fn summary(s: &Scenario, main: &crate::engine::RunOutput, unc: Option<&crate::engine::RunOutput>, report: &Report) -> serde_json::Value {
    serde_json::json!({
        "scenario": s.name,
        "seed": s.seed,
        "duration_s": main.duration.as_secs_f64(),
        "passed": report.passed(),
        "requirements": report.rows,
        "vehicles": main.vehicles.iter().enumerate()
            .map(|(i, v)| requirements::vehicle_summary(v, unc.and_then(|u| u.vehicles.get(i))))
            .collect::<Vec<_>>(),
    })
}

fn cmd_run(args: &[String]) -> i32 {
    let a = match parse_run(args) {
        Ok(a) => a,
        Err(e) => {
            eprintln!("error: {e}\n\n{USAGE}");
            return BAD_INPUT;
        }
    };
    let loaded = match &a.effects {
        Some(f) => crate::identify::feedback::load_with_effects(&a.scenario, f),
        None => Scenario::load(&a.scenario).map_err(|e| e.to_string()),
    };
    let mut s = match loaded {
        Ok(s) => s,
        Err(e) => {
            eprintln!("error: {e}");
            return BAD_INPUT;
        }
    };
    if let Some(seed) = a.seed {
        s.seed = seed;
    }
    let record = cfg!(feature = "record") && !a.no_rrd;
    let started = std::time::Instant::now();
    let (main, unc, report) = run_scenario(&s, record);
    let elapsed = started.elapsed();
    let json_path = a.json.unwrap_or_else(|| a.out.join(format!("{}.json", s.name)));
    let json = serde_json::to_vec_pretty(&summary(&s, &main, unc.as_ref(), &report)).expect("summary serialises");
    if let Err(code) = write_output(&json_path, &json) {
        return code;
    }
    let mut log_paths = Vec::new();
    if let Some(base) = &a.log {
        let period = 1.0 / s.mocap.rate_hz.value as f64;
        for v in &main.vehicles {
            let path = if main.vehicles.len() == 1 {
                base.clone()
            } else {
                let stem = base.file_stem().map(|x| x.to_string_lossy().into_owned()).unwrap_or_default();
                base.with_file_name(format!("{stem}-{}.csv", v.name))
            };
            if let Err(code) = write_output(&path, crate::log::write_csv(v, period).as_bytes()) {
                return code;
            }
            log_paths.push(path);
        }
    }
    let rrd_path = record.then(|| a.rrd.unwrap_or_else(|| a.out.join(format!("{}.rrd", s.name))));
    #[cfg(feature = "record")]
    if let Some(path) = &rrd_path {
        let opts = crate::record::RecordOptions { every: a.rrd_every };
        let bytes = match crate::record::encode(&main, unc.as_ref(), &report, opts) {
            Ok(b) => b,
            Err(e) => {
                eprintln!("error: cannot record the run: {e}");
                return BAD_INPUT;
            }
        };
        if let Err(code) = write_output(path, &bytes) {
            return code;
        }
    }
    let verdict = if report.passed() { "PASS" } else { "FAIL" };
    if !a.quiet {
        println!("{} (seed {}): {:.1} s simulated in {:.2} s wall\n", s.name, s.seed, main.duration.as_secs_f64(), elapsed.as_secs_f64());
        if report.rows.is_empty() && s.requirements.identify.is_some() {
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
    println!("{verdict}: {} of {} requirement checks passed", report.rows.iter().filter(|r| r.pass).count(), report.rows.len());
    if report.passed() { PASS } else { FAIL }
}

fn cmd_check(args: &[String]) -> i32 {
    if args.is_empty() {
        eprintln!("error: which scenario? `flyarena check scenarios/<x>.yaml`\n\n{USAGE}");
        return BAD_INPUT;
    }
    let mut code = PASS;
    for p in args {
        match Scenario::load(Path::new(p)) {
            Ok(s) => println!("{p}: ok ({} vehicle(s), {} phase(s), {:.1} s)", s.vehicles.value.len(), s.plan.value.len(), s.run_time_s()),
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
fn finish_sweep(o: &crate::sweep::SweepOutput, out_dir: &Path, quiet: bool) -> i32 {
    let summary = crate::sweep::summary(o);
    let (json_path, csv_path) = sweep_files(out_dir, &o.scenario);
    let json = serde_json::to_vec_pretty(&serde_json::json!({ "summary": summary, "output": o })).expect("serialises");
    for (path, bytes) in [(&json_path, json), (&csv_path, crate::sweep::csv(o).into_bytes())] {
        if let Err(code) = write_output(path, &bytes) {
            return code;
        }
    }
    let failed = o.rows.iter().filter(|r| !r.passed).count();
    if !quiet {
        println!("{}: {} runs, {} rows\n", o.scenario, o.runs, o.rows.len());
        for g in summary["groups"].as_array().into_iter().flatten() {
            let m = |k: &str, q: &str| g["metrics"][k][q].as_f64().map_or("-".into(), |x| format!("{x:.4}"));
            println!(
                "grid point {}: {}\n  pass rate {:.1} % ({}), roll err p95/p99 {}°/{}°, yaw (gyro) err p99 {}°, spin drift p99 {} m",
                g["grid_point"],
                g["grid"],
                100.0 * g["pass_rate_all"].as_f64().unwrap_or(0.0),
                g["pass_rate"],
                m("roll_err_deg", "p95"),
                m("roll_err_deg", "p99"),
                m("yaw_gyro_err_deg", "p99"),
                m("spin_dev_m", "p99"),
            );
        }
        println!("\nrows: {}\nsummary: {}", csv_path.display(), json_path.display());
    }
    println!("{}: {} of {} rows passed every requirement", if failed == 0 { "PASS" } else { "FAIL" }, o.rows.len() - failed, o.rows.len());
    if failed == 0 { PASS } else { FAIL }
}

fn cmd_sweep(args: &[String]) -> i32 {
    let mut it = args.iter();
    let (mut file, mut runs, mut shard, mut out, mut quiet) = (None, None, None, PathBuf::from("out"), false);
    let bad = |m: String| {
        eprintln!("error: {m}\n\n{USAGE}");
        BAD_INPUT
    };
    while let Some(x) = it.next() {
        match x.as_str() {
            "--runs" => match it.next().and_then(|v| v.parse::<u64>().ok()).filter(|n| (1..=10_000_000).contains(n)) {
                Some(n) => runs = Some(n),
                None => return bad("--runs takes a whole number from 1 to 10000000".into()),
            },
            "--shard" => {
                let v = it.next().cloned().unwrap_or_default();
                match v.split_once('/').and_then(|(k, n)| Some((k.parse::<u64>().ok()?, n.parse::<u64>().ok()?))) {
                    Some((k, n)) if n >= 1 && (1..=n).contains(&k) => shard = Some((k - 1, n)),
                    _ => return bad(format!("--shard takes K/N with 1 ≤ K ≤ N (e.g. 2/8), not `{v}`")),
                }
            }
            "--out" => match it.next() {
                Some(d) => out = PathBuf::from(d),
                None => return bad("--out needs a value".into()),
            },
            "--quiet" | "-q" => quiet = true,
            s if s.starts_with('-') => return bad(format!("unknown option `{s}`")),
            s if file.is_none() => file = Some(PathBuf::from(s)),
            s => return bad(format!("one scenario per sweep; unexpected `{s}`")),
        }
    }
    let Some(file) = file else { return bad("which scenario? `flyarena sweep scenarios/<x>.yaml`".into()) };
    let sweep = match crate::sweep::Sweep::load(&file) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("error: {e}");
            return BAD_INPUT;
        }
    };
    let runs = runs.unwrap_or(sweep.default_runs());
    let mine = crate::sweep::shard_runs(runs, shard).count() as u64;
    use std::io::IsTerminal;
    let bar = if !quiet && std::io::stderr().is_terminal() {
        let b = indicatif::ProgressBar::new(mine);
        b.set_style(indicatif::ProgressStyle::with_template("{bar:40} {pos}/{len} runs  {elapsed} elapsed, ETA {eta}").expect("template"));
        b
    } else {
        indicatif::ProgressBar::hidden()
    };
    // the journal: one line per finished run, so a killed sweep restarted with the same
    // arguments redoes nothing it finished; removed once the outputs are written
    let journal_path = match shard {
        None => out.join(format!("{}.sweep.journal.jsonl", sweep.name())),
        Some((k, n)) => out.join(format!("{}.sweep.shard-{}-of-{n}.journal.jsonl", sweep.name(), k + 1)),
    };
    let header = sweep.journal_header(runs, shard);
    let done = crate::sweep::read_journal(&journal_path, &header);
    let done_mine = crate::sweep::shard_runs(runs, shard).filter(|i| done.contains_key(i)).count() as u64;
    if done_mine > 0 && !quiet {
        eprintln!("resuming: {done_mine} of {mine} runs already done ({})", journal_path.display());
    }
    let journal = (|| -> std::io::Result<std::fs::File> {
        std::fs::create_dir_all(&out)?;
        let mut f = std::fs::OpenOptions::new().create(true).append(true).open(&journal_path)?;
        if done.is_empty() {
            // a new journal (or one of another sweep): start it over
            f = std::fs::File::create(&journal_path)?;
            writeln!(f, "{}", serde_json::to_string(&header).expect("serialises"))?;
        }
        Ok(f)
    })();
    let journal = match journal {
        Ok(f) => std::sync::Mutex::new(f),
        Err(e) => {
            eprintln!("error: cannot write the sweep journal {}: {e}", journal_path.display());
            return BAD_INPUT;
        }
    };
    bar.inc(done_mine);
    let result = sweep.run_resumable(runs, shard, &done, &|_, rows| {
        let line = serde_json::to_string(rows).expect("serialises") + "\n";
        if let Ok(mut f) = journal.lock() {
            // one write per line; a line cut by a kill is skipped on resume
            let _ = f.write_all(line.as_bytes()).and_then(|_| f.flush());
        }
        bar.inc(1);
    });
    bar.finish_and_clear();
    let o = match result {
        Ok(o) => o,
        Err(e) => {
            eprintln!("error: {e}");
            return BAD_INPUT;
        }
    };
    let code = match shard {
        None => finish_sweep(&o, &out, quiet),
        Some((k, n)) => {
            let path = out.join(format!("{}.sweep.shard-{}-of-{n}.json", o.scenario, k + 1));
            if let Err(code) = write_output(&path, &serde_json::to_vec(&o).expect("serialises")) {
                return code;
            }
            println!("shard {}/{n}: {} runs → {} (combine with `flyarena merge`)", k + 1, mine, path.display());
            PASS
        }
    };
    if code != BAD_INPUT {
        let _ = std::fs::remove_file(&journal_path);
    }
    code
}

fn cmd_merge(args: &[String]) -> i32 {
    let mut it = args.iter();
    let (mut files, mut out) = (Vec::new(), PathBuf::from("out"));
    while let Some(x) = it.next() {
        match x.as_str() {
            "--out" => match it.next() {
                Some(d) => out = PathBuf::from(d),
                None => {
                    eprintln!("error: --out needs a value");
                    return BAD_INPUT;
                }
            },
            s if s.starts_with('-') => {
                eprintln!("error: unknown option `{s}`\n\n{USAGE}");
                return BAD_INPUT;
            }
            s => files.push(PathBuf::from(s)),
        }
    }
    let mut parts = Vec::new();
    for f in &files {
        let part = std::fs::read(f).map_err(|e| e.to_string()).and_then(|b| serde_json::from_slice::<crate::sweep::SweepOutput>(&b).map_err(|e| format!("not a shard file: {e}")));
        match part {
            Ok(p) => parts.push(p),
            Err(e) => {
                eprintln!("error: {}: {e}", f.display());
                return BAD_INPUT;
            }
        }
    }
    match crate::sweep::merge(parts) {
        Ok(o) => finish_sweep(&o, &out, false),
        Err(e) => {
            eprintln!("error: {e}");
            BAD_INPUT
        }
    }
}

/// Entry point; returns the process exit code.
struct IdentifyArgs {
    inputs: Vec<PathBuf>,
    forced: Vec<crate::identify::Effect>,
    scenario: Option<PathBuf>,
    mapping: Option<PathBuf>,
    vehicle: Option<String>,
    out: PathBuf,
    json: Option<PathBuf>,
    fragment: Option<PathBuf>,
    seed: Option<u64>,
    smoothing_ms: Option<f64>,
    rrd: Option<PathBuf>,
    no_rrd: bool,
    quiet: bool,
}

fn parse_identify(args: &[String]) -> Result<IdentifyArgs, String> {
    let mut it = args.iter();
    let mut a = IdentifyArgs { inputs: Vec::new(), forced: Vec::new(), scenario: None, mapping: None, vehicle: None, out: PathBuf::from("out"), json: None, fragment: None, seed: None, smoothing_ms: None, rrd: None, no_rrd: false, quiet: false };
    while let Some(x) = it.next() {
        let mut value = |flag: &str| it.next().cloned().ok_or_else(|| format!("{flag} needs a value"));
        match x.as_str() {
            "--with" => {
                for name in value("--with")?.split(',') {
                    let e = crate::identify::Effect::ALL.iter().find(|e| e.key() == name.trim()).ok_or_else(|| {
                        format!("--with: `{name}` is not an effect; the effects are {}", crate::identify::Effect::ALL.iter().map(|e| e.key()).collect::<Vec<_>>().join(", "))
                    })?;
                    a.forced.push(*e);
                }
            }
            "--scenario" => a.scenario = Some(PathBuf::from(value("--scenario")?)),
            "--mapping" => a.mapping = Some(PathBuf::from(value("--mapping")?)),
            "--vehicle" => a.vehicle = Some(value("--vehicle")?),
            "--out" => a.out = PathBuf::from(value("--out")?),
            "--json" => a.json = Some(PathBuf::from(value("--json")?)),
            "--fragment" => a.fragment = Some(PathBuf::from(value("--fragment")?)),
            "--rrd" => a.rrd = Some(PathBuf::from(value("--rrd")?)),
            "--no-rrd" => a.no_rrd = true,
            "--smoothing-ms" => {
                let v = value("--smoothing-ms")?;
                a.smoothing_ms = Some(v.parse().ok().filter(|x: &f64| (2.0..=500.0).contains(x)).ok_or_else(|| format!("--smoothing-ms takes a number of milliseconds from 2 to 500, not `{v}`"))?);
            }
            "--seed" => {
                let v = value("--seed")?;
                a.seed = Some(v.parse().map_err(|_| format!("--seed takes a whole number from 0 to {}, not `{v}`", u64::MAX))?);
            }
            "--quiet" | "-q" => a.quiet = true,
            s if s.starts_with('-') => return Err(format!("unknown option `{s}`")),
            s => a.inputs.push(PathBuf::from(s)),
        }
    }
    let first = a.inputs.first().ok_or("what to identify? `flyarena identify scenarios/<x>.yaml`, or a log with --scenario or --mapping")?;
    let is_yaml = first.extension().is_some_and(|e| e == "yaml" || e == "yml");
    if a.inputs.len() > 1 && a.mapping.is_none() {
        return Err("several inputs (cross-validation) need --mapping: they are logs of other tools".into());
    }
    match (is_yaml, &a.scenario, &a.mapping) {
        (true, None, None) => {}
        (true, _, _) => return Err("a scenario input is run and identified by itself: --scenario and --mapping are for logs".into()),
        (false, Some(_), Some(_)) => return Err("--scenario (a flyarena log) and --mapping (another tool's log) exclude each other".into()),
        (false, None, None) => return Err(format!("{}: a log needs --scenario SCENARIO.yaml (flyarena's own log) or --mapping MAPPING.yaml (another tool's)", first.display())),
        _ => {}
    }
    Ok(a)
}

fn cmd_identify(args: &[String]) -> i32 {
    let a = match parse_identify(args) {
        Ok(a) => a,
        Err(e) => {
            eprintln!("error: {e}\n\n{USAGE}");
            return BAD_INPUT;
        }
    };
    if a.inputs.len() > 1 {
        let inputs: Vec<&Path> = a.inputs.iter().map(PathBuf::as_path).collect();
        return match crate::identify::cli::run_many(&inputs, a.mapping.as_deref().expect("checked"), a.smoothing_ms, &a.forced) {
            Ok(m) => {
                let json_path = a.json.unwrap_or_else(|| a.out.join("cross-validation.identify.json"));
                if let Err(code) = write_output(&json_path, &serde_json::to_vec_pretty(&m.json).expect("serialises")) {
                    return code;
                }
                if !a.quiet {
                    print!("{}", m.text);
                }
                println!("\nreport: {}", json_path.display());
                PASS
            }
            Err(e) => {
                eprintln!("error: {e}");
                BAD_INPUT
            }
        };
    }
    let input = &a.inputs[0];
    match crate::identify::cli::run(input, a.scenario.as_deref(), a.mapping.as_deref(), a.vehicle.as_deref(), a.seed, a.smoothing_ms, &a.forced) {
        Ok(done) => {
            let stem = input.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "identify".into());
            let json_path = a.json.unwrap_or_else(|| a.out.join(format!("{stem}.identify.json")));
            let json = serde_json::to_vec_pretty(&done.json).expect("report serialises");
            if let Err(code) = write_output(&json_path, &json) {
                return code;
            }
            let frag_path = a.fragment.unwrap_or_else(|| a.out.join(format!("{stem}.effects.yaml")));
            if let Err(code) = write_output(&frag_path, done.fragment.as_bytes()) {
                return code;
            }
            let rrd_path = (cfg!(feature = "record") && !a.no_rrd).then(|| a.rrd.clone().unwrap_or_else(|| a.out.join(format!("{stem}.identify.rrd"))));
            #[cfg(feature = "record")]
            if let Some(path) = &rrd_path {
                match crate::record::encode_identify(&stem, &done.report, &done.residuals) {
                    Ok(bytes) => {
                        if let Err(code) = write_output(path, &bytes) {
                            return code;
                        }
                    }
                    Err(e) => {
                        eprintln!("error: cannot record the residuals: {e}");
                        return BAD_INPUT;
                    }
                }
            }
            if !a.quiet {
                print!("{}", done.text);
                println!("\nreport: {}\nscenario fragment: {} (`flyarena run SCENARIO --effects {}`)", json_path.display(), frag_path.display(), frag_path.display());
                if let Some(p) = &rrd_path {
                    println!("residuals: {} (open with `rerun {}`)", p.display(), p.display());
                }
            }
            match &done.requirements {
                Some(req) => {
                    if !a.quiet {
                        println!();
                        print!("{}", req.table());
                        println!();
                    }
                    let verdict = if req.passed() { "PASS" } else { "FAIL" };
                    println!("{verdict}: {} of {} requirement checks passed", req.rows.iter().filter(|r| r.pass).count(), req.rows.len());
                    if req.passed() { PASS } else { FAIL }
                }
                None => PASS,
            }
        }
        Err(e) => {
            eprintln!("error: {e}");
            BAD_INPUT
        }
    }
}

fn cmd_trials(args: &[String]) -> i32 {
    let (mut flights, mut seed, mut out) = (300u64, 1u64, PathBuf::from("out"));
    let mut it = args.iter();
    while let Some(a) = it.next() {
        let mut value = |what: &str| it.next().ok_or_else(|| format!("{a} needs {what}"));
        let parsed = match a.as_str() {
            "--flights" => value("a count").and_then(|v| v.parse::<u64>().ok().filter(|n| (1..=100_000).contains(n)).map(|n| flights = n).ok_or(format!("--flights: `{v}` is not a count in [1, 100000]"))),
            "--seed" => value("a number").and_then(|v| v.parse::<u64>().map(|n| seed = n).map_err(|_| format!("--seed: `{v}` is not a whole number"))),
            "--out" => value("a folder").map(|v| out = PathBuf::from(v)),
            other => Err(format!("trials: unknown option `{other}`")),
        };
        if let Err(e) = parsed {
            eprintln!("error: {e}\n\n{USAGE}");
            return BAD_INPUT;
        }
    }
    let outcomes = crate::identify::trials::run_many(seed, flights, &crate::identify::Options::default());
    let table = crate::identify::trials::render(&outcomes);
    let (by, total) = crate::identify::trials::score(&outcomes);
    let json = serde_json::json!({ "seed": seed, "flights": flights, "scores": by.iter().map(|(e, s)| serde_json::json!({"effect": e, "score": s})).collect::<Vec<_>>(), "total": total, "outcomes": outcomes });
    let path = out.join(format!("trials-{seed}-{flights}.json"));
    if let Err(code) = write_output(&path, &serde_json::to_vec_pretty(&json).expect("serialises")) {
        return code;
    }
    print!("{table}");
    println!("\nreport: {}", path.display());
    PASS
}

pub fn main_with_args(args: &[String]) -> i32 {
    install_interrupt_handler();
    match args.first().map(String::as_str) {
        Some("run") => cmd_run(&args[1..]),
        Some("check") => cmd_check(&args[1..]),
        Some("sweep") => cmd_sweep(&args[1..]),
        Some("merge") => cmd_merge(&args[1..]),
        Some("identify") => cmd_identify(&args[1..]),
        Some("trials") => cmd_trials(&args[1..]),
        Some("-h" | "--help" | "help") => {
            println!("{USAGE}");
            PASS
        }
        Some("-V" | "--version") => {
            println!("flyarena {}", env!("CARGO_PKG_VERSION"));
            PASS
        }
        Some(other) => {
            eprintln!("error: unknown command `{other}`\n\n{USAGE}");
            BAD_INPUT
        }
        None => {
            eprintln!("{USAGE}");
            BAD_INPUT
        }
    }
}

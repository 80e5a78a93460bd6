//! Monte Carlo sweeps: many runs of one scenario with declared parameter variations, in
//! parallel, with per-run metrics and a summary; shardable over machines.
//!
//! Run i of a sweep (i = 0..N) is a pure function of (scenario text, sweep seed, i):
//! * its grid point is i mod G (mixed radix over the `grid` variations in declaration order, the
//!   first varying fastest), G = the product of the grid sizes;
//! * its `uniform`/`normal` values and its scenario seed are drawn from the stream
//!   `Stream::new(sweep seed, Component::Sweep, i)`, in declaration order, seed last.
//!
//! So results do not depend on the thread count or on how runs are split into shards: rows are
//! computed independently and ordered by i. `--shard K/N` runs the i with i mod N = K − 1 and
//! writes its rows; `flyarena merge` puts shards back together and computes the same summary,
//! byte for byte, as one unsharded sweep.
//!
//! The variations are applied to the YAML tree, which is then parsed and validated like any
//! scenario, so a variation that leaves the allowed range is reported like a bad scenario.

use crate::rng::{Component, Stream};
use crate::run::run_scenario;
use crate::scenario::patch::set_path;
use crate::scenario::{Scenario, ScenarioError, SweepCfg, Variation};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Path, PathBuf};

/// Metric names, in column order. Angles in degrees, distances in metres; NaN when a run has no
/// value for it (e.g. no yaw flight).
/// Metrics per row, in this order: the roll and pitch calibration errors, the yaw errors of
/// the gyro alignment and of the straight flight (deg, absolute; then the straight flight's
/// signed, estimate − truth), the spin drift (m) and its ratio to the
/// uncompensated twin's, and |ψ_LS − ψ_RLS| (rad).
pub const METRICS: [&str; 8] = [
    "roll_err_deg",
    "pitch_err_deg",
    "yaw_gyro_err_deg",
    "yaw_ls_err_deg",
    "yaw_ls_signed_err_deg",
    "spin_dev_m",
    "spin_ratio",
    "ls_rls_dpsi_rad",
];
/// Requirement pass flags per row.
pub const REQUIREMENTS: [&str; 4] = ["R1", "R2", "R3", "R4"];

/// Why a sweep cannot run, merge or keep its journal.
#[derive(Debug, thiserror::Error)]
pub enum SweepError {
    /// The scenario itself cannot be run.
    #[error(transparent)]
    Scenario(#[from] ScenarioError),
    /// The `sweep:` section is not valid (which entry, and why).
    #[error("{file}: sweep: {message}")]
    Spec {
        /// The scenario file.
        file: String,
        /// What is wrong.
        message: String,
    },
    /// One run's patched scenario is not valid.
    #[error("run {run}: {message}")]
    Run {
        /// The run's index.
        run: u64,
        /// What is wrong.
        message: String,
    },
    /// Shard files that do not belong together.
    #[error("merge: {0}")]
    Merge(String),
    /// The journal cannot be written.
    #[error("cannot write the sweep journal {}: {source}", path.display())]
    Journal {
        /// The journal's path.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
}

/// One vehicle of one run.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct SweepRow {
    /// The run's index in the sweep.
    pub run: u64,
    /// The scenario seed of the run (drawn from the sweep seed and the run index).
    pub seed: u64,
    /// The index of the grid point the run flew.
    pub grid_point: u64,
    /// The vehicle's name.
    pub vehicle: String,
    /// The varied values, in declaration order.
    pub params: Vec<f64>,
    /// [`METRICS`], in order (`null` in JSON for NaN).
    pub metrics: Vec<Option<f64>>,
    /// [`REQUIREMENTS`] pass flags (`None` when the scenario does not declare it).
    pub requirements: Vec<Option<bool>>,
    /// Whether the row passed every requirement it has.
    pub passed: bool,
}

/// What a (partial) sweep produced: the rows of the runs it ran.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct SweepOutput {
    /// The scenario's name.
    pub scenario: String,
    /// The sweep's own seed (`sweep.seed`), from which every run's seed and draws come.
    pub sweep_seed: u64,
    /// Runs in the whole sweep (a shard holds some of them).
    pub runs: u64,
    /// The varied field paths, in declaration order.
    pub fields: Vec<String>,
    /// Which of `fields` are grids (the rest are random draws).
    pub grid: Vec<bool>,
    /// `[K, N]` for a shard, `None` for a whole sweep.
    pub shard: Option<[u64; 2]>,
    /// The rows, by run and vehicle.
    pub rows: Vec<SweepRow>,
}

/// The plan of a sweep: the YAML tree and the checked variations.
pub struct Sweep {
    name: String,
    /// FNV-1a of the scenario text: a journal of another text is not resumed.
    text_hash: u64,
    tree: serde_json::Value,
    cfg: SweepCfg,
    variations: Vec<Variation>,
    file: String,
}

impl Sweep {
    /// Reads a scenario with a `sweep:` section.
    ///
    /// # Errors
    /// The scenario's own ([`SweepError::Scenario`]) or its `sweep:` section's
    /// ([`SweepError::Spec`]).
    pub fn load(path: &Path) -> Result<Sweep, SweepError> {
        let src =
            std::fs::read_to_string(path).map_err(|source| ScenarioError::Io { file: path.to_path_buf(), source })?;
        let scenario = Scenario::parse(&src, path)?;
        let file = path.display().to_string();
        let spec = |message: String| SweepError::Spec { file: file.clone(), message };
        let cfg = scenario
            .sweep
            .clone()
            .ok_or_else(|| spec("the scenario has no `sweep:` section (see docs/sweeps.md)".into()))?;
        if cfg.vary.is_empty() {
            return Err(spec("`vary` is empty: name at least one field to vary".into()));
        }
        let variations =
            cfg.vary.iter().map(|v| v.variation().map_err(|e| spec(e.to_string()))).collect::<Result<Vec<_>, _>>()?;
        let tree: serde_json::Value = serde_saphyr::from_str(&src).map_err(|e| spec(e.to_string()))?;
        let text_hash =
            src.bytes().fold(0xcbf2_9ce4_8422_2325u64, |h, b| (h ^ b as u64).wrapping_mul(0x0100_0000_01b3));
        let sweep = Sweep { name: scenario.name.clone(), text_hash, tree, cfg, variations, file: file.clone() };
        // every field must exist, once, and take the values its variation reaches, before
        // anything runs: a uniform's two ends (the fields' ranges are intervals), every grid
        // value, a normal's mean (its tails can still fall outside: that run's error names them)
        for (k, v) in sweep.cfg.vary.iter().enumerate() {
            if let Some(j) = sweep.cfg.vary[..k].iter().position(|w| w.field == v.field) {
                return Err(spec(format!("vary[{j}] and vary[{k}] both vary `{}`: vary each field once", v.field)));
            }
            let mut t = sweep.tree.clone();
            set_path(&mut t, &v.field, 0.0).map_err(|m| spec(format!("vary[{k}]: {m}")))?;
            let reached = match &sweep.variations[k] {
                Variation::Uniform(lo, hi) => vec![*lo, *hi],
                Variation::Normal(m, _) => vec![*m],
                Variation::Grid(g) => g.clone(),
            };
            for x in reached {
                let mut check = |x: f64| -> Result<(), SweepError> {
                    set_path(&mut t, &v.field, x).map_err(|m| spec(format!("vary[{k}]: {m}")))?;
                    Scenario::parse(&serde_json::to_string(&t).expect("a JSON tree serialises"), path)
                        .map(drop)
                        .map_err(|e| spec(format!("vary[{k}]: `{}` = {x}: {}", v.field, e.what())))
                };
                if let Err(e) = check(x) {
                    // a uniform never draws its upper end, and its lower end with probability
                    // 2⁻⁵³: an end exactly on an open bound ((0, 3600] s) is fine one ulp inside
                    let inside = match sweep.variations[k] {
                        Variation::Uniform(lo, _) if x == lo => Some(lo.next_up()),
                        Variation::Uniform(_, hi) if x == hi => Some(hi.next_down()),
                        _ => None,
                    };
                    if inside.is_none_or(|y| check(y).is_err()) {
                        return Err(e);
                    }
                }
            }
        }
        Ok(sweep)
    }

    /// The scenario's name.
    pub fn name(&self) -> &str {
        &self.name
    }
    /// The runs the scenario's `sweep.runs` asks for.
    pub fn default_runs(&self) -> u64 {
        self.cfg.runs as u64
    }

    /// The varied values and the scenario seed of run i.
    pub fn draw(&self, i: u64) -> (Vec<f64>, u64, u64) {
        let mut rng = Stream::new(self.cfg.seed, Component::Sweep, i as usize);
        let mut radix = i;
        let mut grid_point = 0;
        let mut stride = 1;
        let params = self
            .variations
            .iter()
            .map(|v| match v {
                Variation::Uniform(lo, hi) => lo + (hi - lo) * rng.uniform(),
                Variation::Normal(m, sd) => m + sd * rng.normal(),
                Variation::Grid(g) => {
                    let k = radix % g.len() as u64;
                    radix /= g.len() as u64;
                    grid_point += k * stride;
                    stride *= g.len() as u64;
                    g[k as usize]
                }
            })
            .collect();
        let seed = rng.next_u64();
        (params, seed, grid_point)
    }

    /// The scenario of run i.
    pub fn scenario(&self, i: u64) -> Result<(Scenario, Vec<f64>, u64), SweepError> {
        let (params, seed, grid_point) = self.draw(i);
        let mut t = self.tree.clone();
        for (v, x) in self.cfg.vary.iter().zip(&params) {
            set_path(&mut t, &v.field, *x)
                .map_err(|message| SweepError::Run { run: i, message: message.to_string() })?;
        }
        t["seed"] = serde_json::json!(seed);
        // YAML is a superset of JSON: the varied tree goes through the same parser and checks
        let text = serde_json::to_string(&t).expect("a JSON tree serialises");
        let s = Scenario::parse(&text, Path::new(&self.file)).map_err(|e| {
            // the varied tree's positions are in no file: name the run's values instead
            let values: Vec<String> =
                self.cfg.vary.iter().zip(&params).map(|(v, x)| format!("{} = {x}", v.field)).collect();
            SweepError::Run { run: i, message: format!("{} ({}): {}", self.file, values.join(", "), e.what()) }
        })?;
        Ok((s, params, grid_point))
    }

    /// Runs the runs `i` with `i % shard.1 == shard.0` (all when `None`), in parallel.
    pub fn run(
        &self,
        runs: u64,
        shard: Option<(u64, u64)>,
        progress: &(dyn Fn() + Sync),
    ) -> Result<SweepOutput, SweepError> {
        self.run_resumable(runs, shard, &std::collections::BTreeMap::new(), &|_, _| progress())
    }

    /// As [`Self::run`], reusing the rows of the runs in `done`, and calling `finished` with
    /// the rows of every run it completes (for a journal).
    pub fn run_resumable(
        &self,
        runs: u64,
        shard: Option<(u64, u64)>,
        done: &std::collections::BTreeMap<u64, Vec<SweepRow>>,
        finished: &(dyn Fn(u64, &[SweepRow]) + Sync),
    ) -> Result<SweepOutput, SweepError> {
        let mine: Vec<u64> = shard_runs(runs, shard).collect();
        // Every run's scenario is drawn and checked before any run flies, so that a normal's tail
        // leaving a field's range stops the sweep before it spends a flight, and the run named is
        // the lowest such run whatever the thread count. (Rayon's collect into a `Result` returns
        // whichever error a thread meets first: under load the sweep named another run.) The
        // check parses each scenario twice (again in `run_one`): 80 parses of the example sweep
        // take about 10 ms, one of its flights about 30 ms (the unit test below, in release).
        let bad: Vec<Option<SweepError>> =
            mine.par_iter().map(|&i| if done.contains_key(&i) { None } else { self.scenario(i).err() }).collect();
        if let Some(e) = bad.into_iter().flatten().next() {
            return Err(e);
        }
        let rows: Vec<Result<Vec<SweepRow>, SweepError>> = mine
            .par_iter()
            .map(|&i| match done.get(&i) {
                Some(r) => Ok(r.clone()),
                None => {
                    let r = self.run_one(i)?;
                    finished(i, &r);
                    Ok(r)
                }
            })
            .collect();
        // in run order: the first error by index, not the first a thread met
        let rows = rows.into_iter().collect::<Result<Vec<_>, _>>()?;
        Ok(SweepOutput {
            scenario: self.name.clone(),
            sweep_seed: self.cfg.seed,
            runs,
            fields: self.cfg.vary.iter().map(|v| v.field.clone()).collect(),
            grid: self.variations.iter().map(|v| matches!(v, Variation::Grid(_))).collect(),
            shard: shard.map(|(k, n)| [k + 1, n]),
            rows: rows.into_iter().flatten().collect(),
        })
    }

    fn run_one(&self, i: u64) -> Result<Vec<SweepRow>, SweepError> {
        let (s, params, grid_point) = self.scenario(i)?;
        let crate::run::Outcome { main, uncompensated: unc, report } = run_scenario(&s, false);
        Ok(main
            .vehicles
            .iter()
            .enumerate()
            .map(|(k, v)| {
                let u = unc.as_ref().and_then(|u| u.vehicles.get(k));
                let c = &v.calibration;
                let t = v.truth.euler;
                let deg = |x: f64| x.abs().to_degrees();
                let metrics = [
                    c.roll_pitch.map(|(r, _, _)| deg(r - t.roll)),
                    c.roll_pitch.map(|(_, p, _)| deg(p - t.pitch)),
                    c.gyro.map(|g| deg(crate::frames::wrap_pi(g.euler.yaw - t.yaw))),
                    c.yaw_offset.map(|y| deg(crate::frames::wrap_pi(y - t.yaw))),
                    c.yaw_offset.map(|y| crate::frames::wrap_pi(y - t.yaw).to_degrees()),
                    v.spin_max_deviation_m,
                    v.spin_max_deviation_m.zip(u.and_then(|u| u.spin_max_deviation_m)).map(|(a, b)| a / b),
                    c.yaw_ls.zip(c.yaw_rls).map(|(a, b)| (a.psi_offset - b.psi_offset).abs()),
                ];
                let rows: Vec<_> = report.rows.iter().filter(|r| r.vehicle == v.name).collect();
                let requirements = REQUIREMENTS.map(|id| {
                    let mine: Vec<_> = rows.iter().filter(|r| r.id == id).collect();
                    (!mine.is_empty()).then(|| mine.iter().all(|r| r.pass))
                });
                SweepRow {
                    run: i,
                    seed: s.seed,
                    grid_point,
                    vehicle: v.name.clone(),
                    params: params.clone(),
                    metrics: metrics.to_vec(),
                    requirements: requirements.to_vec(),
                    passed: rows.iter().all(|r| r.pass),
                }
            })
            .collect())
    }
}

/// The run indices of a shard (0-based `(k, n)`: the runs with i mod n = k), or all runs.
pub fn shard_runs(runs: u64, shard: Option<(u64, u64)>) -> impl Iterator<Item = u64> {
    (0..runs).filter(move |i| shard.is_none_or(|(k, n)| i % n == k))
}

/// The first line of a sweep journal: which sweep the lines after it belong to.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct JournalHeader {
    /// The scenario's name.
    pub scenario: String,
    /// A hash of the scenario's text: an edited scenario starts a new journal.
    pub text_hash: u64,
    /// The sweep's seed.
    pub sweep_seed: u64,
    /// Runs in the whole sweep.
    pub runs: u64,
    /// `[K, N]` (1-based) for a shard.
    pub shard: Option<[u64; 2]>,
}

impl Sweep {
    /// The header a journal of this sweep (`runs`, `shard`) starts with.
    pub fn journal_header(&self, runs: u64, shard: Option<(u64, u64)>) -> JournalHeader {
        JournalHeader {
            scenario: self.name.clone(),
            text_hash: self.text_hash,
            sweep_seed: self.cfg.seed,
            runs,
            shard: shard.map(|(k, n)| [k + 1, n]),
        }
    }
}

/// Reads a journal: the rows of every completed run, if the header matches. Lines that do not
/// parse (a line cut by a kill) or do not hold one run of this sweep as `run_one` writes it (one
/// value per varied field, metric and requirement; a run of this shard) are skipped, and those
/// runs flown again; a journal of another sweep gives nothing.
fn read_journal(path: &Path, header: &JournalHeader, fields: usize) -> std::collections::BTreeMap<u64, Vec<SweepRow>> {
    let mine = |r: &SweepRow| {
        r.run < header.runs
            && header.shard.is_none_or(|[k, n]| n > 0 && r.run % n == k.wrapping_sub(1))
            && (r.params.len(), r.metrics.len(), r.requirements.len()) == (fields, METRICS.len(), REQUIREMENTS.len())
    };
    let mut done = std::collections::BTreeMap::new();
    let Ok(text) = std::fs::read_to_string(path) else { return done };
    let mut lines = text.lines();
    if lines.next().and_then(|l| serde_json::from_str::<JournalHeader>(l).ok()).as_ref() != Some(header) {
        return done;
    }
    for line in lines {
        if let Ok(rows) = serde_json::from_str::<Vec<SweepRow>>(line)
            && let Some(first) = rows.first()
            && rows.iter().all(|r| r.run == first.run && mine(r))
        {
            done.insert(first.run, rows);
        }
    }
    done
}

/// A sweep's journal: one line per finished run (its rows), after a header naming the sweep,
/// so that a killed sweep restarted with the same arguments redoes nothing it finished. It
/// lives beside the outputs (`<name>.sweep.journal.jsonl`, or `.shard-K-of-N.journal.jsonl`)
/// and is removed once they are written ([`Journal::finish`]); on an error it stays.
pub struct Journal {
    path: PathBuf,
    file: std::sync::Mutex<std::fs::File>,
    done: BTreeMap<u64, Vec<SweepRow>>,
}

impl Journal {
    /// Opens the journal of `sweep` (`runs`, `shard`) in the folder `out`, creating the folder;
    /// a journal of another sweep, or none, starts over.
    pub fn open(sweep: &Sweep, runs: u64, shard: Option<(u64, u64)>, out: &Path) -> Result<Journal, SweepError> {
        let path = match shard {
            None => out.join(format!("{}.sweep.journal.jsonl", sweep.name())),
            Some((k, n)) => out.join(format!("{}.sweep.shard-{}-of-{n}.journal.jsonl", sweep.name(), k + 1)),
        };
        let header = sweep.journal_header(runs, shard);
        let done = read_journal(&path, &header, sweep.variations.len());
        let file = (|| -> std::io::Result<std::fs::File> {
            std::fs::create_dir_all(out)?;
            if done.is_empty() {
                let mut f = std::fs::File::create(&path)?;
                writeln!(f, "{}", serde_json::to_string(&header).expect("serialises"))?;
                Ok(f)
            } else {
                std::fs::OpenOptions::new().append(true).open(&path)
            }
        })()
        .map_err(|source| SweepError::Journal { path: path.clone(), source })?;
        Ok(Journal { path, file: std::sync::Mutex::new(file), done })
    }

    /// The rows of the runs a previous attempt finished, by run.
    pub fn done(&self) -> &BTreeMap<u64, Vec<SweepRow>> {
        &self.done
    }

    /// Where the journal is.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Appends the rows of one finished run (one write per line: a line cut by a kill is
    /// skipped on resume; a failed write only costs that run again on resume).
    pub fn record(&self, rows: &[SweepRow]) {
        let line = serde_json::to_string(rows).expect("serialises") + "\n";
        if let Ok(mut f) = self.file.lock() {
            let _ = f.write_all(line.as_bytes()).and_then(|_| f.flush());
        }
    }

    /// The outputs are written: the journal has done its job.
    pub fn finish(self) {
        drop(self.file);
        let _ = std::fs::remove_file(&self.path);
    }
}

/// The shard `[K, N]` of an output, as merge names it (a whole sweep is shard 1 of 1).
fn shard_of(p: &SweepOutput) -> [u64; 2] {
    p.shard.unwrap_or([1, 1])
}

/// Checks that a shard file holds what `flyarena sweep --shard` writes before its rows are
/// trusted: a valid `[K, N]`, a grid flag per field, and per row a run of this shard, one value
/// per field, one entry per metric and per requirement, and no "passed" beside a failed
/// requirement. A file edited by hand or cut and patched gives an error, never a summary.
fn check_part(p: &SweepOutput) -> Result<(), SweepError> {
    let [k, n] = shard_of(p);
    let bad = |m: String| Err(SweepError::Merge(format!("shard {k} of {n} of `{}`: {m}", p.scenario)));
    if !(1..=n).contains(&k) {
        return bad(format!("shard {k} of {n} is no shard (1 ≤ K ≤ N)"));
    }
    if p.grid.len() != p.fields.len() {
        return bad(format!("{} grid flags for {} fields", p.grid.len(), p.fields.len()));
    }
    for r in &p.rows {
        let (run, lens) = (r.run, (r.params.len(), r.metrics.len(), r.requirements.len()));
        if run >= p.runs || run % n != k - 1 {
            return bad(format!(
                "run {run} is not one of this shard's (the runs i < {} with i mod {n} = {})",
                p.runs,
                k - 1
            ));
        }
        if lens != (p.fields.len(), METRICS.len(), REQUIREMENTS.len()) {
            return bad(format!(
                "run {run} ({}) has {} values, {} metrics and {} requirement flags; a row has {}, {} and {}",
                r.vehicle,
                lens.0,
                lens.1,
                lens.2,
                p.fields.len(),
                METRICS.len(),
                REQUIREMENTS.len()
            ));
        }
        if r.passed && r.requirements.contains(&Some(false)) {
            return bad(format!("run {run} ({}) passed with a failed requirement", r.vehicle));
        }
    }
    Ok(())
}

/// Merges shard outputs into the output of the whole sweep: shards of one sweep (scenario,
/// seed, runs, fields and grid alike), split the same way, each once, together every run; a
/// grid point's rows hold its grid values (the same values, the same point), and run i flew
/// grid point i mod G. What merge cannot check without the scenario (a grid value or a seed
/// edited consistently) it takes as written.
pub fn merge(parts: Vec<SweepOutput>) -> Result<SweepOutput, SweepError> {
    let first = parts.first().ok_or_else(|| SweepError::Merge("no shard files given".into()))?;
    let (scenario, seed, runs, fields, grid) =
        (first.scenario.clone(), first.sweep_seed, first.runs, first.fields.clone(), first.grid.clone());
    let split = shard_of(first)[1];
    let mut shards = std::collections::BTreeSet::new();
    for p in &parts {
        check_part(p)?;
        let [k, n] = shard_of(p);
        let differs = [
            (p.scenario != scenario, format!("scenario `{}`, not `{scenario}`", p.scenario)),
            (p.sweep_seed != seed, format!("sweep seed {}, not {seed}", p.sweep_seed)),
            (p.runs != runs, format!("{} runs, not {runs}", p.runs)),
            (p.fields != fields || p.grid != grid, format!("varied fields {:?}, not {fields:?}", p.fields)),
            (n != split, format!("a split into {n} shards, not {split}")),
        ];
        if let Some((_, why)) = differs.iter().find(|d| d.0) {
            return Err(SweepError::Merge(format!(
                "shard {k} of {n} does not belong with shard {} of {split} of `{scenario}`: {why}",
                shard_of(first)[0]
            )));
        }
        if !shards.insert(k) {
            return Err(SweepError::Merge(format!("shard {k} of {n} is given twice")));
        }
    }
    let mut rows: Vec<SweepRow> = parts.into_iter().flat_map(|p| p.rows).collect();
    rows.sort_by(|a, b| (a.run, &a.vehicle).cmp(&(b.run, &b.vehicle)));
    let mut points: BTreeMap<u64, Vec<u64>> = BTreeMap::new();
    for r in &rows {
        let values: Vec<u64> = r.params.iter().zip(&grid).filter(|(_, g)| **g).map(|(v, _)| v.to_bits()).collect();
        let clash = match points.get(&r.grid_point) {
            Some(v) => *v != values,
            None => points.values().any(|v| *v == values),
        };
        if clash {
            return Err(SweepError::Merge(format!(
                "run {} ({}): grid point {} and its grid values do not match the other rows' (one grid point, one set of values)",
                r.run, r.vehicle, r.grid_point
            )));
        }
        points.entry(r.grid_point).or_insert(values);
    }
    // run i flies grid point i mod G (G grid points, the first grid varying fastest): G is the
    // largest point + 1 when every point was flown, and any number above the runs otherwise
    let g = rows.iter().map(|r| r.grid_point).max().map_or(1, |m| m + 1);
    if let Some(r) = rows.iter().find(|r| r.grid_point != r.run % g) {
        return Err(SweepError::Merge(format!(
            "run {} ({}) flew grid point {}, but run i flies grid point i mod {g}",
            r.run, r.vehicle, r.grid_point
        )));
    }
    let mut seen = std::collections::BTreeSet::new();
    for r in &rows {
        if !seen.insert((r.run, r.vehicle.clone())) {
            return Err(SweepError::Merge(format!("run {} ({}) appears twice", r.run, r.vehicle)));
        }
    }
    let flown: std::collections::BTreeSet<u64> = rows.iter().map(|r| r.run).collect();
    let missing: Vec<u64> = (0..runs).filter(|i| !flown.contains(i)).take(5).collect();
    if !missing.is_empty() {
        return Err(SweepError::Merge(format!("runs missing, e.g. {missing:?}: a shard is absent")));
    }
    Ok(SweepOutput { scenario, sweep_seed: seed, runs, fields, grid, shard: None, rows })
}

/// Statistics of one metric over a group of rows (finite values only).
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct Stats {
    /// Finite values.
    pub n: usize,
    /// Their mean.
    pub mean: f64,
    /// Nearest-rank percentiles: the smallest value with at least p·n values at or below it.
    pub p50: f64,
    /// See `p50`.
    pub p95: f64,
    /// See `p50`.
    pub p99: f64,
    /// The largest value.
    pub max: f64,
}

fn stats(mut xs: Vec<f64>) -> Option<Stats> {
    xs.retain(|x| x.is_finite());
    if xs.is_empty() {
        return None;
    }
    xs.sort_by(f64::total_cmp);
    let n = xs.len();
    // nearest rank: the smallest value with at least p·n values at or below it
    let q = |p: f64| xs[((p * n as f64).ceil() as usize).clamp(1, n) - 1];
    Some(Stats { n, mean: xs.iter().sum::<f64>() / n as f64, p50: q(0.5), p95: q(0.95), p99: q(0.99), max: xs[n - 1] })
}

/// The summary of a sweep: one [`Group`] per grid point.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Summary {
    /// The scenario's name.
    pub scenario: String,
    /// The sweep's seed.
    pub sweep_seed: u64,
    /// Runs in the sweep.
    pub runs: u64,
    /// The varied fields, as in [`SweepOutput::fields`].
    pub fields: Vec<String>,
    /// One per grid point, in grid-point order.
    pub groups: Vec<Group>,
}

/// The rows of one grid point: the grid values, pass rates and metric statistics.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Group {
    /// The grid point's index.
    pub grid_point: u64,
    /// The grid fields' values at this point (the random draws vary inside the group).
    pub grid: BTreeMap<String, f64>,
    /// Rows (runs × vehicles).
    pub rows: usize,
    /// The share of rows that passed every requirement.
    pub pass_rate_all: f64,
    /// Per requirement ([`REQUIREMENTS`]), the share of the rows that have it and passed it.
    pub pass_rate: BTreeMap<String, f64>,
    /// Per metric ([`METRICS`]) with at least one finite value.
    pub metrics: BTreeMap<String, Stats>,
}

impl Group {
    /// The statistics of metric `name`, if any row has it.
    pub fn metric(&self, name: &str) -> Option<&Stats> {
        self.metrics.get(name)
    }
}

impl Summary {
    /// Two lines per grid point: its grid values, then the pass rates and the headline
    /// percentiles (`-` where no row has the metric). What `flyarena sweep` prints.
    pub fn text(&self) -> String {
        let mut t = String::new();
        for g in &self.groups {
            let m = |k: &str, q: fn(&Stats) -> f64| g.metric(k).map_or("-".into(), |s| format!("{:.4}", q(s)));
            let json = |v: &BTreeMap<String, f64>| serde_json::to_string(v).expect("a map of numbers serialises");
            t += &format!(
                "grid point {}: {}\n  pass rate {:.1} % ({}), roll err p95/p99 {}°/{}°, yaw (gyro) err p99 {}°, yaw (straight flight) err p95/p99 {}°/{}°, spin drift p99 {} m\n",
                g.grid_point,
                json(&g.grid),
                100.0 * g.pass_rate_all,
                json(&g.pass_rate),
                m("roll_err_deg", |s| s.p95),
                m("roll_err_deg", |s| s.p99),
                m("yaw_gyro_err_deg", |s| s.p99),
                m("yaw_ls_err_deg", |s| s.p95),
                m("yaw_ls_err_deg", |s| s.p99),
                m("spin_dev_m", |s| s.p99),
            );
        }
        t
    }
}

/// The summary of a sweep, per grid point: the grid values, metric statistics, pass rates.
pub fn summary(out: &SweepOutput) -> Summary {
    let points: std::collections::BTreeSet<u64> = out.rows.iter().map(|r| r.grid_point).collect();
    let groups = points
        .iter()
        .map(|&g| {
            let rows: Vec<&SweepRow> = out.rows.iter().filter(|r| r.grid_point == g).collect();
            let metrics = METRICS
                .iter()
                .enumerate()
                .filter_map(|(k, m)| {
                    stats(rows.iter().filter_map(|r| r.metrics[k]).collect()).map(|s| (m.to_string(), s))
                })
                .collect();
            let pass_rate = REQUIREMENTS
                .iter()
                .enumerate()
                .filter_map(|(k, id)| {
                    let flags: Vec<bool> = rows.iter().filter_map(|r| r.requirements[k]).collect();
                    (!flags.is_empty())
                        .then(|| (id.to_string(), flags.iter().filter(|f| **f).count() as f64 / flags.len() as f64))
                })
                .collect();
            let grid = rows
                .first()
                .map(|r| {
                    out.fields
                        .iter()
                        .zip(&r.params)
                        .zip(&out.grid)
                        .filter(|(_, g)| **g)
                        .map(|((f, p), _)| (f.clone(), *p))
                        .collect()
                })
                .unwrap_or_default();
            Group {
                grid_point: g,
                grid,
                rows: rows.len(),
                pass_rate_all: rows.iter().filter(|r| r.passed).count() as f64 / rows.len().max(1) as f64,
                pass_rate,
                metrics,
            }
        })
        .collect();
    Summary {
        scenario: out.scenario.clone(),
        sweep_seed: out.sweep_seed,
        runs: out.runs,
        fields: out.fields.clone(),
        groups,
    }
}

/// One CSV line per row: run, seed, grid_point, vehicle, the varied fields, the metrics, the
/// requirement flags, passed. Numbers with Rust's shortest round-trip formatting.
pub fn csv(out: &SweepOutput) -> String {
    let mut s = String::from("run,seed,grid_point,vehicle");
    for f in &out.fields {
        s += &format!(",{f}");
    }
    for m in METRICS {
        s += &format!(",{m}");
    }
    for r in REQUIREMENTS {
        s += &format!(",{r}");
    }
    s += ",passed\n";
    for r in &out.rows {
        s += &format!("{},{},{},{}", r.run, r.seed, r.grid_point, r.vehicle);
        for p in &r.params {
            s += &format!(",{p}");
        }
        for m in &r.metrics {
            s += &m.map_or(",".into(), |x| format!(",{x}"));
        }
        for q in &r.requirements {
            s += &q.map_or(",".into(), |x| format!(",{x}"));
        }
        s += &format!(",{}\n", r.passed);
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    /// With several runs drawing a value outside a field's range, no run flies and the lowest bad
    /// run is named, whatever the thread count: on one thread and on eight.
    #[test]
    fn a_sweep_with_bad_draws_names_its_lowest_bad_run_before_flying() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR"));
        let good = std::fs::read_to_string(root.join("scenarios/sweep-hover-duration.yaml")).unwrap();
        let path = std::env::temp_dir().join(format!("flyarena-sweep-bad-draws-{}.yaml", std::process::id()));
        std::fs::write(&path, good.replace("uniform: [0.1, 1.0]", "normal: [0.5, 10]")).unwrap();
        let sweep = Sweep::load(&path).unwrap();
        std::fs::remove_file(&path).unwrap();
        // mocap.noise_mm is the fourth varied field; a draw below 0 mm is outside [0, 20]
        let bad: Vec<u64> = (0..40).filter(|&i| sweep.draw(i).0[3] < 0.0).collect();
        assert!(bad.len() >= 2 && bad[0] > 0, "the test needs good runs before two bad ones: {bad:?}");
        for threads in [1, 8] {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            let flown = std::sync::atomic::AtomicUsize::new(0);
            let got = pool.install(|| {
                sweep.run_resumable(40, None, &BTreeMap::new(), &|_, _| {
                    flown.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                })
            });
            match got {
                Err(SweepError::Run { run, .. }) => assert_eq!(run, bad[0], "{threads} threads"),
                other => panic!("{threads} threads: {:?}", other.map(|o| o.rows.len())),
            }
            assert_eq!(flown.into_inner(), 0, "{threads} threads: runs flew before the sweep was rejected");
        }
    }

    #[test]
    fn nearest_rank_percentiles() {
        let s = stats((1..=100).map(|x| x as f64).collect()).unwrap();
        assert_eq!((s.p50, s.p95, s.p99, s.max, s.n), (50.0, 95.0, 99.0, 100.0, 100));
        assert_eq!(s.mean, 50.5);
        assert!(stats(vec![f64::NAN]).is_none());
    }
}

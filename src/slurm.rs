//! Slurm job scripts for a sweep or a batch of trials: a job array of shards and a merge job that
//! waits for it.
//!
//! Every run of a sweep and every trial flight is a pure function of its inputs and its index, so
//! a job array can fly the shards K = 1..N on any nodes and `flyarena merge` gives the unsharded
//! output byte for byte. The scripts written here are what a user submits as they are:
//!
//! - `<name>.array.sbatch`: `#SBATCH --array=1-N`, `--requeue` (a preempted or failed node puts
//!   the task back in the queue), one output file per task under `logs/`, and the options a
//!   cluster asks for (partition, time, CPUs per task, account) where given. Each task runs
//!   `flyarena sweep … --shard K/N` (or `trials … --shard K/N`) into `shards/`, with as many
//!   threads as CPUs it was given. A sweep task that is killed and requeued resumes from its
//!   journal in `shards/` without redoing its finished runs; a trials task flies its shard again.
//! - `<name>.merge.sbatch`: `flyarena merge shards/*.shard-*-of-N.json --out DIR`.
//! - `<name>.submit.sh`: submits the array, then the merge with `--dependency=afterok:<array>`
//!   (it runs only if every task succeeded); extra arguments go to the merge's `sbatch`: with
//!   `--wait` it exits with the merge's code, the verdict (0 every requirement passed, 1 one
//!   failed).
//!
//! Paths in the scripts are absolute: the compute nodes must see the binary, the scenario and the
//! output folder where the login node does (a shared file system, as clusters have).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// What the job array flies.
#[derive(Clone, Debug, PartialEq)]
pub enum Job {
    /// `flyarena sweep SCENARIO --runs RUNS`.
    Sweep {
        /// The scenario (absolute).
        scenario: PathBuf,
        /// Number of runs (`None`: the scenario's).
        runs: Option<u64>,
    },
    /// `flyarena trials --flights FLIGHTS --seed SEED`.
    Trials {
        /// Number of flights.
        flights: u64,
        /// Master seed.
        seed: u64,
    },
}

/// The cluster options passed through to `#SBATCH` lines (none: the cluster's defaults).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Cluster {
    /// `--partition`.
    pub partition: Option<String>,
    /// `--time` (Slurm's formats, e.g. `01:00:00` or `2-00:00:00`).
    pub time: Option<String>,
    /// `--cpus-per-task` (also the task's thread count).
    pub cpus_per_task: Option<u32>,
    /// `--account`.
    pub account: Option<String>,
}

/// The three files of a submission: (file name, text, executable).
#[derive(Clone, Debug, PartialEq)]
pub struct Scripts {
    /// The job array.
    pub array: (String, String),
    /// The merge job.
    pub merge: (String, String),
    /// The submit script.
    pub submit: (String, String),
}

/// A value for an `#SBATCH` line or a shell word: refused if it holds a character that would
/// end the line or the word (whitespace, quotes, `$`, backslash, `;`, `&`, `|`, `#` …).
fn safe(what: &str, v: &str) -> Result<(), String> {
    let ok = !v.is_empty() && v.chars().all(|c| c.is_ascii_alphanumeric() || "-_.:/,+=@%".contains(c));
    if ok {
        Ok(())
    } else {
        Err(format!(
            "{what} `{v}` holds a character a job script cannot carry (letters, digits and - _ . : / , + = @ % only)"
        ))
    }
}

/// The job scripts for `job` split into `tasks` shards, writing into `out` (absolute), run by
/// the binary `flyarena` (absolute); `name` names the files and the jobs.
///
/// # Errors
/// A path or an option that a script line cannot carry (module doc), or 0 tasks.
pub fn scripts(
    job: &Job,
    tasks: u64,
    cluster: &Cluster,
    flyarena: &Path,
    out: &Path,
    name: &str,
) -> Result<Scripts, String> {
    if tasks == 0 {
        return Err("--tasks must be at least 1".into());
    }
    let bin = flyarena.display().to_string();
    let dir = out.display().to_string();
    safe("the binary's path", &bin)?;
    safe("the output folder", &dir)?;
    safe("the name", name)?;
    for (what, v) in [("--partition", &cluster.partition), ("--time", &cluster.time), ("--account", &cluster.account)] {
        if let Some(v) = v {
            safe(what, v)?;
        }
    }
    let (command, shards) = match job {
        Job::Sweep { scenario, runs } => {
            let s = scenario.display().to_string();
            safe("the scenario's path", &s)?;
            let runs = runs.map_or(String::new(), |r| format!(" --runs {r}"));
            // not --quiet: a task that resumes says how many of its runs its journal held
            (format!("{bin} sweep {s}{runs}"), format!("{dir}/shards/*.sweep.shard-*-of-{tasks}.json"))
        }
        Job::Trials { flights, seed } => (
            format!("{bin} trials --flights {flights} --seed {seed}"),
            format!("{dir}/shards/trials-{seed}-{flights}.shard-*-of-{tasks}.json"),
        ),
    };
    let header = |s: &mut String, job_name: &str| {
        let _ = writeln!(s, "#!/bin/bash");
        let _ = writeln!(s, "#SBATCH --job-name={job_name}");
        if let Some(p) = &cluster.partition {
            let _ = writeln!(s, "#SBATCH --partition={p}");
        }
        if let Some(t) = &cluster.time {
            let _ = writeln!(s, "#SBATCH --time={t}");
        }
        if let Some(a) = &cluster.account {
            let _ = writeln!(s, "#SBATCH --account={a}");
        }
    };
    let mut array = String::new();
    header(&mut array, &format!("{name}-shards"));
    let _ = writeln!(array, "#SBATCH --array=1-{tasks}");
    let _ = writeln!(array, "#SBATCH --requeue");
    let _ = writeln!(array, "#SBATCH --output={dir}/logs/%x-%A_%a.out");
    if let Some(c) = cluster.cpus_per_task {
        let _ = writeln!(array, "#SBATCH --cpus-per-task={c}");
    }
    let _ = writeln!(array, "set -euo pipefail");
    let _ = writeln!(array, "# results do not depend on the thread count: as many as the CPUs the task was given");
    let _ = writeln!(array, "export RAYON_NUM_THREADS=\"${{SLURM_CPUS_PER_TASK:-1}}\"");
    let _ = writeln!(array, "exec {command} --shard \"${{SLURM_ARRAY_TASK_ID}}/{tasks}\" --out {dir}/shards");
    let mut merge = String::new();
    header(&mut merge, &format!("{name}-merge"));
    let _ = writeln!(merge, "#SBATCH --output={dir}/logs/%x-%j.out");
    let _ = writeln!(merge, "set -euo pipefail");
    let _ = writeln!(merge, "exec {bin} merge {shards} --out {dir}");
    let array_file = format!("{name}.array.sbatch");
    let merge_file = format!("{name}.merge.sbatch");
    let mut submit = String::new();
    let _ = writeln!(submit, "#!/bin/bash");
    let _ = writeln!(submit, "# submits the shards as a job array, then the merge once every shard succeeded;");
    let _ = writeln!(submit, "# arguments go to the merge's sbatch (e.g. --wait)");
    let _ = writeln!(submit, "set -euo pipefail");
    let _ = writeln!(submit, "mkdir -p {dir}/logs {dir}/shards");
    let _ = writeln!(submit, "array=$(sbatch --parsable {dir}/{array_file})");
    let _ = writeln!(submit, "array=${{array%%;*}}");
    let _ = writeln!(submit, "echo \"shards: job $array\"");
    let _ =
        writeln!(submit, "sbatch --dependency=afterok:\"$array\" --kill-on-invalid-dep=yes \"$@\" {dir}/{merge_file}");
    Ok(Scripts {
        array: (array_file, array),
        merge: (merge_file, merge),
        submit: (format!("{name}.submit.sh"), submit),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The array script of a sweep in 4 shards with every cluster option: the array, the requeue,
    /// the options, the threads and the command with its shard; the merge reads exactly the
    /// shards of a 4-way split; the submit script chains them with afterok.
    #[test]
    fn a_sweep_in_four_shards_with_every_option() {
        let cluster = Cluster {
            partition: Some("short".into()),
            time: Some("01:00:00".into()),
            cpus_per_task: Some(2),
            account: Some("lab-7".into()),
        };
        let job = Job::Sweep { scenario: "/data/s.yaml".into(), runs: Some(400) };
        let s = scripts(&job, 4, &cluster, Path::new("/opt/flyarena"), Path::new("/scratch/run"), "hover").unwrap();
        let a = &s.array.1;
        for line in [
            "#SBATCH --array=1-4",
            "#SBATCH --requeue",
            "#SBATCH --partition=short",
            "#SBATCH --time=01:00:00",
            "#SBATCH --account=lab-7",
            "#SBATCH --cpus-per-task=2",
            "#SBATCH --output=/scratch/run/logs/%x-%A_%a.out",
            "exec /opt/flyarena sweep /data/s.yaml --runs 400 --shard \"${SLURM_ARRAY_TASK_ID}/4\" --out /scratch/run/shards",
        ] {
            assert!(a.lines().any(|l| l == line), "missing `{line}` in\n{a}");
        }
        assert!(
            s.merge
                .1
                .lines()
                .any(|l| l
                    == "exec /opt/flyarena merge /scratch/run/shards/*.sweep.shard-*-of-4.json --out /scratch/run"),
            "{}",
            s.merge.1
        );
        assert!(s.submit.1.contains("sbatch --dependency=afterok:\"$array\""), "{}", s.submit.1);
        assert_eq!(
            (s.array.0.as_str(), s.merge.0.as_str(), s.submit.0.as_str()),
            ("hover.array.sbatch", "hover.merge.sbatch", "hover.submit.sh")
        );
    }

    /// Without options no `#SBATCH` line for them is written (the cluster's defaults hold); a
    /// trials job names its shards by seed and size.
    #[test]
    fn trials_without_options_use_the_clusters_defaults() {
        let s = scripts(
            &Job::Trials { flights: 300, seed: 1 },
            2,
            &Cluster::default(),
            Path::new("/b/flyarena"),
            Path::new("/o"),
            "t",
        )
        .unwrap();
        assert!(
            !s.array.1.contains("--partition")
                && !s.array.1.contains("--time")
                && !s.array.1.contains("--account")
                && !s.array.1.contains("--cpus-per-task"),
            "{}",
            s.array.1
        );
        assert!(
            s.array.1.contains(
                "exec /b/flyarena trials --flights 300 --seed 1 --shard \"${SLURM_ARRAY_TASK_ID}/2\" --out /o/shards"
            ),
            "{}",
            s.array.1
        );
        assert!(s.merge.1.contains("merge /o/shards/trials-1-300.shard-*-of-2.json --out /o"), "{}", s.merge.1);
    }

    /// A value that would break a script line is refused with what it is: a space in a path, a
    /// `$` or a newline in an option; and 0 tasks.
    #[test]
    fn what_a_script_cannot_carry_is_refused() {
        let job = Job::Trials { flights: 10, seed: 1 };
        let bin = Path::new("/b/flyarena");
        assert!(
            scripts(&job, 2, &Cluster::default(), bin, Path::new("/my out"), "t")
                .unwrap_err()
                .contains("the output folder `/my out`")
        );
        let bad = Cluster { partition: Some("x$(rm)".into()), ..Cluster::default() };
        assert!(scripts(&job, 2, &bad, bin, Path::new("/o"), "t").unwrap_err().contains("--partition"));
        let bad = Cluster { account: Some("a\n#SBATCH --x".into()), ..Cluster::default() };
        assert!(scripts(&job, 2, &bad, bin, Path::new("/o"), "t").unwrap_err().contains("--account"));
        assert!(scripts(&job, 0, &Cluster::default(), bin, Path::new("/o"), "t").unwrap_err().contains("at least 1"));
    }
}

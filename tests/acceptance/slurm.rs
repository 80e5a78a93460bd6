//! `flyarena slurm`: the job scripts it writes, submitted as they are to a real Slurm cluster of
//! one node (slurmctld, slurmd and munged started in a scratch folder with their own config and
//! ports, stopped when the test ends, on failure too). `.ci/run` installs `slurm-wlm` and `munge`;
//! outside CI, without them, the test skips with one line.

use std::net::TcpListener;
use std::path::{Path, PathBuf};
use std::process::Command;

/// A one-node cluster in a scratch folder; its daemons are stopped when it is dropped.
struct Cluster {
    dir: PathBuf,
    conf: PathBuf,
}

fn free_tcp_port() -> u16 {
    TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port()
}

fn run_ok(cmd: &mut Command) {
    let out = cmd.output().unwrap_or_else(|e| panic!("{cmd:?}: {e}"));
    assert!(
        out.status.success(),
        "{cmd:?}: {}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}

impl Cluster {
    fn start(dir: &Path) -> Cluster {
        for d in ["state", "spool", "log", "run", "munge"] {
            std::fs::create_dir_all(dir.join(d)).unwrap();
        }
        let munge = dir.join("munge");
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            std::fs::set_permissions(&munge, std::fs::Permissions::from_mode(0o700)).unwrap();
            let key: Vec<u8> = (0..1024u32).map(|i| (i.wrapping_mul(2_654_435_761) >> 13) as u8).collect();
            std::fs::write(munge.join("munge.key"), key).unwrap();
            std::fs::set_permissions(munge.join("munge.key"), std::fs::Permissions::from_mode(0o400)).unwrap();
        }
        let host = String::from_utf8(Command::new("hostname").output().unwrap().stdout).unwrap().trim().to_string();
        let cpus = std::thread::available_parallelism().map_or(1, |n| n.get());
        let (ctld, d) = (free_tcp_port(), free_tcp_port());
        let p = |s: &str| dir.join(s).display().to_string();
        let conf = format!(
            "ClusterName=flyarena\nSlurmctldHost={host}\nSlurmUser=root\nSlurmdUser=root\nSlurmctldPort={ctld}\nSlurmdPort={d}\n\
             AuthType=auth/munge\nAuthInfo=socket={}\nCredType=cred/munge\nProctrackType=proctrack/linuxproc\nTaskPlugin=task/none\n\
             SelectType=select/cons_tres\nSelectTypeParameters=CR_CPU\nStateSaveLocation={}\nSlurmdSpoolDir={}\n\
             SlurmctldPidFile={}\nSlurmdPidFile={}\nSlurmctldLogFile={}\nSlurmdLogFile={}\nReturnToService=2\n\
             JobAcctGatherType=jobacct_gather/none\nAccountingStorageType=accounting_storage/none\nMpiDefault=none\n\
             NodeName={host} CPUs={cpus} State=UNKNOWN\nPartitionName=debug Nodes=ALL Default=YES MaxTime=INFINITE State=UP\n",
            p("munge/munge.sock"),
            p("state"),
            p("spool"),
            p("run/slurmctld.pid"),
            p("run/slurmd.pid"),
            p("log/slurmctld.log"),
            p("log/slurmd.log"),
        );
        let conf_path = dir.join("slurm.conf");
        std::fs::write(&conf_path, conf).unwrap();
        let cluster = Cluster { dir: dir.to_path_buf(), conf: conf_path };
        run_ok(Command::new("munged").args([
            "--key-file",
            &p("munge/munge.key"),
            "--socket",
            &p("munge/munge.sock"),
            "--pid-file",
            &p("munge/munged.pid"),
            "--log-file",
            &p("munge/munged.log"),
            "--seed-file",
            &p("munge/seed"),
            "-f",
        ]));
        run_ok(Command::new("slurmctld").arg("-f").arg(&cluster.conf));
        run_ok(Command::new("slurmd").arg("-f").arg(&cluster.conf));
        // up when the node is idle (seconds)
        let started = std::time::Instant::now();
        loop {
            let out = cluster.cmd("sinfo").args(["-h", "-o", "%T"]).output().unwrap();
            if String::from_utf8_lossy(&out.stdout).trim() == "idle" {
                break;
            }
            assert!(
                started.elapsed().as_secs() < 60,
                "the node did not come up: {}",
                std::fs::read_to_string(dir.join("log/slurmctld.log")).unwrap_or_default()
            );
            std::thread::sleep(std::time::Duration::from_millis(300));
        }
        cluster
    }

    /// A Slurm command against this cluster.
    fn cmd(&self, program: &str) -> Command {
        let mut c = Command::new(program);
        c.env("SLURM_CONF", &self.conf);
        c
    }
}

impl Drop for Cluster {
    /// Stops every daemon and waits until each is gone (10 s, then SIGKILL).
    fn drop(&mut self) {
        for pid_file in ["run/slurmd.pid", "run/slurmctld.pid", "munge/munged.pid"] {
            let Some(pid) =
                std::fs::read_to_string(self.dir.join(pid_file)).ok().and_then(|s| s.trim().parse::<i32>().ok())
            else {
                continue;
            };
            let pid = pid.to_string();
            // running: its /proc entry is there and not a zombie (state Z, after the `)` of its name)
            let alive = || {
                std::fs::read_to_string(format!("/proc/{pid}/stat"))
                    .is_ok_and(|st| st.rsplit(')').next().is_some_and(|rest| !rest.trim_start().starts_with('Z')))
            };
            let _ = Command::new("kill").arg(&pid).status();
            let since = std::time::Instant::now();
            while alive() && since.elapsed().as_secs() < 10 {
                std::thread::sleep(std::time::Duration::from_millis(100));
            }
            if alive() {
                let _ = Command::new("kill").args(["-9", &pid]).status();
            }
        }
    }
}

/// Whether Slurm is installed; outside CI its absence skips the test with one line, under CI
/// (where `.ci/run` installs it) it fails.
fn have_slurm() -> bool {
    if Command::new("slurmctld").arg("-V").output().is_ok_and(|o| o.status.success()) {
        return true;
    }
    assert!(std::env::var("CI").is_err(), "CI must have Slurm (apt-get install slurm-wlm munge, as .ci/run does)");
    eprintln!("skipped: no Slurm here (apt-get install slurm-wlm munge)");
    false
}

fn flyarena(args: &[&str], dir: &Path) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_flyarena")).args(args).current_dir(dir).output().unwrap()
}

/// The scripts `flyarena slurm` writes, submitted as they are to a real one-node cluster: a
/// sweep of 200 runs over 4 array tasks and 6 trial flights over 2, each merged by the job that
/// waits for its array (`--dependency=afterok`), give the unsharded outputs byte for byte and
/// the unsharded verdict (the exit code of `submit.sh --wait`), and every array task wrote its
/// shard.
#[test]
fn the_job_scripts_run_on_a_real_cluster_and_merge_to_the_unsharded_outputs() {
    if !have_slurm() {
        return;
    }
    let d = super::Scratch::new("slurm");
    let cluster = Cluster::start(&d.join("cluster"));
    let scenario = super::root().join("scenarios/sweep-hover-duration.yaml");
    let s = scenario.to_str().unwrap();
    let plain = flyarena(&["sweep", s, "--runs", "200", "--quiet", "--out", "plain"], &d);
    // some runs of this sweep fail a requirement: its verdict is exit 1, on the cluster too
    let verdict = plain.status.code();
    assert!(verdict.is_some_and(|c| c <= 1), "{}", String::from_utf8_lossy(&plain.stderr));
    assert_eq!(flyarena(&["trials", "--flights", "6", "--seed", "3", "--out", "plain"], &d).status.code(), Some(0));
    let wrote = flyarena(&["slurm", "sweep", s, "--runs", "200", "--tasks", "4", "--out", "sweep"], &d);
    assert_eq!(wrote.status.code(), Some(0), "{}", String::from_utf8_lossy(&wrote.stderr));
    assert_eq!(
        flyarena(&["slurm", "trials", "--flights", "6", "--seed", "3", "--tasks", "2", "--out", "trials"], &d)
            .status
            .code(),
        Some(0)
    );
    // `--wait` makes the merge's sbatch exit with the merge's code: the verdict
    for (folder, name, code) in [("sweep", "sweep-hover-duration", verdict), ("trials", "trials-3-6", Some(0))] {
        let submit = d.join(folder).join(format!("{name}.submit.sh"));
        let out = cluster.cmd("timeout").arg("300").arg("bash").arg(&submit).arg("--wait").output().unwrap();
        assert_eq!(
            out.status.code(),
            code,
            "{folder}: {}{}",
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        );
    }
    for (file, shards) in
        [("sweep-hover-duration.sweep.json", 4), ("sweep-hover-duration.sweep.csv", 4), ("trials-3-6.json", 2)]
    {
        let folder = if file.starts_with("trials") { "trials" } else { "sweep" };
        assert_eq!(
            std::fs::read(d.join(folder).join(file)).unwrap(),
            std::fs::read(d.join("plain").join(file)).unwrap(),
            "{file}: merged on the cluster ≠ unsharded"
        );
        let n = std::fs::read_dir(d.join(folder).join("shards"))
            .unwrap()
            .filter(|e| e.as_ref().unwrap().file_name().to_string_lossy().contains(&format!("-of-{shards}.json")))
            .count();
        assert_eq!(n, shards, "{folder}: one shard file per array task");
    }
}

/// A task killed mid-run and submitted again finishes from its journal. A sweep of 600 runs over
/// 2 array tasks is submitted; once task 1 has journalled 20 of its 300 runs (and before it ends)
/// it is cancelled (`scancel JOB_1`), so its shard file is missing and its journal holds what it
/// finished. Task 1 submitted again (`sbatch --array=1` on the same script) says it resumes with at
/// least those runs done, the merge job then gives the unsharded output and verdict byte for
/// byte.
#[test]
fn a_cancelled_task_submitted_again_resumes_from_its_journal() {
    if !have_slurm() {
        return;
    }
    let d = super::Scratch::new("slurm-resume");
    let cluster = Cluster::start(&d.join("cluster"));
    let scenario = super::root().join("scenarios/sweep-hover-duration.yaml");
    let s = scenario.to_str().unwrap();
    let verdict = flyarena(&["sweep", s, "--runs", "600", "--quiet", "--out", "plain"], &d).status.code();
    assert!(verdict.is_some_and(|c| c <= 1));
    assert_eq!(
        flyarena(&["slurm", "sweep", s, "--runs", "600", "--tasks", "2", "--out", "job"], &d).status.code(),
        Some(0)
    );
    let job = d.join("job");
    for sub in ["logs", "shards"] {
        std::fs::create_dir_all(job.join(sub)).unwrap();
    }
    let array = job.join("sweep-hover-duration.array.sbatch");
    let submitted = cluster.cmd("sbatch").arg("--parsable").arg(&array).output().unwrap();
    assert!(submitted.status.success(), "{}", String::from_utf8_lossy(&submitted.stderr));
    let id = String::from_utf8(submitted.stdout).unwrap().trim().split(';').next().unwrap().to_string();
    let journal = job.join("shards/sweep-hover-duration.sweep.shard-1-of-2.journal.jsonl");
    let lines = || std::fs::read_to_string(&journal).map_or(0, |t| t.lines().count());
    let since = std::time::Instant::now();
    while lines() < 21 {
        assert!(since.elapsed().as_secs() < 120, "task 1 journalled {} lines in 120 s", lines());
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    run_ok(cluster.cmd("scancel").arg(format!("{id}_1")));
    // the array ends: task 2 completes, task 1 is cancelled
    let since = std::time::Instant::now();
    while !String::from_utf8_lossy(&cluster.cmd("squeue").args(["-h", "-j", &id]).output().unwrap().stdout)
        .trim()
        .is_empty()
    {
        assert!(since.elapsed().as_secs() < 120, "the array did not end");
        std::thread::sleep(std::time::Duration::from_millis(200));
    }
    let shard1 = job.join("shards/sweep-hover-duration.sweep.shard-1-of-2.json");
    assert!(!shard1.exists(), "task 1 finished before it was cancelled: the test needs more runs");
    // the header line, then one line per finished run (a line cut by the kill is dropped on resume)
    let finished = lines().saturating_sub(2);
    assert!((19..300).contains(&finished), "{finished} runs journalled");
    let again = cluster
        .cmd("timeout")
        .args(["300", "sbatch", "--wait", "--array=1", "--parsable"])
        .arg(&array)
        .output()
        .unwrap();
    assert!(again.status.success(), "{}", String::from_utf8_lossy(&again.stderr));
    assert!(shard1.exists());
    let id2 = String::from_utf8(again.stdout).unwrap().trim().split(';').next().unwrap().to_string();
    let log = std::fs::read_to_string(job.join(format!("logs/sweep-hover-duration-shards-{id2}_1.out"))).unwrap();
    let resumed: usize = log
        .split("resuming: ")
        .nth(1)
        .and_then(|r| r.split(' ').next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("no resume line: {log}"));
    assert!(resumed >= finished && log.contains(&format!("resuming: {resumed} of 300 runs already done")), "{log}");
    let merged = cluster
        .cmd("timeout")
        .args(["300", "sbatch", "--wait"])
        .arg(job.join("sweep-hover-duration.merge.sbatch"))
        .output()
        .unwrap();
    assert_eq!(merged.status.code(), verdict, "{}", String::from_utf8_lossy(&merged.stderr));
    for file in ["sweep-hover-duration.sweep.json", "sweep-hover-duration.sweep.csv"] {
        assert_eq!(
            std::fs::read(job.join(file)).unwrap(),
            std::fs::read(d.join("plain").join(file)).unwrap(),
            "{file}: resumed ≠ unsharded"
        );
    }
}

//! The script `shscale slurm` writes, on a real Slurm: a single-node cluster of the test's own
//! (a munge key and a `slurm.conf` in a temporary folder; `munged`, `slurmctld` and `slurmd`
//! started for the test and stopped at its end, on ports of their own), the array and its
//! merge waited for, and the merged rows compared with an unsharded local run. Then the two
//! failure paths: a shard that fails leaves the merge undone (Slurm holds it, its dependency
//! never satisfied) with the failure in the shard's log; the same script submitted again runs
//! only the missing runs and merges; and once more, with nothing to run, merges again over its
//! own earlier output.
//!
//! Needs root and Debian's `slurm-wlm` and `munge` (`.ci/run` installs them). Without them the
//! test skips with a notice, unless `SHSCALE_REQUIRE_SLURM=1` (set by `.ci/run` where it runs as
//! root), which makes it fail instead.

mod common;
use common::*;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

/// How long one wait for the cluster may take before the test fails with what Slurm says.
const WAIT: Duration = Duration::from_secs(180);

/// A single-node cluster; stopped (daemons killed by their pid files) when dropped.
struct Cluster {
    dir: PathBuf,
    conf: PathBuf,
}

impl Drop for Cluster {
    fn drop(&mut self) {
        for pid in ["slurmd.pid", "slurmctld.pid", "munge/munged.pid"] {
            if let Ok(p) = std::fs::read_to_string(self.dir.join(pid)) {
                let _ = Command::new("kill").arg(p.trim()).status();
            }
        }
        std::thread::sleep(Duration::from_millis(300));
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

/// Output of a command, or why it could not run.
fn sh(cmd: &str, args: &[&str], conf: Option<&Path>) -> Result<String, String> {
    let mut c = Command::new(cmd);
    c.args(args);
    if let Some(conf) = conf {
        c.env("SLURM_CONF", conf);
    }
    let o = c.output().map_err(|e| format!("{cmd}: {e}"))?;
    if !o.status.success() {
        return Err(format!(
            "{cmd} {args:?}: {}{}",
            String::from_utf8_lossy(&o.stdout),
            String::from_utf8_lossy(&o.stderr)
        ));
    }
    Ok(String::from_utf8_lossy(&o.stdout).to_string())
}

/// Why a cluster cannot start here (not root, a program missing), if so.
fn unavailable() -> Option<String> {
    match sh("id", &["-u"], None) {
        Ok(u) if u.trim() == "0" => {}
        _ => return Some("the test's own Slurm needs root".into()),
    }
    for p in [
        "munged",
        "slurmctld",
        "slurmd",
        "sbatch",
        "squeue",
        "scancel",
        "sinfo",
    ] {
        if sh("sh", &["-c", &format!("command -v {p}")], None).is_err() {
            return Some(format!(
                "{p} is not installed (apt-get install slurm-wlm munge)"
            ));
        }
    }
    None
}

/// Start munge, the controller and one node, and wait until the node is idle.
fn start(dir: &Path) -> Cluster {
    let _ = std::fs::remove_dir_all(dir);
    for d in ["munge", "state", "spool", "log"] {
        std::fs::create_dir_all(dir.join(d)).unwrap();
    }
    let cluster = Cluster {
        dir: dir.to_path_buf(),
        conf: dir.join("slurm.conf"),
    };
    let key: Vec<u8> = (0..1024u32)
        .map(|i| (i.wrapping_mul(2654435761) >> 13) as u8 ^ (std::process::id() as u8))
        .collect();
    let keyf = dir.join("munge/munge.key");
    std::fs::write(&keyf, key).unwrap();
    use std::os::unix::fs::PermissionsExt;
    std::fs::set_permissions(&keyf, std::fs::Permissions::from_mode(0o400)).unwrap();
    std::fs::set_permissions(dir.join("munge"), std::fs::Permissions::from_mode(0o755)).unwrap();
    let host = sh("hostname", &[], None).unwrap().trim().to_string();
    let cpus = std::thread::available_parallelism().map_or(1, |n| n.get());
    // Ports of this process's own, away from Slurm's defaults (6817/6818).
    let port = 20000 + (std::process::id() % 20000) * 2;
    let d = dir.display();
    std::fs::write(
        &cluster.conf,
        format!(
            "ClusterName=shscale-test\nSlurmctldHost={host}(127.0.0.1)\nSlurmctldPort={port}\nSlurmdPort={}\n\
AuthType=auth/munge\nAuthInfo=socket={d}/munge/munge.socket\nCredType=cred/munge\n\
StateSaveLocation={d}/state\nSlurmdSpoolDir={d}/spool\nSlurmctldPidFile={d}/slurmctld.pid\nSlurmdPidFile={d}/slurmd.pid\n\
SlurmctldLogFile={d}/log/slurmctld.log\nSlurmdLogFile={d}/log/slurmd.log\nSlurmUser=root\n\
ProctrackType=proctrack/linuxproc\nTaskPlugin=task/none\nSchedulerType=sched/backfill\n\
SelectType=select/cons_tres\nSelectTypeParameters=CR_Core\nReturnToService=2\nMpiDefault=none\n\
JobAcctGatherType=jobacct_gather/none\nAccountingStorageType=accounting_storage/none\n\
NodeName={host} NodeAddr=127.0.0.1 CPUs={cpus} State=UNKNOWN\nPartitionName=test Nodes=ALL Default=YES MaxTime=INFINITE State=UP\n",
            port + 1
        ),
    )
    .unwrap();
    let m = |f: &str| format!("{d}/munge/{f}");
    sh(
        "munged",
        &[
            "--force",
            &format!("--key-file={}", m("munge.key")),
            &format!("--socket={}", m("munge.socket")),
            &format!("--pid-file={}", m("munged.pid")),
            &format!("--log-file={}", m("munged.log")),
            &format!("--seed-file={}", m("munged.seed")),
        ],
        None,
    )
    .unwrap_or_else(|e| panic!("munged did not start: {e}"));
    let conf = cluster.conf.to_str().unwrap();
    sh("slurmctld", &["-f", conf], Some(&cluster.conf))
        .unwrap_or_else(|e| panic!("slurmctld did not start: {e}"));
    sh("slurmd", &["-f", conf, "-N", &host], Some(&cluster.conf))
        .unwrap_or_else(|e| panic!("slurmd did not start: {e}"));
    cluster.wait("the node to be idle", || {
        sh("sinfo", &["-h", "-o", "%T"], Some(&cluster.conf)).is_ok_and(|s| s.trim() == "idle")
    });
    cluster
}

impl Cluster {
    /// Poll `done` every 0.5 s; fail after [`WAIT`] with the queue and the daemons' logs.
    fn wait(&self, what: &str, done: impl Fn() -> bool) {
        let t = Instant::now();
        while !done() {
            if t.elapsed() > WAIT {
                let log = |f: &str| std::fs::read_to_string(self.dir.join(f)).unwrap_or_default();
                panic!(
                    "timed out waiting for {what}\nsqueue: {:?}\nslurmctld.log (end): {}\nslurmd.log (end): {}",
                    sh("squeue", &[], Some(&self.conf)),
                    tail(&log("log/slurmctld.log")),
                    tail(&log("log/slurmd.log"))
                );
            }
            std::thread::sleep(Duration::from_millis(500));
        }
    }

    /// Whether job `id` (or any task of array `id`) is still in the queue.
    fn queued(&self, id: &str) -> bool {
        sh("squeue", &["-h", "-j", id, "-o", "%i"], Some(&self.conf))
            .is_ok_and(|s| !s.trim().is_empty())
    }

    /// The reason Slurm gives for job `id` waiting.
    fn reason(&self, id: &str) -> String {
        sh("squeue", &["-h", "-j", id, "-o", "%r"], Some(&self.conf))
            .unwrap_or_default()
            .trim()
            .to_string()
    }

    /// Submit `script`; the array job's and the merge job's ids.
    fn submit(&self, script: &Path) -> (String, String) {
        let out = sh("bash", &[script.to_str().unwrap()], Some(&self.conf))
            .unwrap_or_else(|e| panic!("the script failed: {e}"));
        // "submitted array job A (N tasks) and merge job M"
        let words: Vec<&str> = out.split_whitespace().collect();
        let after = |w: &str| {
            let i = words
                .iter()
                .position(|x| *x == w)
                .unwrap_or_else(|| panic!("{out}"));
            words[i + 1].to_string()
        };
        (after("job"), words.last().unwrap().to_string())
    }
}

fn tail(s: &str) -> String {
    let lines: Vec<&str> = s.lines().collect();
    lines[lines.len().saturating_sub(15)..].join("\n")
}

#[test]
fn the_slurm_script_runs_its_array_and_merge_on_a_real_slurm() {
    if let Some(why) = unavailable() {
        if std::env::var("SHSCALE_REQUIRE_SLURM").as_deref() == Ok("1") {
            panic!("SHSCALE_REQUIRE_SLURM=1 but no Slurm can start here: {why}");
        }
        eprintln!("notice: skipping the real-Slurm test: {why}");
        return;
    }
    let d = std::env::temp_dir().join(format!("shscale-slurm-real-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    let cluster = start(&d.join("cluster"));
    let cfg = d.join("sl.toml");
    std::fs::write(
        &cfg,
        "experiment = \"sparsity\"\norder = 2\ntau = \"cone\"\nalpha_deg = 45\n[sweep]\nk = [0.5, 0.8, 1.2, 1.5, 2.0, 3.0, 4.0]\n",
    )
    .unwrap();
    // The reference: the same plan, unsharded, here.
    let reference = d.join("ref");
    let r = shscale(&[
        "run",
        cfg.to_str().unwrap(),
        "--out-dir",
        reference.to_str().unwrap(),
    ]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let out = d.join("out");
    let gen = shscale(&[
        "slurm",
        cfg.to_str().unwrap(),
        "--tasks",
        "3",
        "--array-parallel",
        "2",
        "--binary",
        env!("CARGO_BIN_EXE_shscale"),
        "--out-dir",
        out.to_str().unwrap(),
    ]);
    assert!(
        gen.status.success(),
        "{}",
        String::from_utf8_lossy(&gen.stderr)
    );
    let script = d.join("sl.sh");
    std::fs::write(&script, &gen.stdout).unwrap();
    let dir = out.join("sparsity/sl");
    let merged = dir.join("merged/runs.csv");

    // 1. Shard 1 cannot write its file (a folder stands in its place): it fails, and the merge
    //    is never started.
    std::fs::create_dir_all(dir.join("runs.shard-1-of-3.csv")).unwrap();
    let (array, merge) = cluster.submit(&script);
    cluster.wait("the array to end", || !cluster.queued(&array));
    cluster.wait("Slurm to give up on the merge's dependency", || {
        cluster.reason(&merge).contains("DependencyNeverSatisfied")
    });
    assert!(
        !merged.exists(),
        "a failed shard must leave the merge undone"
    );
    let log1 = std::fs::read_to_string(out.join(format!("slurm-{array}_1.log"))).unwrap();
    assert!(
        log1.contains("error") && log1.contains("runs.shard-1-of-3.csv"),
        "the failed shard's log names its failure:\n{log1}"
    );
    sh("scancel", &[&merge], Some(&cluster.conf)).unwrap();

    // 2. The obstacle gone, the same script again: only shard 1's runs run, then the merge.
    std::fs::remove_dir(dir.join("runs.shard-1-of-3.csv")).unwrap();
    let (array, merge) = cluster.submit(&script);
    cluster.wait("the array and the merge to end", || {
        !cluster.queued(&array) && !cluster.queued(&merge)
    });
    let merge_log = |m: &str| {
        std::fs::read_to_string(out.join(format!("slurm-merge-{m}.log"))).unwrap_or_default()
    };
    assert!(merged.exists(), "merge log:\n{}", merge_log(&merge));
    assert_eq!(
        comparable(&merged),
        comparable(&reference.join("sparsity/sl/runs.csv")),
        "the merged rows differ from the unsharded run"
    );
    let log0 = std::fs::read_to_string(out.join(format!("slurm-{array}_0.log"))).unwrap();
    assert!(
        log0.contains("ran 0,"),
        "shard 0 had nothing left to run:\n{log0}"
    );
    let log1 = std::fs::read_to_string(out.join(format!("slurm-{array}_1.log"))).unwrap();
    assert!(!log1.contains("ran 0,"), "shard 1 ran its runs:\n{log1}");

    // 3. Once more, nothing to run: the merge job replaces its own earlier output.
    let before = std::fs::metadata(&merged).unwrap().modified().unwrap();
    let (array, merge) = cluster.submit(&script);
    cluster.wait("the array and the merge to end", || {
        !cluster.queued(&array) && !cluster.queued(&merge)
    });
    let log = merge_log(&merge);
    assert!(!log.contains("error"), "the third merge failed:\n{log}");
    assert!(std::fs::metadata(&merged).unwrap().modified().unwrap() > before);
    assert_eq!(
        comparable(&merged),
        comparable(&reference.join("sparsity/sl/runs.csv"))
    );
    drop(cluster);
    std::fs::remove_dir_all(&d).ok();
}

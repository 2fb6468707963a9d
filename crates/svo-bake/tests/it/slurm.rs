//! A bake in 16 parts on a Slurm cluster of one node (munge, slurmctld and slurmd from
//! Debian's packages, configured here in a temporary folder and stopped at the end), through
//! `scripts/slurm/svo-bake-slurm.sh`: the array job's part 3 is killed on its first run and
//! requeued by Slurm, and the merged file is byte for byte the bake in one process.
//!
//! Needs `munged`, `slurmctld`, `slurmd`, `sbatch`, `squeue`, `scontrol` and `sinfo` (Debian's
//! `slurm-wlm` and `munge`; `.ci/run` installs them) and root to start them: without them the
//! harness reports the test ignored, except under CI, where it fails.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};
use svo_tests::harness::{Need, Test};
use svo_tests::trial;

const TOOLS: [&str; 7] = [
    "munged",
    "slurmctld",
    "slurmd",
    "sbatch",
    "squeue",
    "scontrol",
    "sinfo",
];

/// Slurm's and munge's programs, and root (the cluster's daemons run as root).
fn slurm_need() -> Need {
    Need::new(
        "Slurm and munge, run as root (apt-get install slurm-wlm munge)",
        || {
            if let Some(t) = TOOLS.iter().find(|t| svo_tests::find_tool(t).is_none()) {
                return Err(format!("{t} is not installed"));
            }
            let uid = Command::new("id")
                .arg("-u")
                .output()
                .map_err(|e| e.to_string())?;
            if String::from_utf8_lossy(&uid.stdout).trim() == "0" {
                Ok(())
            } else {
                Err("not running as root".into())
            }
        },
    )
}

/// A free TCP port on this machine (bound, then let go).
fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .map(|a| a.port())
        .unwrap()
}

/// The cluster's daemons: stopped (SIGTERM by their pid files) when dropped.
struct Cluster {
    dir: PathBuf,
    conf: PathBuf,
}

impl Drop for Cluster {
    fn drop(&mut self) {
        for pid in ["slurmd.pid", "slurmctld.pid", "munged.pid"] {
            if let Ok(p) = std::fs::read_to_string(self.dir.join(pid)) {
                let _ = Command::new("kill").arg(p.trim()).status();
            }
        }
    }
}

impl Cluster {
    /// Starts munge, slurmctld and slurmd for one node, this machine, in `dir`.
    fn start(dir: &Path) -> Result<Self, String> {
        let host = String::from_utf8(
            Command::new("hostname")
                .arg("-s")
                .output()
                .map_err(|e| e.to_string())?
                .stdout,
        )
        .map_err(|e| e.to_string())?
        .trim()
        .to_string();
        for d in ["state", "spool", "log"] {
            std::fs::create_dir_all(dir.join(d)).map_err(|e| e.to_string())?;
        }
        let p = |name: &str| dir.join(name).display().to_string();
        // A fresh key: the cluster trusts only itself.
        let key: Vec<u8> = (0..1024u32)
            .map(|i| (i.wrapping_mul(2_654_435_761) >> 13) as u8 ^ std::process::id() as u8)
            .collect();
        std::fs::write(dir.join("munge.key"), key).map_err(|e| e.to_string())?;
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            std::fs::set_permissions(
                dir.join("munge.key"),
                std::fs::Permissions::from_mode(0o600),
            )
            .map_err(|e| e.to_string())?;
        }
        let conf = dir.join("slurm.conf");
        let cpus = std::thread::available_parallelism().map_or(1, std::num::NonZero::get);
        std::fs::write(
            &conf,
            format!(
                "ClusterName=svotest\nSlurmctldHost={host}\nSlurmUser=root\nSlurmdUser=root\n\
                 AuthType=auth/munge\nCredType=cred/munge\nAuthInfo=socket={sock}\n\
                 StateSaveLocation={state}\nSlurmdSpoolDir={spool}\n\
                 SlurmctldPidFile={ctld_pid}\nSlurmdPidFile={d_pid}\n\
                 SlurmctldPort={p1}\nSlurmdPort={p2}\n\
                 SlurmctldLogFile={ctld_log}\nSlurmdLogFile={d_log}\n\
                 ProctrackType=proctrack/linuxproc\nTaskPlugin=task/none\n\
                 JobAcctGatherType=jobacct_gather/none\nAccountingStorageType=accounting_storage/none\n\
                 JobCompType=jobcomp/none\nSchedulerType=sched/backfill\n\
                 SelectType=select/cons_tres\nSelectTypeParameters=CR_Core\n\
                 ReturnToService=2\nMpiDefault=none\nInactiveLimit=0\nMinJobAge=600\nKillWait=2\n\
                 NodeName={host} CPUs={cpus} State=UNKNOWN\n\
                 PartitionName=test Nodes=ALL Default=YES MaxTime=INFINITE State=UP\n",
                sock = p("munge.sock"),
                state = p("state"),
                spool = p("spool"),
                ctld_pid = p("slurmctld.pid"),
                d_pid = p("slurmd.pid"),
                p1 = free_port(),
                p2 = free_port(),
                ctld_log = p("log/slurmctld.log"),
                d_log = p("log/slurmd.log"),
            ),
        )
        .map_err(|e| e.to_string())?;
        let cluster = Cluster {
            dir: dir.to_path_buf(),
            conf: conf.clone(),
        };
        let run = |cmd: &mut Command, what: &str| -> Result<(), String> {
            let out = cmd.output().map_err(|e| format!("{what}: {e}"))?;
            if out.status.success() {
                Ok(())
            } else {
                Err(format!(
                    "{what} failed: {}{}",
                    String::from_utf8_lossy(&out.stdout),
                    String::from_utf8_lossy(&out.stderr)
                ))
            }
        };
        run(
            Command::new("munged").args([
                "--force",
                &format!("--socket={}", p("munge.sock")),
                &format!("--key-file={}", p("munge.key")),
                &format!("--pid-file={}", p("munged.pid")),
                &format!("--log-file={}", p("log/munged.log")),
                &format!("--seed-file={}", p("munge.seed")),
            ]),
            "munged",
        )?;
        run(
            Command::new("slurmctld")
                .arg("-f")
                .arg(&conf)
                .env("SLURM_CONF", &conf),
            "slurmctld",
        )?;
        run(
            Command::new("slurmd")
                .arg("-f")
                .arg(&conf)
                .env("SLURM_CONF", &conf),
            "slurmd",
        )?;
        // The node comes up idle.
        let t = Instant::now();
        loop {
            let out = cluster.cmd("sinfo").args(["-h", "-o", "%t"]).output();
            if out.is_ok_and(|o| String::from_utf8_lossy(&o.stdout).trim() == "idle") {
                return Ok(cluster);
            }
            if t.elapsed() > Duration::from_secs(60) {
                return Err(format!(
                    "the node did not come up: {}",
                    std::fs::read_to_string(dir.join("log/slurmd.log")).unwrap_or_default()
                ));
            }
            std::thread::sleep(Duration::from_millis(300));
        }
    }

    /// A Slurm client command for this cluster.
    fn cmd(&self, tool: &str) -> Command {
        let mut c = Command::new(tool);
        c.env("SLURM_CONF", &self.conf);
        c
    }

    /// What `scontrol show job ID` says, one `key=value` a word.
    fn job(&self, id: &str) -> String {
        self.cmd("scontrol")
            .args(["show", "job", id])
            .output()
            .map(|o| String::from_utf8_lossy(&o.stdout).into_owned())
            .unwrap_or_default()
    }

    /// Waits until job `id` has ended; returns its state.
    fn wait(&self, id: &str, limit: Duration) -> String {
        let t = Instant::now();
        loop {
            let info = self.job(id);
            let state = info
                .split_whitespace()
                .find_map(|w| w.strip_prefix("JobState="))
                .unwrap_or("")
                .to_string();
            if ["COMPLETED", "FAILED", "CANCELLED", "TIMEOUT", "NODE_FAIL"]
                .contains(&state.as_str())
            {
                return state;
            }
            assert!(
                t.elapsed() < limit,
                "job {id} still {state} after {limit:?}:\n{info}"
            );
            std::thread::sleep(Duration::from_millis(500));
        }
    }
}

fn sixteen_parts_on_slurm_with_a_killed_part_merge_into_the_single_process_bake() {
    // The bunny where the shared models are, else the torus fixture.
    let bunny = svo_tests::models_dir().join("stanford/bun_zipper.ply");
    let mesh = if bunny.is_file() {
        bunny
    } else {
        svo_tests::repo_root().join("fixtures/torus.obj")
    };
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let cluster = Cluster::start(&dir.join("cluster"))
        .unwrap_or_else(|e| panic!("a single-node Slurm cluster did not start: {e}"));
    let bin = env!("CARGO_BIN_EXE_svo-bake");
    // The first run of part 3 marks that it runs and waits to be killed; its rerun bakes.
    let mark = dir.join("part3.started");
    let wrapper = dir.join("svo-bake-wrapper.sh");
    std::fs::write(
        &wrapper,
        format!(
            "#!/bin/sh\nif [ \"$1\" = part ] && [ \"$3\" = 3 ] && [ \"${{SLURM_RESTART_COUNT:-0}}\" = 0 ]; then\n\
             touch '{}'; exec sleep 600\nfi\nexec '{bin}' \"$@\"\n",
            mark.display()
        ),
    )
    .unwrap();
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        std::fs::set_permissions(&wrapper, std::fs::Permissions::from_mode(0o755)).unwrap();
    }
    let out = dir.join("bunny.svo");
    let script = svo_tests::repo_root().join("scripts/slurm/svo-bake-slurm.sh");
    let submitted = cluster
        .cmd("bash")
        .arg(&script)
        .arg(&mesh)
        .args(["8", "16"])
        .arg(&out)
        .env("SVO_BAKE", &wrapper)
        .stderr(Stdio::inherit())
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&submitted.stdout).into_owned();
    assert!(submitted.status.success(), "{text}");
    let id = |label: &str| {
        text.lines()
            .find_map(|l| l.strip_prefix(label))
            .and_then(|r| r.split_whitespace().nth(1))
            .unwrap_or_else(|| panic!("no {label} job in {text}"))
            .to_string()
    };
    let (array, merge) = (id("parts:"), id("merge:"));
    // Kill part 3 while it runs: Slurm requeues it.
    let t = Instant::now();
    while !mark.exists() {
        assert!(
            t.elapsed() < Duration::from_secs(120),
            "part 3 never started"
        );
        std::thread::sleep(Duration::from_millis(200));
    }
    let task = format!("{array}_3");
    let requeue = cluster
        .cmd("scontrol")
        .args(["requeue", &task])
        .output()
        .unwrap();
    assert!(
        requeue.status.success(),
        "{}",
        String::from_utf8_lossy(&requeue.stderr)
    );
    // Slurm delays a requeued job's start (by two minutes); this test need not wait.
    let t = Instant::now();
    while !cluster.job(&task).contains("JobState=PENDING") {
        assert!(
            t.elapsed() < Duration::from_secs(60),
            "part 3 was not requeued"
        );
        std::thread::sleep(Duration::from_millis(200));
    }
    let _ = cluster
        .cmd("scontrol")
        .args(["update", &format!("JobId={task}"), "StartTime=now"])
        .output();
    let state = cluster.wait(&merge, Duration::from_secs(600));
    let log = std::fs::read_to_string(dir.join("bunny.merge.log")).unwrap_or_default();
    assert_eq!(state, "COMPLETED", "merge: {log}");
    let info = cluster.job(&task);
    assert!(
        info.contains("Restarts=1"),
        "part 3 was not run again: {info}"
    );
    for i in 0..16 {
        assert_eq!(
            cluster.wait(&format!("{array}_{i}"), Duration::from_secs(10)),
            "COMPLETED"
        );
    }
    // The same bake in one process.
    let single = dir.join("single.svo");
    let st = Command::new(bin)
        .arg(&mesh)
        .args(["--depth", "8", "-q", "-o"])
        .arg(&single)
        .status()
        .unwrap();
    assert!(st.success());
    assert!(
        std::fs::read(&out).unwrap() == std::fs::read(&single).unwrap(),
        "the merged file differs from the single-process bake"
    );
    drop(cluster);
}

/// This module's tests, with what each needs of the machine.
pub(crate) fn trials() -> Vec<Test> {
    vec![trial!(
        sixteen_parts_on_slurm_with_a_killed_part_merge_into_the_single_process_bake,
        slurm_need()
    )]
}

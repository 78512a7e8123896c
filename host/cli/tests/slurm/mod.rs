//! A private single-node Slurm cluster for one test: munged, slurmctld and slurmd started
//! from a configuration written into the test's temporary directory (own munge socket and
//! key, own free ports, own state and spool), so it neither needs nor touches a system
//! Slurm. Dropping the [`Cluster`] cancels its jobs and stops the daemons, also when the
//! test fails. Needs Debian's `slurm-wlm` and `munge` (`.ci/run`'s Slurm step installs
//! them); docs/batch.md shows the same configuration.

use std::fs;
use std::io::Read;
use std::net::TcpListener;
use std::os::unix::fs::PermissionsExt;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// The partition every job of the test cluster runs in (the default one).
pub(crate) const PARTITION: &str = "mesopush";

/// The daemons of a running single-node cluster and the files that configure it.
#[derive(Debug)]
pub(crate) struct Cluster {
    dir: PathBuf,
    conf: PathBuf,
    daemons: Vec<(&'static str, Child)>,
}

/// Two ports free on the loopback interface now (slurmctld's and slurmd's).
fn free_ports() -> (u16, u16) {
    let a = TcpListener::bind("127.0.0.1:0").expect("a free port");
    let b = TcpListener::bind("127.0.0.1:0").expect("a free port");
    (a.local_addr().unwrap().port(), b.local_addr().unwrap().port())
}

fn set_mode(path: &Path, mode: u32) {
    fs::set_permissions(path, fs::Permissions::from_mode(mode)).unwrap();
}

/// A daemon's command: Debian puts them in /usr/sbin, which a user's PATH may lack.
fn daemon_command(name: &str) -> Command {
    let sbin = Path::new("/usr/sbin").join(name);
    Command::new(if sbin.exists() { sbin } else { PathBuf::from(name) })
}

fn short_hostname() -> String {
    let h = fs::read_to_string("/proc/sys/kernel/hostname").expect("the host name");
    h.trim().split('.').next().unwrap_or_default().to_string()
}

fn user_name() -> String {
    let o = Command::new("id").arg("-un").output().expect("id -un runs");
    String::from_utf8_lossy(&o.stdout).trim().to_string()
}

/// slurm.conf for one node with `cpus` CPUs, no cgroups, no accounting: the daemons
/// and every job run as the current user.
fn slurm_conf(dir: &Path, cpus: u32) -> String {
    let (host, user, d) = (short_hostname(), user_name(), dir.display());
    let (ctld_port, d_port) = free_ports();
    format!(
        "ClusterName=mesopushtest\n\
         SlurmctldHost={host}(127.0.0.1)\n\
         SlurmctldPort={ctld_port}\n\
         SlurmdPort={d_port}\n\
         SlurmUser={user}\n\
         SlurmdUser={user}\n\
         AuthType=auth/munge\n\
         CredType=cred/munge\n\
         AuthInfo=socket={d}/munge/munge.socket\n\
         StateSaveLocation={d}/state\n\
         SlurmdSpoolDir={d}/spool\n\
         SlurmctldPidFile={d}/slurmctld.pid\n\
         SlurmdPidFile={d}/slurmd.pid\n\
         SlurmctldLogFile={d}/log/slurmctld.log\n\
         SlurmdLogFile={d}/log/slurmd.log\n\
         ProctrackType=proctrack/linuxproc\n\
         TaskPlugin=task/none\n\
         SelectType=select/cons_tres\n\
         SelectTypeParameters=CR_CPU\n\
         JobAcctGatherType=jobacct_gather/none\n\
         AccountingStorageType=accounting_storage/none\n\
         JobCompType=jobcomp/none\n\
         MpiDefault=none\n\
         ReturnToService=2\n\
         MailProg=/bin/true\n\
         SlurmdParameters=config_overrides\n\
         NodeName={host} NodeAddr=127.0.0.1 CPUs={cpus} State=UNKNOWN\n\
         PartitionName={PARTITION} Nodes={host} Default=YES MaxTime=30 State=UP\n"
    )
}

impl Cluster {
    /// Starts munged, slurmctld and slurmd with `cpus` CPUs in `dir` and waits (up to
    /// 60 s) until the node is idle.
    pub(crate) fn start(dir: &Path, cpus: u32) -> Cluster {
        for sub in ["munge", "state", "spool", "log"] {
            fs::create_dir_all(dir.join(sub)).unwrap();
        }
        let key = dir.join("munge/munge.key");
        let mut bytes = Vec::new();
        fs::File::open("/dev/urandom").unwrap().take(128).read_to_end(&mut bytes).unwrap();
        fs::write(&key, bytes).unwrap();
        set_mode(&key, 0o400);
        set_mode(&dir.join("munge"), 0o700);
        let conf = dir.join("slurm.conf");
        fs::write(&conf, slurm_conf(dir, cpus)).unwrap();
        let mut c = Cluster { dir: dir.to_path_buf(), conf, daemons: Vec::new() };
        let m = dir.join("munge");
        let munged = [
            "-F".to_string(),
            "--force".to_string(),
            format!("--socket={}", m.join("munge.socket").display()),
            format!("--key-file={}", key.display()),
            format!("--pid-file={}", m.join("munged.pid").display()),
            format!("--log-file={}", m.join("munged.log").display()),
            format!("--seed-file={}", m.join("munged.seed").display()),
        ];
        c.spawn("munged", &munged);
        c.wait_for("munge socket", |_| m.join("munge.socket").exists());
        let conf_arg = c.conf.display().to_string();
        c.spawn("slurmctld", &["-D".into(), "-f".into(), conf_arg.clone()]);
        c.spawn("slurmd", &["-D".into(), "-f".into(), conf_arg]);
        c.wait_for("idle node", |c| {
            let o = c.client("sinfo").args(["-h", "-N", "-o", "%T"]).output();
            o.is_ok_and(|o| String::from_utf8_lossy(&o.stdout).trim() == "idle")
        });
        c
    }

    fn spawn(&mut self, name: &'static str, args: &[String]) {
        let log = |ext: &str| fs::File::create(self.dir.join(format!("log/{name}.{ext}"))).unwrap();
        let child = daemon_command(name)
            .args(args)
            .stdin(Stdio::null())
            .stdout(log("out"))
            .stderr(log("err"))
            .spawn()
            .unwrap_or_else(|e| panic!("cannot start {name} (is slurm-wlm installed?): {e}"));
        self.daemons.push((name, child));
    }

    fn wait_for(&mut self, what: &str, ready: impl Fn(&Cluster) -> bool) {
        let t0 = Instant::now();
        while !ready(self) {
            let exited = self
                .daemons
                .iter_mut()
                .find_map(|(name, child)| child.try_wait().ok().flatten().map(|s| (*name, s)));
            if let Some((name, status)) = exited {
                panic!("{name} exited ({status}) waiting for {what}\n{}", self.logs());
            }
            assert!(t0.elapsed() < Duration::from_secs(60), "no {what} in 60 s\n{}", self.logs());
            std::thread::sleep(Duration::from_millis(200));
        }
    }

    /// A Slurm client command (`sbatch`, `sinfo`, …) talking to this cluster only: its
    /// configuration, and none of the caller's own `SLURM_*`/`SBATCH_*` settings.
    pub(crate) fn client(&self, program: &str) -> Command {
        let mut c = Command::new(program);
        for (k, _) in std::env::vars_os() {
            let k = k.to_string_lossy();
            if ["SLURM_", "SBATCH_", "SINFO_", "SQUEUE_", "SALLOC_"]
                .iter()
                .any(|p| k.starts_with(p))
            {
                c.env_remove(k.as_ref());
            }
        }
        c.env("SLURM_CONF", &self.conf);
        c
    }

    /// `sbatch --wait --array=ARRAY script` in `cwd` with `path` first in `PATH`
    /// (the job inherits the environment); panics with the job's and the daemons' logs
    /// when a task fails or the array is not done within `limit`.
    pub(crate) fn run_array(
        &self,
        script: &Path,
        array: &str,
        cwd: &Path,
        path: &Path,
        limit: Duration,
    ) {
        let search = std::env::var_os("PATH").unwrap_or_default();
        let search = std::env::join_paths(
            std::iter::once(path.to_path_buf()).chain(std::env::split_paths(&search)),
        )
        .unwrap();
        let mut child = self
            .client("sbatch")
            .arg("--wait")
            .arg(format!("--array={array}"))
            .arg(script)
            .current_dir(cwd)
            .env("PATH", search)
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("sbatch runs");
        let t0 = Instant::now();
        while child.try_wait().unwrap().is_none() {
            if t0.elapsed() > limit {
                let _ = child.kill();
                let (s, logs) = (script.display(), self.logs());
                panic!("{s}: array not done in {limit:?}\n{}{logs}", job_logs(cwd));
            }
            std::thread::sleep(Duration::from_millis(100));
        }
        let o = child.wait_with_output().unwrap();
        let said =
            format!("{}{}", String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr));
        assert!(
            o.status.success(),
            "{}: sbatch --wait {}: {said}\n{}{}",
            script.display(),
            o.status,
            job_logs(cwd),
            self.logs()
        );
    }

    /// The daemons' logs (their last lines), for a failure message.
    pub(crate) fn logs(&self) -> String {
        let mut s = String::new();
        for f in ["slurmctld.log", "slurmd.log", "munged.err", "slurmctld.err", "slurmd.err"] {
            let text = fs::read_to_string(self.dir.join("log").join(f)).unwrap_or_default();
            let lines: Vec<&str> = text.lines().collect();
            let tail = lines[lines.len().saturating_sub(15)..].join("\n");
            s.push_str(&format!("--- {f} (last lines)\n{tail}\n"));
        }
        s
    }
}

/// The array tasks' output files in `cwd` (`slurm-JOB_TASK.out`), for a failure message.
fn job_logs(cwd: &Path) -> String {
    let mut s = String::new();
    for e in fs::read_dir(cwd).into_iter().flatten().flatten() {
        let name = e.file_name().to_string_lossy().into_owned();
        if name.starts_with("slurm-") && name.ends_with(".out") {
            let text = fs::read_to_string(e.path()).unwrap_or_default();
            s.push_str(&format!("--- {name}\n{text}\n"));
        }
    }
    s
}

impl Drop for Cluster {
    /// Cancels every job of the partition, then stops the daemons (SIGTERM, SIGKILL after 5 s).
    fn drop(&mut self) {
        let _ = self.client("scancel").args(["--partition", PARTITION]).output();
        for (_, child) in self.daemons.iter_mut().rev() {
            let _ = Command::new("kill").args(["-TERM", &child.id().to_string()]).output();
            let t0 = Instant::now();
            while matches!(child.try_wait(), Ok(None)) && t0.elapsed() < Duration::from_secs(5) {
                std::thread::sleep(Duration::from_millis(50));
            }
            let _ = child.kill();
            let _ = child.wait();
        }
    }
}

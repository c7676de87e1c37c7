//! Lock files: one writer for a session log or a set folder.
//!
//! A lock is a file created with `O_EXCL` (`create_new`) holding one line
//! `host=H pid=P started=T`. Its holder also keeps an advisory lock (`flock`) on it while it
//! runs. Another process that finds the file reads the holder's host and pid; the lock is
//! *stale*, and taken over, when the holder ran on this host and either its pid is not alive
//! (`/proc/PID` is absent) or nobody holds the advisory lock (the pid was reused). A lock
//! of another host is never judged stale: the error names its host and pid so the user can
//! check that machine and remove the file. [`LockFile`] removes its file when dropped; a
//! killed holder leaves it behind for its successor to take over.
//!
//! Taking over renames the stale file to a name unique to the taker, so two successors
//! cannot both remove it: only the one whose rename moved the stale file proceeds.
//!
//! **Requeued cluster jobs.** Under Slurm the holder also records its job
//! (`job=SLURM_JOB_ID restart=SLURM_RESTART_COUNT`). A requeued or preempted job restarts
//! with the same job id and a higher restart count, on any node, and only after Slurm has
//! ended the earlier run; so a lock of the same job with a lower restart count is stale on
//! any host, and a requeued array task resumes without anyone removing its locks by hand.

use std::fs::{File, OpenOptions};
use std::io::{self, Read, Write};
use std::path::{Path, PathBuf};

/// Who holds a lock, as written in its file.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Holder {
    /// Host name.
    pub host: String,
    /// Process id.
    pub pid: u32,
    /// When it took the lock (UTC, RFC 3339).
    pub started: String,
    /// The cluster job it ran in (`SLURM_JOB_ID`; an array task has its own), if any.
    pub job: Option<String>,
    /// How often that job had been requeued when it took the lock (`SLURM_RESTART_COUNT`).
    pub restart: u32,
}

impl Holder {
    fn parse(text: &str) -> Option<Holder> {
        let mut host = None;
        let mut pid = None;
        let mut started = String::new();
        let (mut job, mut restart) = (None, 0);
        for word in text.split_whitespace() {
            match word.split_once('=') {
                Some(("host", v)) => host = Some(v.to_owned()),
                Some(("pid", v)) => pid = v.parse().ok(),
                Some(("started", v)) => started = v.to_owned(),
                Some(("job", v)) => job = Some(v.to_owned()),
                Some(("restart", v)) => restart = v.parse().unwrap_or(0),
                _ => {}
            }
        }
        Some(Holder { host: host?, pid: pid?, started, job, restart })
    }

    fn line(&self) -> String {
        let mut line = format!("host={} pid={} started={}", self.host, self.pid, self.started);
        if let Some(job) = &self.job {
            line.push_str(&format!(" job={job} restart={}", self.restart));
        }
        line.push('\n');
        line
    }

    /// This process: host, pid, now, and its Slurm job if it runs in one.
    fn this_process() -> Holder {
        let word = |name: &str| {
            std::env::var(name)
                .ok()
                .map(|v| v.trim().to_owned())
                .filter(|v| !v.is_empty() && !v.contains(char::is_whitespace) && !v.contains('='))
        };
        Holder {
            host: host_name(),
            pid: std::process::id(),
            started: crate::response::utc_timestamp_now(),
            job: word("SLURM_JOB_ID"),
            restart: word("SLURM_RESTART_COUNT").and_then(|v| v.parse().ok()).unwrap_or(0),
        }
    }

    /// Whether `self` is a later run of the requeued job that `earlier` ran in: then the
    /// earlier run has ended, wherever it ran.
    fn requeued_after(&self, earlier: &Holder) -> bool {
        self.job.is_some() && self.job == earlier.job && self.restart > earlier.restart
    }
}

impl std::fmt::Display for Holder {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "host {}, pid {}", self.host, self.pid)?;
        if !self.started.is_empty() {
            write!(f, ", started {}", self.started)?;
        }
        if let Some(job) = &self.job {
            write!(f, ", Slurm job {job} (restart {})", self.restart)?;
        }
        Ok(())
    }
}

/// Why a lock could not be taken.
#[derive(Debug, thiserror::Error)]
pub enum LockError {
    /// Another live process (or a process on another host) holds it.
    #[error("{}: held by another process ({holder})", path.display())]
    Held {
        /// The lock file.
        path: PathBuf,
        /// Its holder.
        holder: Holder,
    },
    /// The lock file could not be created or read.
    #[error("{}: cannot take the lock: {source}", path.display())]
    Io {
        /// The lock file.
        path: PathBuf,
        /// Cause.
        source: io::Error,
    },
}

/// A held lock; the file is removed when it is dropped.
#[derive(Debug)]
pub struct LockFile {
    path: PathBuf,
    file: File,
    /// This process's record in the file.
    pub holder: Holder,
}

/// This machine's host name (`/proc/sys/kernel/hostname`, `/etc/hostname`, `$HOSTNAME`), or
/// `unknown`.
pub fn host_name() -> String {
    ["/proc/sys/kernel/hostname", "/etc/hostname"]
        .iter()
        .find_map(|p| std::fs::read_to_string(p).ok().map(|s| s.trim().to_owned()).filter(|s| !s.is_empty()))
        .or_else(|| std::env::var("HOSTNAME").ok().filter(|s| !s.is_empty()))
        .unwrap_or_else(|| "unknown".to_owned())
        .chars()
        .map(|c| if c.is_whitespace() || c == '=' { '_' } else { c })
        .collect()
}

/// Whether process `pid` is alive on this host. Where `/proc` is not available nothing can
/// be told, and the process counts as alive.
pub fn pid_alive(pid: u32) -> bool {
    if !Path::new("/proc/self").exists() {
        return true;
    }
    // A zombie (killed, not yet reaped) has exited: it writes nothing any more.
    match std::fs::read_to_string(format!("/proc/{pid}/stat")) {
        Err(_) => false,
        Ok(stat) => stat.rfind(')').and_then(|i| stat[i + 1..].split_whitespace().next()) != Some("Z"),
    }
}

/// Age (seconds) at which a lock file that holds no readable holder is judged stale.
const UNREADABLE_STALE_SECONDS: u64 = 5;

impl LockFile {
    /// Takes the lock at `path`, taking over a stale one; refuses a live holder.
    pub fn acquire(path: &Path) -> Result<LockFile, LockError> {
        Self::acquire_as(path, Holder::this_process())
    }

    fn acquire_as(path: &Path, me: Holder) -> Result<LockFile, LockError> {
        let io = |source| LockError::Io { path: path.to_owned(), source };
        // An unreadable file is judged stale only once it is 5 s old (a holder killed between
        // creating and writing it leaves it empty), so the attempts outlast that.
        let deadline = std::time::Instant::now() + std::time::Duration::from_secs(UNREADABLE_STALE_SECONDS + 5);
        while std::time::Instant::now() < deadline {
            match OpenOptions::new().write(true).create_new(true).open(path) {
                Ok(mut file) => {
                    // Advisory lock for the local case; correctness does not depend on it.
                    let _ = file.try_lock();
                    file.write_all(me.line().as_bytes()).map_err(io)?;
                    file.sync_all().map_err(io)?;
                    return Ok(LockFile { path: path.to_owned(), file, holder: me });
                }
                Err(e) if e.kind() == io::ErrorKind::AlreadyExists => {}
                Err(e) => return Err(io(e)),
            }
            let mut text = String::new();
            let file = match File::open(path) {
                Ok(mut f) => {
                    f.read_to_string(&mut text).map_err(io)?;
                    f
                }
                Err(e) if e.kind() == io::ErrorKind::NotFound => continue,
                Err(e) => return Err(io(e)),
            };
            let holder = match Holder::parse(&text) {
                Some(h) => h,
                // Being written by its creator this instant, or damaged: wait, then judge
                // an old unreadable file stale.
                None => {
                    let age = file.metadata().and_then(|m| m.modified()).ok().and_then(|t| t.elapsed().ok());
                    if age.is_some_and(|a| a.as_secs() >= UNREADABLE_STALE_SECONDS) {
                        take_over(path, &text)?;
                    } else {
                        std::thread::sleep(std::time::Duration::from_millis(20));
                    }
                    continue;
                }
            };
            let local = holder.host == me.host;
            let stale = me.requeued_after(&holder)
                || (local && (!pid_alive(holder.pid) || (holder.pid != me.pid && file.try_lock().is_ok())));
            drop(file);
            if !stale {
                return Err(LockError::Held { path: path.to_owned(), holder });
            }
            take_over(path, &text)?;
        }
        Err(io(io::Error::other("the lock file keeps changing; try again")))
    }

    /// The lock file.
    pub fn path(&self) -> &Path {
        &self.path
    }
}

/// Removes the stale lock file whose content is `stale`, unless another process replaced it
/// meanwhile (then it is put back, and the caller tries again).
fn take_over(path: &Path, stale: &str) -> Result<(), LockError> {
    let io = |source| LockError::Io { path: path.to_owned(), source };
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let aside = path.with_file_name(format!(".{name}.stale-{}-{}", host_name(), std::process::id()));
    match std::fs::rename(path, &aside) {
        Ok(()) => {}
        Err(e) if e.kind() == io::ErrorKind::NotFound => return Ok(()),
        Err(e) => return Err(io(e)),
    }
    let moved = std::fs::read_to_string(&aside).unwrap_or_default();
    if moved == stale {
        let _ = std::fs::remove_file(&aside);
    } else {
        // A fresh lock of a faster successor: restore it unless yet another one exists.
        if std::fs::hard_link(&aside, path).is_ok() || !path.exists() {
            let _ = std::fs::rename(&aside, path);
        }
        let _ = std::fs::remove_file(&aside);
    }
    Ok(())
}

impl Drop for LockFile {
    fn drop(&mut self) {
        // Remove the file only while it is still ours.
        let ours = std::fs::read_to_string(&self.path).is_ok_and(|t| t == self.holder.line());
        if ours {
            let _ = std::fs::remove_file(&self.path);
        }
        let _ = self.file.unlock();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_second_acquire_is_refused_and_a_dead_holder_is_taken_over() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("x.lock");
        let held = LockFile::acquire(&path).unwrap();
        let e = LockFile::acquire(&path).unwrap_err();
        let LockError::Held { holder, .. } = &e else { panic!("{e}") };
        assert_eq!((holder.pid, &holder.host), (std::process::id(), &host_name()));
        assert!(e.to_string().contains(&format!("pid {}", std::process::id())), "{e}");
        drop(held);
        assert!(!path.exists());

        // A lock left by a process that no longer runs (pid beyond pid_max) is stale.
        std::fs::write(&path, format!("host={} pid=4294967295 started=x\n", host_name())).unwrap();
        let taken = LockFile::acquire(&path).unwrap();
        assert_eq!(taken.holder.pid, std::process::id());
        drop(taken);

        // Another host's lock is never judged stale.
        std::fs::write(&path, "host=elsewhere pid=4294967295 started=x\n").unwrap();
        let e = LockFile::acquire(&path).unwrap_err().to_string();
        assert!(e.contains("host elsewhere, pid 4294967295"), "{e}");
    }

    #[test]
    fn a_requeued_slurm_job_takes_over_its_earlier_runs_lock_on_any_host() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("x.lock");
        let run = |restart: u32| Holder { job: Some("4242".into()), restart, ..Holder::this_process() };
        // The preempted first run, on another node (alive or not, it is never asked).
        std::fs::write(&path, "host=node-7 pid=4294967295 started=x job=4242 restart=0\n").unwrap();
        // Another job (another array task, or a new submission) must not take it over...
        let other = Holder { job: Some("4243".into()), restart: 5, ..Holder::this_process() };
        let e = LockFile::acquire_as(&path, other).unwrap_err().to_string();
        assert!(e.contains("host node-7") && e.contains("Slurm job 4242 (restart 0)"), "{e}");
        // ...nor a run of the same job that is not later (the same run on another node).
        assert!(LockFile::acquire_as(&path, run(0)).is_err());
        let taken = LockFile::acquire_as(&path, run(1)).unwrap();
        assert_eq!(std::fs::read_to_string(&path).unwrap(), taken.holder.line());
        // The requeued run holds it now; the earlier run's number cannot take it back.
        assert!(LockFile::acquire_as(&path, run(0)).is_err());
        drop(taken);
        assert!(!path.exists());
    }

    #[test]
    fn an_empty_lock_file_of_a_holder_killed_while_creating_it_is_taken_over_once_old() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("x.lock");
        std::fs::write(&path, "").unwrap();
        let old = std::time::SystemTime::now() - std::time::Duration::from_secs(3);
        std::fs::File::options().write(true).open(&path).unwrap().set_modified(old).unwrap();
        // Two more seconds and it is 5 s old: acquire waits for that instead of giving up.
        let started = std::time::Instant::now();
        let taken = LockFile::acquire(&path).unwrap();
        assert!(started.elapsed().as_secs_f64() > 1.5, "{:?}", started.elapsed());
        assert_eq!(std::fs::read_to_string(&path).unwrap(), taken.holder.line());
    }

    #[test]
    fn holder_lines_round_trip() {
        let h = Holder { host: "lab-3".into(), pid: 42, started: "2026-01-01T00:00:00Z".into(), job: None, restart: 0 };
        assert_eq!(Holder::parse(&h.line()), Some(h.clone()));
        let h = Holder { job: Some("981_3".into()), restart: 2, ..h };
        assert_eq!(Holder::parse(&h.line()), Some(h));
        assert_eq!(Holder::parse("garbage"), None);
    }
}

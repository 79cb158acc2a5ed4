//! A lock on a run directory, so that two fits never write one directory at once. The lock
//! file holds the pid and command line of its holder; a lock whose holder is gone (killed,
//! crashed) is taken over instead of blocking forever.

use std::fs::OpenOptions;
use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::{bail, Context};

/// The lock file inside the run directory.
pub const LOCK_FILE: &str = ".slipbayes.lock";

/// A held lock; dropping it releases the directory.
#[derive(Debug)]
pub struct RunLock {
    path: PathBuf,
}

/// Who holds a lock, as its file says.
#[derive(Debug, PartialEq, Eq)]
struct Holder {
    pid: u32,
    command: String,
}

impl Holder {
    fn parse(text: &str) -> Option<Self> {
        let mut lines = text.lines();
        let pid = lines.next()?.trim().parse().ok()?;
        let command = lines.next().unwrap_or_default().to_owned();
        Some(Self { pid, command })
    }

    /// Whether the process that wrote the lock still runs. Where /proc exists (Linux) the pid
    /// must be alive and, since pids are reused, still run the command recorded; elsewhere
    /// the holder is assumed alive (a stale lock is then removed by hand).
    fn is_alive(&self) -> bool {
        if !Path::new("/proc/self").exists() {
            return true;
        }
        match std::fs::read(format!("/proc/{}/cmdline", self.pid)) {
            Ok(cmdline) => {
                let running = cmdline
                    .split(|&b| b == 0)
                    .filter(|a| !a.is_empty())
                    .map(String::from_utf8_lossy)
                    .collect::<Vec<_>>()
                    .join(" ");
                running == self.command
            }
            Err(_) => false,
        }
    }
}

fn this_process() -> Holder {
    Holder {
        pid: std::process::id(),
        command: std::env::args().collect::<Vec<_>>().join(" "),
    }
}

impl RunLock {
    /// Locks the run directory `dir` (which must exist) for this process.
    ///
    /// # Errors
    /// When another live process holds it (naming its pid and command), or the lock file
    /// cannot be written.
    pub fn acquire(dir: &Path) -> anyhow::Result<Self> {
        let path = dir.join(LOCK_FILE);
        let me = this_process();
        // Twice at most: once more after removing a dead holder's lock.
        for _ in 0..2 {
            match OpenOptions::new().write(true).create_new(true).open(&path) {
                Ok(mut file) => {
                    writeln!(file, "{}\n{}", me.pid, me.command)
                        .with_context(|| format!("writing the lock {}", path.display()))?;
                    return Ok(Self { path });
                }
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {
                    let text = std::fs::read_to_string(&path).unwrap_or_default();
                    match Holder::parse(&text) {
                        Some(holder) if holder.is_alive() => bail!(
                            "{} is in use by another fit: process {} (`{}`) holds its lock {}; \
                             wait for it to finish or choose another --out",
                            dir.display(),
                            holder.pid,
                            holder.command,
                            path.display()
                        ),
                        // A dead holder's lock, or one cut short while being written.
                        _ => match std::fs::remove_file(&path) {
                            Ok(()) => {}
                            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
                            Err(e) => {
                                return Err(e).with_context(|| {
                                    format!("removing the stale lock {}", path.display())
                                })
                            }
                        },
                    }
                }
                Err(e) => {
                    return Err(e).with_context(|| format!("creating the lock {}", path.display()))
                }
            }
        }
        bail!(
            "cannot lock {}: another process keeps replacing {}",
            dir.display(),
            path.display()
        )
    }
}

impl Drop for RunLock {
    fn drop(&mut self) {
        // Nothing to do about a failure here: a lock left behind is stale and taken over.
        let _ = std::fs::remove_file(&self.path);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_lock_excludes_this_process_and_is_released_on_drop() {
        let dir = tempfile::tempdir().unwrap();
        let lock = RunLock::acquire(dir.path()).unwrap();
        let err = RunLock::acquire(dir.path()).unwrap_err().to_string();
        assert!(
            err.contains(&format!("process {}", std::process::id())),
            "{err}"
        );
        drop(lock);
        assert!(!dir.path().join(LOCK_FILE).exists());
        RunLock::acquire(dir.path()).unwrap();
    }

    #[test]
    fn a_dead_holders_lock_is_taken_over() {
        let dir = tempfile::tempdir().unwrap();
        let mut child = std::process::Command::new("true").spawn().unwrap();
        let pid = child.id();
        child.wait().unwrap();
        std::fs::write(dir.path().join(LOCK_FILE), format!("{pid}\ntrue\n")).unwrap();
        let _lock = RunLock::acquire(dir.path()).unwrap();
        let text = std::fs::read_to_string(dir.path().join(LOCK_FILE)).unwrap();
        assert_eq!(
            Holder::parse(&text).unwrap().pid,
            std::process::id(),
            "{text}"
        );
    }
}

//! A lock on a run directory, so that two fits never write one directory at once, whichever
//! front end (the command line, the Python package) runs them. The lock file holds the pid and
//! command line of its holder; a lock whose holder is gone (killed, crashed) is taken over
//! instead of blocking forever.

use std::fs::OpenOptions;
use std::io::Write;
use std::path::{Path, PathBuf};

use crate::IoError;

pub use crate::output_dir::LOCK_FILE;

/// Why a run directory could not be locked; each names the directory or the lock file.
#[derive(Debug, thiserror::Error)]
pub enum LockError {
    /// Another live process holds the lock.
    #[error(
        "{} is in use by another fit: process {pid} (`{command}`) holds its lock {}; wait for \
         it to finish or choose another --out",
        dir.display(),
        lock.display()
    )]
    Held {
        /// The run directory.
        dir: PathBuf,
        /// Its lock file.
        lock: PathBuf,
        /// The holder's process id.
        pid: u32,
        /// The holder's command line.
        command: String,
    },
    /// The directory or the lock file could not be created, written or removed.
    #[error(transparent)]
    Io(#[from] IoError),
    /// The lock file was replaced again after a stale one was removed.
    #[error(
        "cannot lock {}: another process keeps replacing {}",
        dir.display(),
        lock.display()
    )]
    Contended {
        /// The run directory.
        dir: PathBuf,
        /// Its lock file.
        lock: PathBuf,
    },
}

/// A held lock on a run directory; dropping it releases the directory.
#[derive(Debug)]
pub struct RunLock {
    dir: PathBuf,
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
    /// Locks the run directory `dir` for this process, creating the directory if need be.
    ///
    /// # Errors
    /// [`LockError::Held`] when another live process holds it (naming its pid and command),
    /// [`LockError::Io`] when the directory or the lock file cannot be created or written,
    /// [`LockError::Contended`] when a stale lock, once removed, is replaced again.
    pub fn acquire(dir: &Path) -> Result<Self, LockError> {
        let io = |action, path: &Path| {
            let path = path.to_path_buf();
            move |source| LockError::Io(IoError::new(action, path, source))
        };
        std::fs::create_dir_all(dir).map_err(io("create the run directory", dir))?;
        let path = dir.join(LOCK_FILE);
        let me = this_process();
        // Twice at most: once more after removing a dead holder's lock.
        for _ in 0..2 {
            match OpenOptions::new().write(true).create_new(true).open(&path) {
                Ok(mut file) => {
                    writeln!(file, "{}\n{}", me.pid, me.command)
                        .map_err(io("write the lock file", &path))?;
                    return Ok(Self {
                        dir: dir.to_path_buf(),
                        path,
                    });
                }
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {
                    let text = std::fs::read_to_string(&path).unwrap_or_default();
                    match Holder::parse(&text) {
                        Some(holder) if holder.is_alive() => {
                            return Err(LockError::Held {
                                dir: dir.to_path_buf(),
                                lock: path,
                                pid: holder.pid,
                                command: holder.command,
                            })
                        }
                        // A dead holder's lock, or one cut short while being written.
                        _ => match std::fs::remove_file(&path) {
                            Ok(()) => {}
                            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
                            Err(e) => return Err(io("remove the stale lock file", &path)(e)),
                        },
                    }
                }
                Err(e) => return Err(io("create the lock file", &path)(e)),
            }
        }
        Err(LockError::Contended {
            dir: dir.to_path_buf(),
            lock: path,
        })
    }

    /// The locked run directory.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// Its lock file.
    pub fn path(&self) -> &Path {
        &self.path
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

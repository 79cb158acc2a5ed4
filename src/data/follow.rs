//! A text export that an instrument is still writing, read as far as its last complete line.
//!
//! Rheometer software appends rows in bursts, may leave the last row half-written between two
//! reads, and may rewrite or rotate the file (a new export replacing the old under the same
//! name). [`Follower`] turns that into a sequence of [`Snapshot`]s: the file's bytes up to its
//! last newline, each time they change, and whether the file was rewritten rather than
//! extended since the snapshot before.

use std::fs::File;
use std::io::{self, Read};
use std::path::{Path, PathBuf};

/// Bytes at the start of the file remembered to recognise a rewrite: a new export has a new
/// header (its date, its sample name) or new first rows.
const HEAD_BYTES: usize = 4096;

/// The complete lines of a followed file at one moment.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Snapshot {
    /// The file's bytes up to and including its last newline.
    pub bytes: Vec<u8>,
    /// Whether the file was rewritten (shorter than before, or a different start) rather than
    /// extended since the previous snapshot.
    pub rewritten: bool,
}

/// Follows a file that grows, one [`poll`](Follower::poll) at a time.
#[derive(Debug)]
pub struct Follower {
    path: PathBuf,
    /// Length of the complete lines of the last snapshot (0 before the first).
    complete: usize,
    /// The first bytes of the last snapshot.
    head: Vec<u8>,
}

impl Follower {
    /// Follows `path`, which need not exist yet.
    pub fn new(path: &Path) -> Self {
        Self {
            path: path.to_path_buf(),
            complete: 0,
            head: Vec::new(),
        }
    }

    /// The followed file.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The file's complete lines when they differ from the last snapshot's; `None` when they
    /// do not, or when the file does not exist at the moment (being rotated, or not yet
    /// created).
    ///
    /// # Errors
    /// An I/O error other than the file's absence.
    pub fn poll(&mut self) -> io::Result<Option<Snapshot>> {
        let mut bytes = Vec::new();
        match File::open(&self.path) {
            Ok(mut file) => file.read_to_end(&mut bytes)?,
            Err(e) if e.kind() == io::ErrorKind::NotFound => return Ok(None),
            Err(e) => return Err(e),
        };
        let complete = complete_lines(&bytes);
        bytes.truncate(complete);
        let head = &bytes[..complete.min(HEAD_BYTES)];
        let shared = head.len().min(self.head.len());
        let rewritten = self.complete > 0
            && (complete < self.complete || head[..shared] != self.head[..shared]);
        if !rewritten && complete == self.complete {
            return Ok(None);
        }
        self.complete = complete;
        self.head = head.to_vec();
        Ok(Some(Snapshot { bytes, rewritten }))
    }
}

/// The length of the complete lines of `bytes`: a row is complete once its newline is
/// written, and what follows the last newline may be half a row. In UTF-16 (an export with a
/// byte-order mark, as RheoCompass writes) a newline is two bytes at an even offset.
fn complete_lines(bytes: &[u8]) -> usize {
    let utf16_newline: Option<[u8; 2]> = match bytes {
        [0xFF, 0xFE, ..] => Some([b'\n', 0]),
        [0xFE, 0xFF, ..] => Some([0, b'\n']),
        _ => None,
    };
    match utf16_newline {
        Some(newline) => bytes
            .chunks_exact(2)
            .rposition(|unit| unit == newline)
            .map_or(0, |i| 2 * i + 2),
        None => bytes.iter().rposition(|&b| b == b'\n').map_or(0, |i| i + 1),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::fs::{self, OpenOptions};
    use std::io::Write;

    fn append(path: &Path, text: &str) {
        let mut f = OpenOptions::new()
            .create(true)
            .append(true)
            .open(path)
            .unwrap();
        f.write_all(text.as_bytes()).unwrap();
    }

    #[test]
    fn complete_lines_only_and_each_change_once() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("export.csv");
        let mut follower = Follower::new(&path);
        assert_eq!(follower.poll().unwrap(), None, "no file yet");
        append(&path, "time_s,force_N\n0,1\n10,2");
        let s = follower.poll().unwrap().unwrap();
        assert_eq!(s.bytes, b"time_s,force_N\n0,1\n");
        assert!(!s.rewritten);
        assert_eq!(follower.poll().unwrap(), None, "half a row is not a change");
        append(&path, ".5\n20,3\n");
        let s = follower.poll().unwrap().unwrap();
        assert_eq!(s.bytes, b"time_s,force_N\n0,1\n10,2.5\n20,3\n");
        assert!(!s.rewritten);
    }

    #[test]
    fn utf16_rows_end_at_a_whole_newline() {
        let encode = |text: &str| -> Vec<u8> {
            let mut bytes = vec![0xFF, 0xFE];
            bytes.extend(text.encode_utf16().flat_map(u16::to_le_bytes));
            bytes
        };
        let full = encode("Time\tForce\n0\t1\n10\t2");
        let complete = encode("Time\tForce\n0\t1\n");
        assert_eq!(complete_lines(&full), complete.len());
        // A newline's first byte alone is half a row.
        let mut half = complete.clone();
        half.extend([b'1', 0, b'\n']);
        assert_eq!(complete_lines(&half), complete.len());
    }

    #[test]
    fn a_rewritten_or_rotated_file_is_said_so() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("export.txt");
        let mut follower = Follower::new(&path);
        fs::write(&path, "header A\n0,1\n10,2\n").unwrap();
        assert!(!follower.poll().unwrap().unwrap().rewritten);
        // Rotated: gone for a moment, then a new export under the same name.
        fs::remove_file(&path).unwrap();
        assert_eq!(follower.poll().unwrap(), None);
        fs::write(&path, "header B\n0,1\n10,2\n20,3\n").unwrap();
        let s = follower.poll().unwrap().unwrap();
        assert!(
            s.rewritten,
            "a different start is a new file, even when longer"
        );
        // Shorter than before: rewritten too.
        fs::write(&path, "header B\n0,1\n").unwrap();
        assert!(follower.poll().unwrap().unwrap().rewritten);
        append(&path, "10,2\n");
        assert!(!follower.poll().unwrap().unwrap().rewritten);
    }
}

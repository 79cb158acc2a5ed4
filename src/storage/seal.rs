//! Checksums that let a run directory prove its files are the ones written.
//!
//! A corrupted file must be refused, never read as valid: truncation already fails to parse,
//! but a flipped byte inside a number parses to another number. So the checkpoint carries a
//! CRC-32 of its own body in a trailer, and, for every complete part it counts, the part's
//! length and CRC-32 (a [`Seal`]); `summary.json` carries a CRC-32 of the rest of its text as
//! its last key. The checkpoint is the root: only a checkpoint verified by its own checksum
//! vouches for the parts, and a sealed checkpoint says that the run's summary is sealed too,
//! so that a flip that destroys a seal's marker is refused rather than taken for a file of an
//! earlier release.
//!
//! CRC-32 (IEEE 802.3) and not a cryptographic hash: the threat is a disk, a copy or an
//! editor, not an adversary, and a CRC-32 detects every error burst of up to 32 bits, so
//! every change of one byte (or of four consecutive bytes) is detected with certainty, not
//! with high probability. It is computed with carry-less multiplication where the processor
//! has it (`crc32fast`, several GB/s rather than a table's few hundred MB/s): a run of 200
//! contacts holds 4.8 GB of chains, and a fit checks them at every reading.

use std::fs::File;
use std::io::Read;
use std::path::Path;

use serde::{Deserialize, Serialize};

use super::StorageError;

/// A running CRC-32 (IEEE 802.3, as zlib and `cksum -a crc32b` compute it).
#[derive(Debug, Clone)]
pub(crate) struct Crc32(crc32fast::Hasher);

impl Crc32 {
    pub(crate) fn new() -> Self {
        Self(crc32fast::Hasher::new())
    }

    pub(crate) fn update(&mut self, bytes: &[u8]) {
        self.0.update(bytes);
    }

    pub(crate) fn value(self) -> u32 {
        self.0.finalize()
    }
}

/// The CRC-32 of `bytes`.
pub(crate) fn crc32(bytes: &[u8]) -> u32 {
    let mut c = Crc32::new();
    c.update(bytes);
    c.value()
}

/// A file's length and CRC-32, as a checkpoint records each complete part.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub(crate) struct Seal {
    pub(crate) bytes: u64,
    pub(crate) crc32: u32,
}

impl Seal {
    /// The seal of the file at `path`, read in blocks.
    pub(crate) fn of_file(path: &Path) -> Result<Self, StorageError> {
        let mut file = File::open(path).map_err(|e| StorageError::io("open", path, e))?;
        let mut crc = Crc32::new();
        let mut bytes = 0u64;
        let mut buffer = vec![0u8; 1 << 16];
        loop {
            let n = file
                .read(&mut buffer)
                .map_err(|e| StorageError::io("read", path, e))?;
            if n == 0 {
                break;
            }
            crc.update(&buffer[..n]);
            bytes += n as u64;
        }
        Ok(Self {
            bytes,
            crc32: crc.value(),
        })
    }
}

/// The end of a sealed binary file: the CRC-32 of everything before it (little-endian), then
/// this marker.
const TRAILER_MARK: &[u8; 8] = b"SBCRC32\n";
const TRAILER_LEN: usize = 4 + TRAILER_MARK.len();

/// `body` followed by its trailer.
pub(crate) fn seal_bytes(mut body: Vec<u8>) -> Vec<u8> {
    let crc = crc32(&body);
    body.extend_from_slice(&crc.to_le_bytes());
    body.extend_from_slice(TRAILER_MARK);
    body
}

/// What the end of a file says of its integrity.
#[derive(Debug, PartialEq, Eq)]
pub(crate) enum Unsealed<'a> {
    /// The file carries a seal and matches it: here is its body.
    Verified(&'a [u8]),
    /// The file carries no seal (written by an earlier release, or its seal is destroyed).
    Absent(&'a [u8]),
    /// The file carries a seal it does not match: it was changed after it was written.
    Mismatch {
        /// The checksum recorded.
        recorded: u32,
        /// The checksum of the body found.
        found: u32,
    },
}

/// Splits a sealed binary file into its verified body.
pub(crate) fn unseal_bytes(bytes: &[u8]) -> Unsealed<'_> {
    let Some(body_len) = bytes.len().checked_sub(TRAILER_LEN) else {
        return Unsealed::Absent(bytes);
    };
    if &bytes[body_len + 4..] != TRAILER_MARK {
        return Unsealed::Absent(bytes);
    }
    let body = &bytes[..body_len];
    let mut recorded = [0u8; 4];
    recorded.copy_from_slice(&bytes[body_len..body_len + 4]);
    let recorded = u32::from_le_bytes(recorded);
    let found = crc32(body);
    if recorded == found {
        Unsealed::Verified(body)
    } else {
        Unsealed::Mismatch { recorded, found }
    }
}

/// The key of the checksum a sealed JSON object ends with.
pub const JSON_CHECKSUM_KEY: &str = "checksum";
const JSON_SEAL_OPEN: &str = ",\n  \"checksum\": \"crc32:";
const JSON_SEAL_CLOSE: &str = "\"\n}\n";

/// A JSON object (pretty-printed or on one line) with a last key
/// `"checksum": "crc32:XXXXXXXX"`, the CRC-32 of the text before that key. The file stays
/// ordinary JSON for every other reader.
///
/// # Panics
/// When `json` is not a non-empty JSON object (a bug of the caller).
pub fn seal_json(json: &[u8]) -> Vec<u8> {
    let text = json.strip_suffix(b"\n").unwrap_or(json);
    let body = text.strip_suffix(b"}").expect("a non-empty JSON object");
    let body = body.strip_suffix(b"\n").unwrap_or(body);
    let mut sealed = body.to_vec();
    sealed.extend_from_slice(JSON_SEAL_OPEN.as_bytes());
    sealed.extend_from_slice(format!("{:08x}", crc32(body)).as_bytes());
    sealed.extend_from_slice(JSON_SEAL_CLOSE.as_bytes());
    sealed
}

/// What the end of a JSON file written by [`seal_json`] says of its integrity.
pub(crate) fn unseal_json(text: &str) -> Unsealed<'_> {
    let absent = Unsealed::Absent(text.as_bytes());
    let Some(rest) = text.strip_suffix(JSON_SEAL_CLOSE) else {
        return absent;
    };
    let Some(open) = rest.rfind(JSON_SEAL_OPEN) else {
        return absent;
    };
    let hex = &rest[open + JSON_SEAL_OPEN.len()..];
    let body = &text.as_bytes()[..open];
    let found = crc32(body);
    // A destroyed hex field is a mismatch, not an absent seal: the marker around it stands.
    let recorded = if hex.len() == 8 && hex.bytes().all(|b| b.is_ascii_hexdigit()) {
        u32::from_str_radix(hex, 16).ok()
    } else {
        None
    };
    match recorded {
        Some(recorded) if recorded == found => Unsealed::Verified(body),
        Some(recorded) => Unsealed::Mismatch { recorded, found },
        None => Unsealed::Mismatch {
            recorded: !found,
            found,
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crc32_matches_the_standard_check_value() {
        // The check value of CRC-32/ISO-HDLC ("123456789"), as zlib computes it.
        assert_eq!(crc32(b"123456789"), 0xCBF4_3926);
        assert_eq!(crc32(b""), 0);
    }

    #[test]
    fn a_sealed_body_round_trips_and_every_byte_flip_is_caught() {
        let sealed = seal_bytes(b"the body of a checkpoint".to_vec());
        assert_eq!(
            unseal_bytes(&sealed),
            Unsealed::Verified(b"the body of a checkpoint")
        );
        for i in 0..sealed.len() {
            for mask in [0x01u8, 0x80, 0xff] {
                let mut bad = sealed.clone();
                bad[i] ^= mask;
                assert!(
                    !matches!(unseal_bytes(&bad), Unsealed::Verified(_)),
                    "byte {i} ^ {mask:#x}"
                );
            }
        }
    }

    #[test]
    fn sealed_json_is_json_and_every_flip_is_caught_or_harmless() {
        let json = serde_json::to_vec_pretty(&serde_json::json!({"a": 1.5, "b": [1, 2]})).unwrap();
        let sealed = seal_json(&json);
        let text = std::str::from_utf8(&sealed).unwrap();
        let value: serde_json::Value = serde_json::from_str(text).unwrap();
        assert_eq!(value["a"], 1.5);
        assert!(value[JSON_CHECKSUM_KEY]
            .as_str()
            .unwrap()
            .starts_with("crc32:"));
        assert!(matches!(unseal_json(text), Unsealed::Verified(_)));
        for i in 0..sealed.len() {
            let mut bad = sealed.clone();
            bad[i] ^= 0x01;
            let Ok(bad) = std::str::from_utf8(&bad) else {
                continue;
            };
            // Absent is acceptable only where the marker itself was hit (the caller refuses an
            // absent seal when the checkpoint says the run seals its summary).
            match unseal_json(bad) {
                Unsealed::Verified(_) => panic!("flip of byte {i} verified"),
                Unsealed::Absent(_) => assert!(i >= json.len() - 2, "flip of byte {i}"),
                Unsealed::Mismatch { .. } => {}
            }
        }
    }
}

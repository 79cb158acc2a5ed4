//! What a chain part says about itself: key–value metadata in its Parquet footer, readable by
//! any Parquet reader (`pyarrow.parquet.read_schema(part).metadata`, polars'
//! `read_parquet_metadata`) without slipbayes.
//!
//! Every part carries, under keys starting with `slipbayes.`: the format of this metadata,
//! the row layout and which index is a chain for which diagnostic, each column's kind, unit
//! and scale, the steps the part holds, and, when the writer was told them, the seed,
//! ensembles, walkers and thinning. The burn-in is known only when a run has finished (its
//! summary decides it), after every part is written: [`ParquetSink::finish`] then rewrites
//! each part's footer with it (a copy of the part with the new footer, renamed over it, so a
//! kill leaves either footer, never a broken part). Until then `slipbayes.burn_in` says
//! `pending`.
//!
//! [`ParquetSink::finish`]: super::ParquetSink::finish

use std::fs::{self, File, OpenOptions};
use std::io::{Seek, SeekFrom, Write};
use std::path::Path;

use crate::data::parquet_footer::{read_footer, FooterError};
use polars_parquet::write::{KeyValue, ThriftFileMetadata};
use polars_parquet_format::thrift::protocol::TCompactOutputProtocol;
use serde::{Deserialize, Serialize};

pub use crate::density::ColumnUnit;

use super::{StorageError, ENSEMBLE_COLUMN, LOG_DENSITY_COLUMN, STEP_COLUMN, WALKER_COLUMN};

/// Version of the key–value metadata of a part; changes when a key changes meaning.
pub const METADATA_FORMAT: &str = "slipbayes-chain-part/1";

/// Prefix of every key slipbayes writes.
const PREFIX: &str = "slipbayes.";

/// How the rows are laid out and which index is a chain for which diagnostic, in words.
pub const LAYOUT: &str = "one row per recorded step, ensemble and walker, in that order \
     (columns `step`, `ensemble`, `walker`); for R-hat a chain is one ensemble (its walkers \
     pooled: walkers of one ensemble move together, ensembles are independent), for ESS a \
     chain is one walker of one ensemble; rows with step < burn_in are burn-in, the rest are \
     the kept draws";

/// What a column holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ColumnKind {
    /// `step`: the sampler's step (a sweep over every block), from 0.
    Step,
    /// `ensemble` or `walker`: which chain the row belongs to.
    Index,
    /// A sampled coordinate.
    Parameter,
    /// `log_density`: ln of the unnormalised density of the sampled coordinates.
    LogDensity,
    /// A value the density derives from each draw.
    Derived,
}

/// One column as the metadata describes it.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct ColumnInfo {
    /// Column name.
    pub name: String,
    /// What it holds.
    pub kind: ColumnKind,
    /// SI unit of the quantity (`1` dimensionless); empty when the writer did not declare it.
    pub unit: String,
    /// Whether the column holds the natural logarithm of the quantity in `unit` (a sampled
    /// coordinate u = ln θ, the log-density) rather than the quantity itself.
    pub log: bool,
}

/// What the writer of a chain store knows about the run, for the parts' metadata
/// ([`ParquetSink::describe`](super::ParquetSink::describe)).
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct ChainDescription {
    /// Seed of every random stream of the run.
    pub seed: u64,
    /// Independent ensembles.
    pub ensembles: usize,
    /// Walkers per ensemble.
    pub walkers: usize,
    /// Steps between recorded rows (1: every step is recorded).
    pub thin: u64,
    /// Units of the parameter columns, in their order (empty: not declared).
    pub param_units: Vec<ColumnUnit>,
    /// Units of the derived columns, in their order (empty: not declared).
    pub derived_units: Vec<ColumnUnit>,
}

/// The metadata of one part, as read back by [`read_part_metadata`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ChainMetadata {
    /// [`METADATA_FORMAT`] of the writer.
    pub format: String,
    /// The row layout in words ([`LAYOUT`]).
    pub layout: String,
    /// Every column in file order, with its kind, unit and scale.
    pub columns: Vec<ColumnInfo>,
    /// Steps held by this part: `first..end`.
    pub steps: std::ops::Range<u64>,
    /// Seed, when described.
    pub seed: Option<u64>,
    /// Ensembles, when described.
    pub ensembles: Option<usize>,
    /// Walkers per ensemble, when described.
    pub walkers: Option<usize>,
    /// Steps between recorded rows, when described.
    pub thin: Option<u64>,
    /// First kept step (rows with a smaller step are burn-in); `None` until the run has
    /// finished.
    pub burn_in: Option<u64>,
}

impl ChainMetadata {
    /// The column called `name`.
    pub fn column(&self, name: &str) -> Option<&ColumnInfo> {
        self.columns.iter().find(|c| c.name == name)
    }

    /// Whether rows of `step` are kept draws: `None` while the burn-in is not known.
    pub fn is_kept(&self, step: u64) -> Option<bool> {
        self.burn_in.map(|b| step >= b)
    }
}

/// The columns of a chain table with their kinds and units; `description` may leave the units
/// out (then they are empty).
pub(super) fn column_infos(
    param_names: &[String],
    derived_names: &[String],
    description: Option<&ChainDescription>,
) -> Vec<ColumnInfo> {
    let info = |name: &str, kind, unit: &str, log| ColumnInfo {
        name: name.to_owned(),
        kind,
        unit: unit.to_owned(),
        log,
    };
    let declared = |units: Option<&Vec<ColumnUnit>>, i: usize| {
        units.and_then(|u| u.get(i)).cloned().unwrap_or_default()
    };
    let mut columns = vec![
        info(ENSEMBLE_COLUMN, ColumnKind::Index, "1", false),
        info(WALKER_COLUMN, ColumnKind::Index, "1", false),
        info(STEP_COLUMN, ColumnKind::Step, "1", false),
    ];
    for (i, name) in param_names.iter().enumerate() {
        let u = declared(description.map(|d| &d.param_units), i);
        columns.push(info(name, ColumnKind::Parameter, &u.unit, u.log));
    }
    columns.push(info(LOG_DENSITY_COLUMN, ColumnKind::LogDensity, "1", true));
    for (i, name) in derived_names.iter().enumerate() {
        let u = declared(description.map(|d| &d.derived_units), i);
        columns.push(info(name, ColumnKind::Derived, &u.unit, u.log));
    }
    columns
}

/// The key–value pairs of a part holding `steps`.
pub(super) fn key_values(
    columns: &[ColumnInfo],
    description: Option<&ChainDescription>,
    steps: std::ops::Range<u64>,
    burn_in: Option<u64>,
) -> Vec<KeyValue> {
    let mut pairs = vec![
        ("format", METADATA_FORMAT.to_owned()),
        ("layout", LAYOUT.to_owned()),
        ("rhat_chain", ENSEMBLE_COLUMN.to_owned()),
        ("ess_chain", format!("{ENSEMBLE_COLUMN},{WALKER_COLUMN}")),
        (
            "columns",
            serde_json::to_string(columns).unwrap_or_else(|_| "[]".to_owned()),
        ),
        ("steps", format!("{}..{}", steps.start, steps.end)),
        (
            "burn_in",
            burn_in.map_or_else(|| "pending".to_owned(), |b| b.to_string()),
        ),
    ];
    if let Some(d) = description {
        pairs.extend([
            ("seed", d.seed.to_string()),
            ("ensembles", d.ensembles.to_string()),
            ("walkers", d.walkers.to_string()),
            ("thin", d.thin.to_string()),
        ]);
    }
    pairs
        .into_iter()
        .map(|(key, value)| KeyValue {
            key: format!("{PREFIX}{key}"),
            value: Some(value),
        })
        .collect()
}

/// Reads the slipbayes metadata of the part at `path`; `None` for a part written before parts
/// carried it.
///
/// # Errors
/// [`StorageError::Io`] or [`StorageError::Parquet`] when the footer cannot be read;
/// [`StorageError::Parquet`] when a slipbayes key holds a value that does not parse.
pub fn read_part_metadata(path: &Path) -> Result<Option<ChainMetadata>, StorageError> {
    let footer = Footer::read(path)?;
    let pairs = footer.metadata.key_value_metadata.unwrap_or_default();
    let get = |key: &str| {
        pairs
            .iter()
            .find(|kv| kv.key.strip_prefix(PREFIX) == Some(key))
            .and_then(|kv| kv.value.clone())
    };
    let Some(format) = get("format") else {
        return Ok(None);
    };
    let bad = |key: &str, value: &str| {
        StorageError::parquet(
            path,
            format!("metadata `{PREFIX}{key}` = {value:?} is unreadable"),
        )
    };
    let number = |key: &str| -> Result<Option<u64>, StorageError> {
        get(key)
            .map(|v| v.parse::<u64>().map_err(|_| bad(key, &v)))
            .transpose()
    };
    let count =
        |key: &str| -> Result<Option<usize>, StorageError> { Ok(number(key)?.map(|v| v as usize)) };
    let columns_text = get("columns").unwrap_or_default();
    let columns: Vec<ColumnInfo> =
        serde_json::from_str(&columns_text).map_err(|_| bad("columns", &columns_text))?;
    let steps_text = get("steps").unwrap_or_default();
    let steps = steps_text
        .split_once("..")
        .and_then(|(a, b)| Some(a.parse::<u64>().ok()?..b.parse::<u64>().ok()?))
        .ok_or_else(|| bad("steps", &steps_text))?;
    let burn_in = match get("burn_in") {
        Some(v) if v == "pending" => None,
        Some(v) => Some(v.parse::<u64>().map_err(|_| bad("burn_in", &v))?),
        None => None,
    };
    Ok(Some(ChainMetadata {
        format,
        layout: get("layout").unwrap_or_default(),
        columns,
        steps,
        seed: number("seed")?,
        ensembles: count("ensembles")?,
        walkers: count("walkers")?,
        thin: number("thin")?,
        burn_in,
    }))
}

/// Writes to `scratch` the complete part `path` with the slipbayes keys of its footer replaced
/// by `pairs` (other keys, such as the Arrow schema, stay): the part is copied, the copy cut
/// where its footer starts, given the new footer and made durable. The caller renames it over
/// the part (once the checkpoint accepts both versions); a kill leaves at most `scratch`,
/// which the caller treats as a leftover.
///
/// # Errors
/// [`StorageError::Io`] or [`StorageError::Parquet`] naming the part.
pub(super) fn rewrite_footer(
    path: &Path,
    scratch: &Path,
    pairs: Vec<KeyValue>,
) -> Result<(), StorageError> {
    let footer = Footer::read(path)?;
    let mut metadata = footer.metadata;
    let mut kept: Vec<KeyValue> = metadata
        .key_value_metadata
        .take()
        .unwrap_or_default()
        .into_iter()
        .filter(|kv| !kv.key.starts_with(PREFIX))
        .collect();
    kept.extend(pairs);
    metadata.key_value_metadata = Some(kept);
    let mut bytes = Vec::new();
    let written = metadata
        .write_to_out_protocol(&mut TCompactOutputProtocol::new(&mut bytes))
        .map_err(|e| StorageError::parquet(path, e))?;
    let length = i32::try_from(written)
        .map_err(|_| StorageError::parquet(path, "footer metadata larger than 2 GiB"))?;
    bytes.extend_from_slice(&length.to_le_bytes());
    bytes.extend_from_slice(MAGIC);

    let copied = (|| {
        fs::copy(path, scratch).map_err(|e| StorageError::io("copy", path, e))?;
        let mut copy = OpenOptions::new()
            .write(true)
            .open(scratch)
            .map_err(|e| StorageError::io("open", scratch, e))?;
        copy.set_len(footer.start)
            .and_then(|()| copy.seek(SeekFrom::End(0)))
            .and_then(|_| copy.write_all(&bytes))
            .and_then(|()| copy.sync_all())
            .map_err(|e| StorageError::io("write", scratch, e))
    })();
    if copied.is_err() {
        // A failed copy (a full disk) must not keep holding a part's worth of space; the part
        // itself is untouched.
        let _ = fs::remove_file(scratch);
    }
    copied
}

/// The closing bytes of a Parquet file.
const MAGIC: &[u8; 4] = b"PAR1";

/// A part's footer: where its metadata starts, and the metadata itself.
struct Footer {
    start: u64,
    metadata: ThriftFileMetadata,
}

impl Footer {
    fn read(path: &Path) -> Result<Self, StorageError> {
        let mut file = File::open(path).map_err(|e| StorageError::io("open", path, e))?;
        let (start, metadata, _) = read_footer(&mut file).map_err(|e| match e {
            FooterError::Io(e) => StorageError::io("read", path, e),
            FooterError::Invalid(problem) => StorageError::parquet(path, problem),
        })?;
        Ok(Self { start, metadata })
    }
}

//! Reading the chains of a run directory back: whole ([`read_chains`]) or one column at a
//! time ([`ChainReader`]).

use std::fs::File;
use std::io::{Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, MutexGuard};

use polars_arrow::array::{Array, PrimitiveArray};
use polars_arrow::datatypes::{ArrowDataType, ArrowSchema, Field};
use polars_arrow::types::NativeType;
use polars_parquet::read::{
    column_iter_to_arrays, infer_schema, read_metadata, BasicDecompressor, FileMetadata, PageReader,
};
use polars_utils::mmap::{MemReader, MemSlice};

use super::metadata::{read_part_metadata, ChainMetadata};
use super::sink::{checkpointed, list_parts};
use super::verify::{verify_run, Integrity};
use super::{
    ChainFiles, StorageError, ENSEMBLE_COLUMN, LOG_DENSITY_COLUMN, STEP_COLUMN, WALKER_COLUMN,
};

/// The chains of a run, in memory, row by row in file order (step, then ensemble, then walker).
#[derive(Debug, Clone, PartialEq)]
pub struct Chains {
    /// The directory the parts were read from.
    pub dir: PathBuf,
    /// Names of the parameter columns, in file order.
    pub param_names: Vec<String>,
    /// Names of the derived columns, in file order.
    pub derived_names: Vec<String>,
    /// Ensemble of each row.
    pub ensemble: Vec<u32>,
    /// Walker of each row, within its ensemble.
    pub walker: Vec<u32>,
    /// Step of each row.
    pub step: Vec<u64>,
    /// Value columns: the parameters, then the log-density, then the derived values (the order
    /// of [`Chains::column_names`]).
    pub columns: Vec<Vec<f64>>,
}

impl Chains {
    /// Number of rows.
    pub fn len(&self) -> usize {
        self.step.len()
    }

    /// Whether there are no rows.
    pub fn is_empty(&self) -> bool {
        self.step.is_empty()
    }

    /// Names of [`Chains::columns`]: parameters, `log_density`, derived values.
    pub fn column_names(&self) -> Vec<&str> {
        self.param_names
            .iter()
            .map(String::as_str)
            .chain(std::iter::once(LOG_DENSITY_COLUMN))
            .chain(self.derived_names.iter().map(String::as_str))
            .collect()
    }

    /// The value column called `name` (a parameter, `log_density` or a derived value).
    ///
    /// # Errors
    /// [`StorageError::ColumnMissing`] when there is no such column.
    pub fn column(&self, name: &str) -> Result<&[f64], StorageError> {
        let index = self
            .column_names()
            .iter()
            .position(|&n| n == name)
            .ok_or_else(|| StorageError::ColumnMissing {
                column: name.to_owned(),
                path: self.dir.clone(),
            })?;
        Ok(&self.columns[index])
    }

    /// The log-density column.
    pub fn log_density(&self) -> &[f64] {
        &self.columns[self.param_names.len()]
    }

    /// Number of ensembles (one past the largest ensemble index).
    pub fn n_ensembles(&self) -> usize {
        self.ensemble.iter().max().map_or(0, |&e| e as usize + 1)
    }

    /// Number of walkers per ensemble (one past the largest walker index).
    pub fn n_walkers(&self) -> usize {
        self.walker.iter().max().map_or(0, |&w| w as usize + 1)
    }

    /// The column `name` split into chains: `series[ensemble][walker]` holds that walker's
    /// values in step order, the layout the diagnostics take. Chains are as long as the steps
    /// recorded for them (all equal for a run written by one sampler).
    ///
    /// # Errors
    /// [`StorageError::ColumnMissing`] when there is no such column;
    /// [`StorageError::Inconsistent`] when a walker's steps are not strictly increasing.
    pub fn series(&self, name: &str) -> Result<Vec<Vec<Vec<f64>>>, StorageError> {
        let values = self.column(name)?;
        let (ne, nw) = (self.n_ensembles(), self.n_walkers());
        let mut series = vec![vec![Vec::new(); nw]; ne];
        let mut last_step: Vec<Vec<Option<u64>>> = vec![vec![None; nw]; ne];
        for (i, &x) in values.iter().enumerate() {
            let (e, w) = (self.ensemble[i] as usize, self.walker[i] as usize);
            let step = self.step[i];
            if last_step[e][w].is_some_and(|last| last >= step) {
                return Err(StorageError::Inconsistent {
                    dir: self.dir.clone(),
                    problem: format!(
                        "walker {w} of ensemble {e} has step {step} after step {}",
                        last_step[e][w].unwrap_or_default()
                    ),
                });
            }
            last_step[e][w] = Some(step);
            series[e][w].push(x);
        }
        Ok(series)
    }
}

/// Reads every complete part in the chains directory `chains_dir` (in part order) into
/// memory. Parts written after the last checkpoint of a killed run are complete files and are
/// included; `.partial` files never are. For a finished run, [`ChainReader`] reads the same
/// values one column at a time instead.
///
/// # Errors
/// [`StorageError::NoChains`] when there is no part; [`StorageError::Inconsistent`] when a part
/// number is missing; [`StorageError::ColumnMissing`] or [`StorageError::SchemaMismatch`] when
/// a part lacks an index or log-density column or differs from the first part;
/// [`StorageError::Parquet`] or [`StorageError::Io`] when a part cannot be read.
pub fn read_chains(chains_dir: &Path) -> Result<Chains, StorageError> {
    chains_of(chains_dir, PartSet::open(chains_dir, None)?)
}

/// Reads the parts of the store `files` that its checkpoint counts, as
/// [`ChainReader::open_at_checkpoint`] opens them: what a reader of a run that a fit may be
/// writing reads.
///
/// # Errors
/// As [`read_chains`] and [`ChainReader::open_at_checkpoint`].
pub fn read_chains_at_checkpoint(files: &ChainFiles) -> Result<Chains, StorageError> {
    chains_of(&files.chains, PartSet::open_at_checkpoint(files)?)
}

fn chains_of(chains_dir: &Path, store: PartSet) -> Result<Chains, StorageError> {
    let mut chains = Chains {
        dir: chains_dir.to_path_buf(),
        columns: Vec::new(),
        param_names: store.param_names.clone(),
        derived_names: store.derived_names.clone(),
        ensemble: Vec::new(),
        walker: Vec::new(),
        step: Vec::new(),
    };
    for part in &store.parts {
        chains.ensemble.extend(part.column::<u32>(ENSEMBLE_COLUMN)?);
        chains.walker.extend(part.column::<u32>(WALKER_COLUMN)?);
        chains.step.extend(part.column::<u64>(STEP_COLUMN)?);
    }
    let names: Vec<String> = chains
        .column_names()
        .into_iter()
        .map(str::to_owned)
        .collect();
    chains.columns = names
        .iter()
        .map(|name| store.column(name, 0))
        .collect::<Result<_, _>>()?;
    Ok(chains)
}

/// The complete parts of a chains directory with their footers, checked to share one schema.
#[derive(Debug, Clone)]
struct PartSet {
    parts: Vec<Part>,
    param_names: Vec<String>,
    derived_names: Vec<String>,
}

/// Times a reader starts again when the run it reads is replaced under it.
const READ_ATTEMPTS: usize = 3;

impl PartSet {
    /// The parts of `files` that its checkpoint counts (all parts when there is no checkpoint,
    /// as in a store copied without it). Each part is opened once and read through that
    /// handle, so that a part replaced or removed afterwards (its footer rewritten when the
    /// run finishes, the run replaced with `--overwrite`) is still read whole as it was.
    /// When the parts the checkpoint counts are gone or differ from it, because the run was
    /// replaced between reading the checkpoint and opening them, it starts again from the
    /// new checkpoint.
    fn open_at_checkpoint(files: &ChainFiles) -> Result<Self, StorageError> {
        let mut attempt = 0;
        loop {
            attempt += 1;
            let counted = checkpointed(files)?;
            let opened =
                Self::open(&files.chains, counted.map(|(parts, _)| parts)).and_then(|set| {
                    match counted {
                        Some((_, rows)) if set.rows() as u64 != rows => {
                            Err(StorageError::Inconsistent {
                                dir: files.dir.clone(),
                                problem: format!(
                                    "{} counts {rows} rows, its parts hold {}",
                                    files.checkpoint.display(),
                                    set.rows()
                                ),
                            })
                        }
                        _ => Ok(set),
                    }
                });
            match opened {
                Err(_) if attempt < READ_ATTEMPTS && checkpointed(files)? != counted => {}
                other => return other,
            }
        }
    }

    /// Rows in all parts.
    fn rows(&self) -> usize {
        self.parts.iter().map(Part::rows).sum()
    }

    /// The complete parts of `chains_dir`, the first `count` only when given (the others may
    /// be beyond the checkpoint).
    fn open(chains_dir: &Path, count: Option<u64>) -> Result<Self, StorageError> {
        let mut listed = list_parts(chains_dir)?;
        if let Some(count) = count {
            listed.retain(|&(index, _)| index < count);
            if listed.len() as u64 != count {
                return Err(StorageError::Inconsistent {
                    dir: chains_dir.to_path_buf(),
                    problem: format!(
                        "the checkpoint counts {count} parts, {} are there (a fit replacing \
                         the run removes them: read it again once it has written its first \
                         checkpoint)",
                        listed.len()
                    ),
                });
            }
        }
        if listed.is_empty() {
            return Err(StorageError::NoChains {
                dir: chains_dir.to_path_buf(),
            });
        }
        if let Some((expected, (found, _))) = listed
            .iter()
            .enumerate()
            .find(|(i, (index, _))| *i as u64 != *index)
        {
            return Err(StorageError::Inconsistent {
                dir: chains_dir.to_path_buf(),
                problem: format!(
                    "{} is missing (found part {found} next)",
                    super::part_name(expected as u64)
                ),
            });
        }
        let mut parts = Vec::with_capacity(listed.len());
        let mut names = None;
        for (_, path) in listed {
            let part = Part::open(path)?;
            let (params, derived) = match &names {
                Some(n) => n,
                None => names.insert(split_names(&part.path, &part.schema)?),
            };
            check_schema(&part.path, &part.schema, &chains_schema(params, derived))?;
            parts.push(part);
        }
        let (param_names, derived_names) = names.unwrap_or_default();
        Ok(Self {
            parts,
            param_names,
            derived_names,
        })
    }

    /// The f64 column `name` from row `first_row` (counted over all parts) to the end.
    fn column(&self, name: &str, first_row: usize) -> Result<Vec<f64>, StorageError> {
        let total: usize = self.parts.iter().map(Part::rows).sum();
        let mut values = Vec::with_capacity(total.saturating_sub(first_row));
        let mut start = 0;
        for part in &self.parts {
            let end = start + part.rows();
            if end > first_row {
                let column = part.column::<f64>(name)?;
                values.extend_from_slice(&column[first_row.saturating_sub(start)..]);
            }
            start = end;
        }
        Ok(values)
    }

    /// Calls `visit(first, chunks)` for every row group holding rows from `first_row` on, in
    /// row order: `chunks[k]` holds the rows `first..first + len` of column `names[k]`
    /// (row groups wholly before `first_row` are not read, and the rows before it are cut
    /// off). Memory holds one row group of these columns at a time.
    fn for_each_chunk<E: From<StorageError>>(
        &self,
        names: &[&str],
        first_row: usize,
        visit: &mut Visit<'_, E>,
    ) -> Result<(), E> {
        let mut start = 0;
        for part in &self.parts {
            if start + part.rows() <= first_row {
                start += part.rows();
                continue;
            }
            let mut file = part.open_file()?;
            for g in 0..part.metadata.row_groups.len() {
                let rows = part.metadata.row_groups[g].num_rows();
                let end = start + rows;
                if end > first_row {
                    let skip = first_row.saturating_sub(start);
                    let mut chunks = Vec::with_capacity(names.len());
                    for name in names {
                        let mut values = part.group_column::<f64>(&mut file, name, g)?;
                        values.drain(..skip);
                        chunks.push(values);
                    }
                    visit(start + skip, &chunks)?;
                }
                start = end;
            }
        }
        Ok(())
    }
}

/// What [`PartSet::for_each_chunk`] calls per row group: (first row, the columns' chunks).
type Visit<'a, E> = dyn FnMut(usize, &[Vec<f64>]) -> Result<(), E> + 'a;

/// One complete part: its path, footer and schema. Columns are read from the file one at a
/// time, so that reading one column never holds the others in memory.
#[derive(Debug, Clone)]
pub(super) struct Part {
    path: PathBuf,
    /// The file as opened with its footer, whatever replaces the path later.
    file: Arc<Mutex<File>>,
    metadata: FileMetadata,
    pub(super) schema: ArrowSchema,
}

impl Part {
    /// Reads the footer of the part at `path`.
    pub(super) fn open(path: PathBuf) -> Result<Self, StorageError> {
        let mut file = File::open(&path).map_err(|e| StorageError::io("open", &path, e))?;
        crate::data::parquet_footer::check_footer(&mut file)
            .map_err(|problem| StorageError::parquet(&path, problem))?;
        let size = file
            .metadata()
            .map_err(|e| StorageError::io("inspect", &path, e))?
            .len();
        let metadata = read_metadata(&mut file).map_err(|e| StorageError::parquet(&path, e))?;
        let schema = infer_schema(&metadata).map_err(|e| StorageError::parquet(&path, e))?;
        // A damaged footer may claim anything: its counts and byte ranges are checked here,
        // once, so that reading never indexes or allocates by an unchecked number.
        let grouped: usize = metadata.row_groups.iter().map(|g| g.num_rows()).sum();
        if grouped != metadata.num_rows {
            return Err(StorageError::parquet(
                &path,
                format!(
                    "the footer counts {} rows but its row groups {grouped}",
                    metadata.num_rows
                ),
            ));
        }
        for (g, group) in metadata.row_groups.iter().enumerate() {
            for range in group.byte_ranges_iter() {
                if range.start > range.end || range.end > size {
                    return Err(StorageError::parquet(
                        &path,
                        format!(
                            "row group {g} places a column at bytes {}..{} of a file of {size}",
                            range.start, range.end
                        ),
                    ));
                }
            }
        }
        Ok(Self {
            path,
            file: Arc::new(Mutex::new(file)),
            metadata,
            schema,
        })
    }

    /// Rows in the part.
    pub(super) fn rows(&self) -> usize {
        self.metadata.num_rows
    }

    /// Steps held by the part, `first..last + 1` (rows are in step order); empty for a part
    /// without rows.
    pub(super) fn step_range(&self) -> Result<std::ops::Range<u64>, StorageError> {
        let steps = self.column::<u64>(STEP_COLUMN)?;
        Ok(match (steps.first(), steps.last()) {
            (Some(&first), Some(&last)) => first..last.saturating_add(1),
            _ => 0..0,
        })
    }

    fn open_file(&self) -> Result<MutexGuard<'_, File>, StorageError> {
        // A reader that panicked mid-read leaves nothing to repair: every read seeks first.
        Ok(self
            .file
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner()))
    }

    /// The column `name`, read row group by row group from the file, as values of `T`
    /// without nulls.
    fn column<T: NativeType>(&self, name: &str) -> Result<Vec<T>, StorageError> {
        let mut file = self.open_file()?;
        let mut values = Vec::with_capacity(self.rows());
        for g in 0..self.metadata.row_groups.len() {
            values.extend_from_slice(&self.group_column::<T>(&mut file, name, g)?);
        }
        Ok(values)
    }

    /// Row group `g` of the column `name`, as values of `T` without nulls.
    fn group_column<T: NativeType>(
        &self,
        file: &mut File,
        name: &str,
        g: usize,
    ) -> Result<Vec<T>, StorageError> {
        let path = &self.path;
        let missing = || StorageError::ColumnMissing {
            column: name.to_owned(),
            path: path.clone(),
        };
        let field = self.schema.get(name).ok_or_else(missing)?;
        let group = &self.metadata.row_groups[g];
        let (pages, types): (Vec<_>, Vec<_>) = group
            .columns_under_root_iter(name)
            .ok_or_else(missing)?
            .map(|chunk| {
                let range = chunk.byte_range();
                let mut bytes = vec![0; (range.end - range.start) as usize];
                file.seek(SeekFrom::Start(range.start))
                    .and_then(|_| file.read_exact(&mut bytes))
                    .map_err(|e| StorageError::io("read", path, e))?;
                let pages = PageReader::new(
                    MemReader::new(MemSlice::from_vec(bytes)),
                    chunk,
                    vec![],
                    usize::MAX,
                );
                Ok((
                    BasicDecompressor::new(pages, vec![]),
                    &chunk.descriptor().descriptor.primitive_type,
                ))
            })
            .collect::<Result<Vec<_>, StorageError>>()?
            .into_iter()
            .unzip();
        let array = column_iter_to_arrays(pages, types, field.clone(), None)
            .map_err(|e| StorageError::parquet(path, e))?;
        let typed = array
            .as_any()
            .downcast_ref::<PrimitiveArray<T>>()
            .ok_or_else(|| StorageError::parquet(path, "column of unexpected type"))?;
        if typed.null_count() > 0 {
            return Err(StorageError::parquet(path, "column holds nulls"));
        }
        if typed.len() != group.num_rows() {
            return Err(StorageError::parquet(
                path,
                format!(
                    "row group {g} of column {name:?} holds {} values, its footer says {}",
                    typed.len(),
                    group.num_rows()
                ),
            ));
        }
        Ok(typed.values().to_vec())
    }
}

/// The chains of a complete run, read one column ([`ChainReader::column`]) or one row group
/// of a few columns ([`ChainReader::for_each_chunk`], [`ChainReader::rows_of`]) at a time:
/// summaries and reports use the latter, so that their memory is one row group, never a
/// whole column.
///
/// Opening checks that the rows form the grid a sampler writes (every step from 0, in each
/// step every ensemble, in each ensemble every walker, in that order), so a row number alone
/// says which step, ensemble and walker it holds.
#[derive(Debug, Clone)]
pub struct ChainReader {
    dir: PathBuf,
    store: PartSet,
    integrity: Integrity,
    ensembles: usize,
    walkers: usize,
    steps: u64,
}

impl ChainReader {
    /// Opens the chains directory `chains_dir`, reading the footers and index columns only.
    ///
    /// # Errors
    /// As [`read_chains`], and [`StorageError::Inconsistent`] naming the part and row when the
    /// rows are not a complete grid of steps × ensembles × walkers.
    pub fn open(chains_dir: &Path) -> Result<Self, StorageError> {
        Self::of(chains_dir, PartSet::open(chains_dir, None)?)
    }

    /// Opens the parts of the store `files` that its checkpoint counts, never one written
    /// after it: a consistent run while a fit writes it (the last checkpoint's chains),
    /// and, once it finished, the whole run. Readers take no lock: they neither wait for the
    /// fit nor hold it up. Without a checkpoint (a store copied without it), every part.
    ///
    /// # Errors
    /// As [`ChainReader::open`]; [`StorageError::BadCheckpoint`] for an unreadable checkpoint;
    /// [`StorageError::Inconsistent`] when the parts do not match the checkpoint, even after
    /// reading again a run replaced while it was read.
    pub fn open_at_checkpoint(files: &ChainFiles) -> Result<Self, StorageError> {
        Self::of(&files.chains, PartSet::open_at_checkpoint(files)?)
    }

    fn of(chains_dir: &Path, store: PartSet) -> Result<Self, StorageError> {
        let inconsistent = |problem: String| StorageError::Inconsistent {
            dir: chains_dir.to_path_buf(),
            problem,
        };
        let index = |part: &Part| -> Result<Vec<(u64, usize, usize)>, StorageError> {
            let ensemble = part.column::<u32>(ENSEMBLE_COLUMN)?;
            let walker = part.column::<u32>(WALKER_COLUMN)?;
            let step = part.column::<u64>(STEP_COLUMN)?;
            Ok((0..step.len())
                .map(|i| (step[i], ensemble[i] as usize, walker[i] as usize))
                .collect())
        };
        // The shape from step 0, whose rows open the first part; then every row is checked
        // against it (a first part cut inside step 0 fails that check).
        let first = index(&store.parts[0])?;
        let step0: Vec<(usize, usize)> = first
            .iter()
            .take_while(|r| r.0 == 0)
            .map(|r| (r.1, r.2))
            .collect();
        let (ensembles, walkers) = grid_of(&step0).ok_or_else(|| {
            inconsistent(
                "the rows of step 0 are not every walker of every ensemble in order".into(),
            )
        })?;
        let mut row = 0usize;
        let mut read = Some(first);
        for part in &store.parts {
            let rows = match read.take() {
                Some(rows) => rows,
                None => index(part)?,
            };
            for (i, found) in rows.into_iter().enumerate() {
                let expected = (
                    (row / (ensembles * walkers)) as u64,
                    (row / walkers) % ensembles,
                    row % walkers,
                );
                if found != expected {
                    return Err(inconsistent(format!(
                        "row {i} of {} holds step {}, ensemble {}, walker {} where step {}, ensemble {}, walker {} was expected",
                        part.path.display(),
                        found.0, found.1, found.2, expected.0, expected.1, expected.2
                    )));
                }
                row += 1;
            }
        }
        if row % (ensembles * walkers) != 0 {
            return Err(inconsistent(format!(
                "{row} rows are not whole steps of {ensembles} ensembles × {walkers} walkers"
            )));
        }
        Ok(Self {
            dir: chains_dir.to_path_buf(),
            steps: (row / (ensembles * walkers)) as u64,
            store,
            ensembles,
            walkers,
            integrity: Integrity::Unverified {
                reason: format!("{} was opened without its checkpoint", chains_dir.display()),
            },
        })
    }

    /// Opens the chains of the store `files` after checking them against its checkpoint
    /// ([`verify_run`]); [`ChainReader::integrity`] says whether they were proved intact.
    ///
    /// # Errors
    /// As [`verify_run`] and [`ChainReader::open`].
    pub fn open_run(files: &ChainFiles) -> Result<Self, StorageError> {
        let integrity = verify_run(files)?;
        let mut reader = Self::open_at_checkpoint(files)?;
        reader.integrity = integrity;
        Ok(reader)
    }

    /// Whether the chains were proved to be the ones written ([`ChainReader::open_run`]).
    pub fn integrity(&self) -> &Integrity {
        &self.integrity
    }

    /// The directory the parts are read from.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// Names of the parameter columns, in file order.
    pub fn param_names(&self) -> &[String] {
        &self.store.param_names
    }

    /// Names of the derived columns, in file order.
    pub fn derived_names(&self) -> &[String] {
        &self.store.derived_names
    }

    /// Number of ensembles.
    pub fn ensembles(&self) -> usize {
        self.ensembles
    }

    /// Walkers per ensemble.
    pub fn walkers(&self) -> usize {
        self.walkers
    }

    /// Steps recorded.
    pub fn steps(&self) -> u64 {
        self.steps
    }

    /// The metadata every part carries in its footer (layout, columns with units, seed,
    /// burn-in: see [`mod@super::metadata`]), for the whole store: the first part's, with the
    /// steps of all parts. `None` when a part was written without it (by an older version).
    ///
    /// # Errors
    /// [`StorageError::Io`] or [`StorageError::Parquet`] when a footer cannot be read or
    /// holds unreadable metadata; [`StorageError::Inconsistent`] when the parts disagree on
    /// the burn-in.
    pub fn metadata(&self) -> Result<Option<ChainMetadata>, StorageError> {
        let mut whole: Option<ChainMetadata> = None;
        for part in &self.store.parts {
            let Some(m) = read_part_metadata(&part.path)? else {
                return Ok(None);
            };
            match &mut whole {
                None => whole = Some(m),
                Some(w) if w.burn_in != m.burn_in => {
                    return Err(StorageError::Inconsistent {
                        dir: self.dir.clone(),
                        problem: format!(
                            "{} records burn-in {:?}, an earlier part {:?}",
                            part.path.display(),
                            m.burn_in,
                            w.burn_in
                        ),
                    })
                }
                Some(w) => w.steps.end = m.steps.end,
            }
        }
        Ok(whole)
    }

    /// Number of rows (steps × ensembles × walkers).
    pub fn rows(&self) -> usize {
        self.steps as usize * self.ensembles * self.walkers
    }

    /// The row holding walker `w` of ensemble `e` at `step`.
    pub fn row(&self, step: u64, e: usize, w: usize) -> usize {
        (step as usize * self.ensembles + e) * self.walkers + w
    }

    /// Step, ensemble and walker of `row`.
    pub fn locate(&self, row: usize) -> (u64, usize, usize) {
        let per_step = self.ensembles * self.walkers;
        (
            (row / per_step) as u64,
            (row / self.walkers) % self.ensembles,
            row % self.walkers,
        )
    }

    /// The value column `name` (a parameter, `log_density` or a derived value), every row.
    ///
    /// # Errors
    /// [`StorageError::ColumnMissing`] when there is no such column; [`StorageError::Parquet`]
    /// or [`StorageError::Io`] when a part cannot be read.
    pub fn column(&self, name: &str) -> Result<Vec<f64>, StorageError> {
        self.column_from(name, 0)
    }

    /// The rows of column `name` from `first_step` on, in row order; parts wholly before it
    /// are not read.
    ///
    /// # Errors
    /// As [`ChainReader::column`].
    pub fn column_from(&self, name: &str, first_step: u64) -> Result<Vec<f64>, StorageError> {
        self.store
            .column(name, self.row(first_step.min(self.steps), 0, 0))
    }

    /// The column `name` split into chains: `series[ensemble][walker]` holds that walker's
    /// values in step order.
    ///
    /// # Errors
    /// As [`ChainReader::column`].
    pub fn series(&self, name: &str) -> Result<Vec<Vec<Vec<f64>>>, StorageError> {
        let values = self.column(name)?;
        Ok((0..self.ensembles)
            .map(|e| {
                (0..self.walkers)
                    .map(|w| (0..self.steps).map(|s| values[self.row(s, e, w)]).collect())
                    .collect()
            })
            .collect())
    }

    /// Reads the columns `names` from `first_step` on, one row group at a time, calling
    /// `visit(first_row, chunks)` for each in row order: `chunks[k]` holds column `names[k]`
    /// at rows `first_row..first_row + chunks[k].len()` (rows counted from the start of the
    /// chains). Memory holds one row group of these columns, whatever the length of the run:
    /// what summaries of long runs use.
    ///
    /// # Errors
    /// As [`ChainReader::column`], and whatever `visit` returns.
    pub fn for_each_chunk<E: From<StorageError>>(
        &self,
        names: &[&str],
        first_step: u64,
        mut visit: impl FnMut(usize, &[Vec<f64>]) -> Result<(), E>,
    ) -> Result<(), E> {
        self.store.for_each_chunk(
            names,
            self.row(first_step.min(self.steps), 0, 0),
            &mut visit,
        )
    }

    /// The values of column `name` at `rows` (ascending row numbers, as [`ChainReader::row`]
    /// gives), read one row group at a time: memory holds one row group and the values
    /// asked for, never the whole column.
    ///
    /// # Errors
    /// As [`ChainReader::column`]; [`StorageError::Inconsistent`] when `rows` is not
    /// ascending or reaches past the last row.
    pub fn rows_of(&self, name: &str, rows: &[usize]) -> Result<Vec<f64>, StorageError> {
        let bad = |problem: String| StorageError::Inconsistent {
            dir: self.dir.clone(),
            problem,
        };
        if rows.windows(2).any(|w| w[0] >= w[1]) {
            return Err(bad(format!(
                "rows of column {name:?} asked for out of order"
            )));
        }
        if let Some(&last) = rows.last().filter(|&&r| r >= self.rows()) {
            return Err(bad(format!(
                "row {last} of column {name:?} asked for, but the chains hold {} rows",
                self.rows()
            )));
        }
        let mut values = Vec::with_capacity(rows.len());
        let Some(&first) = rows.first() else {
            return Ok(values);
        };
        let mut next = 0;
        self.store
            .for_each_chunk::<StorageError>(&[name], first, &mut |start, chunks| {
                let chunk = &chunks[0];
                while next < rows.len() && rows[next] < start + chunk.len() {
                    values.push(chunk[rows[next] - start]);
                    next += 1;
                }
                Ok(())
            })?;
        Ok(values)
    }
}

/// Ensembles and walkers of step 0's rows when they are (0, 0), (0, 1), …, (E−1, W−1).
fn grid_of(first_step: &[(usize, usize)]) -> Option<(usize, usize)> {
    let walkers = first_step.iter().take_while(|&&(e, _)| e == 0).count();
    if walkers == 0 || first_step.len() % walkers != 0 {
        return None;
    }
    let ensembles = first_step.len() / walkers;
    let in_order = first_step
        .iter()
        .enumerate()
        .all(|(i, &(e, w))| e == i / walkers && w == i % walkers);
    in_order.then_some((ensembles, walkers))
}

/// The schema every part of a run with these names has.
pub(super) fn chains_schema(param_names: &[String], derived_names: &[String]) -> ArrowSchema {
    let field = |name: &str, dtype| Field::new(name.into(), dtype, false);
    let mut fields = vec![
        field(ENSEMBLE_COLUMN, ArrowDataType::UInt32),
        field(WALKER_COLUMN, ArrowDataType::UInt32),
        field(STEP_COLUMN, ArrowDataType::UInt64),
    ];
    fields.extend(param_names.iter().map(|n| field(n, ArrowDataType::Float64)));
    fields.push(field(LOG_DENSITY_COLUMN, ArrowDataType::Float64));
    fields.extend(
        derived_names
            .iter()
            .map(|n| field(n, ArrowDataType::Float64)),
    );
    fields.into_iter().collect()
}

/// Checks column names and types (not nullability, which readers may widen).
pub(super) fn check_schema(
    path: &Path,
    found: &ArrowSchema,
    expected: &ArrowSchema,
) -> Result<(), StorageError> {
    let same = found.len() == expected.len()
        && found
            .iter_values()
            .zip(expected.iter_values())
            .all(|(f, e)| f.name == e.name && f.dtype == e.dtype);
    if same {
        Ok(())
    } else {
        Err(StorageError::SchemaMismatch {
            path: path.to_path_buf(),
            expected: describe(expected),
            found: describe(found),
        })
    }
}

fn describe(schema: &ArrowSchema) -> Vec<String> {
    schema
        .iter_values()
        .map(|f| format!("{}: {:?}", f.name, f.dtype))
        .collect()
}

/// Parameter and derived names of a part: the f64 columns before and after `log_density`.
fn split_names(
    path: &Path,
    schema: &ArrowSchema,
) -> Result<(Vec<String>, Vec<String>), StorageError> {
    for required in [
        ENSEMBLE_COLUMN,
        WALKER_COLUMN,
        STEP_COLUMN,
        LOG_DENSITY_COLUMN,
    ] {
        if schema.get(required).is_none() {
            return Err(StorageError::ColumnMissing {
                column: required.to_owned(),
                path: path.to_path_buf(),
            });
        }
    }
    let names: Vec<String> = schema
        .iter_values()
        .map(|f| f.name.to_string())
        .filter(|n| ![ENSEMBLE_COLUMN, WALKER_COLUMN, STEP_COLUMN].contains(&n.as_str()))
        .collect();
    let split = names
        .iter()
        .position(|n| n == LOG_DENSITY_COLUMN)
        .unwrap_or(names.len());
    let derived = names.get(split + 1..).unwrap_or_default().to_vec();
    let mut params = names;
    params.truncate(split);
    Ok((params, derived))
}

//! Reading the chains of a run directory back into memory.

use std::fs::{self, File};
use std::path::{Path, PathBuf};

use polars_arrow::array::{Array, PrimitiveArray};
use polars_arrow::datatypes::{ArrowDataType, ArrowSchema, Field};
use polars_arrow::types::NativeType;
use polars_parquet::read::{
    column_iter_to_arrays, infer_schema, read_metadata, BasicDecompressor, PageReader,
};
use polars_utils::mmap::{MemReader, MemSlice};

use super::sink::list_parts;
use super::{StorageError, ENSEMBLE_COLUMN, LOG_DENSITY_COLUMN, STEP_COLUMN, WALKER_COLUMN};

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
/// memory. Parts written after the last checkpoint of a killed run are complete files and are included; `.partial` files
/// never are.
///
/// # Errors
/// [`StorageError::NoChains`] when there is no part; [`StorageError::Inconsistent`] when a part
/// number is missing; [`StorageError::ColumnMissing`] or [`StorageError::SchemaMismatch`] when
/// a part lacks an index or log-density column or differs from the first part;
/// [`StorageError::Parquet`] or [`StorageError::Io`] when a part cannot be read.
pub fn read_chains(chains_dir: &Path) -> Result<Chains, StorageError> {
    let parts = list_parts(chains_dir)?;
    if parts.is_empty() {
        return Err(StorageError::NoChains {
            dir: chains_dir.to_path_buf(),
        });
    }
    if let Some((expected, (found, _))) = parts
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

    let mut chains: Option<(ArrowSchema, Chains)> = None;
    for (_, path) in &parts {
        let (schema, columns) = read_part(path)?;
        let chains = match &mut chains {
            Some((expected, chains)) => {
                check_schema(path, &schema, expected)?;
                chains
            }
            None => {
                let (params, derived) = split_names(path, &schema)?;
                let expected = chains_schema(&params, &derived);
                check_schema(path, &schema, &expected)?;
                let empty = Chains {
                    dir: chains_dir.to_path_buf(),
                    columns: vec![Vec::new(); params.len() + 1 + derived.len()],
                    param_names: params,
                    derived_names: derived,
                    ensemble: Vec::new(),
                    walker: Vec::new(),
                    step: Vec::new(),
                };
                &mut chains.insert((expected, empty)).1
            }
        };
        let mut columns = columns.into_iter();
        let mut next = || columns.next().unwrap_or_default();
        chains.ensemble.extend(as_values::<u32>(path, next())?);
        chains.walker.extend(as_values::<u32>(path, next())?);
        chains.step.extend(as_values::<u64>(path, next())?);
        for column in &mut chains.columns {
            column.extend(as_values::<f64>(path, next())?);
        }
    }
    chains
        .map(|(_, c)| c)
        .ok_or_else(|| StorageError::NoChains {
            dir: chains_dir.to_path_buf(),
        })
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

/// The Arrow schema and row count of a part, from its footer only.
pub(super) fn read_part_footer(path: &Path) -> Result<(ArrowSchema, u64), StorageError> {
    let mut file = File::open(path).map_err(|e| StorageError::io("open", path, e))?;
    let metadata = read_metadata(&mut file).map_err(|e| StorageError::parquet(path, e))?;
    let schema = infer_schema(&metadata).map_err(|e| StorageError::parquet(path, e))?;
    Ok((schema, metadata.num_rows as u64))
}

/// One column of a part: one array per row group.
type ColumnArrays = Vec<Box<dyn Array>>;

/// Reads a whole part: its schema and each column as row-group arrays.
fn read_part(path: &Path) -> Result<(ArrowSchema, Vec<ColumnArrays>), StorageError> {
    let bytes = fs::read(path).map_err(|e| StorageError::io("read", path, e))?;
    let data = MemSlice::from_vec(bytes);
    let metadata = read_metadata(&mut MemReader::new(data.clone()))
        .map_err(|e| StorageError::parquet(path, e))?;
    let schema = infer_schema(&metadata).map_err(|e| StorageError::parquet(path, e))?;
    let mut columns: Vec<ColumnArrays> = vec![Vec::new(); schema.len()];
    for group in &metadata.row_groups {
        for (field, arrays) in schema.iter_values().zip(&mut columns) {
            let chunks = group.columns_under_root_iter(&field.name).ok_or_else(|| {
                StorageError::ColumnMissing {
                    column: field.name.to_string(),
                    path: path.to_path_buf(),
                }
            })?;
            let (pages, types): (Vec<_>, Vec<_>) = chunks
                .map(|chunk| {
                    let range = chunk.byte_range();
                    let slice = data.slice(range.start as usize..range.end as usize);
                    let pages = PageReader::new(MemReader::new(slice), chunk, vec![], usize::MAX);
                    (
                        BasicDecompressor::new(pages, vec![]),
                        &chunk.descriptor().descriptor.primitive_type,
                    )
                })
                .unzip();
            let array = column_iter_to_arrays(pages, types, field.clone(), None)
                .map_err(|e| StorageError::parquet(path, e))?;
            arrays.push(array);
        }
    }
    Ok((schema, columns))
}

/// The values of a column read as row-group arrays of `T` without nulls.
fn as_values<T: NativeType>(path: &Path, arrays: ColumnArrays) -> Result<Vec<T>, StorageError> {
    let mut values = Vec::with_capacity(arrays.iter().map(|a| a.len()).sum());
    for array in &arrays {
        let typed = array
            .as_any()
            .downcast_ref::<PrimitiveArray<T>>()
            .ok_or_else(|| StorageError::parquet(path, "column of unexpected type"))?;
        if typed.null_count() > 0 {
            return Err(StorageError::parquet(path, "column holds nulls"));
        }
        values.extend_from_slice(typed.values());
    }
    Ok(values)
}

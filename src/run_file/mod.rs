//! Run files (`models/*.toml`): the one file a user writes to fit a model, parsed once here,
//! at the edge, into what each layer reads:
//!
//! - the model specification ([`ModelSpec`]): materials, contacts, runs, levels, the law,
//!   pooling, priors, the likelihood of long runs; with each run's import settings (its data
//!   file, format, columns, units, intervals), which the model reads when it loads the data;
//! - the sampler settings ([`SamplerSpec`], the `[sampler]` table), from which the fit's
//!   settings are made (`fit::FitSettings::for_model`) and the block settings the posterior is
//!   built with ([`RunFile::blocking`]).
//!
//! The model's schema lets the `[sampler]` table through unread; the sampler settings are
//! read from the same text, so that an error anywhere in the file names its line and key as
//! one parse would. [`RunFile::keys`] lists every table and key of the schema.
//!
//! A module of its own rather than part of `fit`: a run file is read without the chain
//! storage `fit` needs (feature `parquet`), e.g. to build a posterior and evaluate it.

mod keys;
mod sampler;

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

pub use keys::SchemaKey;
pub use sampler::SamplerSpec;

use crate::model::{BlockSettings, ModelFile, ModelSpec, Posterior, PosteriorError, SpecError};
use crate::IoError;

/// A run file, validated: the model and how to sample it.
#[derive(Debug, Clone)]
pub struct RunFile {
    /// What is fitted, to which data, with which priors.
    pub model: ModelSpec,
    /// How it is sampled: the `[sampler]` table.
    pub sampler: SamplerSpec,
}

/// The `[sampler]` table of a run file, the rest of the file left to the model's schema.
#[derive(Deserialize)]
struct SamplerTable {
    #[serde(default)]
    sampler: SamplerSpec,
}

/// The whole file as a run directory records it (`model.toml`).
#[derive(Serialize)]
struct Written<'a> {
    #[serde(flatten)]
    model: &'a ModelFile,
    sampler: &'a SamplerSpec,
}

impl RunFile {
    /// Reads and validates a run file; its data paths are relative to its directory.
    ///
    /// # Errors
    /// [`SpecError`] naming the file, the key (and for a TOML error the line) and what to fix.
    pub fn load(path: &Path) -> Result<Self, SpecError> {
        let text = std::fs::read_to_string(path).map_err(IoError::at("read", path))?;
        Self::parse(&text, path)
    }

    /// Parses and validates the text of a run file; data paths are relative to `path`'s
    /// directory.
    ///
    /// # Errors
    /// As [`RunFile::load`].
    pub fn parse(text: &str, path: &Path) -> Result<Self, SpecError> {
        let base_dir = path
            .parent()
            .map(Path::to_path_buf)
            .unwrap_or_else(|| PathBuf::from("."));
        Self::parse_in(text, base_dir, path.to_owned())
    }

    /// Parses and validates the text of a run file named `source` in messages, its data paths
    /// relative to `base_dir` (a run directory's `model.toml`, whose data paths are relative
    /// to the directory its record names).
    ///
    /// # Errors
    /// [`SpecError::Syntax`] for a file that does not parse or fit the schema,
    /// [`SpecError::Invalid`] for an invalid value.
    pub fn parse_in(text: &str, base_dir: PathBuf, source: PathBuf) -> Result<Self, SpecError> {
        let syntax = |e: toml::de::Error| SpecError::Syntax {
            path: source.clone(),
            message: e.to_string(),
        };
        let file: ModelFile = toml::from_str(text).map_err(syntax)?;
        let SamplerTable { sampler } = toml::from_str(text).map_err(syntax)?;
        Self::new(file, sampler, base_dir, source)
    }

    /// Validates a run file given as values (the Python package builds them from a dict);
    /// `source` names it in messages, data paths are relative to `base_dir`.
    ///
    /// # Errors
    /// [`SpecError::Invalid`] naming the key.
    pub fn new(
        file: ModelFile,
        sampler: SamplerSpec,
        base_dir: PathBuf,
        source: PathBuf,
    ) -> Result<Self, SpecError> {
        let model = ModelSpec::validate(file, base_dir, source)?;
        sampler
            .check()
            .map_err(|(key, message)| SpecError::Invalid {
                path: model.source.clone(),
                key,
                message,
            })?;
        Ok(Self { model, sampler })
    }

    /// `model` sampled with the default settings (the command line's quick path).
    pub fn with_default_sampler(model: ModelSpec) -> Self {
        Self {
            model,
            sampler: SamplerSpec::default(),
        }
    }

    /// How the posterior's blocks are grouped and its populations updated.
    pub fn blocking(&self) -> BlockSettings {
        self.sampler.blocking()
    }

    /// The posterior of the model over its data, loaded as each run says, with the file's
    /// block settings.
    ///
    /// # Errors
    /// As [`Posterior::new`].
    pub fn posterior(&self) -> Result<Posterior, PosteriorError> {
        Posterior::new(&self.model, self.blocking())
    }

    /// The file as a run directory records it: every table, the sampler's defaults written
    /// out, so that fitting it again needs nothing else.
    ///
    /// # Errors
    /// A value TOML cannot hold (it cannot happen for a validated file).
    pub fn to_toml(&self) -> Result<String, toml::ser::Error> {
        toml::to_string_pretty(&Written {
            model: &self.model.file,
            sampler: &self.sampler,
        })
    }

    /// Every table and key a run file may hold, with the kind of value each takes, in the
    /// order of the schema: what a guide to the file documents.
    pub fn keys() -> Vec<SchemaKey> {
        keys::run_file_keys()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn repo(path: &str) -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join(path)
    }

    /// What a run directory records of a run file is the file with every default written
    /// out, as the committed demo's `model.toml` holds it (below its header).
    #[test]
    fn the_recorded_run_file_is_the_demos() {
        let run = RunFile::load(&repo("models/demo.toml")).unwrap();
        let recorded = std::fs::read_to_string(repo("reports/demo/model.toml")).unwrap();
        let (_, body) = recorded.split_once('\n').unwrap();
        assert_eq!(run.to_toml().unwrap(), body);
        let again = RunFile::parse_in(body, run.model.base_dir.clone(), "model.toml".into());
        assert_eq!(again.unwrap().sampler, run.sampler);
    }

    /// An error in the `[sampler]` table names its line and key as in the model's tables; the
    /// model's own checks come first.
    #[test]
    fn sampler_errors_name_the_line_and_key() {
        let head = "[[material]]\nname = \"m\"\n[[contact]]\nname = \"c\"\nmaterial = \"m\"\n\
                    [[run]]\nname = \"r\"\ncontact = \"c\"\ndata = \"r.csv\"\n\
                    velocity_m_per_s = 1e-9\nscene = \"first\"\n";
        let path = Path::new("model.toml");
        let e = RunFile::parse(&format!("{head}[sampler]\nwalkerz = 4\n"), path).unwrap_err();
        let text = e.to_string();
        assert!(matches!(e, SpecError::Syntax { .. }), "{text}");
        assert!(
            text.contains("line 13") && text.contains("walkerz"),
            "{text}"
        );
        let e = RunFile::parse(&format!("{head}[sampler]\nensembles = 0\n"), path).unwrap_err();
        assert!(e.to_string().contains("sampler.ensembles"), "{e}");
        let e = RunFile::parse(&format!("{head}[sampler]\nblocks = \"run\"\n"), path).unwrap_err();
        assert!(e.to_string().contains("line 13"), "{e}");
        let plan = RunFile::parse(
            &format!("{head}[sampler]\nblocks = \"material\"\npopulations = \"exact\"\n"),
            path,
        )
        .unwrap()
        .blocking();
        assert_eq!(
            plan,
            BlockSettings {
                blocks: crate::model::Blocking::Material,
                populations: crate::model::PopulationUpdates::Exact,
            }
        );
        let e = RunFile::parse(&format!("velocity = 1\n{head}"), path).unwrap_err();
        assert!(e.to_string().contains("unknown field `velocity`"), "{e}");
    }
}

//! The checks of a model file, one function per concern, in the order a file is read:
//! names, contacts, runs (with their data files' import settings), repeat slides, priors,
//! the law's own keys, pooling, the likelihood, and settings no forward model would read.
//! Each finding names the key at fault and says what to write; [`ModelSpec::validate`] adds
//! the file.

use std::collections::{BTreeSet, HashSet};
use std::path::PathBuf;

use super::params::{ForwardModel, Param};
use super::priors::PRIOR_NAMES;
use super::schema::{Aging, Level, ModelFile, RunSpec, DEFAULT_LIKELIHOOD_TOLERANCE};
use super::{ModelSpec, SpecError};
use crate::data::units::{parse_unit, KNOWN_UNITS};
use crate::law::{LawKind, Scene};

/// What a check found: the key at fault (e.g. `run[2].velocity_m_per_s`) and what is wrong
/// and what to do.
type Finding = (String, String);

impl ModelSpec {
    /// Validates a model given as a value (a run file's model tables, or the quick path's
    /// model built from flags); `source` names it in messages, data paths are relative to
    /// `base_dir`.
    ///
    /// # Errors
    /// [`SpecError::Invalid`] naming the key.
    pub fn validate(
        file: ModelFile,
        base_dir: PathBuf,
        source: PathBuf,
    ) -> Result<Self, SpecError> {
        let invalid = |(key, message): Finding| SpecError::Invalid {
            path: source.clone(),
            key,
            message,
        };
        check_names(&file).map_err(invalid)?;
        let contact_material = resolve_contacts(&file).map_err(invalid)?;
        let run_contact = resolve_runs(&file).map_err(invalid)?;
        let run_follows = resolve_follows(&file, &run_contact).map_err(invalid)?;
        check_priors(&file).map_err(invalid)?;
        check_rate_state(&file).map_err(invalid)?;
        check_pooling(&file).map_err(invalid)?;
        check_likelihood(&file).map_err(invalid)?;
        let spec = Self {
            file,
            base_dir,
            source: source.clone(),
            contact_material,
            run_contact,
            run_follows,
        };
        spec.refuse_unused_settings().map_err(invalid)?;
        Ok(spec)
    }

    /// Every `[levels]`, `[pooling]` and `[priors]` key of the file, as `table.name`, with
    /// whether the model reads it under `forward`.
    fn setting_keys(&self, forward: ForwardModel) -> Vec<(String, bool)> {
        let used = self.params_in_use(forward);
        let priors = self.prior_names_in_use(forward);
        let levels = self
            .file
            .levels
            .keys()
            .map(|p| (format!("levels.{}", p.name()), used.contains(p)));
        let pooling = Param::ALL
            .into_iter()
            .filter(|&p| self.file.pooling.pools(p))
            .map(|p| (format!("pooling.{}", p.name()), used.contains(&p)));
        let prior_keys = self
            .file
            .priors
            .keys()
            .map(|n| (format!("priors.{n}"), priors.contains(n)));
        levels.chain(pooling).chain(prior_keys).collect()
    }

    /// The settings of the file that name a parameter this model does not sample but the
    /// default model (the aging–rejuvenation law through the spring) does: left over when a
    /// model file is fitted again under a rival law with one line changed, which is how rival
    /// models are meant to be compared. They are not read; a fit records them
    /// ([`ForwardModelRecord`](crate::fit::ForwardModelRecord)`::unread`) and says so.
    pub fn unread_settings(&self) -> Vec<String> {
        self.setting_keys(self.forward())
            .into_iter()
            .filter(|(_, read)| !read)
            .map(|(key, _)| key)
            .collect()
    }

    /// A prior, level or pooling that no forward model would read (a/F_d sampled in place of
    /// a, a pooled t0's own prior, a level of a parameter no scene uses): an error naming its
    /// key, since a user who wrote it expects it to act.
    fn refuse_unused_settings(&self) -> Result<(), Finding> {
        // What the default model reads, and the settings of rate-and-state's own parameters
        // (b, D_c): either are left over when a file is refitted under the other law with
        // the law line changed.
        let rate_state = ForwardModel {
            law: LawKind::RateState,
            ..ForwardModel::default()
        };
        let own_to_rate_state = |key: &str| {
            key.split_once('.')
                .is_some_and(|(_, name)| [Param::B, Param::Dc].map(Param::name).contains(&name))
        };
        let default_reads: BTreeSet<String> = self
            .setting_keys(ForwardModel::default())
            .into_iter()
            .chain(
                self.setting_keys(rate_state)
                    .into_iter()
                    .filter(|(key, _)| own_to_rate_state(key)),
            )
            .filter_map(|(key, read)| read.then_some(key))
            .collect();
        let Some((key, _)) = self
            .setting_keys(self.forward())
            .into_iter()
            .find(|(key, read)| !read && !default_reads.contains(key))
        else {
            return Ok(());
        };
        let aging = match self.file.aging {
            Aging::Ratio => "ratio",
            Aging::Absolute => "absolute",
        };
        let read: Vec<String> = self
            .prior_names_in_use(self.forward())
            .into_iter()
            .collect();
        Err((
            key,
            format!(
                "this model (law = \"{}\", elastic = {}, aging = \"{aging}\") samples no \
                 parameter this setting applies to, so it would have no effect; remove it (priors \
                 are read for {})",
                self.file.law,
                self.file.elastic,
                read.join(", ")
            ),
        ))
    }
}

/// At least one material, contact and run, each name unique and usable in a key.
fn check_names(file: &ModelFile) -> Result<(), Finding> {
    if file.materials.is_empty() || file.contacts.is_empty() || file.runs.is_empty() {
        return Err((
            "material/contact/run".into(),
            "a model needs at least one [[material]], one [[contact]] and one [[run]]".into(),
        ));
    }
    unique_names(file.materials.iter().map(|m| m.name.as_str()), "material")?;
    unique_names(file.contacts.iter().map(|c| c.name.as_str()), "contact")?;
    unique_names(file.runs.iter().map(|r| r.name.as_str()), "run")
}

/// The material of each contact, and its normal force when given.
fn resolve_contacts(file: &ModelFile) -> Result<Vec<usize>, Finding> {
    let mut contact_material = Vec::new();
    for (i, c) in file.contacts.iter().enumerate() {
        let m = file
            .materials
            .iter()
            .position(|m| m.name == c.material)
            .ok_or_else(|| {
                (
                    format!("contact[{i}].material"),
                    format!(
                        "no [[material]] named `{}`; declare it or fix the name",
                        c.material
                    ),
                )
            })?;
        if let Some(f) = c.normal_force_n {
            if !(f.is_finite() && f > 0.0) {
                return Err((
                    format!("contact[{i}].normal_force_N"),
                    format!("{f} must be a force > 0 in newtons"),
                ));
            }
        }
        contact_material.push(m);
    }
    Ok(contact_material)
}

/// The contact of each run, its velocity and window, and how its data file is read.
fn resolve_runs(file: &ModelFile) -> Result<Vec<usize>, Finding> {
    let mut run_contact = Vec::new();
    for (i, r) in file.runs.iter().enumerate() {
        let c = file
            .contacts
            .iter()
            .position(|c| c.name == r.contact)
            .ok_or_else(|| {
                (
                    format!("run[{i}].contact"),
                    format!(
                        "no [[contact]] named `{}`; declare it or fix the name",
                        r.contact
                    ),
                )
            })?;
        let v = r.velocity_m_per_s;
        if !(v.is_finite() && v > 0.0) {
            return Err((
                format!("run[{i}].velocity_m_per_s"),
                format!("{v} must be a sliding velocity > 0 in m/s (e.g. 1e-9 for 1 nm/s)"),
            ));
        }
        if let Some([a, b]) = r.window_s {
            if !(a.is_finite() && b.is_finite() && a < b) {
                return Err((
                    format!("run[{i}].window_s"),
                    format!("[{a}, {b}] must be [start, end] with start < end (s)"),
                ));
            }
        }
        check_import(r).map_err(|(k, m)| (format!("run[{i}].{k}"), m))?;
        run_contact.push(c);
    }
    Ok(run_contact)
}

/// For each repeat slide, the first slide of its contact it follows (the one named by
/// `follows`, else the contact's first); `None` for the others.
fn resolve_follows(file: &ModelFile, run_contact: &[usize]) -> Result<Vec<Option<usize>>, Finding> {
    let mut run_follows = Vec::new();
    for (i, r) in file.runs.iter().enumerate() {
        let follows = match (r.scene, &r.follows) {
            (Scene::Repeat, Some(name)) => {
                let j = file
                    .runs
                    .iter()
                    .position(|o| &o.name == name)
                    .ok_or_else(|| {
                        (
                            format!("run[{i}].follows"),
                            format!("no [[run]] named `{name}`"),
                        )
                    })?;
                if file.runs[j].scene != Scene::First || run_contact[j] != run_contact[i] {
                    return Err((
                        format!("run[{i}].follows"),
                        format!("`{name}` must be a first slide of the same contact"),
                    ));
                }
                Some(j)
            }
            (Scene::Repeat, None) => (0..file.runs.len())
                .find(|&j| file.runs[j].scene == Scene::First && run_contact[j] == run_contact[i]),
            (_, Some(_)) => {
                return Err((
                    format!("run[{i}].follows"),
                    "only a repeat slide follows another run".into(),
                ))
            }
            (_, None) => None,
        };
        run_follows.push(follows);
    }
    Ok(run_follows)
}

/// Every prior names a known quantity, is valid, and allows only positive values.
fn check_priors(file: &ModelFile) -> Result<(), Finding> {
    for (name, prior) in &file.priors {
        if !PRIOR_NAMES.contains(&name.as_str()) {
            return Err((
                format!("priors.{name}"),
                format!(
                    "unknown parameter; priors can be given for {}",
                    PRIOR_NAMES.join(", ")
                ),
            ));
        }
        prior
            .validate(name)
            .map_err(|m| (format!("priors.{name}"), m))?;
        if !prior.positive_support() {
            return Err((
                format!("priors.{name}"),
                "parameters are positive and sampled on the log scale: give a prior on θ > 0 \
                 (e.g. `low = 0` for uniform or normal)"
                    .into(),
            ));
        }
    }
    Ok(())
}

/// A pooled parameter is at the contact or run level: a material's population needs members.
fn check_pooling(file: &ModelFile) -> Result<(), Finding> {
    for p in [Param::T0, Param::FD, Param::K, Param::A] {
        let level = file.levels.get(&p).copied().unwrap_or(p.default_level());
        if file.pooling.pools(p) && level == Level::Material {
            return Err((
                format!("pooling.{}", p.name()),
                format!(
                    "{0} pooled within a material needs {0} at the contact or run level: \
                     add `{0} = \"contact\"` under [levels]",
                    p.name()
                ),
            ));
        }
    }
    Ok(())
}

/// The likelihood's tolerance is a log-likelihood error ≥ 0.
fn check_likelihood(file: &ModelFile) -> Result<(), Finding> {
    let tolerance = file.likelihood.tolerance;
    if !(tolerance.is_finite() && tolerance >= 0.0) {
        return Err((
            "likelihood.tolerance".into(),
            format!(
                "{tolerance} must be a log-likelihood error >= 0 (0: every point exactly; \
                 default {DEFAULT_LIKELIHOOD_TOLERANCE})"
            ),
        ));
    }
    Ok(())
}

/// Checks the keys of rate-and-state friction: used only under `law = "rate-state"`, which
/// needs the machine's spring (its k is the spring of the spring-slider) on every run.
fn check_rate_state(file: &ModelFile) -> Result<(), Finding> {
    let rate_state = file.law == LawKind::RateState;
    if !rate_state {
        for (key, given) in [
            ("state_law", file.state_law.is_some()),
            (
                "reference_velocity_m_per_s",
                file.reference_velocity_m_per_s.is_some(),
            ),
        ] {
            if given {
                return Err((
                    key.into(),
                    format!(
                        "only rate-and-state friction has a {key}: add `law = \"rate-state\"` \
                         or remove the key"
                    ),
                ));
            }
        }
        return Ok(());
    }
    if let Some(v) = file.reference_velocity_m_per_s {
        if !(v.is_finite() && v > 0.0) {
            return Err((
                "reference_velocity_m_per_s".into(),
                format!("{v} must be a velocity > 0 in m/s (or remove it: each run's own)"),
            ));
        }
    }
    if !file.elastic {
        return Err((
            "elastic".into(),
            "rate-and-state friction is solved on the spring-slider, whose spring is the \
             machine's stiffness k: remove `elastic = false`"
                .into(),
        ));
    }
    if let Some(i) = file.runs.iter().position(|r| r.scene == Scene::StiffFast) {
        return Err((
            format!("run[{i}].scene"),
            "under rate-and-state every slide is solved through the machine's spring: write \
             `scene = \"first\"` for a fast first slide"
                .into(),
        ));
    }
    Ok(())
}

/// Checks a run's import settings; the error names the key below `run[i]`.
fn check_import(r: &RunSpec) -> Result<(), Finding> {
    if let Some(arm) = r.moment_arm_m {
        if !(arm.is_finite() && arm > 0.0) {
            return Err((
                "moment_arm_m".into(),
                format!("{arm} must be a length > 0 in metres (e.g. 7e-3 for 7 mm)"),
            ));
        }
    }
    if r.bins.is_some() {
        return Err((
            "bins".into(),
            "means of consecutive points are no longer fitted (evaluated at the bin's mean \
             time they bias t0); remove `bins`: a run longer than `[likelihood] exact_up_to` \
             points is reduced to sufficient statistics within `likelihood_tolerance` \
             (docs/model.md §5, \"Long records\")"
                .into(),
        ));
    }
    if let Some(tolerance) = r.likelihood_tolerance {
        if !(tolerance.is_finite() && tolerance >= 0.0) {
            return Err((
                "likelihood_tolerance".into(),
                format!("{tolerance} must be a log-likelihood error >= 0 (0: every point exactly)"),
            ));
        }
    }
    if let Some(map) = &r.columns {
        let mut refs = vec![("time", &map.time), ("force", &map.force)];
        if let Some(normal) = &map.normal_force {
            refs.push(("normal_force", normal));
        }
        for (key, column) in refs {
            if column.name.trim().is_empty() {
                return Err((
                    format!("columns.{key}.name"),
                    "give the column's name as in the file's header".into(),
                ));
            }
            if let Some(unit) = &column.unit {
                if parse_unit(unit).is_none() {
                    return Err((
                        format!("columns.{key}.unit"),
                        format!("unknown unit `{unit}`; slipbayes knows {KNOWN_UNITS}"),
                    ));
                }
            }
        }
    }
    Ok(())
}

fn unique_names<'a>(names: impl Iterator<Item = &'a str>, what: &str) -> Result<(), Finding> {
    let mut seen = HashSet::new();
    for (i, n) in names.enumerate() {
        if n.trim().is_empty() || n.contains(['[', ']', ',']) {
            return Err((
                format!("{what}[{i}].name"),
                format!("`{n}` must be non-empty and free of `[`, `]` and `,`"),
            ));
        }
        if !seen.insert(n) {
            return Err((
                format!("{what}[{i}].name"),
                format!("`{n}` is used twice; {what} names must be unique"),
            ));
        }
    }
    Ok(())
}

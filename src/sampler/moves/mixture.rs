//! The moves a sampler mixes, and their written forms: a mixture as text
//! (`student-t=0.8,stretch=0.2`), a move as its [`MoveSpec`].

use std::fmt;
use std::sync::Arc;

use serde::{Deserialize, Serialize};

use super::{
    directions, DifferentialDirection, DifferentialEvolution, GaussianDirection, Independence, Kde,
    MoveSpec, ProposalMove, SliceDirection, Snooker, Stretch, Walk,
};
use crate::sampler::SamplerError;

/// A move of the sampler's mixture (see
/// [`SamplerConfig::with_moves`](crate::sampler::SamplerConfig::with_moves)): one is drawn
/// per step and ensemble.
///
/// Moves compare, serialise and show as their [`MoveSpec`]; a serialised built-in move reads
/// back, a move of one's own does not.
#[derive(Debug, Clone)]
pub enum Move {
    /// A proposal for every walker, accepted or rejected by Metropolis–Hastings.
    Proposal(Arc<dyn ProposalMove>),
    /// Ensemble slice sampling along directions from the complement: each walker settles on
    /// its new point itself, with as many evaluations as its slice needs (see
    /// [`ensemble_slice`](super::ensemble_slice)).
    Slice(Arc<dyn SliceDirection>),
}

impl Move {
    /// The Metropolis–Hastings move `mv`, built in or one's own.
    pub fn proposal(mv: impl ProposalMove + 'static) -> Self {
        Self::Proposal(Arc::new(mv))
    }

    /// The slice move along the directions `directions`.
    pub fn slice_along(directions: impl SliceDirection + 'static) -> Self {
        Self::Slice(Arc::new(directions))
    }

    /// The move called `name` (one of [`MOVE_NAMES`]) with its default parameters.
    ///
    /// # Errors
    /// A sentence listing the known names.
    pub fn named(name: &str) -> Result<Self, String> {
        match NAMED.iter().find(|(n, _)| *n == name) {
            Some((_, make)) => Ok(make()),
            None => Err(format!(
                "unknown move `{name}`; the moves are {}",
                MOVE_NAMES.join(", ")
            )),
        }
    }

    /// [`Stretch`] move with `a = 2`.
    pub fn stretch() -> Self {
        Self::proposal(Stretch::default())
    }

    /// [`DifferentialEvolution`] with emcee's defaults (`γ₀ = 2.38/√(2 ndim)`, `σ = 1e-5`).
    pub fn differential_evolution() -> Self {
        Self::proposal(DifferentialEvolution::default())
    }

    /// [`Walk`] move over the whole complement.
    pub fn walk() -> Self {
        Self::proposal(Walk::default())
    }

    /// Gaussian [`Independence`] proposal fitted to the complement.
    pub fn gaussian() -> Self {
        Self::proposal(Independence::gaussian())
    }

    /// Student-t [`Independence`] proposal with ν = 5, fitted to the complement.
    pub fn student_t() -> Self {
        Self::proposal(Independence::student_t(5.0).expect("ν = 5 is valid"))
    }

    /// DE-[`Snooker`] with emcee's `γ = 1.7`.
    pub fn snooker() -> Self {
        Self::proposal(Snooker::default())
    }

    /// [`Kde`] proposal with Scott's bandwidth.
    pub fn kde() -> Self {
        Self::proposal(Kde::default())
    }

    /// Ensemble slice sampling along differences of two complement walkers (zeus's default).
    pub fn slice() -> Self {
        Self::slice_along(DifferentialDirection)
    }

    /// Ensemble slice sampling along directions from the Gaussian fitted to the complement.
    pub fn slice_gaussian() -> Self {
        Self::slice_along(GaussianDirection)
    }

    /// The built-in move a spec records, as a sampler configuration or a fit's settings read
    /// back.
    ///
    /// # Errors
    /// [`SamplerError::InvalidMove`] for a kind that is not built in (a move of one's own is
    /// recorded, not read back) or parameters the move refuses.
    pub(crate) fn built_in(spec: &MoveSpec) -> Result<Self, SamplerError> {
        Ok(match spec.kind() {
            "stretch" => Self::proposal(Stretch::from_spec(spec)?),
            "differential_evolution" => Self::proposal(DifferentialEvolution::from_spec(spec)?),
            "walk" => Self::proposal(Walk::from_spec(spec)?),
            "independence" => Self::proposal(Independence::from_spec(spec)?),
            "snooker" => Self::proposal(Snooker::from_spec(spec)?),
            "kde" => Self::proposal(Kde::from_spec(spec)?),
            "slice" => Self::Slice(directions::from_spec(spec)?),
            other => {
                return Err(SamplerError::InvalidMove {
                    detail: format!(
                        "`{other}` is not a built-in move (stretch, differential_evolution, walk, \
                         independence, snooker, kde, slice); a move of one's own is recorded but \
                         not read back: build the configuration in the program that defines it"
                    ),
                })
            }
        })
    }

    /// How the move is recorded: its kind and parameters.
    pub fn spec(&self) -> MoveSpec {
        match self {
            Self::Proposal(m) => m.spec(),
            Self::Slice(d) => d.spec(),
        }
    }

    /// Whether this is the slice move, whose half-steps do not go through the batched
    /// propose, evaluate, accept.
    pub(crate) fn is_slice(&self) -> bool {
        matches!(self, Self::Slice(_))
    }

    /// Checks that the complement (half the ensemble) is large enough for this move in
    /// `ndim` dimensions.
    pub(crate) fn validate_complement(
        &self,
        complement: usize,
        ndim: usize,
    ) -> Result<(), SamplerError> {
        let need = match self {
            Self::Proposal(m) => m.min_complement(ndim),
            Self::Slice(d) => d.min_complement(ndim),
        };
        if complement < need {
            return Err(SamplerError::InvalidMove {
                detail: format!(
                    "{self} needs at least {need} walkers in each half, the ensemble has {complement}"
                ),
            });
        }
        Ok(())
    }
}

impl PartialEq for Move {
    /// The same kind of update with the same spec.
    fn eq(&self, other: &Self) -> bool {
        self.is_slice() == other.is_slice() && self.spec() == other.spec()
    }
}

impl fmt::Display for Move {
    /// The move's spec, e.g. `stretch(a=2)`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.spec().fmt(f)
    }
}

impl Serialize for Move {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        self.spec().serialize(s)
    }
}

impl<'de> Deserialize<'de> for Move {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let spec = MoveSpec::deserialize(d)?;
        Self::built_in(&spec).map_err(serde::de::Error::custom)
    }
}

/// A name of a written mixture and the move it stands for.
type Named = (&'static str, fn() -> Move);

/// The moves a written mixture may name, each with its default parameters.
const NAMED: [Named; 9] = [
    ("stretch", Move::stretch),
    ("de", Move::differential_evolution),
    ("walk", Move::walk),
    ("gaussian", Move::gaussian),
    ("student-t", Move::student_t),
    ("snooker", Move::snooker),
    ("kde", Move::kde),
    ("slice", Move::slice),
    ("slice-gaussian", Move::slice_gaussian),
];

/// The names of the moves in a written mixture, each with its default parameters.
pub const MOVE_NAMES: [&str; NAMED.len()] = {
    let mut names = [""; NAMED.len()];
    let mut i = 0;
    while i < NAMED.len() {
        names[i] = NAMED[i].0;
        i += 1;
    }
    names
};

/// A weighted mixture of moves with their default parameters, as a model file
/// (`[sampler] moves`) or the command line (`--moves`) writes it: `name=weight` pairs
/// separated by commas, e.g. `student-t=0.8,stretch=0.2` (names in [`MOVE_NAMES`]; a name
/// alone has weight 1). Parsed once where it is read, so a bad mixture is an error naming the
/// file, line and key.
#[derive(Debug, Clone, PartialEq)]
pub struct Mixture(Vec<(Move, f64)>);

impl Mixture {
    /// The moves and their weights.
    pub fn moves(&self) -> &[(Move, f64)] {
        &self.0
    }
}

impl std::str::FromStr for Mixture {
    type Err = String;
    fn from_str(text: &str) -> Result<Self, String> {
        parse_mixture(text).map(Self)
    }
}

impl fmt::Display for Mixture {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, (m, w)) in self.0.iter().enumerate() {
            let sep = if i == 0 { "" } else { "," };
            // Every move of a parsed mixture has its named defaults.
            match NAMED.iter().find(|(_, make)| make() == *m) {
                Some((name, _)) => write!(f, "{sep}{name}={w}")?,
                None => write!(f, "{sep}{m}={w}")?,
            }
        }
        Ok(())
    }
}

impl Serialize for Mixture {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_str(self)
    }
}

impl<'de> Deserialize<'de> for Mixture {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let text = String::deserialize(d)?;
        text.parse().map_err(serde::de::Error::custom)
    }
}

/// Parses a written mixture (see [`Mixture`]).
///
/// # Errors
/// A sentence naming the unknown move or the weight that is not a finite positive number.
fn parse_mixture(text: &str) -> Result<Vec<(Move, f64)>, String> {
    let mut moves = Vec::new();
    for part in text.split(',').map(str::trim).filter(|p| !p.is_empty()) {
        let (name, weight) = match part.split_once('=') {
            Some((n, w)) => (n.trim(), w.trim()),
            None => (part, "1"),
        };
        let weight: f64 = weight
            .parse()
            .ok()
            .filter(|w: &f64| w.is_finite() && *w > 0.0)
            .ok_or_else(|| format!("move `{name}`: weight `{weight}` is not a number > 0"))?;
        moves.push((Move::named(name)?, weight));
    }
    if moves.is_empty() {
        return Err("give at least one move, e.g. `student-t=0.8,stretch=0.2`".into());
    }
    Ok(moves)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_written_mixture_parses_and_names_what_is_wrong() {
        assert_eq!(
            parse_mixture("student-t=0.8, stretch=0.2").unwrap(),
            vec![(Move::student_t(), 0.8), (Move::stretch(), 0.2)]
        );
        assert_eq!(
            parse_mixture("de").unwrap(),
            vec![(Move::differential_evolution(), 1.0)]
        );
        let err = parse_mixture("stretch=0.5,hmc=0.5").unwrap_err();
        assert!(
            err.contains("unknown move `hmc`") && err.contains("slice-gaussian"),
            "{err}"
        );
        assert_eq!(
            parse_mixture("student-t=0.4,de=0.4,slice=0.2,slice-gaussian").unwrap()[2..],
            [(Move::slice(), 0.2), (Move::slice_gaussian(), 1.0)]
        );
        let err = parse_mixture("stretch=-1").unwrap_err();
        assert!(err.contains("weight `-1`"), "{err}");
        assert!(parse_mixture(" , ").is_err());
        // Written back as it reads.
        let m: Mixture = "student-t=0.8, stretch".parse().unwrap();
        assert_eq!(m.to_string(), "student-t=0.8,stretch=1");
        assert_eq!(m.to_string().parse::<Mixture>().unwrap(), m);
    }

    /// Every built-in move is written as the closed enum of moves wrote it, and reads back.
    #[test]
    fn every_named_move_is_written_as_before_and_reads_back() {
        let written = [
            r#"{"kind":"stretch","a":2.0}"#,
            r#"{"kind":"differential_evolution","gamma":null,"sigma":0.00001}"#,
            r#"{"kind":"walk","subset":null}"#,
            r#"{"kind":"independence","dof":null}"#,
            r#"{"kind":"independence","dof":5.0}"#,
            r#"{"kind":"snooker","gamma":1.7}"#,
            r#"{"kind":"kde","bandwidth":null}"#,
            r#"{"kind":"slice","gaussian":false}"#,
            r#"{"kind":"slice","gaussian":true}"#,
        ];
        for (name, json) in MOVE_NAMES.iter().zip(written) {
            let m = Move::named(name).unwrap();
            assert_eq!(serde_json::to_string(&m).unwrap(), json, "{name}");
            assert_eq!(serde_json::from_str::<Move>(json).unwrap(), m, "{name}");
        }
        let walk: Move = serde_json::from_str(r#"{"kind":"walk","subset":4}"#).unwrap();
        assert_eq!(walk, Move::proposal(Walk::new(Some(4)).unwrap()));
        let err = serde_json::from_str::<Move>(r#"{"kind":"stretch","a":0.5}"#).unwrap_err();
        assert!(err.to_string().contains("a = 0.5"), "{err}");
        let err = serde_json::from_str::<Move>(r#"{"kind":"hmc"}"#).unwrap_err();
        assert!(err.to_string().contains("not a built-in move"), "{err}");
        assert_ne!(Move::slice(), Move::slice_gaussian());
    }
}

//! How a move is recorded: its kind and parameters.

use std::fmt;

use serde::de::{self, MapAccess, Visitor};
use serde::ser::SerializeMap;
use serde::{Deserialize, Deserializer, Serialize, Serializer};

use crate::sampler::SamplerError;

/// A move's kind and parameters: what a checkpoint records of the moves that drew the chains
/// (a resume with other moves is refused), what a fit's `settings.json` records, and what an
/// error shows. Written as a map, `{"kind": "stretch", "a": 2.0}`; shown as `stretch(a=2)`.
///
/// Two moves with equal specs are taken to propose alike, so a move's spec holds every
/// parameter that changes its proposals.
#[derive(Debug, Clone, PartialEq)]
pub struct MoveSpec {
    kind: String,
    parameters: Vec<(String, Parameter)>,
}

/// The value of one parameter of a move.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Parameter {
    /// A real number.
    Number(f64),
    /// A count, such as a subset size.
    Count(u64),
    /// A choice between two ways.
    Flag(bool),
    /// Left to the move, which may choose from the ensemble (written `null`).
    Auto,
}

impl From<f64> for Parameter {
    fn from(v: f64) -> Self {
        Self::Number(v)
    }
}

impl From<usize> for Parameter {
    fn from(v: usize) -> Self {
        Self::Count(v as u64)
    }
}

impl From<bool> for Parameter {
    fn from(v: bool) -> Self {
        Self::Flag(v)
    }
}

impl<T: Into<Parameter>> From<Option<T>> for Parameter {
    fn from(v: Option<T>) -> Self {
        v.map_or(Self::Auto, Into::into)
    }
}

impl fmt::Display for Parameter {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Number(v) => write!(f, "{v}"),
            Self::Count(v) => write!(f, "{v}"),
            Self::Flag(v) => write!(f, "{v}"),
            Self::Auto => f.write_str("auto"),
        }
    }
}

/// The key that names the move in the written map.
const KIND: &str = "kind";

impl MoveSpec {
    /// A move of kind `kind` (lower case, words joined by `_`) without parameters yet.
    pub fn new(kind: impl Into<String>) -> Self {
        Self {
            kind: kind.into(),
            parameters: Vec::new(),
        }
    }

    /// This spec with parameter `name` of value `value` added after the others.
    ///
    /// # Panics
    /// When `name` is `kind`, the key that names the move in the written map.
    pub fn with(mut self, name: impl Into<String>, value: impl Into<Parameter>) -> Self {
        let name = name.into();
        assert!(name != KIND, "a move's parameter cannot be called `{KIND}`");
        self.parameters.push((name, value.into()));
        self
    }

    /// The kind of move.
    pub fn kind(&self) -> &str {
        &self.kind
    }

    /// The parameters, in the order the move gave them.
    pub fn parameters(&self) -> &[(String, Parameter)] {
        &self.parameters
    }

    /// The value of parameter `name`, if the spec has it.
    pub fn parameter(&self, name: &str) -> Option<Parameter> {
        self.parameters
            .iter()
            .find(|(n, _)| n == name)
            .map(|&(_, v)| v)
    }

    /// An error naming this move and what is wrong with its record.
    fn invalid(&self, what: String) -> SamplerError {
        SamplerError::InvalidMove {
            detail: format!("the record of move `{}`: {what}", self.kind),
        }
    }

    /// Checks that the spec has no parameter but `known`, so that a misspelt one is not
    /// silently left to its default.
    pub(crate) fn only(&self, known: &[&str]) -> Result<&Self, SamplerError> {
        match self.parameters.iter().find(|(n, _)| !known.contains(&&**n)) {
            Some((n, _)) => Err(self.invalid(format!(
                "unknown parameter `{n}` (it has {})",
                if known.is_empty() {
                    "none".to_string()
                } else {
                    known.join(", ")
                }
            ))),
            None => Ok(self),
        }
    }

    /// Parameter `name` as a number (a count is one too); `None` when absent or `auto`.
    pub(crate) fn number(&self, name: &str) -> Result<Option<f64>, SamplerError> {
        match self.parameter(name) {
            None | Some(Parameter::Auto) => Ok(None),
            Some(Parameter::Number(v)) => Ok(Some(v)),
            Some(Parameter::Count(v)) => Ok(Some(v as f64)),
            Some(p) => Err(self.invalid(format!("`{name}` = {p} is not a number"))),
        }
    }

    /// Parameter `name` as a count; `None` when absent or `auto`.
    pub(crate) fn count(&self, name: &str) -> Result<Option<usize>, SamplerError> {
        match self.parameter(name) {
            None | Some(Parameter::Auto) => Ok(None),
            Some(Parameter::Count(v)) => usize::try_from(v)
                .map(Some)
                .map_err(|_| self.invalid(format!("`{name}` = {v} is too large"))),
            Some(p) => Err(self.invalid(format!("`{name}` = {p} is not a count"))),
        }
    }

    /// Parameter `name` as a flag; `None` when absent or `auto`.
    pub(crate) fn flag(&self, name: &str) -> Result<Option<bool>, SamplerError> {
        match self.parameter(name) {
            None | Some(Parameter::Auto) => Ok(None),
            Some(Parameter::Flag(v)) => Ok(Some(v)),
            Some(p) => Err(self.invalid(format!("`{name}` = {p} is not true or false"))),
        }
    }

    /// Parameter `name`, which the move cannot do without.
    pub(crate) fn required<T>(
        &self,
        name: &str,
        read: impl Fn(&Self, &str) -> Result<Option<T>, SamplerError>,
    ) -> Result<T, SamplerError> {
        read(self, name)?.ok_or_else(|| self.invalid(format!("`{name}` is missing")))
    }
}

impl fmt::Display for MoveSpec {
    /// `kind(name=value, ...)`, or `kind` alone without parameters.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.kind)?;
        for (i, (name, value)) in self.parameters.iter().enumerate() {
            let open = if i == 0 { "(" } else { ", " };
            write!(f, "{open}{name}={value}")?;
        }
        if !self.parameters.is_empty() {
            f.write_str(")")?;
        }
        Ok(())
    }
}

impl Serialize for Parameter {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match *self {
            Self::Number(v) => s.serialize_f64(v),
            Self::Count(v) => s.serialize_u64(v),
            Self::Flag(v) => s.serialize_bool(v),
            Self::Auto => s.serialize_none(),
        }
    }
}

impl<'de> Deserialize<'de> for Parameter {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct Value;
        impl<'de> Visitor<'de> for Value {
            type Value = Parameter;
            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str("a number, a count, true, false or null")
            }
            fn visit_f64<E>(self, v: f64) -> Result<Parameter, E> {
                Ok(Parameter::Number(v))
            }
            fn visit_u64<E>(self, v: u64) -> Result<Parameter, E> {
                Ok(Parameter::Count(v))
            }
            fn visit_i64<E>(self, v: i64) -> Result<Parameter, E> {
                Ok(u64::try_from(v).map_or(Parameter::Number(v as f64), Parameter::Count))
            }
            fn visit_bool<E>(self, v: bool) -> Result<Parameter, E> {
                Ok(Parameter::Flag(v))
            }
            fn visit_none<E>(self) -> Result<Parameter, E> {
                Ok(Parameter::Auto)
            }
            fn visit_unit<E>(self) -> Result<Parameter, E> {
                Ok(Parameter::Auto)
            }
            fn visit_some<D: Deserializer<'de>>(self, d: D) -> Result<Parameter, D::Error> {
                Parameter::deserialize(d)
            }
        }
        d.deserialize_any(Value)
    }
}

impl Serialize for MoveSpec {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut map = s.serialize_map(Some(1 + self.parameters.len()))?;
        map.serialize_entry(KIND, &self.kind)?;
        for (name, value) in &self.parameters {
            map.serialize_entry(name, value)?;
        }
        map.end()
    }
}

impl<'de> Deserialize<'de> for MoveSpec {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct Spec;
        impl<'de> Visitor<'de> for Spec {
            type Value = MoveSpec;
            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str("a move: a map with its `kind` and parameters")
            }
            fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<MoveSpec, A::Error> {
                let mut kind = None;
                let mut parameters = Vec::new();
                while let Some(name) = map.next_key::<String>()? {
                    if name == KIND {
                        kind = Some(map.next_value::<String>()?);
                    } else {
                        parameters.push((name, map.next_value::<Parameter>()?));
                    }
                }
                let kind = kind.ok_or_else(|| de::Error::missing_field(KIND))?;
                Ok(MoveSpec { kind, parameters })
            }
        }
        d.deserialize_map(Spec)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_spec_is_written_and_read_back_as_the_moves_record_was() {
        let spec = MoveSpec::new("differential_evolution")
            .with("gamma", None::<f64>)
            .with("sigma", 1e-5);
        let json = serde_json::to_string(&spec).unwrap();
        assert_eq!(
            json,
            r#"{"kind":"differential_evolution","gamma":null,"sigma":0.00001}"#
        );
        assert_eq!(serde_json::from_str::<MoveSpec>(&json).unwrap(), spec);
        assert_eq!(
            spec.to_string(),
            "differential_evolution(gamma=auto, sigma=0.00001)"
        );
        let walk = MoveSpec::new("walk").with("subset", Some(4usize));
        let json = serde_json::to_string(&walk).unwrap();
        assert_eq!(json, r#"{"kind":"walk","subset":4}"#);
        assert_eq!(serde_json::from_str::<MoveSpec>(&json).unwrap(), walk);
        let slice: MoveSpec = serde_json::from_str(r#"{"gaussian":true,"kind":"slice"}"#).unwrap();
        assert_eq!(slice.kind(), "slice");
        assert_eq!(slice.flag("gaussian").unwrap(), Some(true));
        assert_eq!(MoveSpec::new("stretch").to_string(), "stretch");
    }

    #[test]
    fn reading_a_parameter_names_the_move_and_what_is_wrong() {
        let spec = MoveSpec::new("stretch").with("a", true);
        let err = spec.number("a").unwrap_err().to_string();
        assert!(
            err.contains("`stretch`") && err.contains("not a number"),
            "{err}"
        );
        let err = spec.only(&["scale"]).unwrap_err().to_string();
        assert!(err.contains("unknown parameter `a`"), "{err}");
        let err = MoveSpec::new("stretch")
            .required("a", MoveSpec::number)
            .unwrap_err()
            .to_string();
        assert!(err.contains("`a` is missing"), "{err}");
        assert!(serde_json::from_str::<MoveSpec>(r#"{"a":2.0}"#).is_err());
    }
}

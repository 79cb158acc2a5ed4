//! The keys of the run file's schema, read from the serde types themselves so that the list
//! cannot drift from what a file may hold: each table's type is deserialised once per key
//! from a deserializer that feeds only that key and notes what its value is asked to be.

use std::cell::RefCell;
use std::fmt;

use serde::de::{
    self, DeserializeSeed, Deserializer, IntoDeserializer, MapAccess, SeqAccess, Visitor,
};
use serde::Deserialize;

use super::SamplerSpec;
use crate::data::import::{ColumnMap, ColumnRef};
use crate::model::spec::{
    ContactSpec, LikelihoodSpec, MaterialSpec, ModelFile, PoolingSpec, RunSpec,
};

/// One key of a run file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SchemaKey {
    /// The table it belongs to: empty for the top level, `run` for each `[[run]]`,
    /// `run.columns.time` for the time column of a run's `columns`, `sampler`, …
    pub table: String,
    /// The key.
    pub key: String,
    /// What its value is, as the schema asks for it: `string`, `integer`, `number`,
    /// `boolean`, ``one of `a`, `b` ``, `table`, `array of tables`, `array of 2 × number`,
    /// `table of string to value`, each possibly `optional`.
    pub kind: String,
}

/// The tables of a run file and the types that hold them, outermost first. A table whose
/// keys are names (`levels`, `priors`) is a map and has no entry of its own.
pub(super) fn run_file_keys() -> Vec<SchemaKey> {
    let mut keys = Vec::new();
    keys_of::<ModelFile>("", &mut keys);
    keys_of::<MaterialSpec>("material", &mut keys);
    keys_of::<ContactSpec>("contact", &mut keys);
    keys_of::<RunSpec>("run", &mut keys);
    keys_of::<ColumnMap>("run.columns", &mut keys);
    for column in ["time", "force", "normal_force"] {
        keys_of::<ColumnRef>(&format!("run.columns.{column}"), &mut keys);
    }
    keys_of::<PoolingSpec>("pooling", &mut keys);
    keys_of::<SamplerSpec>("sampler", &mut keys);
    keys_of::<LikelihoodSpec>("likelihood", &mut keys);
    keys
}

/// The keys of the table `table`, held by `T`, in the order `T` declares them.
fn keys_of<'de, T: Deserialize<'de>>(table: &str, out: &mut Vec<SchemaKey>) {
    let fields = RefCell::new(Vec::new());
    // The first pass learns the keys; it feeds none.
    let _ = T::deserialize(Fields(&fields));
    for key in fields.take() {
        let kind = RefCell::new(String::new());
        let _ = T::deserialize(OneKey { key, kind: &kind });
        out.push(SchemaKey {
            table: table.to_owned(),
            key: key.to_owned(),
            kind: kind.take(),
        });
    }
}

/// Tracing stops at the first value it has described: the error that says so.
#[derive(Debug)]
struct Stop;

impl fmt::Display for Stop {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("traced")
    }
}

impl std::error::Error for Stop {}

impl de::Error for Stop {
    fn custom<M: fmt::Display>(_: M) -> Self {
        Stop
    }
}

/// Notes the keys of the struct it is asked for.
struct Fields<'a>(&'a RefCell<Vec<&'static str>>);

impl<'de> Deserializer<'de> for Fields<'_> {
    type Error = Stop;

    fn deserialize_struct<V: Visitor<'de>>(
        self,
        _name: &'static str,
        fields: &'static [&'static str],
        _visitor: V,
    ) -> Result<V::Value, Stop> {
        self.0.replace(fields.to_vec());
        Err(Stop)
    }

    fn deserialize_any<V: Visitor<'de>>(self, _visitor: V) -> Result<V::Value, Stop> {
        Err(Stop)
    }

    serde::forward_to_deserialize_any! {
        bool i8 i16 i32 i64 i128 u8 u16 u32 u64 u128 f32 f64 char str string bytes byte_buf
        option unit unit_struct newtype_struct seq tuple tuple_struct map enum identifier
        ignored_any
    }
}

/// A struct whose only key is `key`: its value is described into `kind`.
struct OneKey<'a> {
    key: &'static str,
    kind: &'a RefCell<String>,
}

impl<'de> Deserializer<'de> for OneKey<'_> {
    type Error = Stop;

    fn deserialize_struct<V: Visitor<'de>>(
        self,
        _name: &'static str,
        _fields: &'static [&'static str],
        visitor: V,
    ) -> Result<V::Value, Stop> {
        visitor.visit_map(OneEntry {
            key: Some(self.key),
            kind: self.kind,
        })
    }

    fn deserialize_any<V: Visitor<'de>>(self, _visitor: V) -> Result<V::Value, Stop> {
        Err(Stop)
    }

    serde::forward_to_deserialize_any! {
        bool i8 i16 i32 i64 i128 u8 u16 u32 u64 u128 f32 f64 char str string bytes byte_buf
        option unit unit_struct newtype_struct seq tuple tuple_struct map enum identifier
        ignored_any
    }
}

struct OneEntry<'a> {
    key: Option<&'static str>,
    kind: &'a RefCell<String>,
}

impl<'de> MapAccess<'de> for OneEntry<'_> {
    type Error = Stop;

    fn next_key_seed<K: DeserializeSeed<'de>>(
        &mut self,
        seed: K,
    ) -> Result<Option<K::Value>, Stop> {
        match self.key.take() {
            Some(key) => seed.deserialize(key.into_deserializer()).map(Some),
            None => Ok(None),
        }
    }

    fn next_value_seed<S: DeserializeSeed<'de>>(&mut self, seed: S) -> Result<S::Value, Stop> {
        seed.deserialize(Kind {
            prefix: String::new(),
            kind: self.kind,
        })
    }
}

/// Describes the value it is asked for as `prefix` and the kind, then stops.
struct Kind<'a> {
    prefix: String,
    kind: &'a RefCell<String>,
}

impl Kind<'_> {
    fn note<T>(self, kind: &str) -> Result<T, Stop> {
        self.kind.replace(format!("{}{kind}", self.prefix));
        Err(Stop)
    }

    fn within(&self, prefix: &str) -> Self {
        Kind {
            prefix: format!("{}{prefix}", self.prefix),
            kind: self.kind,
        }
    }
}

macro_rules! noting {
    ($($method:ident => $kind:literal),* $(,)?) => {
        $(
            fn $method<V: Visitor<'de>>(self, _visitor: V) -> Result<V::Value, Stop> {
                self.note($kind)
            }
        )*
    };
}

impl<'de> Deserializer<'de> for Kind<'_> {
    type Error = Stop;

    noting! {
        deserialize_bool => "boolean",
        deserialize_i8 => "integer", deserialize_i16 => "integer", deserialize_i32 => "integer",
        deserialize_i64 => "integer", deserialize_i128 => "integer",
        deserialize_u8 => "integer", deserialize_u16 => "integer", deserialize_u32 => "integer",
        deserialize_u64 => "integer", deserialize_u128 => "integer",
        deserialize_f32 => "number", deserialize_f64 => "number",
        deserialize_char => "string", deserialize_str => "string",
        deserialize_string => "string", deserialize_identifier => "string",
        deserialize_bytes => "bytes", deserialize_byte_buf => "bytes",
        deserialize_unit => "nothing",
        // A value of several shapes (a number, a list or a word), or a table read elsewhere.
        deserialize_any => "value",
        deserialize_ignored_any => "table",
    }

    fn deserialize_option<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, Stop> {
        visitor.visit_some(self.within("optional "))
    }

    fn deserialize_unit_struct<V: Visitor<'de>>(
        self,
        _name: &'static str,
        _visitor: V,
    ) -> Result<V::Value, Stop> {
        self.note("nothing")
    }

    fn deserialize_newtype_struct<V: Visitor<'de>>(
        self,
        _name: &'static str,
        visitor: V,
    ) -> Result<V::Value, Stop> {
        visitor.visit_newtype_struct(self)
    }

    fn deserialize_seq<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, Stop> {
        visitor.visit_seq(Element(self.within("array of ")))
    }

    fn deserialize_tuple<V: Visitor<'de>>(self, len: usize, visitor: V) -> Result<V::Value, Stop> {
        visitor.visit_seq(Element(self.within(&format!("array of {len} × "))))
    }

    fn deserialize_tuple_struct<V: Visitor<'de>>(
        self,
        _name: &'static str,
        len: usize,
        visitor: V,
    ) -> Result<V::Value, Stop> {
        self.deserialize_tuple(len, visitor)
    }

    fn deserialize_map<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, Stop> {
        visitor.visit_map(Entry {
            kind: self,
            key: RefCell::new(String::new()),
        })
    }

    fn deserialize_struct<V: Visitor<'de>>(
        self,
        _name: &'static str,
        _fields: &'static [&'static str],
        _visitor: V,
    ) -> Result<V::Value, Stop> {
        // An array of structs is an array of tables; its keys are listed as a table of their
        // own.
        if self.prefix.ends_with("array of ") {
            let prefix = self.prefix.trim_end_matches("array of ").to_owned();
            self.kind.replace(format!("{prefix}array of tables"));
            return Err(Stop);
        }
        self.note("table")
    }

    fn deserialize_enum<V: Visitor<'de>>(
        self,
        _name: &'static str,
        variants: &'static [&'static str],
        _visitor: V,
    ) -> Result<V::Value, Stop> {
        let names: Vec<String> = variants.iter().map(|v| format!("`{v}`")).collect();
        self.note(&format!("one of {}", names.join(", ")))
    }
}

/// The one element of an array, described with the array's prefix.
struct Element<'a>(Kind<'a>);

impl<'de> SeqAccess<'de> for Element<'_> {
    type Error = Stop;

    fn next_element_seed<T: DeserializeSeed<'de>>(
        &mut self,
        seed: T,
    ) -> Result<Option<T::Value>, Stop> {
        seed.deserialize(self.0.within("")).map(Some)
    }
}

/// The one entry of a table keyed by names: the key's kind, then the value's.
struct Entry<'a> {
    kind: Kind<'a>,
    key: RefCell<String>,
}

impl<'de> MapAccess<'de> for Entry<'_> {
    type Error = Stop;

    fn next_key_seed<K: DeserializeSeed<'de>>(
        &mut self,
        seed: K,
    ) -> Result<Option<K::Value>, Stop> {
        seed.deserialize(Key(&self.key)).map(Some)
    }

    fn next_value_seed<S: DeserializeSeed<'de>>(&mut self, seed: S) -> Result<S::Value, Stop> {
        let key = self.key.take();
        seed.deserialize(self.kind.within(&format!("table of {key} to ")))
    }
}

/// A key of a table keyed by names: notes its kind and gives a key of that kind, so that
/// the value is asked for next.
struct Key<'a>(&'a RefCell<String>);

impl<'de> Deserializer<'de> for Key<'_> {
    type Error = Stop;

    fn deserialize_enum<V: Visitor<'de>>(
        self,
        _name: &'static str,
        variants: &'static [&'static str],
        visitor: V,
    ) -> Result<V::Value, Stop> {
        let names: Vec<String> = variants.iter().map(|v| format!("`{v}`")).collect();
        self.0.replace(format!("one of {}", names.join(", ")));
        let first = variants.first().copied().ok_or(Stop)?;
        visitor.visit_enum(first.into_deserializer())
    }

    fn deserialize_any<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, Stop> {
        self.0.replace("string".to_owned());
        visitor.visit_str("name")
    }

    serde::forward_to_deserialize_any! {
        bool i8 i16 i32 i64 i128 u8 u16 u32 u64 u128 f32 f64 char str string bytes byte_buf
        option unit unit_struct newtype_struct seq tuple tuple_struct map struct identifier
        ignored_any
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn kind_of(keys: &[SchemaKey], table: &str, key: &str) -> String {
        keys.iter()
            .find(|k| k.table == table && k.key == key)
            .map(|k| k.kind.clone())
            .unwrap_or_else(|| panic!("no key {table}.{key} in {keys:?}"))
    }

    #[test]
    fn every_table_and_key_of_the_schema_is_listed_with_its_kind() {
        let keys = run_file_keys();
        assert_eq!(kind_of(&keys, "", "run"), "array of tables");
        assert_eq!(kind_of(&keys, "", "material"), "array of tables");
        assert_eq!(kind_of(&keys, "", "elastic"), "boolean");
        assert_eq!(kind_of(&keys, "", "aging"), "one of `ratio`, `absolute`");
        assert!(
            kind_of(&keys, "", "levels").starts_with("table of one of `alpha`"),
            "{keys:?}"
        );
        assert_eq!(kind_of(&keys, "run", "velocity_m_per_s"), "number");
        assert_eq!(
            kind_of(&keys, "run", "window_s"),
            "optional array of 2 × number"
        );
        assert_eq!(kind_of(&keys, "run", "columns"), "optional table");
        assert_eq!(
            kind_of(&keys, "run.columns.time", "unit"),
            "optional string"
        );
        assert_eq!(kind_of(&keys, "sampler", "walkers"), "optional integer");
        assert_eq!(
            kind_of(&keys, "sampler", "blocks"),
            "one of `material`, `contact`"
        );
        assert_eq!(kind_of(&keys, "likelihood", "exact_up_to"), "integer");
        assert_eq!(kind_of(&keys, "pooling", "F_d"), "boolean");
        // Every key whose value is a table (not a table of names) has its keys listed.
        for k in &keys {
            if k.kind.ends_with("table") || k.kind.ends_with("array of tables") {
                let inner = if k.table.is_empty() {
                    k.key.clone()
                } else {
                    format!("{}.{}", k.table, k.key)
                };
                assert!(
                    keys.iter().any(|o| o.table == inner),
                    "the keys of `{inner}` are not listed"
                );
            }
        }
        // Nothing unknown: every kind was learned from the schema.
        assert!(keys.iter().all(|k| !k.kind.is_empty()), "{keys:?}");
    }
}

//! Reads a JSON request body the way its OpenAPI schema (JSON Schema 2020-12) describes it,
//! where serde_json alone differs in both directions:
//! - serde accepts a JSON array for a struct (its fields in order), so `[null, null]` passed as
//!   a settings patch or training options; the schema says `object`, and here only an object
//!   is a struct (at any depth);
//! - JSON Schema counts `189450.0` as an integer, serde_json refuses it for integer fields; here
//!   a number with no fractional part is offered to the field as an integer (a float field
//!   takes an integer as well).
//!
//! The body is parsed into a [`serde_json::Value`] first (bodies are small: the server's body
//! limit is 64 KiB by default), then the target type is deserialised from it by [`Strict`].
//! Errors name the offending field's path (`answers[2].choice: invalid type …`).

use std::fmt;

use serde::Deserializer;
use serde::de::{
    self, DeserializeOwned, DeserializeSeed, IntoDeserializer, MapAccess, SeqAccess, Unexpected,
    Visitor,
};
use serde_json::{Map, Number, Value};

/// Parses `bytes` as JSON and deserialises `T` from it; the message names the field at fault.
pub fn from_slice<T: DeserializeOwned>(bytes: &[u8]) -> Result<T, String> {
    let value: Value = serde_json::from_slice(bytes).map_err(|e| format!("not valid JSON: {e}"))?;
    T::deserialize(Strict(&value)).map_err(|e| e.to_string())
}

/// A deserialisation failure and the path of the field it happened in.
#[derive(Debug)]
pub struct Error {
    /// Outermost first: object keys and array indices.
    path: Vec<Segment>,
    message: String,
}

#[derive(Debug)]
enum Segment {
    Key(String),
    Index(usize),
}

impl Error {
    fn inside(mut self, segment: Segment) -> Self {
        self.path.insert(0, segment);
        self
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, segment) in self.path.iter().enumerate() {
            match segment {
                Segment::Key(k) if i == 0 => write!(f, "{k}")?,
                Segment::Key(k) => write!(f, ".{k}")?,
                Segment::Index(n) => write!(f, "[{n}]")?,
            }
        }
        if !self.path.is_empty() {
            write!(f, ": ")?;
        }
        f.write_str(&self.message)
    }
}

impl std::error::Error for Error {}

impl de::Error for Error {
    fn custom<T: fmt::Display>(msg: T) -> Self {
        Self {
            path: Vec::new(),
            message: msg.to_string(),
        }
    }
}

/// A deserializer over a parsed JSON value with the schema's reading of structs and integers.
#[derive(Debug, Clone, Copy)]
pub struct Strict<'a>(pub &'a Value);

fn unexpected(v: &Value) -> Unexpected<'_> {
    match v {
        Value::Null => Unexpected::Unit,
        Value::Bool(b) => Unexpected::Bool(*b),
        Value::Number(n) => match (n.as_i64(), n.as_u64(), n.as_f64()) {
            (Some(i), _, _) => Unexpected::Signed(i),
            (_, Some(u), _) => Unexpected::Unsigned(u),
            (_, _, f) => Unexpected::Float(f.unwrap_or(f64::NAN)),
        },
        Value::String(s) => Unexpected::Str(s),
        Value::Array(_) => Unexpected::Seq,
        Value::Object(_) => Unexpected::Map,
    }
}

/// 2^63 and 2^64 as floats (exact): the ranges an integral float converts into.
const TWO_63: f64 = 9_223_372_036_854_775_808.0;
const TWO_64: f64 = 18_446_744_073_709_551_616.0;

fn visit_number<'de, V: Visitor<'de>>(n: &Number, visitor: V) -> Result<V::Value, Error> {
    if let Some(i) = n.as_i64() {
        return visitor.visit_i64(i);
    }
    if let Some(u) = n.as_u64() {
        return visitor.visit_u64(u);
    }
    let f = n.as_f64().unwrap_or(f64::NAN);
    // The casts are exact: `f` is integral and inside the target's range.
    if f.fract() == 0.0 && (-TWO_63..TWO_63).contains(&f) {
        visitor.visit_i64(f as i64)
    } else if f.fract() == 0.0 && (0.0..TWO_64).contains(&f) {
        visitor.visit_u64(f as u64)
    } else {
        visitor.visit_f64(f)
    }
}

impl<'de> Deserializer<'de> for Strict<'de> {
    type Error = Error;

    fn deserialize_any<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, Error> {
        match self.0 {
            Value::Null => visitor.visit_unit(),
            Value::Bool(b) => visitor.visit_bool(*b),
            Value::Number(n) => visit_number(n, visitor),
            Value::String(s) => visitor.visit_borrowed_str(s),
            Value::Array(items) => visit_array(items, visitor),
            Value::Object(map) => visit_object(map, visitor),
        }
    }

    fn deserialize_option<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, Error> {
        match self.0 {
            Value::Null => visitor.visit_none(),
            _ => visitor.visit_some(self),
        }
    }

    fn deserialize_struct<V: Visitor<'de>>(
        self,
        _name: &'static str,
        _fields: &'static [&'static str],
        visitor: V,
    ) -> Result<V::Value, Error> {
        self.deserialize_map(visitor)
    }

    /// Only an object: the point of this deserializer (serde would take an array for a struct).
    fn deserialize_map<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, Error> {
        match self.0 {
            Value::Object(map) => visit_object(map, visitor),
            other => Err(de::Error::invalid_type(unexpected(other), &"a JSON object")),
        }
    }

    /// Enums of the API are unit variants, written as their name.
    fn deserialize_enum<V: Visitor<'de>>(
        self,
        _name: &'static str,
        _variants: &'static [&'static str],
        visitor: V,
    ) -> Result<V::Value, Error> {
        match self.0 {
            Value::String(s) => visitor.visit_enum(s.as_str().into_deserializer()),
            other => Err(de::Error::invalid_type(unexpected(other), &visitor)),
        }
    }

    fn deserialize_newtype_struct<V: Visitor<'de>>(
        self,
        _name: &'static str,
        visitor: V,
    ) -> Result<V::Value, Error> {
        visitor.visit_newtype_struct(self)
    }

    fn deserialize_unit<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, Error> {
        match self.0 {
            Value::Null => visitor.visit_unit(),
            other => Err(de::Error::invalid_type(unexpected(other), &visitor)),
        }
    }

    fn deserialize_ignored_any<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, Error> {
        visitor.visit_unit()
    }

    serde::forward_to_deserialize_any! {
        bool i8 i16 i32 i64 i128 u8 u16 u32 u64 u128 f32 f64 char str string bytes byte_buf
        unit_struct seq tuple tuple_struct identifier
    }
}

fn visit_array<'de, V: Visitor<'de>>(items: &'de [Value], visitor: V) -> Result<V::Value, Error> {
    let mut seq = Seq {
        items: items.iter(),
        index: 0,
    };
    let value = visitor.visit_seq(&mut seq)?;
    if seq.items.len() == 0 {
        Ok(value)
    } else {
        Err(de::Error::invalid_length(items.len(), &"fewer elements"))
    }
}

fn visit_object<'de, V: Visitor<'de>>(
    map: &'de Map<String, Value>,
    visitor: V,
) -> Result<V::Value, Error> {
    visitor.visit_map(Entries {
        entries: map.iter(),
        current: None,
    })
}

struct Seq<'a> {
    items: std::slice::Iter<'a, Value>,
    index: usize,
}

impl<'de> SeqAccess<'de> for &mut Seq<'de> {
    type Error = Error;

    fn next_element_seed<T: DeserializeSeed<'de>>(
        &mut self,
        seed: T,
    ) -> Result<Option<T::Value>, Error> {
        let Some(item) = self.items.next() else {
            return Ok(None);
        };
        let index = self.index;
        self.index += 1;
        seed.deserialize(Strict(item))
            .map(Some)
            .map_err(|e| e.inside(Segment::Index(index)))
    }

    fn size_hint(&self) -> Option<usize> {
        Some(self.items.len())
    }
}

struct Entries<'a> {
    entries: serde_json::map::Iter<'a>,
    current: Option<(&'a str, &'a Value)>,
}

impl<'de> MapAccess<'de> for Entries<'de> {
    type Error = Error;

    fn next_key_seed<K: DeserializeSeed<'de>>(
        &mut self,
        seed: K,
    ) -> Result<Option<K::Value>, Error> {
        let Some((key, value)) = self.entries.next() else {
            return Ok(None);
        };
        self.current = Some((key, value));
        seed.deserialize(de::value::BorrowedStrDeserializer::new(key))
            .map(Some)
    }

    fn next_value_seed<V: DeserializeSeed<'de>>(&mut self, seed: V) -> Result<V::Value, Error> {
        let (key, value) = self
            .current
            .take()
            .ok_or_else(|| <Error as de::Error>::custom("value asked before its key"))?;
        seed.deserialize(Strict(value))
            .map_err(|e| e.inside(Segment::Key(key.to_string())))
    }

    fn size_hint(&self) -> Option<usize> {
        Some(self.entries.len())
    }
}

#[cfg(test)]
mod tests {
    use serde::Deserialize;

    use super::*;

    #[derive(Debug, Deserialize, PartialEq)]
    #[serde(deny_unknown_fields)]
    struct Inner {
        n: u32,
        x: f64,
    }

    #[derive(Debug, Deserialize, PartialEq)]
    #[serde(deny_unknown_fields)]
    struct Outer {
        inner: Option<Inner>,
        list: Vec<Inner>,
        #[serde(default)]
        id: i64,
    }

    #[test]
    fn structs_only_from_objects() {
        let e = from_slice::<Inner>(b"[1, 2.0]").unwrap_err();
        assert_eq!(e, "invalid type: sequence, expected a JSON object");
        let e = from_slice::<Outer>(br#"{"inner": [1, 2], "list": []}"#).unwrap_err();
        assert!(e.starts_with("inner: invalid type: sequence"), "{e}");
        let e = from_slice::<Outer>(br#"{"list": [{"n": 1, "x": 1}, [2, 2]]}"#).unwrap_err();
        assert!(e.starts_with("list[1]: invalid type: sequence"), "{e}");
        let e = from_slice::<Outer>(br#"{"list": [{"n": 1, "x": 1, "y": 0}]}"#).unwrap_err();
        assert!(e.starts_with("list[0]: unknown field `y`"), "{e}");
    }

    #[test]
    fn whole_numbers_are_integers() {
        let o: Outer = from_slice(br#"{"inner": {"n": 189450.0, "x": 3}, "list": [], "id": -4e3}"#)
            .expect("whole floats are integers");
        assert_eq!(o.inner, Some(Inner { n: 189450, x: 3.0 }));
        assert_eq!(o.id, -4000);
        let e = from_slice::<Inner>(br#"{"n": 1.5, "x": 0}"#).unwrap_err();
        assert!(
            e.starts_with("n: invalid type: floating point `1.5`"),
            "{e}"
        );
        let e = from_slice::<Inner>(br#"{"n": 4294967296.0, "x": 0}"#).unwrap_err();
        assert!(
            e.starts_with("n: invalid value: integer `4294967296`"),
            "{e}"
        );
        assert!(from_slice::<Inner>(b"{\"n\": 1, \"x\": 0} x").is_err());
    }
}

//! Schemas of values the Rust types hold as plain strings but the server only accepts from a
//! fixed list or in a fixed form (reason codes, export files, demographics, external ids):
//! fields name them with `#[schema(value_type = …)]`, so the document lists exactly what the
//! server's validation accepts. The lists come from the constants the validation reads.

use std::borrow::Cow;

use utoipa::openapi::schema::{ObjectBuilder, Schema, Type};
use utoipa::openapi::{RefOr, schema::SchemaType};
use utoipa::{PartialSchema, ToSchema};

use crate::flow;
use crate::studies::export;

fn string_enum(values: impl IntoIterator<Item = &'static str>, description: &str) -> RefOr<Schema> {
    ObjectBuilder::new()
        .schema_type(SchemaType::Type(Type::String))
        .enum_values(Some(values))
        .description(Some(description))
        .into()
}

fn pattern_string(pattern: &str, description: &str) -> RefOr<Schema> {
    ObjectBuilder::new()
        .schema_type(SchemaType::Type(Type::String))
        .pattern(Some(pattern))
        .description(Some(description))
        .into()
}

macro_rules! schema_only {
    ($(#[$doc:meta])* $name:ident => $schema:expr) => {
        $(#[$doc])*
        pub struct $name;

        impl PartialSchema for $name {
            fn schema() -> RefOr<Schema> {
                $schema
            }
        }

        impl ToSchema for $name {
            fn name() -> Cow<'static, str> {
                Cow::Borrowed(stringify!($name))
            }
        }
    };
}

schema_only!(
    /// A reason code of the "why did you choose?" questionnaire ([`flow::REASONS`]).
    ReasonCode => string_enum(
        flow::REASONS.iter().map(|(_, code, _)| *code),
        "A reason code of the \"why did you choose?\" questionnaire.",
    )
);

schema_only!(
    /// An export file name ([`export::FILES`]).
    ExportFile => string_enum(export::FILES.iter().copied(), "An export file.")
);

schema_only!(
    /// The demographics' gender (empty: not answered).
    Gender => string_enum(
        flow::GENDERS.iter().copied(),
        "Gender (the empty string: not answered).",
    )
);

schema_only!(
    /// The demographics' art experience (empty: not answered).
    ArtExperience => string_enum(
        flow::ART_EXPERIENCE.iter().copied(),
        "Art experience (the empty string: not answered).",
    )
);

schema_only!(
    /// A worker id in the block list: 1–200 characters, not only white space.
    BlockedWorker => ObjectBuilder::new()
        .schema_type(SchemaType::Type(Type::String))
        .min_length(Some(1))
        .max_length(Some(200))
        .pattern(Some(r"\S"))
        .description(Some("A worker id (MTurk workerId, Prolific PROLIFIC_PID or a direct \
            participant id): 1-200 characters, not only white space."))
        .into()
);

schema_only!(
    /// A Prolific completion or screen-out code.
    ProlificCode => pattern_string(
        "^[A-Za-z0-9]{1,64}$",
        "A Prolific code: 1-64 ASCII letters and digits.",
    )
);

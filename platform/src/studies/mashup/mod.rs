//! The mash-up study (issue 17, Garces et al. 2014 §5.7.3): each worker composes a scene on the
//! canvas from clip art found with the search, under one of two conditions assigned at random
//! and never named to the worker — A, results sorted by style (the learned metric, ordered by
//! the pieces already on the canvas); B, the same keyword/category matches in random order.
//! The server logs every search with the list it returned and every piece added or removed;
//! the report is the mean position, in its list, of each piece used in a submitted composition
//! (the paper: 24 ± 4.4 with the metric, 40 ± 7.1 without).
//!
//! The shared HIT machinery is used as for the other kinds, with one HIT = one composition
//! task: there are no hidden controls or training (a free composition has no known answer),
//! and quality control is the study's minimum numbers of pieces and searches and the validity
//! of the submitted document.

mod conditions;
#[cfg(test)]
mod db_tests;
pub mod drawn;
pub mod events;
pub mod log;
pub mod pool;
pub mod report;
pub mod submit;

use serde::{Deserialize, Serialize};

use crate::error::{AppError, Result};
use crate::mashup::backgrounds;

pub use conditions::{condition_at, shuffle_seed};
pub use report::{ConditionReport, MashupReport, summarise};

/// Longest task text, in characters.
pub const MAX_TASK_CHARS: usize = 2000;

/// The search condition of an assignment (§5.7.3).
#[derive(
    Debug,
    Clone,
    Copy,
    PartialEq,
    Eq,
    PartialOrd,
    Ord,
    Hash,
    Serialize,
    Deserialize,
    utoipa::ToSchema,
)]
pub enum Condition {
    /// Results sorted by style (the learned metric).
    A,
    /// Results in random order.
    B,
}

impl Condition {
    /// As stored in `mashup_conditions.condition`.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::A => "A",
            Self::B => "B",
        }
    }

    /// The stored form; anything else is an internal error (only this module writes it).
    pub fn from_stored(s: &str) -> Result<Self> {
        match s {
            "A" => Ok(Self::A),
            "B" => Ok(Self::B),
            other => Err(AppError::Internal(format!(
                "mashup_conditions: unknown condition {other:?}"
            ))),
        }
    }

    /// The other one.
    pub fn other(self) -> Self {
        match self {
            Self::A => Self::B,
            Self::B => Self::A,
        }
    }
}

/// What a mash-up study asks (stored in the study's settings as `mashup`).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize, utoipa::ToSchema)]
#[serde(deny_unknown_fields)]
pub struct MashupSettings {
    /// The task shown above the canvas (an open topic or a fixed story), 1–2000 characters.
    pub task: String,
    /// A fixed background (one of the canvas's 11 names); `None`: the worker chooses.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub background: Option<String>,
    /// Pieces the submitted composition must have (1–200).
    #[serde(default = "default_min_pieces")]
    pub min_pieces: u32,
    /// Searches the worker must have made before submitting (0–1000).
    #[serde(default = "default_min_searches")]
    pub min_searches: u32,
}

fn default_min_pieces() -> u32 {
    3
}

fn default_min_searches() -> u32 {
    1
}

impl MashupSettings {
    /// Checks every field; a bad one is a 400 naming it.
    pub fn validate(&self) -> Result<()> {
        let task = self.task.trim();
        if task.is_empty() || task.chars().count() > MAX_TASK_CHARS {
            return Err(AppError::BadRequest(format!(
                "task: 1..={MAX_TASK_CHARS} characters"
            )));
        }
        if let Some(b) = &self.background
            && backgrounds::by_name(b).is_none()
        {
            let names: Vec<&str> = backgrounds::BACKGROUNDS.iter().map(|b| b.name).collect();
            return Err(AppError::BadRequest(format!(
                "background: {b:?} is not one of {}",
                names.join(", ")
            )));
        }
        let max_pieces = crate::mashup::document::MAX_PIECES as u32;
        if !(1..=max_pieces).contains(&self.min_pieces) {
            return Err(AppError::BadRequest(format!(
                "min_pieces: {} not in 1..={max_pieces}",
                self.min_pieces
            )));
        }
        if self.min_searches > 1000 {
            return Err(AppError::BadRequest(format!(
                "min_searches: {} not in 0..=1000",
                self.min_searches
            )));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn settings() -> MashupSettings {
        MashupSettings {
            task: "A picnic in the park".into(),
            background: Some("grass".into()),
            min_pieces: 3,
            min_searches: 1,
        }
    }

    #[test]
    fn settings_are_validated_field_by_field() {
        settings().validate().unwrap();
        let bad = [
            MashupSettings {
                task: "  ".into(),
                ..settings()
            },
            MashupSettings {
                task: "x".repeat(MAX_TASK_CHARS + 1),
                ..settings()
            },
            MashupSettings {
                background: Some("moon".into()),
                ..settings()
            },
            MashupSettings {
                min_pieces: 0,
                ..settings()
            },
            MashupSettings {
                min_pieces: 201,
                ..settings()
            },
            MashupSettings {
                min_searches: 1001,
                ..settings()
            },
        ];
        for s in bad {
            assert!(
                matches!(s.validate(), Err(AppError::BadRequest(_))),
                "{s:?} was accepted"
            );
        }
    }

    #[test]
    fn settings_json_defaults_and_unknown_fields() {
        let s: MashupSettings = serde_json::from_str(r#"{"task":"t"}"#).unwrap();
        assert_eq!((s.min_pieces, s.min_searches, s.background), (3, 1, None));
        assert!(serde_json::from_str::<MashupSettings>(r#"{"task":"t","pieces":2}"#).is_err());
    }
}

//! Study kinds (issue 17): what differs between the triplet study of §5.4 and the two studies
//! of §5.7.3 that measure whether style search helps, behind one small interface. Everything
//! else — HITs of replicated slots, the training gate, hidden controls, QC, resume, the
//! MTurk/Prolific hand-back — is the same machinery for every kind (`crate::flow`).
//!
//! What a kind decides:
//! - how a tuple is shown ([`StudyKind::shows_reference`]): a triplet shows its reference `a`
//!   above `b` and `c`; a composition pair shows only `b` and `c`, side by side in the
//!   per-worker random order every question has;
//! - the question text ([`StudyKind::prompt`]);
//! - which answers are valid ([`StudyKind::answer`]): one of the two pictures shown, or a
//!   composition made on the mash-up canvas;
//! - how the report summarises the answers ([`crate::studies::report`]).

use serde::{Deserialize, Serialize};

use crate::error::{AppError, Result};

/// What a study asks of its workers.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize, utoipa::ToSchema)]
#[serde(rename_all = "kebab-case")]
pub enum StudyKind {
    /// "Is A more similar in style to B or to C?" (§5.4).
    #[default]
    Triplet,
    /// Two compositions, one made with style-sorted search (condition A) and one with
    /// random-order results (condition B): which is more coherent in style, or liked better
    /// (2AFC, §5.7.3, Appendix 5.B).
    CompositionRating,
    /// Compose a scene on the mash-up canvas with condition A or B search (§5.7.3).
    Mashup,
    /// Find icons of a few labels in one style, several sets in different styles, with the
    /// style explorer (condition A) or the search ordered by style (condition B) (Garces et
    /// al. 2016 §6.6).
    Iconset,
}

/// What a valid answer of a kind is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AnswerShape {
    /// One of the two pictures shown (`b` or `c` of the tuple).
    Choice,
    /// A composition document submitted from the canvas.
    Composition,
    /// A tray of icon sets, every slot filled.
    IconSets,
}

/// The question of a composition-rating study (one per study: see docs/platform/README.md).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize, utoipa::ToSchema)]
#[serde(rename_all = "lowercase")]
pub enum RatingQuestion {
    /// "Which composition has a more coherent style?"
    #[default]
    Coherence,
    /// "Which composition do you like better?"
    Preference,
}

impl StudyKind {
    /// Every kind.
    pub const ALL: [StudyKind; 4] = [
        Self::Triplet,
        Self::CompositionRating,
        Self::Mashup,
        Self::Iconset,
    ];

    /// As stored in `studies.kind` and written on the command line.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Triplet => "triplet",
            Self::CompositionRating => "composition-rating",
            Self::Mashup => "mashup",
            Self::Iconset => "iconset",
        }
    }

    /// The stored or typed form; an unknown kind is a 400 naming the known ones.
    pub fn parse(s: &str) -> Result<Self> {
        Self::ALL
            .into_iter()
            .find(|k| k.as_str() == s)
            .ok_or_else(|| {
                AppError::BadRequest(format!(
                    "kind: {s:?} is not one of triplet, composition-rating, mashup, iconset"
                ))
            })
    }

    /// Whether a question shows the tuple's reference `a` (only triplets have one).
    pub fn shows_reference(self) -> bool {
        self == Self::Triplet
    }

    /// The question asked about each tuple (the mash-up's task text is the study's own).
    pub fn prompt(self, question: RatingQuestion) -> &'static str {
        match (self, question) {
            (Self::CompositionRating, RatingQuestion::Coherence) => {
                "Which composition has a more coherent style?"
            }
            (Self::CompositionRating, RatingQuestion::Preference) => {
                "Which composition do you like better?"
            }
            (Self::Mashup, _) => "Compose a scene from clip art as the task says.",
            (Self::Iconset, _) => "Find icons in one style for every slot of each set.",
            (Self::Triplet, _) => "Which picture below is more similar in style to the one above?",
        }
    }

    /// What a valid answer is.
    pub fn answer(self) -> AnswerShape {
        match self {
            Self::Triplet | Self::CompositionRating => AnswerShape::Choice,
            Self::Mashup => AnswerShape::Composition,
            Self::Iconset => AnswerShape::IconSets,
        }
    }

    /// A new study's settings before a settings file, flags or form fields: the paper's triplet
    /// defaults; for a composition rating its own instructions, no worked example or reasons
    /// questionnaire (both are about triplets) and the coherence question; for a mash-up study
    /// one composition task per HIT (`mashup::pool::defaults`); for an icon-set study one tray
    /// of sets per HIT (`iconset::pool::defaults`).
    pub fn default_settings(self) -> crate::studies::study::StudySettings {
        use crate::studies::study::StudySettings;
        match self {
            Self::CompositionRating => StudySettings {
                description: "Compare two compositions of clip art.".into(),
                instructions: crate::studies::rating::INSTRUCTIONS.into(),
                show_worked_example: false,
                reasons_probability: 0.0,
                question: Some(RatingQuestion::Coherence),
                ..StudySettings::default()
            },
            Self::Mashup => crate::studies::mashup::pool::defaults(None),
            Self::Iconset => crate::studies::iconset::pool::defaults(None),
            Self::Triplet => StudySettings::default(),
        }
    }

    /// Whether the start page may show a worked example (a triplet with its answer): the
    /// example's wording is about a reference, which only triplets have.
    pub fn has_worked_example(self) -> bool {
        self == Self::Triplet
    }
}

impl std::fmt::Display for StudyKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kinds_round_trip_and_unknown_ones_are_refused() {
        for k in StudyKind::ALL {
            assert_eq!(StudyKind::parse(k.as_str()).unwrap(), k);
            let json = serde_json::to_string(&k).unwrap();
            assert_eq!(json, format!("\"{}\"", k.as_str()));
        }
        assert!(StudyKind::parse("icons").is_err());
        assert!(StudyKind::Triplet.shows_reference());
        assert!(!StudyKind::CompositionRating.shows_reference());
    }
}

//! A study's settings: the paper's defaults, what each field means and its bounds, and the
//! validation every way of creating or editing a study goes through.

use serde::{Deserialize, Serialize};

use crate::error::{AppError, Result};
use crate::store::ids::{ID_LIMIT, StudyId};

/// Which MTurk site a study's HITs live on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, utoipa::ToSchema)]
#[serde(rename_all = "lowercase")]
pub enum MturkMode {
    /// workersandbox.mturk.com: no money changes hands.
    Sandbox,
    /// www.mturk.com.
    Live,
}

impl MturkMode {
    /// Where the ExternalQuestion form posts to.
    pub fn submit_host(self) -> &'static str {
        match self {
            Self::Sandbox => "https://workersandbox.mturk.com",
            Self::Live => "https://www.mturk.com",
        }
    }
}

/// Most main tuples of a study.
pub const MAX_TUPLES: u32 = 1_000_000;

/// Most slots (main tuples × replication) of a study. A slot with its index entries takes
/// ~120 bytes in SQLite, so 20 million are ~2.4 GB, written in ~2 minutes
/// (docs/platform/README.md); 1,000,000 × 100 (100 million slots) was never finished.
pub const MAX_SLOTS: u64 = 20_000_000;

/// The largest control-error threshold (a HIT has at most 499 controls).
pub const MAX_CONTROL_ERRORS: u32 = 500;

/// A study's settings. `Default` is the paper's set-up (Garces et al. 2014 §5.4).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, utoipa::ToSchema)]
#[serde(default, deny_unknown_fields)]
pub struct StudySettings {
    /// Text shown to workers before they start (plain text; also MTurk's preview).
    #[schema(max_length = 5000)]
    pub description: String,
    /// Instructions shown on the start page (Markdown without raw HTML; `![caption](item:NAME)`
    /// shows the library item NAME).
    #[schema(max_length = 20000)]
    pub instructions: String,
    /// Show a worked example (a practice triplet with its answer) under the instructions, as
    /// the thesis does before the test (Fig. 5.2, left).
    pub show_worked_example: bool,
    /// Informed-consent text (Markdown without raw HTML). Not empty: workers must tick "I
    /// agree" before they start; declining ends the task and is recorded.
    #[schema(max_length = 20000)]
    pub consent: String,
    /// Questions in one HIT, controls included (paper: 50).
    #[schema(minimum = 1, maximum = 500)]
    pub questions_per_hit: u32,
    /// Hidden control questions in one HIT (paper: 5); fewer than `questions_per_hit`.
    #[schema(minimum = 0, maximum = 499)]
    pub controls_per_hit: u32,
    /// Training triplets that must all be answered correctly first.
    #[schema(minimum = 0, maximum = 20)]
    pub training_questions: u32,
    /// Training attempts before the worker is screened out.
    #[schema(minimum = 1, maximum = 100)]
    pub max_training_attempts: u32,
    /// Main tuples to generate: at most the library's distinct triplets (n·(n−1)·(n−2)/2 for
    /// n items), and tuples × replication at most 20,000,000 slots.
    #[schema(minimum = 1, maximum = 1_000_000)]
    pub tuples: u32,
    /// Distinct workers per main tuple (R; the paper's test set used 10).
    #[schema(minimum = 1, maximum = 100)]
    pub replication: u32,
    /// Probability of the "why did you choose?" questionnaire after a question (2016: 0.1).
    #[schema(minimum = 0, maximum = 1)]
    pub reasons_probability: f64,
    /// A HIT with at least this many control errors is rejected (paper: 2).
    #[schema(minimum = 1, maximum = 500)]
    pub reject_at_control_errors: u32,
    /// MTurk sandbox or live.
    pub mturk_mode: MturkMode,
    /// Prolific completion code (configured on Prolific) for the completion redirect.
    #[schema(value_type = Option<crate::web::api::schema::ProlificCode>)]
    pub prolific_completion_code: Option<String>,
    /// Prolific screen-out code for workers who give up the training.
    #[schema(value_type = Option<crate::web::api::schema::ProlificCode>)]
    pub prolific_screenout_code: Option<String>,
    /// Prolific code for participants who do not consent (a code set up on Prolific to ask
    /// them to return the study); without it they are asked to return the study.
    #[schema(value_type = Option<crate::web::api::schema::ProlificCode>)]
    pub prolific_noconsent_code: Option<String>,
    /// Worker ids (MTurk/Prolific/direct) that may not take part.
    #[schema(value_type = Vec<crate::web::api::schema::BlockedWorker>, max_items = 100_000)]
    pub blocked_workers: Vec<String>,
    /// Workers who took part in these studies may not take part.
    #[schema(max_items = 1000)]
    pub exclude_workers_of: Vec<StudyId>,
    /// The question of a composition-rating study (`coherence` or `preference`); absent for
    /// the other kinds.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub question: Option<crate::studies::kind::RatingQuestion>,
    /// What a mash-up study asks (task, background, minimum pieces and searches); absent for
    /// the other kinds.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mashup: Option<crate::studies::mashup::MashupSettings>,
    /// What an icon-set study asks (labels, sets, model, taxonomy κ and τ); absent for the
    /// other kinds.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub iconset: Option<crate::studies::iconset::IconsetSettings>,
    /// Seed of the tuple generation (below 2^53, so JavaScript reads it exactly).
    #[schema(minimum = 0, maximum = 9_007_199_254_740_991_u64)]
    pub seed: u64,
}

/// The instructions of a new study: what the task is and what "style" means here.
pub const DEFAULT_INSTRUCTIONS: &str = "\
Each question shows one picture on top, the **reference**, and two pictures below it.

**Choose the picture below that is more similar in _style_ to the reference** — not the one \
that shows the same thing. Style is *how* a picture is drawn:

- **colours** — palette, saturation, brightness;
- **shading** — flat colour or gradients and highlights;
- **outlines** — thick, thin or none;
- **shapes** — round or angular, simple or detailed.

Click or tap a picture (on a keyboard: ← or 1 for the left one, → or 2 for the right one). \
There are no trick questions: go with your first impression.";

impl Default for StudySettings {
    fn default() -> Self {
        Self {
            description: "Compare the style of clip art.".into(),
            instructions: DEFAULT_INSTRUCTIONS.into(),
            show_worked_example: true,
            consent: String::new(),
            questions_per_hit: 50,
            controls_per_hit: 5,
            training_questions: 3,
            max_training_attempts: 5,
            tuples: 1000,
            replication: 1,
            reasons_probability: 0.1,
            reject_at_control_errors: 2,
            mturk_mode: MturkMode::Sandbox,
            prolific_completion_code: None,
            prolific_screenout_code: None,
            prolific_noconsent_code: None,
            blocked_workers: Vec::new(),
            exclude_workers_of: Vec::new(),
            question: None,
            mashup: None,
            iconset: None,
            seed: 1,
        }
    }
}

impl StudySettings {
    /// Checks every field; the message names the offending one.
    pub fn validate(&self) -> Result<()> {
        let bad = |m: String| Err(AppError::BadRequest(m));
        if self.description.chars().count() > 5000 {
            return bad("description: at most 5000 characters".into());
        }
        for (field, text) in [
            ("instructions", &self.instructions),
            ("consent", &self.consent),
        ] {
            if text.chars().count() > crate::studies::markdown::MAX_MARKDOWN_CHARS {
                return bad(format!(
                    "{field}: at most {} characters",
                    crate::studies::markdown::MAX_MARKDOWN_CHARS
                ));
            }
        }
        if !(1..=500).contains(&self.questions_per_hit) {
            return bad(format!(
                "questions_per_hit: {} not in 1..=500",
                self.questions_per_hit
            ));
        }
        if self.controls_per_hit >= self.questions_per_hit {
            return bad(format!(
                "controls_per_hit: {} must be below questions_per_hit {}",
                self.controls_per_hit, self.questions_per_hit
            ));
        }
        if let Some(m) = &self.mashup {
            m.validate()?;
        }
        if let Some(i) = &self.iconset {
            i.validate()?;
        }
        if self.training_questions > 20 {
            return bad(format!(
                "training_questions: {} not in 0..=20",
                self.training_questions
            ));
        }
        if !(1..=100).contains(&self.max_training_attempts) {
            return bad(format!(
                "max_training_attempts: {} not in 1..=100",
                self.max_training_attempts
            ));
        }
        if !(1..=MAX_TUPLES).contains(&self.tuples) {
            return bad(format!("tuples: {} not in 1..={MAX_TUPLES}", self.tuples));
        }
        if !(1..=100).contains(&self.replication) {
            return bad(format!("replication: {} not in 1..=100", self.replication));
        }
        let slots = u64::from(self.tuples) * u64::from(self.replication);
        if slots > MAX_SLOTS {
            return bad(format!(
                "tuples × replication: {} × {} = {slots} slots, more than the {MAX_SLOTS} a \
                 study can hold; lower tuples or replication",
                self.tuples, self.replication
            ));
        }
        if !(0.0..=1.0).contains(&self.reasons_probability) {
            return bad(format!(
                "reasons_probability: {} not in [0, 1]",
                self.reasons_probability
            ));
        }
        if !(1..=MAX_CONTROL_ERRORS).contains(&self.reject_at_control_errors) {
            return bad(format!(
                "reject_at_control_errors: {} not in 1..={MAX_CONTROL_ERRORS}",
                self.reject_at_control_errors
            ));
        }
        for code in [
            &self.prolific_completion_code,
            &self.prolific_screenout_code,
            &self.prolific_noconsent_code,
        ]
        .into_iter()
        .flatten()
        {
            if code.is_empty()
                || code.len() > 64
                || !code.chars().all(|c| c.is_ascii_alphanumeric())
            {
                return bad("prolific codes: 1-64 ASCII letters and digits".into());
            }
        }
        if self.blocked_workers.len() > 100_000 {
            return bad("blocked_workers: at most 100000".into());
        }
        if self
            .blocked_workers
            .iter()
            .any(|w| w.trim().is_empty() || w.chars().count() > 200)
        {
            return bad("blocked_workers: each worker id must be 1-200 characters".into());
        }
        if self.exclude_workers_of.len() > 1000 {
            return bad("exclude_workers_of: at most 1000 studies".into());
        }
        if self.seed >= ID_LIMIT as u64 {
            return bad(format!("seed: {} not below 2^53", self.seed));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn settings_are_validated() {
        assert!(StudySettings::default().validate().is_ok());
        let bad = StudySettings {
            controls_per_hit: 50,
            ..StudySettings::default()
        };
        assert!(bad.validate().is_err());
        let bad = StudySettings {
            reasons_probability: 1.5,
            ..StudySettings::default()
        };
        assert!(bad.validate().is_err());
    }

    #[test]
    fn a_pool_beyond_the_slot_limit_is_refused_with_its_size() {
        let size = |tuples, replication| StudySettings {
            tuples,
            replication,
            ..StudySettings::default()
        };
        assert!(size(200_000, 100).validate().is_ok());
        let message = size(1_000_000, 100).validate().unwrap_err().to_string();
        assert!(
            message.contains("1000000 × 100 = 100000000 slots") && message.contains("20000000"),
            "{message}"
        );
        assert!(size(1_000_001, 1).validate().is_err());
    }
}

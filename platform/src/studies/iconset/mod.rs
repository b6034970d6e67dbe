//! The icon-set study (issue 18; Garces et al. 2016, "Style-Based Exploration of Illustration
//! Datasets", §6.6): each worker finds icons for a few semantic labels — by default face, fish,
//! flower and bird — all in one style, and makes several such sets, each in another style. Two
//! conditions, assigned balanced and never named to the worker: A, the style explorer (the
//! taxonomy's representative styles of the labels, §6.5.1, and a style's branch on the balanced
//! grid with its hidden images, §6.5.2), computed once when the study is created; B, the search
//! ordered by style only (the mash-up study's style-sorted search, §5.7.3, ordered by the icons
//! already in the set). The server logs when the worker opened the task and every add, remove
//! and finished set; the report is the time per set and the deletions per set, per condition,
//! with 95% t intervals (the thesis: 79 ± 20 s vs 108 ± 27 s per set, 0.6 vs 2.8 deletions).
//!
//! A HIT is one tray of sets in the shared HIT machinery (one question, no controls or
//! practice, as the mash-up study): the tray's submission answers its one question.
//!
//! An item's semantic label is its style label (`items.style`), as for the Explore pages
//! (`crate::explore`).

pub mod explorer;
pub mod log;
pub mod pool;
pub mod report;

use serde::{Deserialize, Serialize};

use crate::error::{AppError, Result};
use crate::explore::{LabelCount, label_counts};
use crate::store::db::Db;
use crate::store::ids::{LibraryId, ModelId};

pub use crate::studies::mashup::Condition;
pub use report::{IconsetReport, summarise};

/// Most labels (slots per set).
pub const MAX_LABELS: usize = 8;

/// Most sets per HIT.
pub const MAX_SETS: u32 = 10;

/// The labels of the thesis's task (§6.6).
pub const DEFAULT_LABELS: [&str; 4] = ["face", "fish", "flower", "bird"];

/// Sets per HIT in the thesis's task.
pub const DEFAULT_SETS: u32 = 4;

/// What an icon-set study asks (stored in the study's settings as `iconset`).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize, utoipa::ToSchema)]
#[serde(deny_unknown_fields)]
pub struct IconsetSettings {
    /// The semantic labels of a set's slots (style labels of the library's items), 1–8,
    /// distinct.
    #[serde(default = "default_labels")]
    pub labels: Vec<String>,
    /// Sets per HIT, each in another style (1–10).
    #[serde(default = "default_sets")]
    pub sets: u32,
    /// The trained model whose metric orders the search and shapes the explorer; `null`:
    /// uniform weights.
    #[serde(default)]
    pub model: Option<ModelId>,
    /// κ of the explorer's taxonomy: a representative style's branch holds more than κ items
    /// (§6.5.1; default 20).
    #[serde(default = "default_kappa")]
    pub kappa: usize,
    /// τ of the explorer's taxonomy: it holds more than τ items of every label (default 2).
    #[serde(default = "default_tau")]
    pub tau: usize,
}

fn default_labels() -> Vec<String> {
    DEFAULT_LABELS.iter().map(|l| l.to_string()).collect()
}

fn default_sets() -> u32 {
    DEFAULT_SETS
}

fn default_kappa() -> usize {
    learner::explore::TaxonomyParams::default().kappa
}

fn default_tau() -> usize {
    learner::explore::TaxonomyParams::default().tau
}

impl Default for IconsetSettings {
    fn default() -> Self {
        Self {
            labels: default_labels(),
            sets: DEFAULT_SETS,
            model: None,
            kappa: default_kappa(),
            tau: default_tau(),
        }
    }
}

impl IconsetSettings {
    /// Checks every field alone; a bad one is a 400 naming it. [`Self::check_library`] checks
    /// them against a library.
    pub fn validate(&self) -> Result<()> {
        let bad = |m: String| Err(AppError::BadRequest(m));
        if self.labels.is_empty() || self.labels.len() > MAX_LABELS {
            return bad(format!(
                "labels: {} given, 1..={MAX_LABELS} wanted",
                self.labels.len()
            ));
        }
        for (i, l) in self.labels.iter().enumerate() {
            let t = crate::explore::text("labels", l)?;
            if t.is_empty() || t != *l {
                return bad(format!("labels: {l:?} is empty or has surrounding spaces"));
            }
            if self.labels[..i].contains(l) {
                return bad(format!("labels: {l:?} is given twice"));
            }
        }
        if !(1..=MAX_SETS).contains(&self.sets) {
            return bad(format!("sets: {} not in 1..={MAX_SETS}", self.sets));
        }
        if self.kappa > 1_000_000 || self.tau > 1_000_000 {
            return bad("kappa and tau: at most 1000000".into());
        }
        Ok(())
    }

    /// Checks the labels against the library's label counts: each exists and has at least one
    /// item per set (an icon is used in one set only), and the explorer's taxonomy keeps a
    /// branch (κ and τ do not prune every branch).
    pub fn check_counts(&self, counts: &[LabelCount]) -> Result<()> {
        crate::explore::taxonomy::check_labels(counts, &self.labels)?;
        for l in &self.labels {
            let n = counts.iter().find(|c| &c.label == l).map_or(0, |c| c.count);
            if n < self.sets as usize {
                return Err(AppError::BadRequest(format!(
                    "labels: {l:?} has {n} items in this library; {} sets need at least {}",
                    self.sets, self.sets
                )));
            }
        }
        let params = learner::explore::TaxonomyParams {
            kappa: self.kappa,
            tau: self.tau,
            ..Default::default()
        };
        crate::explore::taxonomy::check(counts, &self.labels, &params)
    }

    /// [`Self::validate`], then [`Self::check_counts`] on `library`'s items.
    pub async fn check_library(&self, db: &Db, library: LibraryId) -> Result<()> {
        self.validate()?;
        self.check_counts(&label_counts(db, library).await?)
    }

    /// The task as the worker reads it.
    pub fn task(&self) -> String {
        let labels = match self.labels.as_slice() {
            [one] => one.clone(),
            [init @ .., last] => format!("{} and {last}", init.join(", ")),
            [] => String::new(),
        };
        let sets = if self.sets == 1 {
            "one set".to_string()
        } else {
            format!("{} sets, each in a different style", self.sets)
        };
        format!("Find icons for {labels} in one style. Make {sets}.")
    }

    /// The slot of `label` in a set, if it is one of the study's labels.
    pub fn slot(&self, label: &str) -> Option<usize> {
        self.labels.iter().position(|l| l == label)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn counts(list: &[(&str, usize)]) -> Vec<LabelCount> {
        list.iter()
            .map(|&(label, count)| LabelCount {
                label: label.into(),
                count,
            })
            .collect()
    }

    #[test]
    fn settings_are_validated_field_by_field() {
        let ok = IconsetSettings::default();
        ok.validate().unwrap();
        assert_eq!(
            ok.task(),
            "Find icons for face, fish, flower and bird in one style. Make 4 sets, each in a \
             different style."
        );
        for change in [
            |s: &mut IconsetSettings| s.labels.clear(),
            |s: &mut IconsetSettings| s.labels.push("face".into()),
            |s: &mut IconsetSettings| s.labels[0] = " face".into(),
            |s: &mut IconsetSettings| s.labels[0] = String::new(),
            |s: &mut IconsetSettings| s.labels = (0..9).map(|i| format!("l{i}")).collect(),
            |s: &mut IconsetSettings| s.sets = 0,
            |s: &mut IconsetSettings| s.sets = 11,
        ] {
            let mut s = IconsetSettings::default();
            change(&mut s);
            assert!(
                matches!(s.validate(), Err(AppError::BadRequest(_))),
                "{s:?} was accepted"
            );
        }
        let s: IconsetSettings = serde_json::from_str(r#"{"sets": 2}"#).unwrap();
        assert_eq!((s.labels.len(), s.sets, s.kappa, s.tau), (4, 2, 20, 2));
        assert!(serde_json::from_str::<IconsetSettings>(r#"{"set": 2}"#).is_err());
    }

    #[test]
    fn labels_must_exist_with_an_item_per_set() {
        let s = IconsetSettings {
            kappa: 3,
            tau: 1,
            ..IconsetSettings::default()
        };
        let lib = counts(&[("face", 8), ("fish", 4), ("flower", 4), ("bird", 4)]);
        s.check_counts(&lib).unwrap();
        let e = s
            .check_counts(&counts(&[("face", 8), ("fish", 4), ("flower", 4)]))
            .unwrap_err();
        assert!(e.to_string().contains("bird not in this library"), "{e}");
        let e = s
            .check_counts(&counts(&[
                ("face", 8),
                ("fish", 3),
                ("flower", 4),
                ("bird", 4),
            ]))
            .unwrap_err();
        assert!(e.to_string().contains("\"fish\" has 3 items"), "{e}");
        let strict = IconsetSettings { tau: 4, ..s };
        let e = strict.check_counts(&lib).unwrap_err();
        assert!(e.to_string().contains("prune every branch"), "{e}");
    }
}

//! What a study's pool lacks against its settings, said plainly where the researcher looks (the
//! command line's output, the API's study responses, the study page): no or too few hidden
//! controls, no or too few practice triplets. Automatic controls and practice triplets come
//! from the library's style labels, so a library imported without labels gives neither, and
//! a study over it silently ran without quality control and without the training gate.

use std::collections::BTreeMap;

use sqlx::Row;

use super::{Study, StudySettings};
use crate::error::Result;
use crate::store::db::Db;
use crate::studies::library::ItemInfo;

/// The style labels of a library, as the automatic controls need them.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct LabelStats {
    /// Items.
    pub items: usize,
    /// Items with a style label.
    pub labelled: usize,
    /// Distinct styles.
    pub styles: usize,
    /// Items of the largest style.
    pub largest: usize,
}

impl LabelStats {
    /// Of items in memory.
    pub fn of(items: &[ItemInfo]) -> Self {
        let mut groups: BTreeMap<&str, usize> = BTreeMap::new();
        for style in items.iter().filter_map(|i| i.style.as_deref()) {
            *groups.entry(style).or_default() += 1;
        }
        Self {
            items: items.len(),
            labelled: groups.values().sum(),
            styles: groups.len(),
            largest: groups.values().copied().max().unwrap_or(0),
        }
    }

    /// Whether style triplets can be drawn at all: two styles, one with two items.
    fn enough(&self) -> bool {
        self.styles >= 2 && self.largest >= 2
    }

    fn describe(&self) -> String {
        format!(
            "the library's {} items carry {} style labels in {} styles, and automatic ones need \
             at least two styles, one of them on two items or more (`platform library import \
             --labels`)",
            self.items, self.labelled, self.styles
        )
    }
}

/// The warnings for a pool of `controls` control and `training` practice triplets under
/// `settings` (empty when the pool is what the settings ask for).
pub fn pool_warnings(
    settings: &StudySettings,
    controls: usize,
    training: usize,
    labels: &LabelStats,
) -> Vec<String> {
    let mut out = Vec::new();
    let want_controls = settings.controls_per_hit as usize;
    if want_controls > 0 && controls == 0 {
        let why = if labels.enough() {
            "the style groups gave no triplet with a known answer to spare after the practice \
             ones"
                .to_string()
        } else {
            labels.describe()
        };
        out.push(format!(
            "No hidden control questions: {why}. HITs will have no controls (each holds {} \
             questions instead of {}), so no worker is rejected for control errors; add curated \
             controls to check workers.",
            settings.questions_per_hit as usize - want_controls,
            settings.questions_per_hit
        ));
    } else if controls < want_controls {
        out.push(format!(
            "Only {controls} control triplets for {want_controls} controls per HIT: each HIT \
             has {controls} controls."
        ));
    }
    let want_training = settings.training_questions as usize;
    if want_training > 0 && training == 0 {
        let why = if labels.enough() {
            "the style groups gave no triplet with a known answer".to_string()
        } else {
            labels.describe()
        };
        out.push(format!(
            "No practice questions: {why}. Workers start the HIT without the training gate \
             (and without the worked example); add curated training triplets to have one."
        ));
    } else if training < want_training {
        out.push(format!(
            "Only {training} practice triplets for {want_training} per attempt: each attempt \
             shows {training}."
        ));
    }
    out
}

/// The warnings of a stored study, from the control and practice triplets it has now (curated
/// ones included, so adding them clears the warning).
pub async fn warnings(db: &Db, study: &Study) -> Result<Vec<String>> {
    let mut controls = 0;
    let mut training = 0;
    let rows = sqlx::query(
        "SELECT kind, CAST(COUNT(*) AS BIGINT) AS n FROM tuples \
         WHERE study_id = $1 AND kind IN ('control', 'training') GROUP BY kind",
    )
    .bind(study.id.0)
    .fetch_all(&db.pool)
    .await?;
    for r in rows {
        let n = r.try_get::<i64, _>("n")? as usize;
        match r.try_get::<String, _>("kind")?.as_str() {
            "control" => controls = n,
            _ => training = n,
        }
    }
    let mut labels = LabelStats::default();
    let groups = sqlx::query(
        "SELECT style, CAST(COUNT(*) AS BIGINT) AS n FROM items WHERE library_id = $1 \
         GROUP BY style",
    )
    .bind(study.library.0)
    .fetch_all(&db.pool)
    .await?;
    for g in groups {
        let n = g.try_get::<i64, _>("n")? as usize;
        labels.items += n;
        if g.try_get::<Option<String>, _>("style")?.is_some() {
            labels.labelled += n;
            labels.styles += 1;
            labels.largest = labels.largest.max(n);
        }
    }
    Ok(pool_warnings(&study.settings, controls, training, &labels))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_unlabelled_library_warns_of_no_controls_and_no_practice() {
        let settings = StudySettings::default();
        let none = LabelStats {
            items: 30,
            ..LabelStats::default()
        };
        let w = pool_warnings(&settings, 0, 0, &none);
        assert_eq!(w.len(), 2, "{w:?}");
        assert!(w[0].starts_with("No hidden control questions"), "{w:?}");
        assert!(w[0].contains("30 items carry 0 style labels"), "{w:?}");
        assert!(w[0].contains("45 questions instead of 50"), "{w:?}");
        assert!(w[1].starts_with("No practice questions"), "{w:?}");
    }

    #[test]
    fn a_full_pool_has_no_warning_and_a_short_one_says_how_short() {
        let settings = StudySettings::default();
        let labels = LabelStats {
            items: 24,
            labelled: 24,
            styles: 4,
            largest: 6,
        };
        assert!(pool_warnings(&settings, 100, 16, &labels).is_empty());
        let w = pool_warnings(&settings, 2, 1, &labels);
        assert_eq!(
            w,
            [
                "Only 2 control triplets for 5 controls per HIT: each HIT has 2 controls.",
                "Only 1 practice triplets for 3 per attempt: each attempt shows 1."
            ]
        );
        let none = StudySettings {
            controls_per_hit: 0,
            training_questions: 0,
            ..settings
        };
        assert!(pool_warnings(&none, 0, 0, &LabelStats::default()).is_empty());
    }
}

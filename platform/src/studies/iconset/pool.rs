//! An icon-set study's settings and pool in the shared HIT machinery, as the mash-up study's
//! (`crate::studies::mashup::pool`): one HIT is one tray of sets, so each HIT has one question
//! and no hidden controls or practice (a set of icons has no known answer), and each main tuple
//! stands for one worker's tray. Its items are never shown.

use super::IconsetSettings;
use crate::error::{AppError, Result};
use crate::store::ids::ItemId;
use crate::studies::mashup::pool::one_task_per_hit;
use crate::studies::study::{DrawnPool, StudySettings};

/// The instructions of a new icon-set study (the task itself is shown above the tray).
pub const INSTRUCTIONS: &str = "\
You will make **sets of icons**: each set has one icon for every word shown, and all the icons \
of a set must be in **one style** — drawn the same way (colours, shading, outlines, shapes). \
Each set must be in a **different style** from the others.

Pick an icon to put it into its place in the current set; remove it if you change your mind. \
When every place of the set is filled, press **Finish this set**. After the last set, press \
**Submit**.";

/// Trays a new icon-set study collects when `--tuples` is not given.
pub const DEFAULT_TRAYS: u32 = 40;

/// A new icon-set study's settings: one tray per HIT, no controls, practice or "why?"
/// questionnaire, and the study's `iconset` part.
pub fn defaults(iconset: Option<IconsetSettings>) -> StudySettings {
    StudySettings {
        description: "Find sets of icons in one style.".into(),
        instructions: INSTRUCTIONS.into(),
        show_worked_example: false,
        questions_per_hit: 1,
        controls_per_hit: 0,
        training_questions: 0,
        tuples: DEFAULT_TRAYS,
        replication: 1,
        reasons_probability: 0.0,
        iconset,
        ..StudySettings::default()
    }
}

/// Checks that `settings` describe an icon-set study and makes its pool: `settings.tuples`
/// trays over a library whose first item is `placeholder` (stored as the tuples' items, never
/// shown).
pub fn draw(settings: &StudySettings, placeholder: Option<ItemId>) -> Result<DrawnPool> {
    let Some(iconset) = &settings.iconset else {
        return Err(AppError::BadRequest(
            "an icon-set study needs its \"iconset\" settings".into(),
        ));
    };
    iconset.validate()?;
    one_task_per_hit(
        settings,
        placeholder,
        "an icon-set HIT is one tray of sets",
        "the library has no items",
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_pool_has_one_task_per_tray_and_nothing_else() {
        let mut s = defaults(Some(IconsetSettings::default()));
        s.tuples = 5;
        s.validate().unwrap();
        let pool = draw(&s, Some(ItemId(3))).unwrap();
        assert_eq!(pool.main.len(), 5);
        assert!(pool.controls.is_empty() && pool.training.is_empty());
        assert!(draw(&defaults(None), Some(ItemId(3))).is_err());
        let mut two = defaults(Some(IconsetSettings::default()));
        two.questions_per_hit = 2;
        assert!(draw(&two, Some(ItemId(3))).is_err());
    }
}

//! A mash-up study's settings and pool in the shared HIT machinery: one HIT is one composition
//! task, so each HIT has one question and no hidden controls or practice (a free composition
//! has no known answer), and each main tuple stands for one worker's composition. Its items are
//! never shown: the task page shows the canvas, not the tuple.

use super::MashupSettings;
use crate::error::{AppError, Result};
use crate::store::ids::ItemId;
use crate::studies::study::{DrawnPool, NewTuple, StudySettings};

/// The instructions of a new mash-up study (the task text is shown above the canvas).
pub const INSTRUCTIONS: &str = "\
You will put together a **scene** from pieces of clip art, as the task above the canvas says.

Search for pieces with words (and a category if you like), drag them onto the canvas, then \
move, resize or rotate them. When the scene is finished, press **Submit**.";

/// Compositions a new mash-up study collects when `--tuples` is not given.
pub const DEFAULT_COMPOSITIONS: u32 = 40;

/// A new mash-up study's settings: one composition per HIT, no controls, practice or "why?"
/// questionnaire, and the study's `mashup` part.
pub fn defaults(mashup: Option<MashupSettings>) -> StudySettings {
    StudySettings {
        description: "Put together a scene from clip art.".into(),
        instructions: INSTRUCTIONS.into(),
        show_worked_example: false,
        questions_per_hit: 1,
        controls_per_hit: 0,
        training_questions: 0,
        tuples: DEFAULT_COMPOSITIONS,
        replication: 1,
        reasons_probability: 0.0,
        mashup,
        ..StudySettings::default()
    }
}

/// Checks that `settings` describe a mash-up study and makes its pool: `settings.tuples`
/// composition tasks over a library whose first item is `placeholder` (stored as the tuples'
/// items, never shown).
pub fn draw(settings: &StudySettings, placeholder: Option<ItemId>) -> Result<DrawnPool> {
    let Some(mashup) = &settings.mashup else {
        return Err(AppError::BadRequest(
            "a mash-up study needs a task (--task TEXT, or \"mashup\": {\"task\": …} in the \
             settings file)"
                .into(),
        ));
    };
    mashup.validate()?;
    one_task_per_hit(
        settings,
        placeholder,
        "a mash-up HIT is one composition task",
        "the library has no items to compose with",
    )
}

/// The pool of a study whose HIT is one task with no known answer (the mash-up and icon-set
/// studies): `settings.tuples` main tuples of the `placeholder` item, no controls or practice.
/// The HIT shape must say so (`hit` names the task in the message); `no_items` is the message
/// for a library without items.
pub(crate) fn one_task_per_hit(
    settings: &StudySettings,
    placeholder: Option<ItemId>,
    hit: &str,
    no_items: &str,
) -> Result<DrawnPool> {
    let fixed = [
        ("questions_per_hit", settings.questions_per_hit, 1),
        ("controls_per_hit", settings.controls_per_hit, 0),
        ("training_questions", settings.training_questions, 0),
        ("replication", settings.replication, 1),
    ];
    for (field, got, want) in fixed {
        if got != want {
            return Err(AppError::BadRequest(format!(
                "{field}: {got}, but {hit} ({field} = {want})"
            )));
        }
    }
    let Some(item) = placeholder else {
        return Err(AppError::BadRequest(no_items.into()));
    };
    let tuple = NewTuple {
        a: item,
        b: item,
        c: item,
    };
    Ok(DrawnPool {
        main: vec![tuple; settings.tuples as usize],
        ..DrawnPool::default()
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn mashup() -> MashupSettings {
        MashupSettings {
            task: "A day at the beach".into(),
            background: None,
            min_pieces: 2,
            min_searches: 1,
        }
    }

    #[test]
    fn the_pool_has_one_task_per_composition_and_nothing_else() {
        let mut s = defaults(Some(mashup()));
        s.tuples = 6;
        s.validate().unwrap();
        let pool = draw(&s, Some(ItemId(3))).unwrap();
        assert_eq!(pool.main.len(), 6);
        assert!(pool.controls.is_empty() && pool.training.is_empty());
    }

    #[test]
    fn settings_that_do_not_fit_a_composition_task_are_refused() {
        assert!(draw(&defaults(None), Some(ItemId(3))).is_err());
        assert!(draw(&defaults(Some(mashup())), None).is_err());
        for change in [
            |s: &mut StudySettings| s.questions_per_hit = 2,
            |s: &mut StudySettings| s.replication = 2,
            |s: &mut StudySettings| s.training_questions = 1,
        ] {
            let mut s = defaults(Some(mashup()));
            change(&mut s);
            let e = draw(&s, Some(ItemId(3))).unwrap_err();
            assert!(matches!(e, AppError::BadRequest(_)), "{e:?}");
        }
    }
}

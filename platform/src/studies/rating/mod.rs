//! The composition-rating study (2AFC, Garces et al. 2014 §5.7.3, Appendix 5.B): pairs of
//! compositions made in the mash-up study's two conditions — A, results sorted by style; B,
//! results in random order — shown side by side, "Which composition has a more coherent
//! style?" or "Which composition do you like better?".
//!
//! Input: a folder of composition images and a CSV `file,condition,task[,control_expected]`,
//! or the submitted compositions of mash-up studies ([`from_mashup`]).
//! From the CSV, pairs are made within each task, every condition-A composition with every
//! condition-B one.
//! A pair is stored as a tuple with `b` = the A composition and `c` = the B one (`a` = `b`,
//! never shown), so the shared answer path stores `b` when A was chosen; the left/right order
//! is the per-worker random order every question has. Tasks whose rows carry
//! `control_expected` are known-answer pairs (e.g. a deliberately incoherent composition
//! against a coherent one): they become the practice questions and the hidden controls, with
//! the expected composition as `b`, exactly as triplet studies' controls.

use std::collections::{BTreeMap, HashMap};
use std::path::Path;

use rand::SeedableRng;
use rand::seq::SliceRandom;

use crate::error::{AppError, Result};
use crate::store::ids::ItemId;
use crate::studies::study::{DrawnPool, NewTuple, StudySettings, practice_pool_size};

pub mod from_mashup;
mod pairing;
mod report;

pub use pairing::balanced_pairs;
pub use report::{RatingReport, RatingStats, WorkerRate, report};

/// The instructions of a new composition-rating study.
pub const INSTRUCTIONS: &str = "\
Each question shows two **compositions**: scenes put together from pieces of clip art.

Look at both and answer the question above them by clicking or tapping one (on a keyboard: ← or \
1 for the left one, → or 2 for the right one). There are no trick questions: go with your first \
impression.";

/// The search condition a composition was made under.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Condition {
    /// Results sorted by style (the learned metric).
    A,
    /// Results in random order.
    B,
}

/// One row of the compositions CSV.
#[derive(Debug, Clone, PartialEq)]
pub struct CompositionRow {
    /// 1-based line in the file.
    pub line: u64,
    /// The image, relative to the folder (the library item's name).
    pub file: String,
    /// Its condition.
    pub condition: Condition,
    /// The task it was made for (pairs are made within a task).
    pub task: String,
    /// For known-answer tasks: whether this composition is the expected answer.
    pub control_expected: Option<bool>,
}

/// Reads `file,condition,task[,control_expected]`; every bad row is a 400 naming its line.
pub fn read_rows(path: &Path) -> Result<Vec<CompositionRow>> {
    let bad = |m: String| AppError::BadRequest(format!("{}: {m}", path.display()));
    let mut reader = csv::Reader::from_path(path).map_err(|e| bad(e.to_string()))?;
    let headers = reader.headers().map_err(|e| bad(e.to_string()))?.clone();
    let column = |name: &str| headers.iter().position(|h| h.trim() == name);
    let (Some(file_col), Some(condition_col), Some(task_col)) =
        (column("file"), column("condition"), column("task"))
    else {
        return Err(bad("needs 'file', 'condition' and 'task' columns".into()));
    };
    let expected_col = column("control_expected");
    let mut rows = Vec::new();
    for (i, record) in reader.records().enumerate() {
        let line = i as u64 + 2;
        let record = record.map_err(|e| bad(format!("line {line}: {e}")))?;
        let get = |c: usize| record.get(c).unwrap_or_default().trim().to_string();
        let file = get(file_col);
        if file.is_empty() {
            return Err(bad(format!("line {line}: the row names no file")));
        }
        let condition = match get(condition_col).to_ascii_uppercase().as_str() {
            "A" => Condition::A,
            "B" => Condition::B,
            other => {
                return Err(bad(format!(
                    "line {line}: condition {other:?} is not A (style-sorted) or B (random)"
                )));
            }
        };
        let task = get(task_col);
        if task.is_empty() || task.len() > 200 {
            return Err(bad(format!("line {line}: task must be 1-200 characters")));
        }
        let control_expected = match expected_col.map(get).as_deref() {
            None | Some("") => None,
            Some("1" | "yes" | "true") => Some(true),
            Some("0" | "no" | "false") => Some(false),
            Some(other) => {
                return Err(bad(format!(
                    "line {line}: control_expected {other:?} is not 1/0, yes/no or true/false"
                )));
            }
        };
        rows.push(CompositionRow {
            line,
            file,
            condition,
            task,
            control_expected,
        });
    }
    if rows.is_empty() {
        return Err(bad("no rows".into()));
    }
    Ok(rows)
}

/// Makes the study's pool from the rows, `ids` mapping each file to its imported item. Sets
/// nothing in `settings`: the caller sets `tuples` to the number of main pairs.
pub fn draw(
    rows: &[CompositionRow],
    ids: &HashMap<String, ItemId>,
    settings: &StudySettings,
) -> Result<DrawnPool> {
    let mut tasks: BTreeMap<&str, Vec<&CompositionRow>> = BTreeMap::new();
    let mut seen: HashMap<&str, u64> = HashMap::new();
    for row in rows {
        if let Some(first) = seen.insert(&row.file, row.line) {
            return Err(AppError::BadRequest(format!(
                "line {}: {:?} is listed twice (first on line {first})",
                row.line, row.file
            )));
        }
        if !ids.contains_key(&row.file) {
            return Err(AppError::BadRequest(format!(
                "line {}: no imported composition is named {:?}",
                row.line, row.file
            )));
        }
        tasks.entry(&row.task).or_default().push(row);
    }
    let mut main = Vec::new();
    let mut known = Vec::new();
    let mut warnings = Vec::new();
    for (task, members) in &tasks {
        let id = |r: &CompositionRow| ids[&r.file];
        if members.iter().any(|r| r.control_expected.is_some()) {
            let expected: Vec<_> = members
                .iter()
                .filter(|r| r.control_expected == Some(true))
                .collect();
            let others: Vec<_> = members
                .iter()
                .filter(|r| r.control_expected == Some(false))
                .collect();
            if members.len() != 2 || expected.len() != 1 || others.len() != 1 {
                return Err(AppError::BadRequest(format!(
                    "task {task:?}: a known-answer task has exactly two compositions, one \
                     with control_expected 1 and one with 0 (line {})",
                    members[0].line
                )));
            }
            let (right, wrong) = (id(expected[0]), id(others[0]));
            known.push(NewTuple {
                a: right,
                b: right,
                c: wrong,
            });
            continue;
        }
        let of = |c: Condition| members.iter().filter(move |r| r.condition == c);
        let (a_count, b_count) = (of(Condition::A).count(), of(Condition::B).count());
        if a_count == 0 || b_count == 0 {
            warnings.push(format!(
                "task {task:?} has {a_count} condition-A and {b_count} condition-B \
                 compositions: it makes no pair"
            ));
            continue;
        }
        for x in of(Condition::A) {
            for y in of(Condition::B) {
                main.push(NewTuple {
                    a: id(x),
                    b: id(x),
                    c: id(y),
                });
            }
        }
    }
    if main.is_empty() {
        return Err(AppError::BadRequest(
            "no task has both a condition-A and a condition-B composition: there is no pair \
             to rate"
                .into(),
        ));
    }
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(settings.seed);
    main.shuffle(&mut rng);
    known.shuffle(&mut rng);
    // Practice first, as for triplets: a small set still gets its practice.
    let practice = practice_pool_size(settings).min(known.len());
    let training: Vec<NewTuple> = known[..practice].to_vec();
    let controls: Vec<NewTuple> = known[practice..].to_vec();
    if settings.controls_per_hit > 0 && controls.is_empty() {
        warnings.push(format!(
            "controls_per_hit is {} but no known-answer pair is left for hidden controls \
             (add tasks with control_expected)",
            settings.controls_per_hit
        ));
    }
    if settings.training_questions as usize > training.len() {
        warnings.push(format!(
            "training_questions is {} but there are {} known-answer pairs for practice",
            settings.training_questions,
            training.len()
        ));
    }
    Ok(DrawnPool {
        main,
        controls,
        training,
        warnings,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(
        line: u64,
        file: &str,
        condition: Condition,
        task: &str,
        e: Option<bool>,
    ) -> CompositionRow {
        CompositionRow {
            line,
            file: file.into(),
            condition,
            task: task.into(),
            control_expected: e,
        }
    }

    #[test]
    fn pairs_are_made_within_tasks_with_a_as_b() {
        use Condition::*;
        let rows = vec![
            row(2, "a1", A, "farm", None),
            row(3, "a2", A, "farm", None),
            row(4, "b1", B, "farm", None),
            row(5, "a3", A, "city", None),
            row(6, "b3", B, "sea", None),
            row(7, "good", A, "ctl", Some(true)),
            row(8, "bad", B, "ctl", Some(false)),
        ];
        let ids: HashMap<String, ItemId> = rows
            .iter()
            .enumerate()
            .map(|(i, r)| (r.file.clone(), ItemId(i as i64 + 1)))
            .collect();
        let settings = StudySettings {
            training_questions: 0,
            ..StudySettings::default()
        };
        let pool = draw(&rows, &ids, &settings).unwrap();
        let mut pairs: Vec<(i64, i64)> = pool.main.iter().map(|t| (t.b.0, t.c.0)).collect();
        pairs.sort_unstable();
        assert_eq!(pairs, vec![(1, 3), (2, 3)]);
        assert!(pool.main.iter().all(|t| t.a == t.b));
        assert_eq!(pool.controls.len(), 1);
        assert_eq!((pool.controls[0].b.0, pool.controls[0].c.0), (6, 7));
        assert_eq!(pool.warnings.len(), 2, "{:?}", pool.warnings);

        let mut unknown = rows.clone();
        unknown[0].file = "missing".into();
        assert!(draw(&unknown, &ids, &settings).is_err());
        let mut twice = rows.clone();
        twice[1].file = "a1".into();
        assert!(draw(&twice, &ids, &settings).is_err());
        let mut bad_known = rows;
        bad_known[6].control_expected = Some(true);
        assert!(draw(&bad_known, &ids, &settings).is_err());
    }
}

//! `platform study ...`: create, edit and inspect studies.

use std::path::PathBuf;

use clap::Subcommand;

use super::DbArgs;
use crate::error::{AppError, Result};
use crate::store::ids::StudyId;
use crate::studies::kind::{RatingQuestion, StudyKind};
use crate::studies::mashup::{self, MashupSettings};
use crate::studies::study::{self, MturkMode, StudySettings};
use crate::studies::study_edit::{self, SettingsPatch};
use crate::studies::{dashboard, library, rating};

/// A new study's settings before the file and the flags: the paper's triplet defaults, and for
/// a composition rating its own instructions, no reasons questionnaire (its questions are about
/// triplets) and the coherence question.
fn kind_defaults(kind: StudyKind) -> StudySettings {
    match kind {
        StudyKind::CompositionRating => StudySettings {
            description: "Compare two compositions of clip art.".into(),
            instructions: rating::INSTRUCTIONS.into(),
            show_worked_example: false,
            reasons_probability: 0.0,
            question: Some(RatingQuestion::Coherence),
            ..StudySettings::default()
        },
        StudyKind::Mashup => mashup::pool::defaults(None),
        StudyKind::Triplet => StudySettings::default(),
    }
}

/// Imports the compositions into the library `lib`, makes the pairs and stores the study.
async fn rating_pool(
    db: &crate::store::db::Db,
    name: &str,
    lib: &str,
    folder: &std::path::Path,
    csv: &std::path::Path,
    mut s: StudySettings,
) -> Result<study::PendingPool> {
    let rows = rating::read_rows(csv)?;
    let report = library::import_paths(db, lib, &[folder.to_path_buf()], None).await?;
    for (at, why) in &report.skipped {
        eprintln!("skipped {at}: {why}");
    }
    let library = report
        .library
        .ok_or_else(|| AppError::Internal("the import made no library".into()))?;
    let ids = library::list_items(db, library)
        .await?
        .into_iter()
        .map(|i| (i.name, i.id))
        .collect();
    let pool = rating::draw(&rows, &ids, &s)?;
    s.tuples = u32::try_from(pool.main.len()).unwrap_or(u32::MAX);
    study::begin_drawn(db, name, library, StudyKind::CompositionRating, s, pool).await
}

/// `platform study ...`.
#[derive(Debug, Subcommand)]
pub enum StudyCommand {
    /// Create a study and its tuple pool.
    Create {
        /// Database.
        #[command(flatten)]
        db: DbArgs,
        /// Study name.
        #[arg(long)]
        name: String,
        /// Library name.
        #[arg(long, default_value = "default")]
        library: String,
        /// JSON file with settings (missing fields: the paper's defaults); flags override it.
        #[arg(long)]
        settings: Option<PathBuf>,
        /// Questions per HIT.
        #[arg(long)]
        questions_per_hit: Option<u32>,
        /// Hidden controls per HIT.
        #[arg(long)]
        controls_per_hit: Option<u32>,
        /// Main tuples.
        #[arg(long)]
        tuples: Option<u32>,
        /// Replication R.
        #[arg(long)]
        replication: Option<u32>,
        /// MTurk `sandbox` or `live`.
        #[arg(long, value_parser = ["sandbox", "live"])]
        mturk_mode: Option<String>,
        /// Study kind: `triplet` (style triplets), `composition-rating` (2AFC over pairs of
        /// compositions: needs --compositions and --pairs) or `mashup`.
        #[arg(long, default_value = "triplet")]
        kind: String,
        /// composition-rating: the folder of composition images, imported into --library.
        #[arg(long)]
        compositions: Option<PathBuf>,
        /// composition-rating: CSV `file,condition,task[,control_expected]` (file relative to
        /// --compositions, condition A or B; rows with control_expected are known-answer
        /// pairs for practice and hidden controls).
        #[arg(long)]
        pairs: Option<PathBuf>,
        /// composition-rating: `coherence` ("Which composition has a more coherent style?")
        /// or `preference` ("Which composition do you like better?").
        #[arg(long, value_parser = ["coherence", "preference"])]
        question: Option<String>,
        /// mashup: the task shown above the canvas (an open topic or a fixed story).
        #[arg(long)]
        task: Option<String>,
        /// mashup: a fixed background (`blank`, `grass`, …); without it the worker chooses.
        #[arg(long)]
        background: Option<String>,
        /// mashup: pieces the submitted composition must have (default 3).
        #[arg(long)]
        min_pieces: Option<u32>,
        /// mashup: searches the worker must make before submitting (default 1).
        #[arg(long)]
        min_searches: Option<u32>,
    },
    /// Change a study's settings (each change is audited). Fields that only steer what happens
    /// next change at any time; the HIT shape and the MTurk site only while the study has no
    /// assignment; the tuple pool's fields (tuples, replication, seed, training questions)
    /// never.
    Edit {
        /// Database.
        #[command(flatten)]
        db: DbArgs,
        /// Study id.
        id: StudyId,
        /// JSON file with the fields to change (a partial settings object, as the API's
        /// PATCH takes); flags override it.
        #[arg(long, visible_alias = "settings-json")]
        settings: Option<PathBuf>,
        /// Text shown to workers before they start.
        #[arg(long)]
        description: Option<String>,
        /// Training attempts before a worker is screened out.
        #[arg(long)]
        max_training_attempts: Option<u32>,
        /// Probability of the "why?" questionnaire (HITs allocated from now on).
        #[arg(long)]
        reasons_probability: Option<f64>,
        /// Control errors that reject a HIT (HITs completed from now on).
        #[arg(long)]
        reject_at_control_errors: Option<u32>,
        /// Prolific completion code (empty: remove it).
        #[arg(long)]
        prolific_completion_code: Option<String>,
        /// Prolific screen-out code (empty: remove it).
        #[arg(long)]
        prolific_screenout_code: Option<String>,
        /// Prolific no-consent code (empty: remove it).
        #[arg(long)]
        prolific_noconsent_code: Option<String>,
        /// Markdown file with the instructions shown on the start page.
        #[arg(long)]
        instructions_file: Option<PathBuf>,
        /// Markdown file with the informed-consent text (an empty file removes the consent step).
        #[arg(long)]
        consent_file: Option<PathBuf>,
        /// Show the worked example under the instructions (`true` or `false`).
        #[arg(long)]
        show_worked_example: Option<bool>,
        /// Block this worker id (repeatable); added to the study's block list.
        #[arg(long)]
        block_worker: Vec<String>,
        /// Remove this worker id from the block list (repeatable).
        #[arg(long)]
        unblock_worker: Vec<String>,
        /// Exclude the workers of this study (repeatable); added to the list.
        #[arg(long)]
        exclude_workers_of: Vec<StudyId>,
        /// Questions per HIT (only while the study has no assignment).
        #[arg(long)]
        questions_per_hit: Option<u32>,
        /// Hidden controls per HIT (only while the study has no assignment).
        #[arg(long)]
        controls_per_hit: Option<u32>,
        /// MTurk `sandbox` or `live` (only while the study has no assignment).
        #[arg(long, value_parser = ["sandbox", "live"])]
        mturk_mode: Option<String>,
    },
    /// Print a study's dashboard as JSON.
    Status {
        /// Database.
        #[command(flatten)]
        db: DbArgs,
        /// Study id.
        id: StudyId,
    },
}

/// Runs a `platform study` subcommand.
pub async fn run(command: StudyCommand) -> Result<()> {
    match command {
        StudyCommand::Create {
            db,
            name,
            library: lib,
            settings,
            questions_per_hit,
            controls_per_hit,
            tuples,
            replication,
            mturk_mode,
            kind,
            compositions,
            pairs,
            question,
            task,
            background,
            min_pieces,
            min_searches,
        } => {
            let kind = StudyKind::parse(&kind)?;
            let db = db.connect().await?;
            // The kind's defaults, then the file's fields over them.
            let mut base = serde_json::to_value(kind_defaults(kind)).map_err(AppError::internal)?;
            if let Some(path) = settings {
                let text = std::fs::read_to_string(&path)
                    .map_err(|e| AppError::BadRequest(format!("{}: {e}", path.display())))?;
                let file: serde_json::Value = serde_json::from_str(&text)
                    .map_err(|e| AppError::BadRequest(format!("{}: {e}", path.display())))?;
                let Some(fields) = file.as_object() else {
                    return Err(AppError::BadRequest(format!(
                        "{}: settings must be a JSON object",
                        path.display()
                    )));
                };
                if let Some(b) = base.as_object_mut() {
                    b.extend(fields.clone());
                }
            }
            let mut s: StudySettings = serde_json::from_value(base)
                .map_err(|e| AppError::BadRequest(format!("settings: {e}")))?;
            if let Some(q) = question {
                s.question = Some(if q == "preference" {
                    RatingQuestion::Preference
                } else {
                    RatingQuestion::Coherence
                });
            }
            if let Some(v) = questions_per_hit {
                s.questions_per_hit = v;
            }
            if let Some(v) = controls_per_hit {
                s.controls_per_hit = v;
            }
            if let Some(v) = tuples {
                s.tuples = v;
            }
            if let Some(v) = replication {
                s.replication = v;
            }
            if let Some(m) = mturk_mode {
                s.mturk_mode = if m == "live" {
                    MturkMode::Live
                } else {
                    MturkMode::Sandbox
                };
            }
            let mashup_flags = task.is_some()
                || background.is_some()
                || min_pieces.is_some()
                || min_searches.is_some();
            if mashup_flags && kind != StudyKind::Mashup {
                return Err(AppError::BadRequest(
                    "--task, --background, --min-pieces and --min-searches are for --kind mashup"
                        .into(),
                ));
            }
            if kind == StudyKind::Mashup {
                // The flags over the file's `mashup` object (a task from either is needed).
                let mut m = s.mashup.take();
                if let Some(task) = task {
                    m.get_or_insert_with(|| MashupSettings {
                        task: String::new(),
                        background: None,
                        min_pieces: 3,
                        min_searches: 1,
                    })
                    .task = task;
                }
                if let Some(m) = m.as_mut() {
                    m.background = background.or(m.background.take());
                    m.min_pieces = min_pieces.unwrap_or(m.min_pieces);
                    m.min_searches = min_searches.unwrap_or(m.min_searches);
                }
                s.mashup = m;
            }
            let pending = match kind {
                StudyKind::Triplet => {
                    let library = library::ensure_existing(&db, &lib).await?;
                    study::begin(&db, &name, library, s).await?
                }
                StudyKind::CompositionRating => {
                    let (Some(folder), Some(csv)) = (compositions, pairs) else {
                        return Err(AppError::BadRequest(
                            "a composition-rating study needs --compositions DIR and --pairs CSV"
                                .into(),
                        ));
                    };
                    rating_pool(&db, &name, &lib, &folder, &csv, s).await?
                }
                StudyKind::Mashup => {
                    let library = library::ensure_existing(&db, &lib).await?;
                    let first = library::list_items(&db, library)
                        .await?
                        .first()
                        .map(|i| i.id);
                    let pool = mashup::pool::draw(&s, first)?;
                    study::begin_drawn(&db, &name, library, kind, s, pool).await?
                }
            };
            let (id, warnings) = (pending.id, pending.warnings.clone());
            // The pool is written in chunks (a server on the same database keeps answering);
            // a large one reports its progress every tenth.
            let (_, total) = pending.progress();
            let mut shown = 0;
            let pool = pending
                .build(&db, |done, total| {
                    let tenth = done * 10 / total.max(1);
                    if tenth > shown && tenth < 10 {
                        shown = tenth;
                        eprintln!("study {id}: tuple pool {done} of {total} rows written");
                    }
                })
                .await?;
            outln!(
                "study {id}: {} main tuples, {} slots, {} controls, {} training",
                pool.main,
                pool.slots,
                pool.controls,
                pool.training
            )?;
            if total > study::CHUNK_ROWS as i64 {
                eprintln!("study {id}: tuple pool complete ({total} rows); workers can start");
            }
            for w in warnings {
                eprintln!("warning: study {id}: {w}");
            }
            Ok(())
        }
        StudyCommand::Edit {
            db,
            id,
            settings,
            description,
            max_training_attempts,
            reasons_probability,
            reject_at_control_errors,
            prolific_completion_code,
            prolific_screenout_code,
            prolific_noconsent_code,
            instructions_file,
            consent_file,
            show_worked_example,
            block_worker,
            unblock_worker,
            exclude_workers_of,
            questions_per_hit,
            controls_per_hit,
            mturk_mode,
        } => {
            let db = db.connect().await?;
            let mut patch: SettingsPatch = match settings {
                Some(path) => {
                    let text = std::fs::read_to_string(&path)
                        .map_err(|e| AppError::BadRequest(format!("{}: {e}", path.display())))?;
                    serde_json::from_str(&text)
                        .map_err(|e| AppError::BadRequest(format!("{}: {e}", path.display())))?
                }
                None => SettingsPatch::default(),
            };
            // Flags win over the file.
            patch.description = description.or(patch.description);
            patch.max_training_attempts = max_training_attempts.or(patch.max_training_attempts);
            patch.reasons_probability = reasons_probability.or(patch.reasons_probability);
            patch.reject_at_control_errors =
                reject_at_control_errors.or(patch.reject_at_control_errors);
            patch.questions_per_hit = questions_per_hit.or(patch.questions_per_hit);
            patch.controls_per_hit = controls_per_hit.or(patch.controls_per_hit);
            if let Some(m) = mturk_mode {
                patch.mturk_mode = Some(if m == "live" {
                    MturkMode::Live
                } else {
                    MturkMode::Sandbox
                });
            }
            // An empty code removes it (a flag cannot say `null`).
            let code = |c: String| Some(Some(c).filter(|c| !c.is_empty()));
            if let Some(c) = prolific_completion_code {
                patch.prolific_completion_code = code(c);
            }
            if let Some(c) = prolific_screenout_code {
                patch.prolific_screenout_code = code(c);
            }
            if let Some(c) = prolific_noconsent_code {
                patch.prolific_noconsent_code = code(c);
            }
            let markdown = |path: &PathBuf| {
                std::fs::read_to_string(path)
                    .map_err(|e| AppError::BadRequest(format!("{}: {e}", path.display())))
            };
            if let Some(path) = &instructions_file {
                patch.instructions = Some(markdown(path)?);
            }
            if let Some(path) = &consent_file {
                patch.consent = Some(markdown(path)?);
            }
            patch.show_worked_example = show_worked_example.or(patch.show_worked_example);
            // The list flags add to (or remove from) the list the file gives or the study has.
            if !block_worker.is_empty() || !unblock_worker.is_empty() {
                let mut list = match patch.blocked_workers.take() {
                    Some(list) => list,
                    None => study::load(&db, id).await?.settings.blocked_workers,
                };
                for w in block_worker {
                    if !list.contains(&w) {
                        list.push(w);
                    }
                }
                list.retain(|w| !unblock_worker.contains(w));
                patch.blocked_workers = Some(list);
            }
            if !exclude_workers_of.is_empty() {
                let mut list = match patch.exclude_workers_of.take() {
                    Some(list) => list,
                    None => study::load(&db, id).await?.settings.exclude_workers_of,
                };
                for s in exclude_workers_of {
                    if !list.contains(&s) {
                        list.push(s);
                    }
                }
                patch.exclude_workers_of = Some(list);
            }
            let edited = study_edit::edit(&db, id, &patch, "cli").await?;
            if edited.changes.is_empty() {
                outln!("study {id}: no change")?;
            }
            for c in &edited.changes {
                outln!("study {id}: {}: {} -> {}", c.field, c.old, c.new)?;
            }
            Ok(())
        }
        StudyCommand::Status { db, id } => {
            let db = db.connect().await?;
            let s = study::load(&db, id).await?;
            let (d, _) = dashboard::compute(&db, &s).await?;
            outln!(
                "{}",
                serde_json::to_string_pretty(&d).map_err(AppError::internal)?
            )?;
            Ok(())
        }
    }
}

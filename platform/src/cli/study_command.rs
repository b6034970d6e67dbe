//! `platform study ...`: create, edit and inspect studies.

use std::path::PathBuf;

use clap::Subcommand;

use super::DbArgs;
use super::study_create::CreateArgs;
use crate::error::{AppError, Result};
use crate::store::ids::StudyId;
use crate::studies::dashboard;
use crate::studies::study::{self, MturkMode};
use crate::studies::study_edit::{self, SettingsPatch};

/// `platform study ...`.
#[derive(Debug, Subcommand)]
pub enum StudyCommand {
    /// Create a study and its tuple pool.
    Create(CreateArgs),
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
        StudyCommand::Create(args) => super::study_create::run(args).await,
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

//! The command line: one clap `Cli` whose settings all have `--flag` and `PLATFORM_*`
//! environment variables; [`run`] wires them to the library. `main` only parses and reports.

use std::net::SocketAddr;
use std::path::PathBuf;

use clap::{Args, Parser, Subcommand};

use crate::db::{Db, redact};
use crate::error::{AppError, Result};
use crate::export::ExportOptions;
use crate::ids::StudyId;
use crate::study::{MturkMode, StudySettings};
use crate::study_edit::{self, SettingsPatch};
use crate::train::{self, TrainOptions};
use crate::{AppState, admin, bench, dashboard, demo, export, library, study};

/// Rating-study platform for clip-art style similarity.
#[derive(Debug, Parser)]
#[command(name = "platform", version, about)]
pub struct Cli {
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// Subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Run the server.
    Serve(ServerArgs),
    /// A ready-to-use demo: SQLite file, fixture library, a study, an admin, then serve.
    Demo(DemoArgs),
    /// Manage item libraries.
    #[command(subcommand)]
    Library(LibraryCommand),
    /// Manage studies.
    #[command(subcommand)]
    Study(StudyCommand),
    /// Write a study's export files into a folder.
    Export(ExportArgs),
    /// Fit the style metric on a study's answers and store it (with the learner's report)
    /// in the database.
    Train(TrainArgs),
    /// Manage admin accounts.
    #[command(subcommand)]
    Admin(AdminCommand),
    /// Load benchmark against a real server on loopback.
    Bench(bench::BenchArgs),
}

/// Database settings.
#[derive(Debug, Clone, Args)]
pub struct DbArgs {
    /// `sqlite://PATH` (created if missing) or `postgres://USER:PASS@HOST/DB`.
    #[arg(
        long,
        env = "PLATFORM_DATABASE_URL",
        default_value = "sqlite://platform.db"
    )]
    pub database_url: String,
    /// Connection pool size.
    #[arg(long, env = "PLATFORM_MAX_CONNECTIONS", default_value_t = 16)]
    pub max_connections: u32,
}

impl DbArgs {
    /// Connects and migrates.
    pub async fn connect(&self) -> Result<Db> {
        if !(1..=1000).contains(&self.max_connections) {
            return Err(AppError::BadRequest("--max-connections: 1..=1000".into()));
        }
        Db::connect(&self.database_url, self.max_connections).await
    }
}

/// Server settings.
#[derive(Debug, Clone, Args)]
pub struct ServerArgs {
    /// Database.
    #[command(flatten)]
    pub db: DbArgs,
    /// Address to listen on (port 0 picks a free port; the address is printed).
    #[arg(long, env = "PLATFORM_BIND", default_value = "127.0.0.1:8080")]
    pub bind: SocketAddr,
    /// Public base address used in links (default: http://BIND).
    #[arg(long, env = "PLATFORM_PUBLIC_URL")]
    pub public_url: Option<String>,
    /// Mark the session cookie `Secure` (set this behind HTTPS).
    #[arg(long, env = "PLATFORM_SECURE_COOKIES")]
    pub secure_cookies: bool,
    /// Largest accepted request body in bytes (uploads: 50 MB).
    #[arg(long, env = "PLATFORM_MAX_BODY_BYTES", default_value_t = 64 * 1024)]
    pub max_body_bytes: usize,
}

impl ServerArgs {
    /// Binds, prints `listening on http://ADDR`, and returns the listener with its state.
    pub async fn bind(&self, db: Db) -> Result<(tokio::net::TcpListener, AppState)> {
        let listener = tokio::net::TcpListener::bind(self.bind)
            .await
            .map_err(|e| AppError::BadRequest(format!("cannot listen on {}: {e}", self.bind)))?;
        let addr = listener.local_addr().map_err(AppError::internal)?;
        let public = self
            .public_url
            .clone()
            .unwrap_or_else(|| format!("http://{addr}"));
        outln!("listening on http://{addr}")?;
        Ok((
            listener,
            AppState::new(db, public, self.secure_cookies, self.max_body_bytes),
        ))
    }
}

/// `platform demo`.
#[derive(Debug, Clone, Args)]
pub struct DemoArgs {
    /// Server settings (the database defaults to `platform-demo.db` here).
    #[command(flatten)]
    pub server: ServerArgs,
    /// Folder of the fixture clip art (with `labels.csv`).
    #[arg(long, env = "PLATFORM_FIXTURES")]
    pub fixtures: Option<PathBuf>,
    /// Run this many simulated workers (20% spammers) so the dashboard has data, then train
    /// the style metric on their answers.
    #[arg(long, default_value_t = 0)]
    pub simulate: u32,
    /// Set everything up, print the links, and exit without serving.
    #[arg(long)]
    pub no_serve: bool,
}

/// `platform library ...`.
#[derive(Debug, Subcommand)]
pub enum LibraryCommand {
    /// Import SVG/raster folders and Iconify JSON files.
    Import {
        /// Database.
        #[command(flatten)]
        db: DbArgs,
        /// Library name.
        #[arg(long, default_value = "default")]
        name: String,
        /// CSV with `file,style,keywords` columns (style labels feed automatic controls).
        #[arg(long)]
        labels: Option<PathBuf>,
        /// Folders and files.
        #[arg(required = true)]
        paths: Vec<PathBuf>,
    },
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

/// `platform export`.
#[derive(Debug, Args)]
pub struct ExportArgs {
    /// Database.
    #[command(flatten)]
    pub db: DbArgs,
    /// Study id.
    pub id: StudyId,
    /// Output folder.
    #[arg(long)]
    pub out: PathBuf,
    /// Public base address for the ExternalQuestion.
    #[arg(
        long,
        env = "PLATFORM_PUBLIC_URL",
        default_value = "http://127.0.0.1:8080"
    )]
    pub public_url: String,
    /// Include hidden-control answers.
    #[arg(long)]
    pub include_controls: bool,
    /// Include rejected HITs.
    #[arg(long)]
    pub include_rejected: bool,
    /// Include HITs not completed.
    #[arg(long)]
    pub include_incomplete: bool,
    /// Name workers by a pseudonym instead of their crowd platform id and leave out the payment
    /// files (for sharing the data outside the research team).
    #[arg(long)]
    pub pseudonymous: bool,
}

/// `platform train`.
#[derive(Debug, Args)]
pub struct TrainArgs {
    /// Database.
    #[command(flatten)]
    pub db: DbArgs,
    /// Study id.
    pub id: StudyId,
    /// λ of eq. 5.8 (L1 weight); default: chosen by cross-validation.
    #[arg(long)]
    pub lambda: Option<f64>,
    /// Cross-validation folds (grouped by worker when there are enough workers).
    #[arg(long, default_value_t = 5)]
    pub folds: usize,
    /// Also write the report and `model.json` into this folder.
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// `platform admin ...`.
#[derive(Debug, Subcommand)]
pub enum AdminCommand {
    /// Create an admin (or reset its password). The password comes from
    /// `PLATFORM_ADMIN_PASSWORD` or is generated and printed once.
    Create {
        /// Database.
        #[command(flatten)]
        db: DbArgs,
        /// Username.
        #[arg(long, default_value = "admin")]
        username: String,
    },
}

/// Runs a parsed command.
pub async fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Serve(args) => {
            let db = args.db.connect().await?;
            eprintln!("database: {}", redact(&args.db.database_url));
            let (listener, state) = args.bind(db).await?;
            crate::serve(listener, state)
                .await
                .map_err(AppError::internal)
        }
        Command::Demo(args) => demo::run(args).await,
        Command::Library(LibraryCommand::Import {
            db,
            name,
            labels,
            paths,
        }) => {
            let db = db.connect().await?;
            let report = library::import_paths(&db, &name, &paths, labels.as_deref()).await?;
            outln!(
                "imported {} item(s) into '{name}' ({} already present, {} skipped)",
                report.imported,
                report.existing,
                report.skipped.len()
            )?;
            for (location, why) in &report.skipped {
                eprintln!("skipped {location}: {why}");
            }
            Ok(())
        }
        Command::Study(StudyCommand::Create {
            db,
            name,
            library: lib,
            settings,
            questions_per_hit,
            controls_per_hit,
            tuples,
            replication,
            mturk_mode,
        }) => {
            let db = db.connect().await?;
            let mut s: StudySettings = match settings {
                Some(path) => {
                    let text = std::fs::read_to_string(&path)
                        .map_err(|e| AppError::BadRequest(format!("{}: {e}", path.display())))?;
                    serde_json::from_str(&text)
                        .map_err(|e| AppError::BadRequest(format!("{}: {e}", path.display())))?
                }
                None => StudySettings::default(),
            };
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
            let library = library::ensure_existing(&db, &lib).await?;
            let (id, pool) = study::create(&db, &name, library, s).await?;
            outln!(
                "study {id}: {} main tuples, {} slots, {} controls, {} training",
                pool.main,
                pool.slots,
                pool.controls,
                pool.training
            )?;
            Ok(())
        }
        Command::Study(StudyCommand::Edit {
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
        }) => {
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
        Command::Study(StudyCommand::Status { db, id }) => {
            let db = db.connect().await?;
            let s = study::load(&db, id).await?;
            let (d, _) = dashboard::compute(&db, &s).await?;
            outln!(
                "{}",
                serde_json::to_string_pretty(&d).map_err(AppError::internal)?
            )?;
            Ok(())
        }
        Command::Export(args) => {
            let db = args.db.connect().await?;
            let s = study::load(&db, args.id).await?;
            let opts = ExportOptions {
                include_controls: args.include_controls,
                include_rejected: args.include_rejected,
                include_incomplete: args.include_incomplete,
                pseudonymous: args.pseudonymous,
            };
            let files = export::write_dir(&db, &s, opts, &args.public_url, &args.out).await?;
            outln!("wrote {} to {}", files.join(", "), args.out.display())?;
            Ok(())
        }
        Command::Train(args) => {
            let db = args.db.connect().await?;
            let s = study::load(&db, args.id).await?;
            let opts = TrainOptions {
                lambda: args.lambda,
                folds: args.folds,
            };
            eprintln!("training the style metric of study {} …", s.id);
            let m = train::run(&db, &s, opts).await?;
            let pct =
                |v: Option<f64>| v.map_or_else(|| "–".into(), |v| format!("{:.1}%", 100.0 * v));
            outln!(
                "model {}: {} answers, λ = {:.4}, {} of 169 weights non-zero; agreement with the \
                 answers {} (uniform weights {}), held-out {}",
                m.id,
                m.triplets.unwrap_or(0),
                m.lambda.unwrap_or(f64::NAN),
                m.nonzero.unwrap_or(0),
                pct(m.train_accuracy),
                pct(m.uniform_accuracy),
                pct(m.cv_accuracy),
            )?;
            if let Some(note) = &m.message {
                outln!("note: {note}")?;
            }
            if let Some(dir) = &args.out {
                std::fs::create_dir_all(dir)
                    .map_err(|e| AppError::BadRequest(format!("{}: {e}", dir.display())))?;
                for name in train::file_names(&db, s.id, m.id).await? {
                    let (_, bytes) = train::file(&db, s.id, m.id, &name).await?;
                    std::fs::write(dir.join(&name), bytes)
                        .map_err(|e| AppError::BadRequest(format!("{}: {e}", dir.display())))?;
                }
                outln!("report: {}", dir.join("index.html").display())?;
            }
            outln!("shown at /admin/studies/{}/models/{}/report/", s.id, m.id)?;
            Ok(())
        }
        Command::Admin(AdminCommand::Create { db, username }) => {
            let db = db.connect().await?;
            let (password, generated) = match std::env::var("PLATFORM_ADMIN_PASSWORD") {
                Ok(p) if !p.is_empty() => (p, false),
                _ => (demo::generate_password(), true),
            };
            admin::create_admin(&db, &username, &password).await?;
            if generated {
                outln!("admin '{username}' password (shown once): {password}")?;
            } else {
                outln!("admin '{username}' created")?;
            }
            Ok(())
        }
        Command::Bench(args) => bench::run(args).await,
    }
}

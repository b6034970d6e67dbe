//! The command line: one clap `Cli` whose settings all have `--flag` and `PLATFORM_*`
//! environment variables; [`run`] wires them to the library. `main` only parses and reports.

use std::net::SocketAddr;
use std::path::PathBuf;

use clap::{Args, Parser, Subcommand};

use crate::AppState;
use crate::error::{AppError, Result};
use crate::store::db::{Db, redact};
use crate::store::ids::StudyId;
use crate::studies::export::ExportOptions;
use crate::studies::study;
use crate::studies::train::{self, TrainOptions};
use crate::studies::{export, library};
use crate::web::admin;

pub mod bench;
pub mod demo;

mod study_command;
mod study_create;
pub use study_command::StudyCommand;

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
    // Its own database by default, so that trying the demo never touches `platform.db`; set
    // here so that `demo --help` shows the file it really uses.
    #[command(mut_arg("database_url", |a| a.default_value(DEMO_DATABASE_URL)))]
    Demo(DemoArgs),
    /// Manage item libraries.
    #[command(subcommand)]
    Library(LibraryCommand),
    /// Manage studies.
    #[command(subcommand)]
    Study(Box<StudyCommand>),
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

/// The demo's database when neither `--database-url` nor `PLATFORM_DATABASE_URL` is given.
pub const DEMO_DATABASE_URL: &str = "sqlite://platform-demo.db";

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
    /// Largest accepted request body in bytes (item uploads have their own limit: 5 MB per file,
    /// 20 files per upload).
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
        outln!("listening on http://{addr}")?;
        Ok((
            listener,
            AppState::new(
                db,
                self.public_base(addr),
                self.secure_cookies,
                self.max_body_bytes,
            ),
        ))
    }

    /// The base address of links: `--public-url`, else `http://ADDR` of the bound address.
    pub fn public_base(&self, addr: SocketAddr) -> String {
        self.public_url
            .clone()
            .unwrap_or_else(|| format!("http://{addr}"))
    }
}

/// `platform demo`.
#[derive(Debug, Clone, Args)]
pub struct DemoArgs {
    /// Server settings (the database defaults to [`DEMO_DATABASE_URL`] here).
    #[command(flatten)]
    pub server: ServerArgs,
    /// Folder of the fixture clip art (with `labels.csv`).
    #[arg(long, env = "PLATFORM_FIXTURES")]
    pub fixtures: Option<PathBuf>,
    /// Run this many simulated workers (20% spammers) so the dashboard has data, then train
    /// the style metric on their answers.
    #[arg(long, default_value_t = 0)]
    pub simulate: u32,
    /// Seed of the simulated workers (default: the clock, so that every run adds new workers).
    #[arg(long)]
    pub seed: Option<u64>,
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
            for warning in &report.warnings {
                eprintln!("warning: {warning}");
            }
            // An import that stored nothing (no usable item, nothing already there) is a
            // failure a script must see.
            if report.imported == 0 && report.existing == 0 {
                return Err(AppError::BadRequest(format!(
                    "nothing imported from {}: no usable item found",
                    paths
                        .iter()
                        .map(|p| p.display().to_string())
                        .collect::<Vec<_>>()
                        .join(", ")
                )));
            }
            Ok(())
        }
        Command::Study(command) => study_command::run(*command).await,
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
            outln!("{}", m.describe())?;
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

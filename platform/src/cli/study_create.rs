//! `platform study create`: a study of any kind and its tuple pool.

use std::path::PathBuf;

use clap::Args;

use super::DbArgs;
use crate::error::{AppError, Result};
use crate::store::ids::StudyId;
use crate::studies::iconset::{self, IconsetSettings};
use crate::studies::kind::{RatingQuestion, StudyKind};
use crate::studies::mashup::{self, MashupSettings};
use crate::studies::study::{self, MturkMode, StudySettings};
use crate::studies::{library, rating};

/// The flags of `platform study create`.
#[derive(Debug, Args)]
pub struct CreateArgs {
    /// Database.
    #[command(flatten)]
    db: DbArgs,
    /// Study name.
    #[arg(long)]
    name: String,
    /// Library name (default `default`; with --from-mashup, `mashup-ID-compositions`, where
    /// the rendered compositions are stored).
    #[arg(long)]
    library: Option<String>,
    /// JSON file with settings (missing fields: the paper's defaults); flags override it.
    #[arg(long)]
    settings: Option<PathBuf>,
    /// Questions per HIT.
    #[arg(long)]
    questions_per_hit: Option<u32>,
    /// Hidden controls per HIT.
    #[arg(long)]
    controls_per_hit: Option<u32>,
    /// Main tuples (with --from-mashup: the pairs made from each mash-up study).
    #[arg(long)]
    tuples: Option<u32>,
    /// Replication R.
    #[arg(long)]
    replication: Option<u32>,
    /// Seed of the tuple generation (below 2^53).
    #[arg(long)]
    seed: Option<u64>,
    /// MTurk `sandbox` or `live`.
    #[arg(long, value_parser = ["sandbox", "live"])]
    mturk_mode: Option<String>,
    /// Study kind: `triplet` (style triplets), `composition-rating` (2AFC over pairs of
    /// compositions: needs --from-mashup, or --compositions and --pairs), `mashup` or
    /// `iconset` (sets of icons in one style, with the explorer or the search).
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
    /// composition-rating: the mash-up study whose submitted compositions are rendered and
    /// paired, A with B (repeatable: pairs stay within each mash-up study's task).
    #[arg(long)]
    from_mashup: Vec<StudyId>,
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
    /// iconset: the labels of a set's slots, comma-separated (items' style labels; default
    /// face,fish,flower,bird).
    #[arg(long)]
    labels: Option<String>,
    /// iconset: sets per HIT, each in another style (default 4).
    #[arg(long)]
    sets: Option<u32>,
    /// iconset: the model ordering the search and shaping the explorer: a model id,
    /// `uniform`, or by default the newest trained model over the library.
    #[arg(long)]
    model: Option<String>,
    /// iconset: κ of the explorer's taxonomy (a representative style's branch holds more than
    /// κ items; default 20).
    #[arg(long)]
    kappa: Option<usize>,
    /// iconset: τ of the explorer's taxonomy (more than τ items of every label; default 2).
    #[arg(long)]
    tau: Option<usize>,
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

/// Checks an icon-set study's settings against the library, computes condition A's explorer
/// (so that no HIT waits on it) and stores the study with it.
async fn iconset_study(
    db: &crate::store::db::Db,
    name: &str,
    lib: &str,
    s: StudySettings,
) -> Result<study::PendingPool> {
    let library = library::ensure_existing(db, lib).await?;
    let first = library::list_items(db, library)
        .await?
        .first()
        .map(|i| i.id);
    let pool = iconset::pool::draw(&s, first)?;
    let settings: &IconsetSettings = s
        .iconset
        .as_ref()
        .ok_or_else(|| AppError::Internal("no iconset settings".into()))?;
    let cache = crate::search::IndexCache::default();
    let explorer = iconset::explorer::compute(db, &cache, library, settings).await?;
    let pending = study::begin_drawn(db, name, library, StudyKind::Iconset, s, pool).await?;
    iconset::explorer::store(db, pending.id, &explorer).await?;
    eprintln!(
        "study {}: explorer of {} representative styles over {} items ({} in no style)",
        pending.id,
        explorer.styles.len(),
        explorer.items,
        explorer.unassigned
    );
    Ok(pending)
}

/// The defaults, then the settings file's fields over them.
fn base_settings(defaults: StudySettings, file: Option<&PathBuf>) -> Result<StudySettings> {
    let mut base = serde_json::to_value(defaults).map_err(AppError::internal)?;
    if let Some(path) = file {
        let text = std::fs::read_to_string(path)
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
    serde_json::from_value(base).map_err(|e| AppError::BadRequest(format!("settings: {e}")))
}

/// Refuses flags of one kind given to another, and the two inputs of a rating study together.
fn check_flags(a: &CreateArgs, kind: StudyKind) -> Result<()> {
    let bad = |m: &str| Err(AppError::BadRequest(m.into()));
    let mashup_flags = a.task.is_some()
        || a.background.is_some()
        || a.min_pieces.is_some()
        || a.min_searches.is_some();
    if mashup_flags && kind != StudyKind::Mashup {
        return bad("--task, --background, --min-pieces and --min-searches are for --kind mashup");
    }
    let iconset_flags = a.labels.is_some()
        || a.sets.is_some()
        || a.model.is_some()
        || a.kappa.is_some()
        || a.tau.is_some();
    if iconset_flags && kind != StudyKind::Iconset {
        return bad("--labels, --sets, --model, --kappa and --tau are for --kind iconset");
    }
    let rating_inputs = a.compositions.is_some() || a.pairs.is_some() || !a.from_mashup.is_empty();
    if rating_inputs && kind != StudyKind::CompositionRating {
        return bad("--compositions, --pairs and --from-mashup are for --kind composition-rating");
    }
    if !a.from_mashup.is_empty() && (a.compositions.is_some() || a.pairs.is_some()) {
        return bad(
            "--from-mashup takes the compositions of a mash-up study; --compositions and \
             --pairs take them from a folder: give one or the other",
        );
    }
    Ok(())
}

/// Runs `platform study create`.
pub async fn run(a: CreateArgs) -> Result<()> {
    let kind = StudyKind::parse(&a.kind)?;
    check_flags(&a, kind)?;
    let db = a.db.connect().await?;
    let mut defaults = kind.default_settings();
    if !a.from_mashup.is_empty() {
        rating::from_mashup::no_known_answers(&mut defaults);
    }
    let mut s = base_settings(defaults, a.settings.as_ref())?;
    if let Some(q) = &a.question {
        s.question = Some(if q == "preference" {
            RatingQuestion::Preference
        } else {
            RatingQuestion::Coherence
        });
    }
    s.questions_per_hit = a.questions_per_hit.unwrap_or(s.questions_per_hit);
    s.controls_per_hit = a.controls_per_hit.unwrap_or(s.controls_per_hit);
    s.tuples = a.tuples.unwrap_or(s.tuples);
    s.replication = a.replication.unwrap_or(s.replication);
    s.seed = a.seed.unwrap_or(s.seed);
    if let Some(m) = &a.mturk_mode {
        s.mturk_mode = if m == "live" {
            MturkMode::Live
        } else {
            MturkMode::Sandbox
        };
    }
    if kind == StudyKind::Mashup {
        // The flags over the file's `mashup` object (a task from either is needed).
        let mut m = s.mashup.take();
        if let Some(task) = a.task {
            m.get_or_insert_with(|| MashupSettings {
                task: String::new(),
                background: None,
                min_pieces: 3,
                min_searches: 1,
            })
            .task = task;
        }
        if let Some(m) = m.as_mut() {
            m.background = a.background.or(m.background.take());
            m.min_pieces = a.min_pieces.unwrap_or(m.min_pieces);
            m.min_searches = a.min_searches.unwrap_or(m.min_searches);
        }
        s.mashup = m;
    }
    let lib_name = a.library.clone().unwrap_or_else(|| "default".into());
    if kind == StudyKind::Iconset {
        let mut i = s.iconset.take().unwrap_or_default();
        if let Some(labels) = &a.labels {
            i.labels = labels.split(',').map(|l| l.trim().to_string()).collect();
        }
        i.sets = a.sets.unwrap_or(i.sets);
        i.kappa = a.kappa.unwrap_or(i.kappa);
        i.tau = a.tau.unwrap_or(i.tau);
        if a.model.is_some() || i.model.is_none() {
            // A model id, `uniform`, or the newest finished model over the library.
            i.model = crate::explore::resolve(&db, &lib_name, a.model.as_deref())
                .await?
                .1;
        }
        s.iconset = Some(i);
    }
    let lib = a
        .library
        .clone()
        .unwrap_or_else(|| match a.from_mashup.first() {
            Some(id) => format!("mashup-{id}-compositions"),
            None => "default".into(),
        });
    let pending = match kind {
        StudyKind::Triplet => {
            let library = library::ensure_existing(&db, &lib).await?;
            study::begin(&db, &a.name, library, s).await?
        }
        StudyKind::CompositionRating if !a.from_mashup.is_empty() => {
            rating::from_mashup::create(&db, &a.name, &lib, &a.from_mashup, a.tuples, s).await?
        }
        StudyKind::CompositionRating => {
            let (Some(folder), Some(csv)) = (&a.compositions, &a.pairs) else {
                return Err(AppError::BadRequest(
                    "a composition-rating study needs --from-mashup STUDY_ID, or \
                     --compositions DIR and --pairs CSV"
                        .into(),
                ));
            };
            rating_pool(&db, &a.name, &lib, folder, csv, s).await?
        }
        StudyKind::Mashup => {
            let library = library::ensure_existing(&db, &lib).await?;
            let first = library::list_items(&db, library)
                .await?
                .first()
                .map(|i| i.id);
            let pool = mashup::pool::draw(&s, first)?;
            study::begin_drawn(&db, &a.name, library, kind, s, pool).await?
        }
        StudyKind::Iconset => iconset_study(&db, &a.name, &lib, s).await?,
    };
    let (id, warnings) = (pending.id, pending.warnings.clone());
    // The pool is written in chunks (a server on the same database keeps answering); a large
    // one reports its progress every tenth.
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

//! A composition-rating study made from mash-up studies (§5.7.3): the compositions workers
//! submitted are rendered with the server renderer (`crate::mashup::render`, the same picture
//! as the canvas's PNG export) into items of the rating study's library, and condition-A
//! compositions are paired with condition-B ones of the same mash-up study — one task, so an
//! open topic or a fixed story is only ever compared with itself — by [`balanced_pairs`].
//!
//! As for the CSV input, a pair is a tuple with `b` = the A composition and `c` = the B one
//! (`a` = `b`, never shown); the side each is shown on is the per-question random left/right
//! order of the shared HIT machinery. Mash-up compositions carry no known answer, so such a
//! study has no practice or hidden controls of its own (the warnings say so).

use sqlx::Row;

use super::pairing::balanced_pairs;
use crate::error::{AppError, Result};
use crate::mashup::{render, store};
use crate::store::db::Db;
use crate::store::ids::{CompositionId, ItemId, LibraryId, StudyId};
use crate::studies::kind::StudyKind;
use crate::studies::library::{self, Inserted, NewItem};
use crate::studies::mashup::Condition;
use crate::studies::study::{self, DrawnPool, NewTuple, PendingPool, StudySettings};

/// The defaults of a rating study made from mash-up compositions, which carry no known answer:
/// no hidden controls and no practice (a settings file or flags may still ask for them, and
/// get a warning).
pub fn no_known_answers(s: &mut StudySettings) {
    s.controls_per_hit = 0;
    s.training_questions = 0;
}

/// The submitted compositions of one mash-up study, per condition (by composition id).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Submissions {
    /// The mash-up study.
    pub study: StudyId,
    /// Its library (the clip art the pieces come from).
    pub library: LibraryId,
    /// Condition A (style-sorted results).
    pub a: Vec<CompositionId>,
    /// Condition B (random order).
    pub b: Vec<CompositionId>,
}

/// The submissions of mash-up study `id`; a 400 naming the study when it does not exist, is
/// another kind, or has no submitted composition in one of the conditions.
pub async fn submissions(db: &Db, id: StudyId) -> Result<Submissions> {
    let s = match study::load(db, id).await {
        Ok(s) => s,
        Err(AppError::NotFound(_)) => {
            return Err(AppError::BadRequest(format!(
                "from mash-up: there is no study {id}"
            )));
        }
        Err(e) => return Err(e),
    };
    if s.kind != StudyKind::Mashup {
        return Err(AppError::BadRequest(format!(
            "from mash-up: study {id} ({:?}) is a {} study, not a mash-up study",
            s.name, s.kind
        )));
    }
    let rows = sqlx::query(
        "SELECT c.condition, s.composition_id FROM mashup_conditions c \
         JOIN mashup_submissions s ON s.assignment_id = c.assignment_id \
         WHERE c.study_id = $1 ORDER BY s.composition_id",
    )
    .bind(id.0)
    .fetch_all(&db.pool)
    .await?;
    let (mut a, mut b) = (Vec::new(), Vec::new());
    for r in rows {
        let composition = CompositionId(r.try_get("composition_id")?);
        match Condition::from_stored(&r.try_get::<String, _>("condition")?)? {
            Condition::A => a.push(composition),
            Condition::B => b.push(composition),
        }
    }
    if a.is_empty() || b.is_empty() {
        return Err(AppError::BadRequest(format!(
            "from mash-up: study {id} ({:?}) has {} submitted compositions in condition A and \
             {} in condition B; a pair needs one of each",
            s.name,
            a.len(),
            b.len()
        )));
    }
    Ok(Submissions {
        study: id,
        library: s.library,
        a,
        b,
    })
}

/// The item of `library` called `name`, if any.
async fn item_named(db: &Db, library: LibraryId, name: &str) -> Result<Option<ItemId>> {
    let row = sqlx::query("SELECT id FROM items WHERE library_id = $1 AND name = $2")
        .bind(library.0)
        .bind(name)
        .fetch_optional(&db.pool)
        .await?;
    row.map(|r| Ok(ItemId(r.try_get("id")?))).transpose()
}

/// Renders composition `id` of mash-up study `study` into `library` (once: a second rating
/// study over the same compositions, e.g. the other question, reuses the items).
async fn render_item(
    db: &Db,
    library: LibraryId,
    study: StudyId,
    id: CompositionId,
) -> Result<ItemId> {
    let name = format!("mashup-{study}-composition-{id}");
    if let Some(item) = item_named(db, library, &name).await? {
        return Ok(item);
    }
    let doc = store::get(db, id).await?.document;
    let sources = render::load_sources(db, &doc).await?;
    let svg = render::svg(&doc, &sources)?;
    let (image, svg) = tokio::task::spawn_blocking(move || {
        let image = learner::render::render_svg(svg.as_bytes())?;
        let source = library::svg_source(svg.as_bytes())?;
        Ok::<_, learner::Error>((image, source))
    })
    .await
    .map_err(AppError::internal)?
    .map_err(|e| AppError::internal(format!("composition {id}: {e}")))?;
    let item = NewItem {
        name: name.clone(),
        style: None,
        tags: Vec::new(),
        image,
        cutout: None,
        svg: Some(svg),
    };
    match library::insert_item(db, library, item).await? {
        Inserted::New(item) => Ok(item),
        Inserted::AlreadyPresent => item_named(db, library, &name)
            .await?
            .ok_or_else(|| AppError::internal(format!("item {name} vanished"))),
        Inserted::Unusable(why) => Err(AppError::BadRequest(format!(
            "from mash-up: composition {id} of study {study} cannot be rated: {why}"
        ))),
    }
}

/// Makes a composition-rating study `name` in the library `library_name` from the mash-up
/// studies `sources`: `pairs` pairs per mash-up study (default: as many as its larger
/// condition has compositions, so every composition is rated), drawn with `settings.seed`.
/// Everything that can be refused is checked before an item is rendered.
pub async fn create(
    db: &Db,
    name: &str,
    library_name: &str,
    sources: &[StudyId],
    pairs: Option<u32>,
    mut settings: StudySettings,
) -> Result<PendingPool> {
    if sources.is_empty() {
        return Err(AppError::BadRequest(
            "from mash-up: name at least one mash-up study".into(),
        ));
    }
    // The name is checked again when the study is stored; here so that a bad one renders
    // nothing.
    if name.trim().is_empty() || name.trim().len() > 200 {
        return Err(AppError::BadRequest("name: 1-200 characters".into()));
    }
    let mut all = Vec::new();
    for (i, &id) in sources.iter().enumerate() {
        if sources[..i].contains(&id) {
            return Err(AppError::BadRequest(format!(
                "from mash-up: study {id} is named twice"
            )));
        }
        all.push(submissions(db, id).await?);
    }
    let mut counts = Vec::new();
    for s in &all {
        let (m, n) = (s.a.len(), s.b.len());
        let count = pairs.map_or(m.max(n), |p| p as usize);
        if count == 0 || count > m * n {
            return Err(AppError::BadRequest(format!(
                "tuples: {count} pairs from mash-up study {}, whose {m} condition-A and {n} \
                 condition-B compositions make 1..={} distinct pairs",
                s.study,
                m * n
            )));
        }
        counts.push(count);
    }
    settings.tuples = u32::try_from(counts.iter().sum::<usize>()).unwrap_or(u32::MAX);
    settings.validate()?;
    let library = library::ensure_library(db, library_name).await?;
    if let Some(s) = all.iter().find(|s| s.library == library) {
        return Err(AppError::BadRequest(format!(
            "library: {library_name:?} holds the clip art of mash-up study {}; the rendered \
             compositions need a library of their own (they would appear in its search)",
            s.study
        )));
    }
    let mut main = Vec::new();
    for (s, &count) in all.iter().zip(&counts) {
        let (mut a, mut b) = (Vec::new(), Vec::new());
        for &c in &s.a {
            a.push(render_item(db, library, s.study, c).await?);
        }
        for &c in &s.b {
            b.push(render_item(db, library, s.study, c).await?);
        }
        // Each mash-up study gets its own stream of the seed.
        let seed = settings.seed ^ (s.study.0 as u64).rotate_left(17);
        for (x, y) in balanced_pairs(&a, &b, count, seed)? {
            main.push(NewTuple { a: x, b: x, c: y });
        }
    }
    let mut warnings = Vec::new();
    if settings.controls_per_hit > 0 {
        warnings.push(format!(
            "controls_per_hit is {} but mash-up compositions carry no known answer: the HITs \
             have no hidden controls (set controls_per_hit to 0, or use --compositions and \
             --pairs with control_expected rows)",
            settings.controls_per_hit
        ));
    }
    if settings.training_questions > 0 {
        warnings.push(format!(
            "training_questions is {} but mash-up compositions carry no known answer: there \
             is no practice",
            settings.training_questions
        ));
    }
    let pool = DrawnPool {
        main,
        warnings,
        ..DrawnPool::default()
    };
    study::begin_drawn(
        db,
        name,
        library,
        StudyKind::CompositionRating,
        settings,
        pool,
    )
    .await
}

//! Studies: settings (the paper's defaults), creation of the tuple pool (uniform random main
//! triplets with R slots each, automatic controls and training triplets from style groups) and
//! curated controls.

use std::collections::{BTreeMap, HashMap, HashSet};

use rand::seq::{IndexedRandom, SliceRandom};
use rand::{Rng, SeedableRng};
use serde::{Deserialize, Serialize};
use sqlx::Row;

use crate::db::{Db, WriteTx, now_ms};
use crate::error::{AppError, Result};
use crate::ids::{ID_LIMIT, ItemId, LibraryId, SlotId, StudyId, TupleId, random_token};
use crate::library::{self, ItemInfo};

/// Which MTurk site a study's HITs live on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, utoipa::ToSchema)]
#[serde(rename_all = "lowercase")]
pub enum MturkMode {
    /// workersandbox.mturk.com: no money changes hands.
    Sandbox,
    /// www.mturk.com.
    Live,
}

impl MturkMode {
    /// Where the ExternalQuestion form posts to.
    pub fn submit_host(self) -> &'static str {
        match self {
            Self::Sandbox => "https://workersandbox.mturk.com",
            Self::Live => "https://www.mturk.com",
        }
    }
}

/// The largest control-error threshold (a HIT has at most 499 controls).
pub const MAX_CONTROL_ERRORS: u32 = 500;

/// A study's settings. `Default` is the paper's set-up (Garces et al. 2014 §5.4).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, utoipa::ToSchema)]
#[serde(default, deny_unknown_fields)]
pub struct StudySettings {
    /// Text shown to workers before they start (plain text; also MTurk's preview).
    #[schema(max_length = 5000)]
    pub description: String,
    /// Instructions shown on the start page (Markdown without raw HTML; `![caption](item:NAME)`
    /// shows the library item NAME).
    #[schema(max_length = 20000)]
    pub instructions: String,
    /// Show a worked example (a practice triplet with its answer) under the instructions, as
    /// the thesis does before the test (Fig. 5.2, left).
    pub show_worked_example: bool,
    /// Informed-consent text (Markdown without raw HTML). Not empty: workers must tick "I
    /// agree" before they start; declining ends the task and is recorded.
    #[schema(max_length = 20000)]
    pub consent: String,
    /// Questions in one HIT, controls included (paper: 50).
    #[schema(minimum = 1, maximum = 500)]
    pub questions_per_hit: u32,
    /// Hidden control questions in one HIT (paper: 5); fewer than `questions_per_hit`.
    #[schema(minimum = 0, maximum = 499)]
    pub controls_per_hit: u32,
    /// Training triplets that must all be answered correctly first.
    #[schema(minimum = 0, maximum = 20)]
    pub training_questions: u32,
    /// Training attempts before the worker is screened out.
    #[schema(minimum = 1, maximum = 100)]
    pub max_training_attempts: u32,
    /// Main tuples to generate.
    #[schema(minimum = 1, maximum = 1_000_000)]
    pub tuples: u32,
    /// Distinct workers per main tuple (R; the paper's test set used 10).
    #[schema(minimum = 1, maximum = 100)]
    pub replication: u32,
    /// Probability of the "why did you choose?" questionnaire after a question (2016: 0.1).
    #[schema(minimum = 0, maximum = 1)]
    pub reasons_probability: f64,
    /// A HIT with at least this many control errors is rejected (paper: 2).
    #[schema(minimum = 1, maximum = 500)]
    pub reject_at_control_errors: u32,
    /// MTurk sandbox or live.
    pub mturk_mode: MturkMode,
    /// Prolific completion code (configured on Prolific) for the completion redirect.
    #[schema(value_type = Option<crate::api::schema::ProlificCode>)]
    pub prolific_completion_code: Option<String>,
    /// Prolific screen-out code for workers who give up the training.
    #[schema(value_type = Option<crate::api::schema::ProlificCode>)]
    pub prolific_screenout_code: Option<String>,
    /// Prolific code for participants who do not consent (a code set up on Prolific to ask
    /// them to return the study); without it they are asked to return the study.
    #[schema(value_type = Option<crate::api::schema::ProlificCode>)]
    pub prolific_noconsent_code: Option<String>,
    /// Worker ids (MTurk/Prolific/direct) that may not take part.
    #[schema(value_type = Vec<crate::api::schema::BlockedWorker>, max_items = 100_000)]
    pub blocked_workers: Vec<String>,
    /// Workers who took part in these studies may not take part.
    #[schema(max_items = 1000)]
    pub exclude_workers_of: Vec<StudyId>,
    /// Seed of the tuple generation (below 2^53, so JavaScript reads it exactly).
    #[schema(minimum = 0, maximum = 9_007_199_254_740_991_u64)]
    pub seed: u64,
}

/// The instructions of a new study: what the task is and what "style" means here.
pub const DEFAULT_INSTRUCTIONS: &str = "\
Each question shows one picture on top, the **reference**, and two pictures below it.

**Choose the picture below that is more similar in _style_ to the reference** — not the one \
that shows the same thing. Style is *how* a picture is drawn:

- **colours** — palette, saturation, brightness;
- **shading** — flat colour or gradients and highlights;
- **outlines** — thick, thin or none;
- **shapes** — round or angular, simple or detailed.

Click or tap a picture (on a keyboard: ← or 1 for the left one, → or 2 for the right one). \
There are no trick questions: go with your first impression.";

impl Default for StudySettings {
    fn default() -> Self {
        Self {
            description: "Compare the style of clip art.".into(),
            instructions: DEFAULT_INSTRUCTIONS.into(),
            show_worked_example: true,
            consent: String::new(),
            questions_per_hit: 50,
            controls_per_hit: 5,
            training_questions: 3,
            max_training_attempts: 5,
            tuples: 1000,
            replication: 1,
            reasons_probability: 0.1,
            reject_at_control_errors: 2,
            mturk_mode: MturkMode::Sandbox,
            prolific_completion_code: None,
            prolific_screenout_code: None,
            prolific_noconsent_code: None,
            blocked_workers: Vec::new(),
            exclude_workers_of: Vec::new(),
            seed: 1,
        }
    }
}

impl StudySettings {
    /// Checks every field; the message names the offending one.
    pub fn validate(&self) -> Result<()> {
        let bad = |m: String| Err(AppError::BadRequest(m));
        if self.description.chars().count() > 5000 {
            return bad("description: at most 5000 characters".into());
        }
        for (field, text) in [
            ("instructions", &self.instructions),
            ("consent", &self.consent),
        ] {
            if text.chars().count() > crate::markdown::MAX_MARKDOWN_CHARS {
                return bad(format!(
                    "{field}: at most {} characters",
                    crate::markdown::MAX_MARKDOWN_CHARS
                ));
            }
        }
        if !(1..=500).contains(&self.questions_per_hit) {
            return bad(format!(
                "questions_per_hit: {} not in 1..=500",
                self.questions_per_hit
            ));
        }
        if self.controls_per_hit >= self.questions_per_hit {
            return bad(format!(
                "controls_per_hit: {} must be below questions_per_hit {}",
                self.controls_per_hit, self.questions_per_hit
            ));
        }
        if self.training_questions > 20 {
            return bad(format!(
                "training_questions: {} not in 0..=20",
                self.training_questions
            ));
        }
        if !(1..=100).contains(&self.max_training_attempts) {
            return bad(format!(
                "max_training_attempts: {} not in 1..=100",
                self.max_training_attempts
            ));
        }
        if !(1..=1_000_000).contains(&self.tuples) {
            return bad(format!("tuples: {} not in 1..=1000000", self.tuples));
        }
        if !(1..=100).contains(&self.replication) {
            return bad(format!("replication: {} not in 1..=100", self.replication));
        }
        if !(0.0..=1.0).contains(&self.reasons_probability) {
            return bad(format!(
                "reasons_probability: {} not in [0, 1]",
                self.reasons_probability
            ));
        }
        if !(1..=MAX_CONTROL_ERRORS).contains(&self.reject_at_control_errors) {
            return bad(format!(
                "reject_at_control_errors: {} not in 1..={MAX_CONTROL_ERRORS}",
                self.reject_at_control_errors
            ));
        }
        for code in [
            &self.prolific_completion_code,
            &self.prolific_screenout_code,
            &self.prolific_noconsent_code,
        ]
        .into_iter()
        .flatten()
        {
            if code.is_empty()
                || code.len() > 64
                || !code.chars().all(|c| c.is_ascii_alphanumeric())
            {
                return bad("prolific codes: 1-64 ASCII letters and digits".into());
            }
        }
        if self.blocked_workers.len() > 100_000 {
            return bad("blocked_workers: at most 100000".into());
        }
        if self
            .blocked_workers
            .iter()
            .any(|w| w.trim().is_empty() || w.chars().count() > 200)
        {
            return bad("blocked_workers: each worker id must be 1-200 characters".into());
        }
        if self.exclude_workers_of.len() > 1000 {
            return bad("exclude_workers_of: at most 1000 studies".into());
        }
        if self.seed >= ID_LIMIT as u64 {
            return bad(format!("seed: {} not below 2^53", self.seed));
        }
        Ok(())
    }
}

/// A stored study.
#[derive(Debug, Clone, Serialize, utoipa::ToSchema)]
pub struct Study {
    /// Id.
    pub id: StudyId,
    /// Name.
    pub name: String,
    /// The library its items come from.
    pub library: LibraryId,
    /// Settings.
    pub settings: StudySettings,
    /// HMAC key of completion codes (never serialised).
    #[serde(skip)]
    pub secret: String,
    /// Creation time (Unix ms).
    pub created_at: i64,
}

/// Loads a study.
pub async fn load(db: &Db, id: StudyId) -> Result<Study> {
    load_on(&mut *db.pool.acquire().await?, id).await
}

/// Loads a study through `conn` (e.g. inside a write transaction).
pub async fn load_on(conn: &mut sqlx::AnyConnection, id: StudyId) -> Result<Study> {
    let row = sqlx::query(
        "SELECT id, name, library_id, settings, secret, created_at FROM studies WHERE id = $1",
    )
    .bind(id.0)
    .fetch_optional(&mut *conn)
    .await?
    .ok_or(AppError::NotFound("study"))?;
    let settings: String = row.try_get("settings")?;
    Ok(Study {
        id: StudyId(row.try_get("id")?),
        name: row.try_get("name")?,
        library: LibraryId(row.try_get("library_id")?),
        settings: serde_json::from_str(&settings).map_err(AppError::internal)?,
        secret: row.try_get("secret")?,
        created_at: row.try_get("created_at")?,
    })
}

/// A study's settings as stored now, read on the SQLite answer writer's connection inside its
/// transaction (settings may be edited while a study runs).
pub(crate) fn settings_sqlite(conn: &rusqlite::Connection, id: StudyId) -> Result<StudySettings> {
    let settings = crate::sqlite_direct::optional_row(
        conn,
        "SELECT settings FROM studies WHERE id = $1",
        &[&id.0],
        |r| r.get::<_, String>(0),
    )?
    .ok_or(AppError::NotFound("study"))?;
    serde_json::from_str(&settings).map_err(AppError::internal)
}

/// All studies, newest first.
pub async fn list(db: &Db) -> Result<Vec<Study>> {
    let rows = sqlx::query("SELECT id FROM studies ORDER BY created_at DESC")
        .fetch_all(&db.pool)
        .await?;
    let mut out = Vec::with_capacity(rows.len());
    for r in rows {
        out.push(load(db, StudyId(r.try_get("id")?)).await?);
    }
    Ok(out)
}

/// What tuple generation produced.
#[derive(Debug, Clone, Default, Serialize, utoipa::ToSchema)]
pub struct PoolSummary {
    /// Main tuples.
    pub main: usize,
    /// Slots (main tuples × R).
    pub slots: usize,
    /// Automatic control tuples.
    pub controls: usize,
    /// Training tuples.
    pub training: usize,
}

/// A tuple to insert.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct NewTuple {
    /// Reference.
    pub a: ItemId,
    /// First candidate (the expected answer of controls and training).
    pub b: ItemId,
    /// Second candidate.
    pub c: ItemId,
}

/// Uniform random triplets over `items`: three distinct items, no triplet twice (B and C
/// unordered). Returns fewer than `count` only when the library has fewer distinct triplets.
pub fn random_triplets(items: &[ItemId], count: usize, rng: &mut impl Rng) -> Vec<NewTuple> {
    let n = items.len();
    if n < 3 {
        return Vec::new();
    }
    let distinct = n as u128 * (n as u128 - 1) * (n as u128 - 2) / 2;
    let count = (count as u128).min(distinct) as usize;
    let mut seen = HashSet::with_capacity(count);
    let mut out = Vec::with_capacity(count);
    while out.len() < count {
        let a = rng.random_range(0..n);
        let b = rng.random_range(0..n);
        let c = rng.random_range(0..n);
        if a == b || a == c || b == c {
            continue;
        }
        if seen.insert((a, b.min(c), b.max(c))) {
            out.push(NewTuple {
                a: items[a],
                b: items[b],
                c: items[c],
            });
        }
    }
    out
}

/// Triplets with a known answer from style groups: A and B from one group, C from one of the
/// groups farthest from it (mean feature vectors, the farther half). Empty when fewer than two
/// groups have items (at least two in A's group).
pub fn style_triplets(
    items: &[ItemInfo],
    features: &HashMap<ItemId, Vec<f64>>,
    count: usize,
    rng: &mut impl Rng,
) -> Vec<NewTuple> {
    let mut groups: BTreeMap<&str, Vec<ItemId>> = BTreeMap::new();
    for item in items {
        if let Some(style) = &item.style {
            groups.entry(style.as_str()).or_default().push(item.id);
        }
    }
    let names: Vec<&str> = groups.keys().copied().collect();
    if names.len() < 2 || !groups.values().any(|g| g.len() >= 2) {
        return Vec::new();
    }
    let centroid = |g: &[ItemId]| -> Vec<f64> {
        let dim = g.iter().find_map(|i| features.get(i)).map_or(0, Vec::len);
        let mut sum = vec![0.0; dim];
        for f in g.iter().filter_map(|i| features.get(i)) {
            for (s, v) in sum.iter_mut().zip(f) {
                *s += v;
            }
        }
        sum.iter().map(|s| s / g.len().max(1) as f64).collect()
    };
    let centroids: Vec<Vec<f64>> = names.iter().map(|n| centroid(&groups[n])).collect();
    // For each group, the other groups sorted by decreasing distance; keep the farther half.
    let far: Vec<Vec<usize>> = (0..names.len())
        .map(|g| {
            let mut others: Vec<(f64, usize)> = (0..names.len())
                .filter(|&o| o != g)
                .map(|o| {
                    let d: f64 = centroids[g]
                        .iter()
                        .zip(&centroids[o])
                        .map(|(x, y)| (x - y) * (x - y))
                        .sum();
                    (d, o)
                })
                .collect();
            others.sort_by(|x, y| y.0.total_cmp(&x.0));
            let keep = others.len().div_ceil(2);
            others.into_iter().take(keep).map(|(_, o)| o).collect()
        })
        .collect();
    let eligible: Vec<usize> = (0..names.len())
        .filter(|&g| groups[names[g]].len() >= 2)
        .collect();
    let mut seen = HashSet::new();
    let mut out = Vec::with_capacity(count);
    let mut attempts = 0;
    while out.len() < count && attempts < count * 50 {
        attempts += 1;
        let Some(&g) = eligible.choose(rng) else {
            break;
        };
        let members = &groups[names[g]];
        let pair: Vec<ItemId> = members.choose_multiple(rng, 2).copied().collect();
        let Some(&o) = far[g].choose(rng) else { break };
        let Some(&c) = groups[names[o]].choose(rng) else {
            continue;
        };
        let t = NewTuple {
            a: pair[0],
            b: pair[1],
            c,
        };
        if seen.insert((t.a, t.b, t.c)) {
            out.push(t);
        }
    }
    out
}

/// Creates a study over `library` and generates its tuple pool.
pub async fn create(
    db: &Db,
    name: &str,
    library: LibraryId,
    settings: StudySettings,
) -> Result<(StudyId, PoolSummary)> {
    settings.validate()?;
    let name = name.trim();
    if name.is_empty() || name.len() > 200 {
        return Err(AppError::BadRequest("name: 1-200 characters".into()));
    }
    let items = library::list_items(db, library).await?;
    if items.len() < 3 {
        return Err(AppError::BadRequest(format!(
            "the library has {} items; a study needs at least 3",
            items.len()
        )));
    }
    let features = library::item_features(db, library).await?;
    let ids: Vec<ItemId> = items.iter().map(|i| i.id).collect();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(settings.seed);
    let main = random_triplets(&ids, settings.tuples as usize, &mut rng);
    let control_count = (settings.controls_per_hit as usize * 20).max(50);
    let practice_count = practice_pool_size(&settings);
    let mut labelled = style_triplets(&items, &features, control_count + practice_count, &mut rng);
    labelled.shuffle(&mut rng);
    // Practice first: a small library that cannot fill both pools still gets its practice.
    let training: Vec<NewTuple> = labelled.iter().take(practice_count).copied().collect();
    let controls: Vec<NewTuple> = labelled.iter().skip(practice_count).copied().collect();

    let id = StudyId::generate();
    let mut tx = db.begin_write().await?;
    sqlx::query(
        "INSERT INTO studies (id, name, library_id, settings, secret, created_at) \
         VALUES ($1, $2, $3, $4, $5, $6)",
    )
    .bind(id.0)
    .bind(name)
    .bind(library.0)
    .bind(serde_json::to_string(&settings).map_err(AppError::internal)?)
    .bind(format!("{}{}", random_token(), random_token()))
    .bind(now_ms())
    .execute(&mut *tx)
    .await?;
    let main_ids = free_tuple_block(&mut tx, main.len()).await?;
    let mut summary = PoolSummary::default();
    for (kind, tuples) in [
        ("main", &main),
        ("control", &controls),
        ("training", &training),
    ] {
        for (seq, t) in tuples.iter().enumerate() {
            let tuple = if kind == "main" {
                TupleId(main_ids.start + seq as i64)
            } else {
                outside(&main_ids)
            };
            let expected = (kind != "main").then_some("b");
            sqlx::query(
                "INSERT INTO tuples (id, study_id, seq, kind, a, b, c, expected, origin) \
                 VALUES ($1, $2, $3, $4, $5, $6, $7, $8, 'auto')",
            )
            .bind(tuple.0)
            .bind(id.0)
            .bind(seq as i64)
            .bind(kind)
            .bind(t.a.0)
            .bind(t.b.0)
            .bind(t.c.0)
            .bind(expected)
            .execute(&mut *tx)
            .await?;
            if kind == "main" {
                for replica in 0..settings.replication {
                    sqlx::query(
                        "INSERT INTO slots (id, study_id, tuple_id, seq, replica) \
                         VALUES ($1, $2, $3, $4, $5)",
                    )
                    .bind(SlotId::generate().0)
                    .bind(id.0)
                    .bind(tuple.0)
                    .bind(seq as i64)
                    .bind(i64::from(replica))
                    .execute(&mut *tx)
                    .await?;
                    summary.slots += 1;
                }
            }
        }
    }
    tx.commit().await?;
    summary.main = main.len();
    summary.controls = controls.len();
    summary.training = training.len();
    Ok((id, summary))
}

/// `n` consecutive tuple ids, none of them taken, for a study's main tuples.
///
/// Main tuples are numbered in `seq` order because a HIT claims the slots of consecutive `seq`s
/// (see `SlotClaim`), and each claim writes an entry of the slots' `(tuple_id, worker_id)`
/// unique index: with consecutive ids a HIT's ~45 claims share one or two index pages instead
/// of writing ~45 pages spread over the index (each then written to the WAL at commit and
/// again by a checkpoint). Tuple ids never reach a worker (questions are addressed by
/// position), so their order reveals nothing about which questions are controls, whose ids
/// stay random. The base is random, like every id, and checked against the ids already taken
/// inside the study's write transaction.
async fn free_tuple_block(tx: &mut WriteTx, n: usize) -> Result<std::ops::Range<i64>> {
    let n = n as i64;
    for _ in 0..16 {
        let base = rand::rng().random_range(1..ID_LIMIT - n);
        let taken: i64 = sqlx::query(
            "SELECT CAST(COUNT(*) AS BIGINT) AS n FROM tuples WHERE id >= $1 AND id < $2",
        )
        .bind(base)
        .bind(base + n)
        .fetch_one(&mut **tx)
        .await?
        .try_get("n")?;
        if taken == 0 {
            return Ok(base..base + n);
        }
    }
    Err(AppError::Internal(
        "no free block of tuple ids in 16 random tries".into(),
    ))
}

/// A random tuple id outside the main tuples' `block`.
fn outside(block: &std::ops::Range<i64>) -> TupleId {
    loop {
        let id = TupleId::generate();
        if !block.contains(&id.0) {
            return id;
        }
    }
}

/// The practice pool a study draws: `training_questions` triplets per attempt for
/// max(`max_training_attempts`, 5) attempts, so that a retry shows other triplets (attempts may
/// be raised later, hence at least 5), and one more, the worked example, which no attempt's
/// block reaches (`flow::training`).
pub fn practice_pool_size(s: &StudySettings) -> usize {
    let n = s.training_questions as usize;
    if n == 0 {
        0
    } else {
        n * s.max_training_attempts.max(5) as usize + 1
    }
}

/// Adds a curated control (or training) triplet given by item names; `b` is the expected answer.
pub async fn add_curated(db: &Db, study: &Study, kind: &str, names: [&str; 3]) -> Result<TupleId> {
    if kind != "control" && kind != "training" {
        return Err(AppError::BadRequest(
            "kind must be 'control' or 'training'".into(),
        ));
    }
    let mut ids = Vec::new();
    for name in names {
        let row = sqlx::query("SELECT id FROM items WHERE library_id = $1 AND name = $2")
            .bind(study.library.0)
            .bind(name)
            .fetch_optional(&db.pool)
            .await?
            .ok_or_else(|| {
                AppError::BadRequest(format!("no item named {name:?} in the library"))
            })?;
        ids.push(row.try_get::<i64, _>("id")?);
    }
    if ids[0] == ids[1] || ids[0] == ids[2] || ids[1] == ids[2] {
        return Err(AppError::BadRequest("a, b and c must be distinct".into()));
    }
    let seq_row = sqlx::query(
        "SELECT CAST(COALESCE(MAX(seq), -1) AS BIGINT) AS m FROM tuples WHERE study_id = $1 AND kind = $2",
    )
    .bind(study.id.0)
    .bind(kind)
    .fetch_one(&db.pool)
    .await?;
    let seq: i64 = seq_row.try_get("m")?;
    let id = TupleId::generate();
    sqlx::query(
        "INSERT INTO tuples (id, study_id, seq, kind, a, b, c, expected, origin) \
         VALUES ($1, $2, $3, $4, $5, $6, $7, 'b', 'curated')",
    )
    .bind(id.0)
    .bind(study.id.0)
    .bind(seq + 1)
    .bind(kind)
    .bind(ids[0])
    .bind(ids[1])
    .bind(ids[2])
    .execute(&mut *db.write_conn().await?)
    .await?;
    Ok(id)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn random_triplets_are_distinct_and_capped() {
        let items: Vec<ItemId> = (1..=4).map(ItemId).collect();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let t = random_triplets(&items, 1000, &mut rng);
        // 4 * 3 * 2 / 2 = 12 distinct triplets with B, C unordered.
        assert_eq!(t.len(), 12);
        for x in &t {
            assert!(x.a != x.b && x.a != x.c && x.b != x.c);
        }
        assert!(random_triplets(&items[..2], 5, &mut rng).is_empty());
    }

    #[test]
    fn style_triplets_pair_a_with_b_from_one_group() {
        let items: Vec<ItemInfo> = (1..=8)
            .map(|i| ItemInfo {
                id: ItemId(i),
                name: format!("i{i}"),
                style: Some(if i <= 4 { "x" } else { "y" }.into()),
            })
            .collect();
        let style: HashMap<ItemId, &str> = items
            .iter()
            .map(|i| (i.id, i.style.as_deref().unwrap_or("")))
            .collect();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
        let t = style_triplets(&items, &HashMap::new(), 20, &mut rng);
        assert_eq!(t.len(), 20);
        for x in t {
            assert_eq!(style[&x.a], style[&x.b]);
            assert_ne!(style[&x.a], style[&x.c]);
            assert_ne!(x.a, x.b);
        }
    }

    #[test]
    fn the_practice_pool_holds_five_attempts_or_more_and_the_worked_example() {
        let with = |n: u32, attempts: u32| StudySettings {
            training_questions: n,
            max_training_attempts: attempts,
            ..StudySettings::default()
        };
        assert_eq!(practice_pool_size(&with(3, 1)), 16);
        assert_eq!(practice_pool_size(&with(3, 8)), 25);
        assert_eq!(practice_pool_size(&with(0, 8)), 0);
    }

    #[test]
    fn settings_are_validated() {
        assert!(StudySettings::default().validate().is_ok());
        let bad = StudySettings {
            controls_per_hit: 50,
            ..StudySettings::default()
        };
        assert!(bad.validate().is_err());
        let bad = StudySettings {
            reasons_probability: 1.5,
            ..StudySettings::default()
        };
        assert!(bad.validate().is_err());
    }
}

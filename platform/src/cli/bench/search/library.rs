//! The search benchmark's library: the fixture items' real features followed by jittered
//! copies up to `--items` (inserted in batches, or found from an earlier run), and an optional
//! learner model stored as the library's trained model.

use std::path::PathBuf;
use std::time::Instant;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use sqlx::Row;

use super::{LIBRARY, SearchBenchArgs};
use crate::error::{AppError, Result};
use crate::store::db::{Db, now_ms};
use crate::store::ids::{ItemId, LibraryId, ModelId};
use crate::studies::library::{self, read_labels};
use crate::studies::study::{self, StudySettings};

/// Rows per INSERT statement (8 parameters each: within SQLite's and PostgreSQL's limits).
const INSERT_ROWS: usize = 500;

/// Items of the features file.
pub(super) fn real_count(a: &SearchBenchArgs) -> Result<usize> {
    Ok(learner::table::read_features(&a.features)
        .map_err(|e| AppError::BadRequest(e.to_string()))?
        .len()
        .min(a.items))
}

/// The benchmark library with `--items` items: found, or made (and the seconds the inserts
/// took).
pub(super) async fn ensure_library(
    db: &Db,
    a: &SearchBenchArgs,
) -> Result<(LibraryId, Option<f64>)> {
    let lib = library::ensure_library(db, LIBRARY).await?;
    let have: i64 = sqlx::query("SELECT COUNT(*) AS n FROM items WHERE library_id = $1")
        .bind(lib.0)
        .fetch_one(&db.pool)
        .await?
        .try_get("n")?;
    if have as usize == a.items {
        return Ok((lib, None));
    }
    if have != 0 {
        return Err(AppError::BadRequest(format!(
            "library {LIBRARY} holds {have} items, not {}: use a fresh database",
            a.items
        )));
    }
    let table = learner::table::read_features(&a.features)
        .map_err(|e| AppError::BadRequest(e.to_string()))?;
    let catalogue: Vec<&str> = learner::features::catalogue()
        .iter()
        .map(|f| f.name)
        .collect();
    if table.names() != catalogue.as_slice() {
        return Err(AppError::BadRequest(format!(
            "{}: not the {} features of `learner features`",
            a.features.display(),
            catalogue.len()
        )));
    }
    let labels = read_labels(&a.labels)?;
    let t = Instant::now();
    let png = placeholder_png()?;
    let dim = table.dim();
    // Per-feature standard deviation over the real items: the unit of the jitter.
    let sd: Vec<f64> = (0..dim)
        .map(|k| {
            let n = table.len() as f64;
            let mean = (0..table.len()).map(|i| table.row(i)[k]).sum::<f64>() / n;
            ((0..table.len())
                .map(|i| (table.row(i)[k] - mean).powi(2))
                .sum::<f64>()
                / n)
                .sqrt()
        })
        .collect();
    let mut rng = ChaCha8Rng::seed_from_u64(a.seed);
    let mut tx = db.begin_write().await?;
    let mut seq = 0usize;
    while seq < a.items {
        let n = INSERT_ROWS.min(a.items - seq);
        let mut sql = String::from(
            "INSERT INTO items (id, library_id, seq, name, style, tags, png, features) VALUES ",
        );
        for r in 0..n {
            let p = r * 8;
            sql.push_str(&format!(
                "{}(${}, ${}, ${}, ${}, ${}, ${}, ${}, ${})",
                if r == 0 { "" } else { ", " },
                p + 1,
                p + 2,
                p + 3,
                p + 4,
                p + 5,
                p + 6,
                p + 7,
                p + 8
            ));
        }
        // Only numbered placeholders are formatted into it; every value is bound.
        let mut query = sqlx::query(sqlx::AssertSqlSafe(sql));
        for s in seq..seq + n {
            let real = s % table.len();
            let copy = s / table.len();
            let id = &table.ids()[real];
            let raw = table.row(real);
            let features: Vec<f64> = if copy == 0 {
                raw.to_vec()
            } else {
                raw.iter()
                    .zip(&sd)
                    .map(|(v, sd)| round6(v + rng.random_range(-1.0..=1.0) * a.jitter * sd))
                    .collect()
            };
            let name = if copy == 0 {
                id.clone()
            } else {
                format!("{id}#{copy}")
            };
            query = query
                .bind(ItemId::generate().0)
                .bind(lib.0)
                .bind(s as i64 + 1)
                .bind(name)
                .bind(labels.styles.get(id).cloned())
                .bind(
                    serde_json::to_string(labels.keywords.get(id).unwrap_or(&Vec::new()))
                        .map_err(AppError::internal)?,
                )
                .bind(png.clone())
                .bind(serde_json::to_string(&features).map_err(AppError::internal)?);
        }
        query.execute(&mut *tx).await?;
        seq += n;
    }
    tx.commit().await?;
    Ok((lib, Some(t.elapsed().as_secs_f64())))
}

/// `v` to 6 significant digits (short JSON; far finer than the jitter).
fn round6(v: f64) -> f64 {
    format!("{v:.5e}").parse().unwrap_or(v)
}

/// A 4×4 grey PNG standing in for every image.
fn placeholder_png() -> Result<Vec<u8>> {
    let mut png = Vec::new();
    image::RgbImage::from_pixel(4, 4, image::Rgb([200, 200, 200]))
        .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
        .map_err(AppError::internal)?;
    Ok(png)
}

/// Stores `path` as a finished model of a study over the library, so that searches use it.
pub(super) async fn store_model(db: &Db, lib: LibraryId, path: &PathBuf) -> Result<ModelId> {
    let bytes = std::fs::read(path)
        .map_err(|e| AppError::BadRequest(format!("{}: {e}", path.display())))?;
    let _: learner::metric::Model = serde_json::from_slice(&bytes)
        .map_err(|e| AppError::BadRequest(format!("{}: not a model: {e}", path.display())))?;
    let settings = StudySettings {
        training_questions: 0,
        tuples: 100,
        ..StudySettings::default()
    };
    let (study, _) = study::create(db, "bench search", lib, settings).await?;
    let id = ModelId::generate();
    let now = now_ms();
    let mut tx = db.begin_write().await?;
    sqlx::query(
        "INSERT INTO models (id, study_id, status, started_at, finished_at) \
         VALUES ($1, $2, 'done', $3, $4)",
    )
    .bind(id.0)
    .bind(study.0)
    .bind(now)
    .bind(now)
    .execute(&mut *tx)
    .await?;
    sqlx::query("INSERT INTO model_files (model_id, name, bytes) VALUES ($1, 'model.json', $2)")
        .bind(id.0)
        .bind(bytes)
        .execute(&mut *tx)
        .await?;
    tx.commit().await?;
    Ok(id)
}

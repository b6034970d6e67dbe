//! Training the style metric from a study's answers (`platform train ID`, or the admin's Train
//! button): the study's `triplets.csv` export over the library's stored features goes to
//! [`learner::metric::train::train`] (eqs. 5.5–5.8 of Garces et al. 2014, λ by cross-validation
//! unless fixed); the model, its scores and the learner's HTML report are stored in the
//! database (`models`, `model_files`), so every server behind a load balancer can show them.

mod fit;

use learner::metric::train::{LambdaChoice, TrainParams};
use serde::{Deserialize, Serialize};
use sqlx::Row;

use crate::error::{AppError, Result};
use crate::store::db::{Db, now_ms};
use crate::store::ids::{ModelId, StudyId};
use crate::studies::study::Study;
pub use fit::{Fitted, TrainingData, collect, fit};

/// A training that started this long ago and never finished is taken for dead (its server
/// stopped); a new one may start.
pub const STALE_AFTER_MS: i64 = 6 * 3600 * 1000;

/// Files stored for every finished model: the learner's report (`index.html` and its figures)
/// and `model.json`.
const CONTENT_TYPES: &[(&str, &str)] = &[
    (".html", "text/html; charset=utf-8"),
    (".svg", "image/svg+xml"),
    (".png", "image/png"),
    (".json", "application/json"),
];

/// What the admin may choose; the rest follows the learner's defaults (the paper's).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrainOptions {
    /// λ of eq. 5.8; `None`: chosen by cross-validation (default).
    pub lambda: Option<f64>,
    /// Cross-validation folds (grouped by worker when there are enough workers). Default 5.
    pub folds: usize,
}

impl Default for TrainOptions {
    fn default() -> Self {
        Self {
            lambda: None,
            folds: 5,
        }
    }
}

impl TrainOptions {
    fn params(&self) -> Result<TrainParams> {
        let params = TrainParams {
            lambda: match self.lambda {
                Some(l) => LambdaChoice::Fixed(l),
                None => LambdaChoice::Auto(None),
            },
            folds: self.folds,
            ..TrainParams::default()
        };
        params
            .validate()
            .map_err(|e| AppError::BadRequest(e.to_string()))?;
        Ok(params)
    }
}

/// One trained (or training, or failed) model of a study.
#[derive(Debug, Clone, PartialEq, Serialize, utoipa::ToSchema)]
pub struct ModelSummary {
    /// Id.
    pub id: ModelId,
    /// `running`, `done` or `failed`.
    pub status: String,
    /// Why it failed, or notes on how it was trained.
    pub message: Option<String>,
    /// Unix ms.
    pub started_at: i64,
    /// Unix ms, once finished.
    pub finished_at: Option<i64>,
    /// Training triplets (answers).
    pub triplets: Option<i64>,
    /// λ used.
    pub lambda: Option<f64>,
    /// Non-zero weights of the 169.
    pub nonzero: Option<i64>,
    /// Fraction of the training answers the learned metric agrees with.
    pub train_accuracy: Option<f64>,
    /// The same for the uniform metric (all weights equal), the baseline.
    pub uniform_accuracy: Option<f64>,
    /// Held-out accuracy at the chosen λ (cross-validation, mean over folds), when λ was chosen.
    pub cv_accuracy: Option<f64>,
    /// Held-out agreement of the learned and the uniform metric with 95% intervals, when λ was
    /// chosen by cross-validation (absent for models trained before it was recorded).
    pub held_out: Option<HeldOut>,
}

/// A proportion with its 95% interval.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, utoipa::ToSchema)]
pub struct Interval {
    /// The estimate.
    pub value: f64,
    /// 2.5th percentile of the bootstrap.
    pub low: f64,
    /// 97.5th percentile of the bootstrap.
    pub high: f64,
}

impl From<learner::eval::triplets::Estimate> for Interval {
    fn from(e: learner::eval::triplets::Estimate) -> Self {
        Self {
            value: e.value,
            low: e.low,
            high: e.high,
        }
    }
}

/// Agreement with the answers on held-out data: every answer predicted by the
/// cross-validation fold model that did not see it (at the chosen λ), intervals by bootstrap
/// over workers (or tuples, when folds were grouped by tuple).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, utoipa::ToSchema)]
pub struct HeldOut {
    /// What the bootstrap resamples: `worker` or `tuple`.
    pub unit: String,
    /// Distinct workers (or tuples).
    pub units: i64,
    /// Answers scored.
    pub answers: i64,
    /// Fraction of the answers the learned metric predicts.
    pub learned: Interval,
    /// The same for uniform weights.
    pub uniform: Interval,
    /// Learned minus uniform, with its paired interval.
    pub difference: Interval,
}

impl From<&learner::metric::cv::HeldOutAgreement> for HeldOut {
    fn from(a: &learner::metric::cv::HeldOutAgreement) -> Self {
        Self {
            unit: a.unit.clone(),
            units: a.units as i64,
            answers: a.answers as i64,
            learned: a.learned.into(),
            uniform: a.uniform.into(),
            difference: a.difference.into(),
        }
    }
}

impl HeldOut {
    /// The learned metric's interval lies wholly above the uniform metric's.
    pub fn learned_clearly_better(&self) -> bool {
        self.learned.low > self.uniform.high
    }
}

impl ModelSummary {
    /// One line for the CLI: answers, λ, sparsity, agreement on the training answers and
    /// held out, with intervals.
    pub fn describe(&self) -> String {
        let pct = |v: Option<f64>| v.map_or_else(|| "–".into(), |v| format!("{:.1}%", 100.0 * v));
        let interval = |i: &Interval| {
            format!(
                "{:.1}% [{:.1}, {:.1}]",
                100.0 * i.value,
                100.0 * i.low,
                100.0 * i.high
            )
        };
        let held_out = match &self.held_out {
            Some(h) => format!(
                "held-out: learned {}, uniform weights {} (95% intervals, bootstrap over {} \
                 {}s){}",
                interval(&h.learned),
                interval(&h.uniform),
                h.units,
                h.unit,
                if h.learned_clearly_better() {
                    ""
                } else {
                    "; the intervals overlap"
                }
            ),
            None => format!("held-out {}", pct(self.cv_accuracy)),
        };
        format!(
            "model {}: {} answers, λ = {:.4}, {} of 169 weights non-zero; agreement with the \
             answers {} (uniform weights {}); {held_out}",
            self.id,
            self.triplets.unwrap_or(0),
            self.lambda.unwrap_or(f64::NAN),
            self.nonzero.unwrap_or(0),
            pct(self.train_accuracy),
            pct(self.uniform_accuracy),
        )
    }
}

/// Records a training as running. Refuses when another one of the study is running (and not
/// stale), so repeated clicks do not queue CPU-heavy fits.
pub async fn begin(db: &Db, study: StudyId) -> Result<ModelId> {
    let mut tx = db.begin_write().await?;
    let running: i64 = sqlx::query(
        "SELECT COUNT(*) AS n FROM models WHERE study_id = $1 AND status = 'running' \
         AND started_at > $2",
    )
    .bind(study.0)
    .bind(now_ms() - STALE_AFTER_MS)
    .fetch_one(&mut *tx)
    .await?
    .try_get("n")?;
    if running > 0 {
        return Err(AppError::Conflict(
            "a training of this study is already running".into(),
        ));
    }
    let id = ModelId::generate();
    sqlx::query(
        "INSERT INTO models (id, study_id, status, started_at) VALUES ($1, $2, 'running', $3)",
    )
    .bind(id.0)
    .bind(study.0)
    .bind(now_ms())
    .execute(&mut *tx)
    .await?;
    tx.commit().await?;
    Ok(id)
}

/// Stores the outcome of a training started with [`begin`].
pub async fn complete(db: &Db, id: ModelId, outcome: Result<Fitted>) -> Result<()> {
    let mut tx = db.begin_write().await?;
    match outcome {
        Ok(f) => {
            let message = (!f.notes.is_empty()).then(|| f.notes.join("; "));
            let held_out = f
                .held_out
                .as_ref()
                .map(serde_json::to_string)
                .transpose()
                .map_err(AppError::internal)?;
            sqlx::query(
                "UPDATE models SET status = 'done', message = $1, finished_at = $2, triplets = $3, \
                 lambda = $4, nonzero = $5, train_accuracy = $6, uniform_accuracy = $7, \
                 cv_accuracy = $8, held_out = $9 WHERE id = $10",
            )
            .bind(message)
            .bind(now_ms())
            .bind(f.model.data.triplets as i64)
            .bind(f.model.lambda)
            .bind(f.model.nonzero as i64)
            .bind(f.train_accuracy)
            .bind(f.uniform_accuracy)
            .bind(f.cv_accuracy)
            .bind(held_out)
            .bind(id.0)
            .execute(&mut *tx)
            .await?;
            for (name, bytes) in f.files {
                sqlx::query("INSERT INTO model_files (model_id, name, bytes) VALUES ($1, $2, $3)")
                    .bind(id.0)
                    .bind(name)
                    .bind(bytes)
                    .execute(&mut *tx)
                    .await?;
            }
        }
        Err(e) => {
            sqlx::query(
                "UPDATE models SET status = 'failed', message = $1, finished_at = $2 WHERE id = $3",
            )
            .bind(e.to_string())
            .bind(now_ms())
            .bind(id.0)
            .execute(&mut *tx)
            .await?;
        }
    }
    tx.commit().await?;
    Ok(())
}

/// Fits on a blocking thread and stores the outcome; the error of the fit (if any) is stored
/// with the model and returned.
pub async fn fit_and_store(
    db: &Db,
    id: ModelId,
    data: TrainingData,
    opts: TrainOptions,
) -> Result<()> {
    let outcome = tokio::task::spawn_blocking(move || fit(data, &opts))
        .await
        .unwrap_or_else(|e| Err(AppError::Internal(format!("training thread: {e}"))));
    let failure = outcome.as_ref().err().map(ToString::to_string);
    complete(db, id, outcome).await?;
    match failure {
        Some(why) => Err(AppError::BadRequest(why)),
        None => Ok(()),
    }
}

/// Trains now and waits (the CLI): collect, record, fit, store.
pub async fn run(db: &Db, study: &Study, opts: TrainOptions) -> Result<ModelSummary> {
    let data = collect(db, study, &opts).await?;
    let id = begin(db, study.id).await?;
    fit_and_store(db, id, data, opts).await?;
    get(db, study.id, id).await
}

/// Starts a training in the background (the admin page and API) and returns at once. Errors
/// found before fitting (no answers, a training already running) are returned; later ones are
/// stored with the model.
pub async fn start(db: &Db, study: &Study, opts: TrainOptions) -> Result<ModelId> {
    let data = collect(db, study, &opts).await?;
    let id = begin(db, study.id).await?;
    let db = db.clone();
    tokio::spawn(async move {
        if let Err(e) = fit_and_store(&db, id, data, opts).await {
            eprintln!("training {id}: {e}");
        }
    });
    Ok(id)
}

fn summary(r: &sqlx::any::AnyRow) -> Result<ModelSummary> {
    Ok(ModelSummary {
        id: ModelId(r.try_get("id")?),
        status: r.try_get("status")?,
        message: r.try_get("message")?,
        started_at: r.try_get("started_at")?,
        finished_at: r.try_get("finished_at")?,
        triplets: r.try_get("triplets")?,
        lambda: r.try_get("lambda")?,
        nonzero: r.try_get("nonzero")?,
        train_accuracy: r.try_get("train_accuracy")?,
        uniform_accuracy: r.try_get("uniform_accuracy")?,
        cv_accuracy: r.try_get("cv_accuracy")?,
        held_out: r
            .try_get::<Option<String>, _>("held_out")?
            .map(|text| serde_json::from_str(&text))
            .transpose()
            .map_err(AppError::internal)?,
    })
}

/// `SELECT <summary columns> FROM models <rest>` as one static string (sqlx takes only
/// static SQL, which keeps every value a bound parameter).
macro_rules! select_models {
    ($rest:literal) => {
        concat!(
            "SELECT id, status, message, started_at, finished_at, triplets, lambda, nonzero, \
             train_accuracy, uniform_accuracy, cv_accuracy, held_out FROM models ",
            $rest
        )
    };
}

/// The models of a study, newest first.
pub async fn list(db: &Db, study: StudyId) -> Result<Vec<ModelSummary>> {
    sqlx::query(select_models!(
        "WHERE study_id = $1 ORDER BY started_at DESC, id"
    ))
    .bind(study.0)
    .fetch_all(&db.pool)
    .await?
    .iter()
    .map(summary)
    .collect()
}

/// One model of a study.
pub async fn get(db: &Db, study: StudyId, id: ModelId) -> Result<ModelSummary> {
    let row = sqlx::query(select_models!("WHERE study_id = $1 AND id = $2"))
        .bind(study.0)
        .bind(id.0)
        .fetch_optional(&db.pool)
        .await?
        .ok_or(AppError::NotFound("model"))?;
    summary(&row)
}

/// Names of the stored files of a model (report, figures, `model.json`), sorted.
pub async fn file_names(db: &Db, study: StudyId, id: ModelId) -> Result<Vec<String>> {
    let rows = sqlx::query(
        "SELECT f.name FROM model_files f JOIN models m ON m.id = f.model_id \
         WHERE m.study_id = $1 AND f.model_id = $2 ORDER BY f.name",
    )
    .bind(study.0)
    .bind(id.0)
    .fetch_all(&db.pool)
    .await?;
    rows.iter()
        .map(|r| r.try_get("name").map_err(AppError::from))
        .collect()
}

/// A stored report file or `model.json` with its content type. Only names the learner writes
/// are looked up (no path traversal: names are compared, never joined to a path).
pub async fn file(
    db: &Db,
    study: StudyId,
    id: ModelId,
    name: &str,
) -> Result<(&'static str, Vec<u8>)> {
    let name = if name.is_empty() { "index.html" } else { name };
    let content_type = CONTENT_TYPES
        .iter()
        .find(|(ext, _)| name.ends_with(ext))
        .map(|(_, t)| *t)
        .ok_or(AppError::NotFound("report file"))?;
    let row = sqlx::query(
        "SELECT f.bytes FROM model_files f JOIN models m ON m.id = f.model_id \
         WHERE m.study_id = $1 AND f.model_id = $2 AND f.name = $3",
    )
    .bind(study.0)
    .bind(id.0)
    .bind(name)
    .fetch_optional(&db.pool)
    .await?
    .ok_or(AppError::NotFound("report file"))?;
    Ok((content_type, row.try_get("bytes")?))
}

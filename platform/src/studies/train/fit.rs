//! Collecting a study's answers and features, fitting the metric and rendering its report.

use std::path::Path;

use learner::metric::model::Model;
use learner::table::FeatureTable;
use learner::triplets::TripletSet;

use super::{HeldOut, TrainOptions};
use crate::error::{AppError, Result};
use crate::store::db::Db;
use crate::studies::export::{self, ExportOptions};
use crate::studies::library;
use crate::studies::study::Study;

/// The library's features and the study's answers, ready for the learner.
#[derive(Debug, Clone)]
pub struct TrainingData {
    /// Features of every library item, ids = item names (as in `triplets.csv`).
    pub table: FeatureTable,
    /// The exported answers (completed, non-rejected HITs; no controls, no training).
    pub set: TripletSet,
    /// Notes for the admin (e.g. folds grouped by tuple for lack of workers).
    pub notes: Vec<String>,
}

/// Reads the training data of `study`. Fails with a clear message when there are no answers.
pub async fn collect(db: &Db, study: &Study, opts: &TrainOptions) -> Result<TrainingData> {
    opts.params()?;
    let items = library::list_items(db, study.library).await?;
    let mut features = library::item_features(db, study.library).await?;
    let names: Vec<String> = learner::features::catalogue()
        .into_iter()
        .map(|f| f.name.to_string())
        .collect();
    let mut ids = Vec::with_capacity(items.len());
    let mut values = Vec::with_capacity(items.len() * names.len());
    for item in &items {
        let row = features
            .remove(&item.id)
            .ok_or_else(|| AppError::Internal(format!("item {} has no features", item.name)))?;
        if row.len() != names.len() {
            return Err(AppError::Internal(format!(
                "item {} has {} features, expected {}",
                item.name,
                row.len(),
                names.len()
            )));
        }
        ids.push(item.name.clone());
        values.extend(row);
    }
    let table = FeatureTable::new(names, ids, values).map_err(AppError::internal)?;
    let files = export::build(db, study, ExportOptions::default(), "").await?;
    let csv = files
        .into_iter()
        .find(|(name, _)| name == "triplets.csv")
        .map(|(_, bytes)| bytes)
        .ok_or_else(|| AppError::Internal("export has no triplets.csv".into()))?;
    let answers = csv
        .iter()
        .filter(|&&b| b == b'\n')
        .count()
        .saturating_sub(1);
    if answers == 0 {
        return Err(AppError::Conflict(
            "no answers to train on yet: the metric is fitted on the main answers of completed, \
             non-rejected HITs"
                .into(),
        ));
    }
    let mut set = learner::triplets::read_triplets_from(
        csv.as_slice(),
        Path::new("triplets.csv"),
        &table,
        false,
    )
    .map_err(|e| AppError::Internal(format!("exported triplets do not read back: {e}")))?;
    let mut notes = Vec::new();
    if opts.lambda.is_none() {
        let workers: std::collections::HashSet<Option<u32>> =
            set.triplets.iter().map(|t| t.worker).collect();
        let tuples: std::collections::HashSet<u32> = set.triplets.iter().map(|t| t.tuple).collect();
        if set.has_workers && workers.len() < opts.folds {
            set.has_workers = false;
            notes.push(format!(
                "cross-validation folds grouped by tuple: only {} worker(s) for {} folds",
                workers.len(),
                opts.folds
            ));
        }
        if tuples.len() < opts.folds {
            return Err(AppError::Conflict(format!(
                "too few answers to choose λ by {}-fold cross-validation ({} distinct triplets); \
                 collect more answers or give λ",
                opts.folds,
                tuples.len()
            )));
        }
    }
    Ok(TrainingData { table, set, notes })
}

/// A fitted model with its scores and the files to store.
#[derive(Debug, Clone)]
pub struct Fitted {
    /// The model.
    pub model: Model,
    /// Training-set accuracy of the learned metric.
    pub train_accuracy: f64,
    /// Training-set accuracy of the uniform metric.
    pub uniform_accuracy: f64,
    /// Held-out accuracy at the chosen λ.
    pub cv_accuracy: Option<f64>,
    /// Held-out agreement with intervals, when λ was cross-validated.
    pub held_out: Option<HeldOut>,
    /// `(name, bytes)`: `index.html`, its figures, `model.json`.
    pub files: Vec<(String, Vec<u8>)>,
    /// Notes carried from [`TrainingData`].
    pub notes: Vec<String>,
}

/// Fraction of answers a metric agrees with (`P(q = 1)` per triplet; ties count half).
fn accuracy(p_q1: &[f64], set: &TripletSet) -> f64 {
    let agree: f64 = p_q1
        .iter()
        .zip(&set.triplets)
        .map(|(&p, t)| {
            let p_answer = if t.q { p } else { 1.0 - p };
            if p_answer > 0.5 {
                1.0
            } else if p_answer == 0.5 {
                0.5
            } else {
                0.0
            }
        })
        .sum();
    agree / set.triplets.len().max(1) as f64
}

fn html_escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

/// Fits the metric and renders the report (CPU-bound: call from a blocking thread).
pub fn fit(data: TrainingData, opts: &TrainOptions) -> Result<Fitted> {
    let params = opts.params()?;
    let TrainingData {
        table,
        set,
        mut notes,
    } = data;
    let model = learner::metric::train::train(&table, &set, &params, &mut |_| {})
        .map_err(|e| AppError::BadRequest(format!("training failed: {e}")))?;
    // What the learner found questionable about the λ choice (grid edge, one-SE rule
    // overruled, no better than uniform weights) goes to the model's note, so the study page
    // and `platform train` show it beside the figures.
    if let Some(cv) = &model.cv {
        notes.extend(cv.warnings.iter().map(ToString::to_string));
    }
    if model.nonzero == 0 {
        // Cross-validation's one-standard-error rule may prefer the empty metric on little or
        // noisy data; say so rather than show a report of zeros without comment.
        notes.push(format!(
            "every weight is zero at λ = {:.4}: the answers show no style signal the features \
             capture consistently; collect more answers or give a smaller λ",
            model.lambda
        ));
    }
    let predict = |w: &[f64]| {
        learner::eval::predict(&model, &table, &set.triplets, w)
            .map_err(|e| AppError::Internal(e.to_string()))
    };
    let train_accuracy = accuracy(&predict(&model.weights)?, &set);
    let uniform_accuracy = accuracy(
        &predict(&vec![model.uniform_scale; model.weights.len()])?,
        &set,
    );
    let cv_accuracy = model
        .cv
        .as_ref()
        .and_then(|cv| cv.chosen_row())
        .map(|r| r.accuracy);
    let held_out = model
        .cv
        .as_ref()
        .and_then(|cv| cv.agreement.as_ref())
        .map(HeldOut::from);
    let interval = |i: &super::Interval| format!("{:.3} [{:.3}, {:.3}]", i.value, i.low, i.high);
    let (held_learned, held_uniform, held_head) = match &held_out {
        Some(h) => (
            interval(&h.learned),
            interval(&h.uniform),
            format!(
                "held-out answers ({}-fold cross-validation, 95% interval by bootstrap over {} \
                 {}s)",
                params.folds,
                h.units,
                html_escape(&h.unit)
            ),
        ),
        None => ("–".into(), "–".into(), "held-out answers".into()),
    };
    let mut extra = format!(
        "<h2>Agreement with the study's answers</h2><table><tr><th>metric</th><th>training \
         answers</th><th>{held_head}</th></tr><tr><td style=\"text-align:left\">learned</td>\
         <td>{train_accuracy:.3}</td><td>{held_learned}</td></tr><tr><td \
         style=\"text-align:left\">uniform weights</td><td>{uniform_accuracy:.3}</td><td>\
         {held_uniform}</td></tr></table>"
    );
    if let Some(h) = &held_out {
        extra.push_str(&format!(
            "<p>On held-out answers the learned metric {} uniform weights (difference {}).</p>",
            if h.learned_clearly_better() {
                "beats"
            } else {
                "is not clearly better than"
            },
            interval(&h.difference)
        ));
    }
    for note in &notes {
        extra.push_str(&format!("<p>{}</p>", html_escape(note)));
    }
    let dir = tempfile::tempdir().map_err(AppError::internal)?;
    let written = learner::eval::report::write_report(dir.path(), &model, None, &extra)
        .map_err(AppError::internal)?;
    let model_path = dir.path().join("model.json");
    model.save(&model_path).map_err(AppError::internal)?;
    let mut files = Vec::new();
    for path in written.iter().chain(std::iter::once(&model_path)) {
        let name = path
            .file_name()
            .and_then(|n| n.to_str())
            .ok_or_else(|| AppError::Internal("report file without a name".into()))?
            .to_string();
        files.push((name, std::fs::read(path).map_err(AppError::internal)?));
    }
    Ok(Fitted {
        model,
        train_accuracy,
        uniform_accuracy,
        cv_accuracy,
        held_out,
        files,
        notes,
    })
}

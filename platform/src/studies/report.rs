//! What a study's answers say, per kind: a triplet study is summarised by its dashboard and
//! trained into a metric (`dashboard`, `train`); a composition rating by the preference rate
//! for the style-sorted condition and its t-test (`rating`); a mash-up study by the mean
//! position of the pieces used per condition (`mashup`); an icon-set study by the time and
//! deletions per set per condition (`iconset`).

use serde::Serialize;

use crate::error::Result;
use crate::store::db::Db;
use crate::studies::iconset::{self, IconsetReport};
use crate::studies::kind::StudyKind;
use crate::studies::mashup::{self, MashupReport};
use crate::studies::rating::{self, RatingReport};
use crate::studies::study::Study;

/// A study's report, tagged with its kind.
#[derive(Debug, Clone, Serialize, utoipa::ToSchema)]
#[serde(tag = "kind", rename_all = "kebab-case")]
pub enum StudyReport {
    /// Triplet studies are summarised by the dashboard and the trained metric.
    Triplet,
    /// The 2AFC report.
    CompositionRating(RatingReport),
    /// The mean position of the pieces used, per condition.
    Mashup(MashupReport),
    /// The time and deletions per set, per condition.
    Iconset(IconsetReport),
}

/// The report of `study`.
pub async fn report(db: &Db, study: &Study) -> Result<StudyReport> {
    Ok(match study.kind {
        StudyKind::Triplet => StudyReport::Triplet,
        StudyKind::CompositionRating => {
            StudyReport::CompositionRating(rating::report(db, study).await?)
        }
        StudyKind::Mashup => StudyReport::Mashup(mashup::report::report(db, study.id).await?),
        StudyKind::Iconset => StudyReport::Iconset(iconset::report::report(db, study).await?),
    })
}

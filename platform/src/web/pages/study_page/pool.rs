//! The top of the study page about its tuple pool: the progress of a pool still being written
//! (followed live by `dashboard.js`, which reloads the page once it is complete), why a
//! creation failed, and what the pool lacks against the settings.

use crate::error::Result;
use crate::store::db::Db;
use crate::studies::study::{self, Study, StudyStatus};

/// What the page says about the pool.
pub(super) struct PoolView {
    /// `creating`, `ready` or `failed`.
    pub status: &'static str,
    pub rows_done: i64,
    pub rows_total: i64,
    pub percent: i64,
    pub error: String,
    /// Plain-words warnings ([`study::warnings`]).
    pub warnings: Vec<String>,
}

impl PoolView {
    pub(super) async fn of(db: &Db, s: &Study) -> Result<Self> {
        // A pool still being written has its controls and practice triplets already (they
        // are in the study's first transaction), so its warnings are final.
        let warnings = if s.status == StudyStatus::Failed {
            Vec::new()
        } else {
            study::warnings(db, s).await?
        };
        Ok(Self {
            status: s.status.as_str(),
            rows_done: s.progress.rows_done,
            rows_total: s.progress.rows_total,
            percent: s.progress.percent(),
            error: s.progress.error.clone().unwrap_or_default(),
            warnings,
        })
    }
}

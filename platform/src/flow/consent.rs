//! Informed consent: a study whose settings carry a consent text shows it before anything else
//! and starts only a worker who ticked "I agree". A worker who declines gets an assignment with
//! status `declined` and no HIT, so the refusal is on record (and in the exports) and a reload
//! shows the same end page; on Prolific they are sent back with the no-consent code when one is
//! configured, on MTurk asked to return the HIT.
//!
//! The record keeps a version of the text (the first 12 hex digits of its SHA-256), so an edit
//! of the consent text after some workers agreed does not blur what they agreed to.

use sha2::{Digest, Sha256};

use super::{
    Assignment, Handback, NewAssignment, PROLIFIC_COMPLETE, StartOutcome, ensure_worker,
    existing_token,
};
use crate::error::{AppError, Result};
use crate::store::db::Db;
use crate::studies::study::Study;

/// Records the consent answer `$1` (`agreed`/`declined`) to text version `$2` at `$3` of
/// assignment `$4`.
pub(super) const RECORD: &str =
    "UPDATE assignments SET consent = $1, consent_version = $2, consent_at = $3 WHERE id = $4";

/// Whether the study asks for consent.
pub(super) fn required(study: &Study) -> bool {
    !study.settings.consent.trim().is_empty()
}

/// The version of a consent text: 12 hex digits of its SHA-256.
pub fn consent_version(text: &str) -> String {
    hex::encode(&Sha256::digest(text.as_bytes())[..6])
}

/// Stores a declined consent as an assignment without a HIT. A worker who already has an
/// assignment in the study (a concurrent start) resumes it instead.
pub(super) async fn decline(
    db: &Db,
    study: &Study,
    new: NewAssignment,
    external: &str,
) -> Result<StartOutcome> {
    let mut tx = db.begin_write().await?;
    let worker = ensure_worker(&mut tx, new.source, external).await?;
    if new.insert(&mut tx, worker).await? {
        tx.commit().await?;
        return Ok(StartOutcome::Started {
            token: new.token,
            resumed: false,
        });
    }
    tx.rollback().await?;
    let token = existing_token(db, study.id, worker)
        .await?
        .ok_or(AppError::Internal("assignment vanished".into()))?;
    Ok(StartOutcome::Started {
        token,
        resumed: true,
    })
}

/// How a worker who declined leaves: Prolific's no-consent code when the study has one.
pub(super) fn handback(study: &Study, a: &Assignment) -> Handback {
    match (a.source.as_str(), &study.settings.prolific_noconsent_code) {
        ("prolific", Some(cc)) => Handback::Redirect {
            url: format!("{PROLIFIC_COMPLETE}?cc={cc}"),
        },
        _ => Handback::Return,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn versions_follow_the_text() {
        let v = consent_version("I agree to take part.");
        assert_eq!(v.len(), 12);
        assert_eq!(v, consent_version("I agree to take part."));
        assert_ne!(v, consent_version("I agree to take part"));
    }
}

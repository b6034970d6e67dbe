//! Bonuses an admin records for a worker's HIT (from the worker's row on the study page or the
//! JSON API): an amount and the reason the worker is shown, stored with who recorded it and
//! when. The platform pays nothing itself; the exports turn the records into the files the
//! crowd platforms are paid with (`mturk_bonuses.csv` for `aws mturk send-bonus`,
//! `prolific_bonuses.csv` for Prolific's bulk bonus).

use serde::Serialize;
use sqlx::Row;

use crate::error::{AppError, Result};
use crate::store::db::{Db, now_ms};
use crate::store::ids::{AssignmentId, BonusId, StudyId};

/// The largest bonus one record may carry, in cents (100.00): a guard against typing 425 for 4.25
/// (Prolific pays an amount of 30 as 30.00, and MTurk takes the amount as given).
pub const MAX_BONUS_CENTS: i64 = 10_000;

/// The longest reason, in characters.
pub const MAX_REASON_CHARS: usize = 500;

/// Parses an amount written as a decimal with at most two decimals (`4`, `4.5`, `4.25`), the
/// way MTurk's `BonusAmount` and Prolific's bulk bonus take it, into cents.
pub fn parse_amount(text: &str) -> Result<i64> {
    let text = text.trim();
    let bad = || {
        AppError::BadRequest(format!(
            "amount: {text:?} is not an amount like 1.50 (digits, at most two decimals, no \
             currency sign)"
        ))
    };
    let (whole, fraction) = text.split_once('.').unwrap_or((text, ""));
    let digits = |s: &str| s.chars().all(|c| c.is_ascii_digit());
    if whole.is_empty() || whole.len() > 6 || !digits(whole) || fraction.len() > 2 {
        return Err(bad());
    }
    if !digits(fraction) || (text.contains('.') && fraction.is_empty()) {
        return Err(bad());
    }
    let whole: i64 = whole.parse().map_err(|_| bad())?;
    let fraction: i64 = match fraction.len() {
        0 => 0,
        1 => fraction.parse::<i64>().map_err(|_| bad())? * 10,
        _ => fraction.parse().map_err(|_| bad())?,
    };
    let cents = whole * 100 + fraction;
    if cents == 0 {
        return Err(AppError::BadRequest("amount: must be more than 0".into()));
    }
    if cents > MAX_BONUS_CENTS {
        return Err(AppError::BadRequest(format!(
            "amount: at most {} per bonus (record several for more)",
            format_cents(MAX_BONUS_CENTS)
        )));
    }
    Ok(cents)
}

/// Cents as the crowd platforms write amounts: `4.25`.
pub fn format_cents(cents: i64) -> String {
    format!("{}.{:02}", cents / 100, cents % 100)
}

/// Checks the reason a worker is shown with a bonus; returns it trimmed.
pub fn check_reason(reason: &str) -> Result<&str> {
    let reason = reason.trim();
    if reason.is_empty() {
        return Err(AppError::BadRequest(
            "reason: required (MTurk shows it to the worker with the bonus)".into(),
        ));
    }
    if reason.chars().count() > MAX_REASON_CHARS {
        return Err(AppError::BadRequest(format!(
            "reason: at most {MAX_REASON_CHARS} characters"
        )));
    }
    // The payment files carry the reason to the worker as it is: one starting like a formula
    // would reach them with the export's spreadsheet quote in front.
    if reason.starts_with(['=', '+', '-', '@', '\'']) {
        return Err(AppError::BadRequest(
            "reason: may not start with =, +, -, @ or ' (spreadsheets read that as a formula)"
                .into(),
        ));
    }
    if reason.chars().any(char::is_control) {
        return Err(AppError::BadRequest(
            "reason: one line of text (no line breaks or control characters)".into(),
        ));
    }
    Ok(reason)
}

/// A recorded bonus, with the worker and HIT it is for.
#[derive(Debug, Clone, Serialize, utoipa::ToSchema)]
pub struct BonusRecord {
    /// The bonus (also its `UniqueRequestToken` in `mturk_bonuses.csv`: `bonus-ID`).
    pub id: BonusId,
    /// The HIT it is for.
    pub assignment: AssignmentId,
    /// The worker's id on their crowd platform (MTurk `workerId`, Prolific `PROLIFIC_PID`, the
    /// `participant` of a direct link).
    pub worker_id: String,
    /// `mturk`, `prolific` or `direct`.
    pub source: String,
    /// MTurk's `assignmentId` of the HIT (MTurk only).
    pub external_assignment: Option<String>,
    /// Prolific's `STUDY_ID` (Prolific only; a bulk bonus is paid per Prolific study).
    pub prolific_study: Option<String>,
    /// The amount in cents.
    pub amount_cents: i64,
    /// The amount as the platforms take it (`4.25`).
    pub amount: String,
    /// The reason the worker is shown.
    pub reason: String,
    /// Who recorded it (`admin:NAME`).
    pub actor: String,
    /// When (Unix ms).
    pub created_at: i64,
    /// The HIT's status now.
    pub status: String,
    /// The HIT's decision now.
    pub decision: Option<String>,
}

/// Records a bonus for `assignment` of `study`. Refused (409) while the HIT is still open:
/// MTurk pays bonuses on submitted assignments only.
pub async fn record(
    db: &Db,
    study: StudyId,
    assignment: AssignmentId,
    amount_cents: i64,
    reason: &str,
    actor: &str,
) -> Result<BonusRecord> {
    if !(1..=MAX_BONUS_CENTS).contains(&amount_cents) {
        return Err(AppError::BadRequest(format!(
            "amount: between 0.01 and {}",
            format_cents(MAX_BONUS_CENTS)
        )));
    }
    let reason = check_reason(reason)?;
    let id = BonusId::generate();
    let mut tx = db.begin_write().await?;
    let row = sqlx::query("SELECT status FROM assignments WHERE id = $1 AND study_id = $2")
        .bind(assignment.0)
        .bind(study.0)
        .fetch_optional(&mut *tx)
        .await?
        .ok_or(AppError::NotFound("assignment"))?;
    let status: String = row.try_get("status")?;
    if status == "training" || status == "active" {
        return Err(AppError::Conflict(format!(
            "a bonus is for a finished HIT, and this one is still {status}"
        )));
    }
    sqlx::query(
        "INSERT INTO bonuses (id, study_id, assignment_id, amount_cents, reason, actor, created_at) \
         VALUES ($1, $2, $3, $4, $5, $6, $7)",
    )
    .bind(id.0)
    .bind(study.0)
    .bind(assignment.0)
    .bind(amount_cents)
    .bind(reason)
    .bind(actor)
    .bind(now_ms())
    .execute(&mut *tx)
    .await?;
    tx.commit().await?;
    list(db, study)
        .await?
        .into_iter()
        .find(|b| b.id == id)
        .ok_or_else(|| AppError::internal("the recorded bonus is not listed"))
}

/// The bonuses of a study, newest first.
pub async fn list(db: &Db, study: StudyId) -> Result<Vec<BonusRecord>> {
    let rows = sqlx::query(
        "SELECT b.id, b.assignment_id, b.amount_cents, b.reason, b.actor, b.created_at, \
           w.external_id, a.source, a.external_assignment, a.prolific_study, a.status, a.decision \
         FROM bonuses b JOIN assignments a ON a.id = b.assignment_id \
           JOIN workers w ON w.id = a.worker_id \
         WHERE b.study_id = $1 ORDER BY b.created_at DESC, b.id DESC",
    )
    .bind(study.0)
    .fetch_all(&db.pool)
    .await?;
    rows.iter()
        .map(|r| {
            let cents: i64 = r.try_get("amount_cents")?;
            Ok(BonusRecord {
                id: BonusId(r.try_get("id")?),
                assignment: AssignmentId(r.try_get("assignment_id")?),
                worker_id: r.try_get("external_id")?,
                source: r.try_get("source")?,
                external_assignment: r.try_get("external_assignment")?,
                prolific_study: r.try_get("prolific_study")?,
                amount_cents: cents,
                amount: format_cents(cents),
                reason: r.try_get("reason")?,
                actor: r.try_get("actor")?,
                created_at: r.try_get("created_at")?,
                status: r.try_get("status")?,
                decision: r.try_get("decision")?,
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn amounts_are_decimals_with_at_most_two_places() {
        for (text, cents) in [("4", 400), ("4.5", 450), ("4.25", 425), (" 0.01 ", 1)] {
            assert_eq!(parse_amount(text).ok(), Some(cents), "{text}");
        }
        assert_eq!(parse_amount("100.00").ok(), Some(MAX_BONUS_CENTS));
        for bad in [
            "", "0", "0.00", "-1", "+1", "1.234", "1.", ".5", "1,50", "$1", "1e2", "abc", "100.01",
            "9999999",
        ] {
            let e = parse_amount(bad).expect_err(bad);
            assert!(e.to_string().starts_with("amount:"), "{bad}: {e}");
        }
    }

    #[test]
    fn cents_are_written_as_the_platforms_take_them() {
        assert_eq!(format_cents(425), "4.25");
        assert_eq!(format_cents(5), "0.05");
        assert_eq!(format_cents(1000), "10.00");
    }

    #[test]
    fn reasons_are_one_line_of_bounded_text() {
        assert_eq!(check_reason("  Great work  ").ok(), Some("Great work"));
        for bad in [
            "",
            "   ",
            "two\nlines",
            "=HYPERLINK(\"x\")",
            "-1",
            &"x".repeat(MAX_REASON_CHARS + 1),
        ] {
            let e = check_reason(bad).expect_err("invalid");
            assert!(e.to_string().starts_with("reason:"), "{e}");
        }
    }
}

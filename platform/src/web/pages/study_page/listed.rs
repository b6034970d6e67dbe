//! The study page's lists as it shows them: settings changes, audited decisions and bonuses,
//! each with a readable UTC time.

use crate::flow::qc::DecisionRecord;
use crate::studies::bonus::BonusRecord;
use crate::studies::study_edit::SettingsChange;

use crate::time::utc_minute;

/// A settings change as the study page lists it.
pub(super) struct ChangeRow {
    pub(super) at: String,
    pub(super) field: String,
    pub(super) old: String,
    pub(super) new: String,
    pub(super) actor: String,
}

impl From<SettingsChange> for ChangeRow {
    fn from(c: SettingsChange) -> Self {
        Self {
            at: utc_minute(c.changed_at),
            field: c.field,
            old: c.old.to_string(),
            new: c.new.to_string(),
            actor: c.actor,
        }
    }
}

/// An audited decision as the study page lists it.
pub(super) struct AuditRow {
    pub(super) at: String,
    pub(super) worker_id: String,
    pub(super) source: String,
    pub(super) decision: String,
    pub(super) rule: String,
    pub(super) actor: String,
    pub(super) control_errors: i64,
}

impl From<DecisionRecord> for AuditRow {
    fn from(d: DecisionRecord) -> Self {
        Self {
            at: utc_minute(d.decided_at),
            worker_id: d.worker_id,
            source: d.source,
            decision: d.decision,
            rule: d.rule,
            actor: d.actor,
            control_errors: d.control_errors,
        }
    }
}

/// A recorded bonus as the study page lists it.
pub(super) struct BonusRow {
    pub(super) at: String,
    pub(super) worker_id: String,
    pub(super) source: String,
    pub(super) amount: String,
    pub(super) reason: String,
    pub(super) actor: String,
}

impl From<BonusRecord> for BonusRow {
    fn from(b: BonusRecord) -> Self {
        Self {
            at: utc_minute(b.created_at),
            worker_id: b.worker_id,
            source: b.source,
            amount: b.amount,
            reason: b.reason,
            actor: b.actor,
        }
    }
}

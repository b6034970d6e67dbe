//! The columns of every CSV export (the data dictionary of `manifest.json`) and the manifest's
//! notes on identifiers, filters, payment files, spreadsheets and times.

use serde_json::{Value, json};

use super::table::{Column, Kind, Table};

pub(super) const fn text(name: &'static str, about: &'static str) -> Column {
    Column {
        name,
        kind: Kind::Text,
        about,
    }
}

pub(super) const fn number(name: &'static str, about: &'static str) -> Column {
    Column {
        name,
        kind: Kind::Number,
        about,
    }
}

pub(super) const WORKER_ID: &str = "the worker's id on their crowd platform: MTurk workerId, Prolific \
                         PROLIFIC_PID, the participant parameter of a direct link (a pseudonym \
                         W… in a pseudonymous export)";

pub(super) const TRIPLETS: Table = Table {
    file: "triplets.csv",
    header: true,
    columns: &[
        text("a", "reference item (library item name)"),
        text("b", "first candidate item"),
        text("c", "second candidate item"),
        number(
            "q",
            "1 if the worker judged A closer in style to B, 0 if to C",
        ),
        text(
            "worker",
            "the same as worker_id: the learner's triplet format groups answers by this column",
        ),
        text(
            "tuple_id",
            "id of the triplet; replicated tuples share it; control:ID for a hidden control",
        ),
        text("worker_id", WORKER_ID),
    ],
};

pub(super) const REASONS: Table = Table {
    file: "reasons.csv",
    header: true,
    columns: &[
        text("worker_id", WORKER_ID),
        text("tuple_id", "triplet id (control:ID for a hidden control)"),
        text("a", "reference item"),
        text("b", "first candidate"),
        text("c", "second candidate"),
        number("q", "1 if B was chosen"),
        text(
            "reasons",
            "chosen reason codes separated by ';' (attribute:code)",
        ),
        text("text", "optional free text"),
    ],
};

pub(super) const WORKERS: Table = Table {
    file: "workers.csv",
    header: true,
    columns: &[
        text("worker_id", WORKER_ID),
        text("source", "mturk, prolific or direct"),
        text(
            "status",
            "training, active, completed, screened_out, declined (no consent) or abandoned (expired or blocked)",
        ),
        text("decision", "approved, rejected or empty"),
        number(
            "answered",
            "main questions answered (with include_controls: hidden controls too)",
        ),
        number("control_errors", "wrong or unanswered hidden controls"),
        number("training_attempts", "training attempts used"),
        number(
            "bonus",
            "sum of the bonuses recorded for the HIT (bonuses.csv)",
        ),
        number("blocked", "1 if the worker id is on the study's block list"),
        text("gender", "self-reported, optional"),
        text("art_experience", "none, some or professional (optional)"),
    ],
};

pub(super) const ASSIGNMENTS: Table = Table {
    file: "assignments.csv",
    header: true,
    columns: &[
        number("assignment", "assignment id (the platform's own)"),
        text("worker_id", WORKER_ID),
        text("source", "mturk, prolific or direct"),
        number("sandbox", "1 for the MTurk sandbox"),
        text(
            "status",
            "training, active, completed, screened_out, declined (no consent) or abandoned (expired or blocked)",
        ),
        text("decision", "approved, rejected or empty"),
        number(
            "questions",
            "main questions in the HIT (with include_controls: hidden controls too)",
        ),
        number(
            "answered",
            "main questions answered (with include_controls: hidden controls too)",
        ),
        number("control_errors", "wrong or unanswered hidden controls"),
        number("started_at", "Unix ms"),
        text("started_at_utc", "started_at in ISO 8601 UTC"),
        number("completed_at", "Unix ms, empty while the HIT is open"),
        text("completed_at_utc", "completed_at in ISO 8601 UTC"),
        text(
            "consent",
            "agreed, declined, or empty when the study asked for no consent",
        ),
        text(
            "consent_version",
            "first 12 hex digits of the SHA-256 of the consent text answered",
        ),
        number("consent_at", "Unix ms of the consent answer"),
        text("consent_at_utc", "consent_at in ISO 8601 UTC"),
    ],
};

pub(super) const BONUSES: Table = Table {
    file: "bonuses.csv",
    header: true,
    columns: &[
        text(
            "bonus",
            "bonus id (bonus-ID, mturk_bonuses.csv's UniqueRequestToken)",
        ),
        number("assignment", "assignment id (assignments.csv)"),
        text("worker_id", WORKER_ID),
        text("source", "mturk, prolific or direct"),
        number(
            "amount",
            "in the platform's currency (MTurk: US dollars; Prolific: the study's currency)",
        ),
        text("reason", "the reason the worker is shown"),
        text("by", "who recorded it (admin:NAME)"),
        number("created_at", "Unix ms"),
        text("created_at_utc", "created_at in ISO 8601 UTC"),
    ],
};

pub(super) const MTURK_DECISIONS: Table = Table {
    file: "mturk_decisions.csv",
    header: true,
    columns: &[
        text("AssignmentId", "MTurk assignment id (identifying)"),
        text(
            "WorkerId",
            "MTurk worker id (identifying; worker_id elsewhere)",
        ),
        text("HITId", "MTurk HIT id"),
        text("Approve", "x when approved"),
        text("Reject", "rejection reason when rejected"),
    ],
};

pub(super) const MTURK_BONUSES: Table = Table {
    file: "mturk_bonuses.csv",
    header: true,
    columns: &[
        text(
            "WorkerId",
            "MTurk worker id (--worker-id of aws mturk send-bonus)",
        ),
        text("AssignmentId", "MTurk assignment id (--assignment-id)"),
        number("BonusAmount", "US dollars, e.g. 1.50 (--bonus-amount)"),
        text("Reason", "shown to the worker (--reason)"),
        text(
            "UniqueRequestToken",
            "bonus-ID (--unique-request-token): MTurk refuses to pay the same token twice",
        ),
    ],
};

pub(super) const PROLIFIC_BONUSES: Table = Table {
    file: "prolific_bonuses.csv",
    header: false,
    columns: &[
        text(
            "participant_id",
            "PROLIFIC_PID (no header line: the format of Prolific's bulk bonus, \
             `<participant_id>,<amount>` per line)",
        ),
        number("amount", "in the Prolific study's currency, e.g. 4.25"),
    ],
};

pub(super) const REPORT: Table = Table {
    file: "report.csv",
    header: true,
    columns: &[
        text(
            "kind",
            "the study's kind: triplet, composition-rating, mashup or iconset",
        ),
        text(
            "group",
            "empty for the whole study, A or B for a mash-up or icon-set condition, worker N \
             for one worker of a composition rating (the platform's worker number, as in report.json)",
        ),
        text(
            "measure",
            "the field of report.json: for a composition rating question, workers, answers, \
             chose_a, mean_rate (the preference rate for condition A), t, df, p (one-sided, \
             against 0.5), effect_size (Cohen's d), sd, ci_low, ci_high, note, and per worker \
             answers, chose_a, rate; for a mash-up study per condition workers, pieces, \
             searches and position_mean, position_half_width, position_low, position_high, \
             position_sd; for an icon-set study confidence and per condition workers, sets and \
             seconds_per_set_, deletions_per_set_, searches_per_set_ and spread_per_set_ mean, half_width, low, \
             high, sd",
        ),
        number(
            "value",
            "the number (empty when the report has none, e.g. no test yet)",
        ),
        text("text", "the question, or why there is no test"),
    ],
};

/// Every CSV file, in the order of [`super::FILES`].
pub(super) const TABLES: [&Table; 12] = [
    &TRIPLETS,
    &REASONS,
    &WORKERS,
    &ASSIGNMENTS,
    &BONUSES,
    &super::mashup::SEARCHES,
    &super::mashup::EVENTS,
    &super::iconset::SETS,
    &MTURK_DECISIONS,
    &MTURK_BONUSES,
    &PROLIFIC_BONUSES,
    &REPORT,
];

/// The files that exist to pay workers: they need the real ids, list every HIT or bonus
/// whatever the filters, and are left out of a pseudonymous export.
pub(super) const PAYMENT_FILES: [&str; 3] = [
    "mturk_decisions.csv",
    "mturk_bonuses.csv",
    "prolific_bonuses.csv",
];

/// The data dictionary: file → column → meaning.
pub(super) fn dictionary() -> Value {
    Value::Object(
        TABLES
            .iter()
            .map(|t| {
                let cols = t
                    .columns
                    .iter()
                    .map(|c| (c.name.to_string(), Value::String(c.about.to_string())))
                    .collect();
                (t.file.to_string(), Value::Object(cols))
            })
            .collect(),
    )
}

/// File → the columns written as numbers (every other column is text, neutralised).
pub(super) fn number_columns() -> Value {
    Value::Object(
        TABLES
            .iter()
            .map(|t| (t.file.to_string(), json!(t.number_columns())))
            .collect(),
    )
}

/// The manifest's notes: what the ids are, what each filter does to each file, why the
/// payment files ignore the filters, how text cells are written, what the times are.
pub(super) fn notes() -> Value {
    json!({
        "identifiers": "worker_id (and triplets.csv's worker) is the id the worker's crowd \
            platform uses — MTurk workerId, Prolific PROLIFIC_PID, the participant parameter of \
            a direct link — the same id the study page, the block list and the payment files \
            use. It identifies a person: share only a pseudonymous export (pseudonymous=true).",
        "filters": {
            "default": "Without options, triplets.csv, reasons.csv, workers.csv, \
                assignments.csv, bonuses.csv, the mash-up study's mashup_searches.csv and \
                mashup_events.csv and the icon-set study's iconset_sets.csv hold the completed, \
                non-rejected HITs and, of \
                their questions, the main ones only (training answers are never exported).",
            "include_controls": {
                "triplets.csv": "adds the answers to hidden controls (tuple_id control:ID)",
                "reasons.csv": "adds the reasons given on hidden controls",
                "workers.csv": "answered counts the hidden controls too",
                "assignments.csv": "questions and answered count the hidden controls too",
                "bonuses.csv": "no effect (a bonus is for a whole HIT)",
                "mashup_searches.csv": "no effect (a mash-up HIT has no controls)",
                "mashup_events.csv": "no effect (a mash-up HIT has no controls)",
                "iconset_sets.csv": "no effect (an icon-set HIT has no controls)",
            },
            "include_rejected": {
                "triplets.csv": "adds the answers of rejected HITs",
                "reasons.csv": "adds the reasons given in rejected HITs",
                "workers.csv": "adds the workers whose HIT was rejected",
                "assignments.csv": "adds the rejected HITs",
                "bonuses.csv": "adds the bonuses recorded for rejected HITs",
                "mashup_searches.csv": "adds the searches of rejected HITs",
                "mashup_events.csv": "adds the canvas events of rejected HITs",
                "iconset_sets.csv": "adds the sets of rejected HITs",
            },
            "include_incomplete": {
                "triplets.csv": "adds the answers of HITs that are not completed (in \
                    training, answering, screened out, or ended by expiry or a block)",
                "reasons.csv": "adds the reasons given in HITs that are not completed",
                "workers.csv": "adds the workers whose HIT is not completed",
                "assignments.csv": "adds the HITs that are not completed",
                "bonuses.csv": "adds the bonuses of HITs that are not completed (e.g. \
                    screened out)",
                "mashup_searches.csv": "adds the searches of HITs not submitted",
                "mashup_events.csv": "adds the canvas events of HITs not submitted",
                "iconset_sets.csv": "adds the finished sets of HITs not submitted",
            },
            "pseudonymous": {
                "every file": "worker_id and triplets.csv's worker hold a pseudonym (W and \
                    10 hex digits, an HMAC of the study's secret: stable within the study, not \
                    linkable to the platform id without the secret) instead of the platform id",
                "mturk_decisions.csv, mturk_bonuses.csv, prolific_bonuses.csv": "left out: \
                    they exist to pay the workers and need their real ids",
            },
        },
        "payment_files": "mturk_decisions.csv lists every completed MTurk HIT whatever the \
            filters: MTurk needs a decision for every submitted assignment, rejected ones \
            included, and the filters select data for analysis, not whom to pay. For the same \
            reason mturk_bonuses.csv and prolific_bonuses.csv list every bonus recorded for an \
            MTurk or Prolific HIT. mturk_bonuses.csv's UniqueRequestToken makes `aws mturk \
            send-bonus` refuse a bonus it already paid; Prolific's bulk bonus has no such \
            guard, so pay each of its lines once (a Prolific bulk bonus is for one Prolific \
            study).",
        "spreadsheets": "A text cell that starts with =, +, -, @, a tab, a carriage return \
            or ' is written with one ' in front, so that a spreadsheet shows it as text instead \
            of running it as a formula (OWASP's CSV injection rule). A program reading the \
            files removes that one leading ' (the learner does). The columns listed in \
            number_columns are numbers the platform wrote and are left as they are.",
        "times": "Columns ending in _at are Unix milliseconds; those ending in _at_utc are \
            the same instant in ISO 8601 UTC (YYYY-MM-DDTHH:MM:SS.sssZ).",
    })
}

//! The SQLite forms of the flow's writes that run as jobs of the answer writer
//! ([`crate::store::answer_writer`]), on its connection and inside its transaction: a HIT start, a HIT
//! allocation after training and a completion. Same statements as the sqlx forms in the parent
//! module (shared text), driven directly ([`crate::store::sqlite_direct`]): one short prepared
//! statement per row instead of one multi-row statement per round trip, since a statement is
//! a function call here and no longer a hand-off to sqlx's connection thread.

use rand::Rng;
use rusqlite::Connection;

use super::{
    ACTIVATE, Allocated, Allocation, COMPLETE, INSERT_ASSIGNMENT, INSERT_WORKER, NewAssignment,
    SlotClaim, Source, WORKER_ID, check_unchanged, hit_questions,
};
use crate::error::{AppError, Result};
use crate::flow::qc;
use crate::store::db::now_ms;
use crate::store::ids::{AssignmentId, WorkerId};
use crate::store::sqlite_direct::{execute, optional_row, rows};
use crate::studies::study::Study;

impl Allocation {
    /// [`Allocation::run`] on the answer writer's connection, inside its savepoint.
    pub(super) fn run_sqlite(mut self, conn: &Connection) -> Result<Allocated> {
        check_unchanged(
            &self.study.settings,
            &crate::studies::study::settings_sqlite(conn, self.study.id)?,
            Some(&self.external),
        )?;
        let worker = match self.known {
            Some(w) => w,
            None => ensure_worker(conn, self.new.source, &self.external)?,
        };
        if !self.new.insert_sqlite(conn, worker)? {
            return Ok(Allocated::Raced(worker));
        }
        if !self.training {
            fill_hit(
                conn,
                &self.study,
                self.new.id,
                worker,
                &self.controls,
                &mut self.rng,
            )?;
        }
        Ok(Allocated::New(self.new.token))
    }
}

/// Creates the worker unless a concurrent request just did; returns its id.
fn ensure_worker(conn: &Connection, source: Source, external: &str) -> Result<WorkerId> {
    execute(
        conn,
        INSERT_WORKER,
        &[
            &WorkerId::generate().0,
            &source.as_str(),
            &external,
            &now_ms(),
        ],
    )?;
    let id = optional_row(conn, WORKER_ID, &[&source.as_str(), &external], |r| {
        r.get::<_, i64>(0)
    })?
    .ok_or_else(|| AppError::Internal("the worker just inserted is missing".into()))?;
    Ok(WorkerId(id))
}

impl NewAssignment {
    /// [`NewAssignment::insert`] on the answer writer's connection.
    fn insert_sqlite(&self, conn: &Connection, worker: WorkerId) -> Result<bool> {
        let req = &self.req;
        let inserted = execute(
            conn,
            INSERT_ASSIGNMENT,
            &[
                &self.id.0,
                &self.token,
                &self.study.0,
                &worker.0,
                &self.source.as_str(),
                &i64::from(self.sandbox),
                &req.assignment_id,
                &req.hit_id,
                &self.submit_to(),
                &req.prolific_study_id,
                &req.prolific_session_id,
                &self.demographics,
                &self.status,
                &now_ms(),
            ],
        )?;
        if inserted != 1 {
            return Ok(false);
        }
        if let Some((answer, version)) = &self.consent {
            execute(
                conn,
                super::consent::RECORD,
                &[answer, version, &now_ms(), &self.id.0],
            )?;
        }
        Ok(true)
    }
}

/// [`super::allocate`]'s write on the answer writer's connection: 0 when the assignment was no
/// longer in training (a concurrent request allocated it).
pub(super) fn allocate(
    conn: &Connection,
    study: &Study,
    assignment: AssignmentId,
    worker: WorkerId,
    controls: &[i64],
    rng: &mut impl Rng,
) -> Result<usize> {
    check_unchanged(
        &study.settings,
        &crate::studies::study::settings_sqlite(conn, study.id)?,
        None,
    )?;
    if execute(conn, ACTIVATE, &[&assignment.0])? == 0 {
        return Ok(0);
    }
    fill_hit(conn, study, assignment, worker, controls, rng)
}

/// One free slot of each of the first `$4` tuples of study `$1` with `$2 < seq < $3`, as
/// (slot, tuple, seq, rowid). The rowid (SQLite's row address; the `BIGINT` id is a separate
/// unique index over random ids) lets the claim update the row without a lookup in that index,
/// whose pages are spread at random over the table's whole id range.
const FREE_SLOTS: &str = "SELECT MIN(s.id), s.tuple_id, s.seq, s.rowid FROM slots s \
     WHERE s.study_id = $1 AND s.assignment_id IS NULL AND s.seq > $2 AND s.seq < $3 \
     GROUP BY s.seq ORDER BY s.seq LIMIT $4";

/// Claims the slot at rowid `$4` for assignment `$1` of worker `$2` at `$3`, if it is still
/// free (the rowid was read in the same transaction, so it still addresses that slot).
const CLAIM_SLOT: &str = "UPDATE slots SET assignment_id = $1, worker_id = $2, claimed_at = $3 \
     WHERE rowid = $4 AND assignment_id IS NULL";

/// One question of a HIT (`$1` assignment … `$6` ask_reasons, in the column order).
const INSERT_QUESTION: &str = "INSERT INTO questions \
     (assignment_id, position, tuple_id, slot_id, swapped, ask_reasons) \
     VALUES ($1, $2, $3, $4, $5, $6)";

/// [`super::fill_hit`] on the answer writer's connection: the writer holds SQLite's write lock,
/// so the free slots read are still free when claimed (each claim is still conditional, and
/// checked).
fn fill_hit(
    conn: &Connection,
    study: &Study,
    assignment: AssignmentId,
    worker: WorkerId,
    controls: &[i64],
    rng: &mut impl Rng,
) -> Result<usize> {
    let claim = SlotClaim::new(study, assignment, worker, rng);
    let mut claimed = claim.range(conn, claim.start, i64::MAX, claim.wanted)?;
    if claimed.len() < claim.wanted {
        // Wrap around: from the first tuple up to where the first pass began.
        let upper = claimed
            .iter()
            .map(|&(_, _, seq)| seq)
            .min()
            .unwrap_or(claim.start + 1);
        let missing = claim.wanted - claimed.len();
        claimed.extend(claim.range(conn, -1, upper, missing)?);
    }
    let claimed: Vec<(i64, i64)> = claimed
        .into_iter()
        .map(|(slot, tuple, _)| (slot, tuple))
        .collect();
    let questions = hit_questions(&claimed, controls, &study.settings, rng)?;
    for (position, q) in questions.iter().enumerate() {
        execute(
            conn,
            INSERT_QUESTION,
            &[
                &assignment.0,
                &(position as i64),
                &q.tuple,
                &q.slot,
                &i64::from(q.swapped),
                &i64::from(q.ask_reasons),
            ],
        )?;
    }
    Ok(questions.len())
}

impl SlotClaim {
    /// Claims one free slot of each of the first `limit` tuples with `lower < seq < upper`;
    /// returns (slot, tuple, seq) of each.
    fn range(
        &self,
        conn: &Connection,
        lower: i64,
        upper: i64,
        limit: usize,
    ) -> Result<Vec<(i64, i64, i64)>> {
        let free = rows(
            conn,
            FREE_SLOTS,
            &[&self.study.0, &lower, &upper, &(limit as i64)],
            |r| Ok(((r.get(0)?, r.get(1)?, r.get(2)?), r.get::<_, i64>(3)?)),
        )?;
        for &((slot, _, _), rowid) in &free {
            let done = execute(
                conn,
                CLAIM_SLOT,
                &[&self.assignment.0, &self.worker.0, &self.now, &rowid],
            )?;
            if done != 1 {
                return Err(AppError::Internal(format!(
                    "slot {slot} was read as free but could not be claimed"
                )));
            }
        }
        Ok(free.into_iter().map(|(claimed, _)| claimed).collect())
    }
}

/// [`super::answers::complete_in`] on the answer writer's connection, inside its transaction.
pub(crate) fn complete_in_sqlite(conn: &Connection, a: AssignmentId, threshold: u32) -> Result<()> {
    if execute(conn, COMPLETE, &[&now_ms(), &a.0])? == 1 {
        let errors = qc::control_errors_sqlite(conn, a)?;
        qc::record_sqlite(
            conn,
            a,
            qc::verdict(errors, threshold),
            &qc::rule_name(threshold),
            "rule",
            errors,
        )?;
    }
    Ok(())
}

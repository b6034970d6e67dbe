//! A HIT's questions: allocation after the gate (slots claimed transactionally, hidden controls
//! at random positions) and their release when an assignment is abandoned or ended.

use super::*;

/// Expires assignments that started more than `older_than_ms` ago and are still in training or
/// answering: they become `abandoned` (further answers are refused) and the slots of their
/// unanswered questions are freed for other workers. Answers already given are kept. Returns
/// the number of expired assignments.
pub async fn release_abandoned(db: &Db, study: StudyId, older_than_ms: i64) -> Result<usize> {
    let cutoff = now_ms() - older_than_ms.max(0);
    let rows = sqlx::query(
        "SELECT id FROM assignments WHERE study_id = $1 AND status IN ('training', 'active') \
         AND started_at <= $2",
    )
    .bind(study.0)
    .bind(cutoff)
    .fetch_all(&db.pool)
    .await?;
    let mut released = 0;
    for r in rows {
        let id = AssignmentId(r.try_get("id")?);
        let mut tx = db.begin_write().await?;
        if end_open_assignment(&mut tx, id).await? {
            released += 1;
        }
        tx.commit().await?;
    }
    Ok(released)
}

/// Ends an assignment still in training or answering, inside `tx`: it becomes `abandoned`
/// (further answers are refused) and the slots of its unanswered questions are freed for
/// other workers; answers already given are kept. `false` if it was not open.
pub(crate) async fn end_open_assignment(tx: &mut AnyConnection, id: AssignmentId) -> Result<bool> {
    let moved = sqlx::query(
        "UPDATE assignments SET status = 'abandoned', completed_at = $1 WHERE id = $2 \
         AND status IN ('training', 'active')",
    )
    .bind(now_ms())
    .bind(id.0)
    .execute(&mut *tx)
    .await?;
    if moved.rows_affected() == 0 {
        return Ok(false);
    }
    sqlx::query(
        "UPDATE slots SET assignment_id = NULL, worker_id = NULL, claimed_at = NULL \
         WHERE assignment_id = $1 AND id IN \
         (SELECT slot_id FROM questions WHERE assignment_id = $1 AND choice IS NULL \
          AND slot_id IS NOT NULL)",
    )
    .bind(id.0)
    .execute(&mut *tx)
    .await?;
    sqlx::query("UPDATE questions SET slot_id = NULL WHERE assignment_id = $1 AND choice IS NULL")
        .bind(id.0)
        .execute(&mut *tx)
        .await?;
    Ok(true)
}

/// Allocates the HIT of an assignment that has passed its training: moves it from `training`
/// to `active` and fills it, in one write transaction (on SQLite a job of the answer writer,
/// sharing the answers' commit). Returns the number of questions; 0 when a concurrent request
/// had already allocated it.
pub async fn allocate(
    db: &Db,
    study: &Study,
    assignment: AssignmentId,
    worker: WorkerId,
) -> Result<usize> {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(rand::rng().random());
    let controls = hit_controls(db, study).await?;
    if db.backend == Backend::Sqlite {
        let study = study.clone();
        return db
            .answers
            .job(move |conn| {
                sqlite_writes::allocate(conn, &study, assignment, worker, &controls, &mut rng)
            })
            .await;
    }
    let mut tx = db.begin_write().await?;
    let row = sqlx::query(SETTINGS_NOW_POSTGRES)
        .bind(study.id.0)
        .fetch_one(&mut *tx)
        .await?;
    check_unchanged(
        &study.settings,
        &parse_settings(&row.try_get::<String, _>("settings")?)?,
        None,
    )?;
    let moved = sqlx::query(ACTIVATE)
        .bind(assignment.0)
        .execute(&mut *tx)
        .await?;
    if moved.rows_affected() == 0 {
        // Already allocated by a concurrent request.
        return Ok(0);
    }
    let n = fill_hit(&mut tx, study, assignment, worker, &controls, &mut rng).await?;
    tx.commit().await?;
    Ok(n)
}

/// Moves assignment `$1` from training to answering.
pub(super) const ACTIVATE: &str =
    "UPDATE assignments SET status = 'active' WHERE id = $1 AND status = 'training'";

/// The hidden controls of a new HIT, drawn uniformly without replacement (read before the
/// write transaction so that it does not hold the writer). The database draws them: a study
/// has ~100 controls and a HIT 5, and each row a sqlx read returns is one hand-off between
/// threads.
pub(super) async fn hit_controls(db: &Db, study: &Study) -> Result<Vec<i64>> {
    let rows = sqlx::query(
        "SELECT id FROM tuples WHERE study_id = $1 AND kind = 'control' \
         ORDER BY random() LIMIT $2",
    )
    .bind(study.id.0)
    .bind(i64::from(study.settings.controls_per_hit))
    .fetch_all(&db.pool)
    .await?;
    Ok(rows
        .iter()
        .map(|r| r.try_get("id"))
        .collect::<Result<_, _>>()?)
}

/// One question of a new HIT, at its index's position.
pub(super) struct NewQuestion {
    pub(super) tuple: i64,
    /// The claimed slot (`None`: a hidden control).
    pub(super) slot: Option<i64>,
    /// B and C shown the other way round.
    pub(super) swapped: bool,
    /// Ask the reasons questionnaire after it.
    pub(super) ask_reasons: bool,
}

/// The questions of a HIT from its claimed (slot, tuple) pairs and its controls, in random
/// positions, each shown swapped with probability ½ and asking for reasons with the study's
/// probability. No claimed slot is a conflict: the study has no more questions to give.
pub(super) fn hit_questions(
    claimed: &[(i64, i64)],
    controls: &[i64],
    settings: &study::StudySettings,
    rng: &mut impl Rng,
) -> Result<Vec<NewQuestion>> {
    if claimed.is_empty() {
        return Err(AppError::Conflict(
            "this study has no more questions available".into(),
        ));
    }
    let mut drawn: Vec<(i64, Option<i64>)> = claimed.iter().map(|&(s, t)| (t, Some(s))).collect();
    drawn.extend(controls.iter().map(|&t| (t, None)));
    drawn.shuffle(rng);
    Ok(drawn
        .into_iter()
        .map(|(tuple, slot)| {
            let ask_reasons = rng.random_bool(settings.reasons_probability);
            NewQuestion {
                tuple,
                slot,
                swapped: rng.random_bool(0.5),
                ask_reasons,
            }
        })
        .collect())
}

/// Fills a HIT inside `tx` (PostgreSQL; SQLite: [`sqlite_writes`]): claims up to `questions -
/// controls` free slots of distinct tuples the worker has never seen (conditional `UPDATE`s: a
/// slot is filled by exactly one assignment), adds the hidden controls, shuffles positions. A
/// study without a free slot is a conflict (the caller's transaction is then rolled back).
pub(super) async fn fill_hit(
    tx: &mut AnyConnection,
    study: &Study,
    assignment: AssignmentId,
    worker: WorkerId,
    controls: &[i64],
    rng: &mut impl Rng,
) -> Result<usize> {
    let claim = SlotClaim::new(study, assignment, worker, rng);
    let claimed = claim.one_per_statement(tx).await?;
    let questions = hit_questions(&claimed, controls, &study.settings, rng)?;
    // One multi-row INSERT instead of one statement per question (one round trip).
    let sql = questions_insert_sql(questions.len());
    let mut insert = sqlx::query(sqlx::AssertSqlSafe(sql));
    for (position, q) in questions.iter().enumerate() {
        insert = insert
            .bind(assignment.0)
            .bind(position as i64)
            .bind(q.tuple)
            .bind(q.slot)
            .bind(i64::from(q.swapped))
            .bind(i64::from(q.ask_reasons));
    }
    insert.execute(&mut *tx).await?;
    Ok(questions.len())
}

/// Claims up to `wanted` free slots of distinct tuples for one assignment, scanning tuples in
/// `seq` order from `start` and wrapping around once. A worker has one assignment per study, so
/// it holds no other slot of this study; the unique index on (tuple_id, worker_id) stays the
/// hard guarantee of distinct tuples, and the outer `assignment_id IS NULL` the final guard
/// against a double fill.
pub(super) struct SlotClaim {
    pub(super) assignment: AssignmentId,
    pub(super) worker: WorkerId,
    pub(super) study: StudyId,
    pub(super) now: i64,
    pub(super) wanted: usize,
    pub(super) start: i64,
}

impl SlotClaim {
    /// The claim of one HIT: `questions - controls` slots, starting at a random tuple (and
    /// wrapping around once), so that concurrent allocators spread over the table instead of
    /// all scanning (and, on PostgreSQL, skipping) the same first free rows.
    pub(super) fn new(
        study: &Study,
        assignment: AssignmentId,
        worker: WorkerId,
        rng: &mut impl Rng,
    ) -> Self {
        let s = &study.settings;
        Self {
            assignment,
            worker,
            study: study.id,
            now: now_ms(),
            wanted: (s.questions_per_hit - s.controls_per_hit) as usize,
            start: rng.random_range(-1..i64::from(s.tuples).max(0)),
        }
    }

    /// Binds `$1..$6` of the PostgreSQL claim statement: who claims, when, in which study, and
    /// the open `seq` range.
    pub(super) fn bind_claim<'q>(
        &self,
        query: sqlx::query::Query<'q, Any, sqlx::any::AnyArguments>,
        lower: i64,
        upper: i64,
    ) -> sqlx::query::Query<'q, Any, sqlx::any::AnyArguments> {
        query
            .bind(self.assignment.0)
            .bind(self.worker.0)
            .bind(self.now)
            .bind(self.study.0)
            .bind(lower)
            .bind(upper)
    }

    /// PostgreSQL: one claim per statement, the first free slot after the previously claimed
    /// tuple; the row lock is taken on that slot only and rows other allocators are claiming
    /// are skipped, so concurrent allocations neither wait on nor deadlock with each other.
    pub(super) async fn one_per_statement(
        &self,
        tx: &mut AnyConnection,
    ) -> Result<Vec<(i64, i64)>> {
        let mut claimed = Vec::with_capacity(self.wanted);
        let (mut lower, mut upper) = (self.start, i64::MAX);
        let (mut first_seq, mut wrapped) = (None, false);
        while claimed.len() < self.wanted {
            let query = sqlx::query(
                "UPDATE slots SET assignment_id = $1, worker_id = $2, claimed_at = $3 \
                 WHERE assignment_id IS NULL AND id = (SELECT s.id FROM slots s \
                   WHERE s.study_id = $4 AND s.assignment_id IS NULL AND s.seq > $5 AND s.seq < $6 \
                   ORDER BY s.seq, s.replica LIMIT 1 FOR UPDATE OF s SKIP LOCKED) \
                 RETURNING id, tuple_id, seq",
            );
            let row = self
                .bind_claim(query, lower, upper)
                .fetch_optional(&mut *tx)
                .await?;
            match row {
                Some(r) => {
                    claimed.push((r.try_get("id")?, r.try_get("tuple_id")?));
                    lower = r.try_get("seq")?;
                    first_seq.get_or_insert(lower);
                }
                None if !wrapped => {
                    wrapped = true;
                    upper = first_seq.unwrap_or(self.start + 1);
                    lower = -1;
                }
                None => break,
            }
        }
        Ok(claimed)
    }
}

/// `INSERT INTO questions … VALUES ($1…$6), ($7…$12), …` for `rows` rows. Only placeholders are
/// generated here; every value is bound (a HIT has at most a few hundred questions, far below
/// either database's parameter limit).
pub(super) fn questions_insert_sql(rows: usize) -> String {
    let mut sql = String::from(
        "INSERT INTO questions (assignment_id, position, tuple_id, slot_id, swapped, ask_reasons) VALUES ",
    );
    for row in 0..rows {
        let p = row * 6;
        if row > 0 {
            sql.push_str(", ");
        }
        sql.push_str(&format!(
            "(${}, ${}, ${}, ${}, ${}, ${})",
            p + 1,
            p + 2,
            p + 3,
            p + 4,
            p + 5,
            p + 6
        ));
    }
    sql
}

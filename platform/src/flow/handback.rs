//! Where an assignment stands and how the worker is handed back to the crowd platform, with
//! the HMAC completion and screen-out codes.

use super::*;

/// How to hand the worker back to the crowd platform.
#[derive(Debug, Clone, Serialize, ToSchema)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Handback {
    /// POST a form to MTurk's externalSubmit with these fields.
    MturkForm {
        /// Form action.
        action: String,
        /// MTurk assignmentId.
        assignment_id: String,
        /// Our completion code (also sent as a field).
        completion_code: String,
    },
    /// Redirect the browser.
    Redirect {
        /// Address.
        url: String,
    },
    /// Show the code; nothing else to do.
    Code,
    /// Nothing to submit: the worker returns the task on their crowd platform (MTurk HIT,
    /// Prolific study) or closes the page (a participant who did not consent).
    Return,
}

/// Everything the worker client needs to continue: the single source of truth for resume.
#[derive(Debug, Clone, Serialize, ToSchema)]
pub struct AssignmentState {
    /// `training`, `active`, `completed`, `screened_out`, `declined` (no consent) or
    /// `abandoned` (expired).
    pub status: String,
    /// `mturk`, `prolific`, `direct`.
    pub source: String,
    /// MTurk sandbox (shown as a banner).
    pub sandbox: bool,
    /// Study description.
    pub description: String,
    /// Training questions (while in training).
    pub training: Vec<QuestionView>,
    /// Training attempts used.
    pub training_attempts: i64,
    /// Training attempts allowed.
    pub max_training_attempts: i64,
    /// The questions of the last training attempt with the right answers (after a failed
    /// attempt; empty before the first).
    pub last_training_attempt: Vec<TrainingReview>,
    /// A question whose questionnaire is pending.
    pub reasons_for: Option<i64>,
    /// That question as it was shown.
    pub reasons_question: Option<QuestionView>,
    /// The picture the worker chose in it.
    pub reasons_choice: Option<ItemId>,
    /// The next question to answer.
    pub question: Option<QuestionView>,
    /// Images of the question after it (to preload).
    pub preload: Vec<String>,
    /// Answered questions.
    pub answered: i64,
    /// Questions in the HIT.
    pub total: i64,
    /// Completion code (when completed).
    pub completion_code: Option<String>,
    /// Screen-out code (when screened out).
    pub screenout_code: Option<String>,
    /// How to hand back (when completed or screened out).
    pub handback: Option<Handback>,
}

/// The state of an assignment.
pub async fn state(db: &Db, study: &Study, a: &Assignment) -> Result<AssignmentState> {
    let mut st = AssignmentState {
        status: a.status.clone(),
        source: a.source.clone(),
        sandbox: a.sandbox,
        description: study.settings.description.clone(),
        training: Vec::new(),
        training_attempts: a.training_attempts,
        max_training_attempts: i64::from(study.settings.max_training_attempts),
        last_training_attempt: Vec::new(),
        reasons_for: None,
        reasons_question: None,
        reasons_choice: None,
        question: None,
        preload: Vec::new(),
        answered: 0,
        total: 0,
        completion_code: None,
        screenout_code: None,
        handback: None,
    };
    match a.status.as_str() {
        "training" => {
            st.training = training::questions(db, study, a).await?;
            st.last_training_attempt = training::last_attempt(db, study.kind, a).await?;
        }
        "abandoned" => {}
        "declined" => st.handback = Some(consent::handback(study, a)),
        "screened_out" => {
            let code = code(&study.secret, "screenout", a.id);
            st.handback = Some(handback(study, a, &code, true));
            st.screenout_code = Some(code);
        }
        _ => {
            let rows = sqlx::query(
                "SELECT q.position, q.swapped, q.choice, q.ask_reasons, q.reasons, t.a, t.b, t.c \
                 FROM questions q JOIN tuples t ON t.id = q.tuple_id WHERE q.assignment_id = $1 \
                 ORDER BY q.position",
            )
            .bind(a.id.0)
            .fetch_all(&db.pool)
            .await?;
            st.total = rows.len() as i64;
            let mut upcoming = Vec::new();
            for r in &rows {
                let position: i64 = r.try_get("position")?;
                let choice: Option<String> = r.try_get("choice")?;
                if choice.is_some() {
                    st.answered += 1;
                    let pending = r.try_get::<i64, _>("ask_reasons")? != 0
                        && r.try_get::<Option<String>, _>("reasons")?.is_none();
                    if pending && st.reasons_for.is_none() {
                        let (b, c): (i64, i64) = (r.try_get("b")?, r.try_get("c")?);
                        st.reasons_for = Some(position);
                        st.reasons_question = Some(view(
                            study.kind,
                            position,
                            r.try_get("a")?,
                            b,
                            c,
                            r.try_get::<i64, _>("swapped")? != 0,
                        ));
                        st.reasons_choice =
                            Some(ItemId(if choice.as_deref() == Some("b") { b } else { c }));
                    }
                } else if upcoming.len() < 2 {
                    upcoming.push(view(
                        study.kind,
                        position,
                        r.try_get("a")?,
                        r.try_get("b")?,
                        r.try_get("c")?,
                        r.try_get::<i64, _>("swapped")? != 0,
                    ));
                }
            }
            let mut upcoming = upcoming.into_iter();
            st.question = upcoming.next();
            if let Some(next) = upcoming.next() {
                st.preload = next
                    .reference
                    .into_iter()
                    .chain([next.left, next.right])
                    .map(|i| i.url)
                    .collect();
            }
            if a.status == "completed" {
                let code = code(&study.secret, "complete", a.id);
                st.handback = Some(handback(study, a, &code, false));
                st.completion_code = Some(code);
            }
        }
    }
    Ok(st)
}

pub(super) fn handback(study: &Study, a: &Assignment, code: &str, screened_out: bool) -> Handback {
    match a.source.as_str() {
        "mturk" => Handback::MturkForm {
            action: format!(
                "{}/mturk/externalSubmit",
                a.submit_to
                    .as_deref()
                    .unwrap_or(study.settings.mturk_mode.submit_host())
            ),
            assignment_id: a.external_assignment.clone().unwrap_or_default(),
            completion_code: code.to_string(),
        },
        "prolific" => {
            let cc = if screened_out {
                study.settings.prolific_screenout_code.as_deref()
            } else {
                study.settings.prolific_completion_code.as_deref()
            };
            match cc {
                Some(cc) => Handback::Redirect {
                    url: format!("{PROLIFIC_COMPLETE}?cc={cc}"),
                },
                None => Handback::Code,
            }
        }
        _ => Handback::Code,
    }
}

/// The unforgeable code of an assignment: HMAC-SHA256(study secret, `kind:assignment id`),
/// 12 hex characters.
pub fn code(secret: &str, kind: &str, a: AssignmentId) -> String {
    let Ok(mut mac) = Hmac::<Sha256>::new_from_slice(secret.as_bytes()) else {
        // HMAC accepts keys of any length; this branch cannot be taken.
        return String::new();
    };
    mac.update(kind.as_bytes());
    mac.update(b":");
    mac.update(a.0.to_string().as_bytes());
    let out = mac.finalize().into_bytes();
    hex::encode_upper(&out[..6])
}

/// Finds the assignment a completion code belongs to (for requesters checking submissions).
pub async fn verify_code(db: &Db, study: &Study, code_given: &str) -> Result<Option<AssignmentId>> {
    let rows =
        sqlx::query("SELECT id FROM assignments WHERE study_id = $1 AND status = 'completed'")
            .bind(study.id.0)
            .fetch_all(&db.pool)
            .await?;
    let given = code_given.trim().to_ascii_uppercase();
    for r in rows {
        let id = AssignmentId(r.try_get("id")?);
        if code(&study.secret, "complete", id) == given {
            return Ok(Some(id));
        }
    }
    Ok(None)
}

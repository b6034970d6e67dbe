//! The reasons questionnaire (Garces et al. 2016 §6.3.2).

use super::*;

/// The reasons a worker may give, grouped by attribute (Garces et al. 2016 §6.3.2).
pub const REASONS: &[(&str, &str, &str)] = &[
    ("colour", "colour_palette", "Similar colours"),
    (
        "colour",
        "colour_saturation",
        "Similar saturation / brightness",
    ),
    ("shading", "shading_flat", "Both flat / both shaded"),
    (
        "shading",
        "shading_gradients",
        "Similar gradients or highlights",
    ),
    ("texture", "texture", "Similar texture or pattern"),
    ("stroke", "stroke_width", "Similar outline thickness"),
    ("stroke", "stroke_presence", "Both have / lack outlines"),
    (
        "shape",
        "shape_geometry",
        "Similar shapes (round, angular…)",
    ),
    ("shape", "shape_detail", "Similar level of detail"),
    ("other", "other", "Something else"),
];

/// Answers to the "why did you choose?" questionnaire.
#[derive(Debug, Clone, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct ReasonsRequest {
    /// The question's position.
    pub position: i64,
    /// Reason codes (may be empty to skip).
    #[schema(value_type = Vec<crate::web::api::schema::ReasonCode>, max_items = 10)]
    pub reasons: Vec<String>,
    /// Optional free text (at most 1000 characters).
    #[schema(max_length = 1000)]
    pub text: Option<String>,
}

/// Stores the questionnaire of a question that asked for it (idempotent: first answer wins).
pub async fn submit_reasons(db: &Db, a: &Assignment, req: &ReasonsRequest) -> Result<()> {
    if req.reasons.len() > REASONS.len() {
        return Err(AppError::BadRequest("reasons: too many".into()));
    }
    for r in &req.reasons {
        if !REASONS.iter().any(|(_, code, _)| code == r) {
            return Err(AppError::BadRequest(format!("reasons: unknown code {r:?}")));
        }
    }
    // Counted before trimming, as the schema's maxLength counts.
    if req
        .text
        .as_deref()
        .is_some_and(|t| t.chars().count() > 1000)
    {
        return Err(AppError::BadRequest("text: at most 1000 characters".into()));
    }
    let text = req.text.as_deref().map(str::trim).filter(|t| !t.is_empty());
    let row = sqlx::query(
        "SELECT ask_reasons, choice FROM questions WHERE assignment_id = $1 AND position = $2",
    )
    .bind(a.id.0)
    .bind(req.position)
    .fetch_optional(&db.pool)
    .await?
    .ok_or(AppError::NotFound("question"))?;
    if row.try_get::<i64, _>("ask_reasons")? == 0 {
        return Err(AppError::BadRequest(
            "this question has no questionnaire".into(),
        ));
    }
    if row.try_get::<Option<String>, _>("choice")?.is_none() {
        return Err(AppError::Conflict("answer the question first".into()));
    }
    sqlx::query(
        "UPDATE questions SET reasons = $1, reason_text = $2 WHERE assignment_id = $3 \
         AND position = $4 AND reasons IS NULL",
    )
    .bind(serde_json::to_string(&req.reasons).map_err(AppError::internal)?)
    .bind(text)
    .bind(a.id.0)
    .bind(req.position)
    .execute(&mut *db.write_conn().await?)
    .await?;
    Ok(())
}

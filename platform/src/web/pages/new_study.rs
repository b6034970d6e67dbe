//! The admin forms that create a composition-rating study from a mash-up study, a mash-up
//! study (§5.7.3) and an icon-set study (Garces et al. 2016 §6.6, its explorer computed before
//! the study is stored), beside the triplet form of the studies list. A refused form is shown
//! again, with its values and the reason, and a 400; nothing is stored.

use askama::Template;
use axum::Router;
use axum::extract::State;
use axum::http::StatusCode;
use axum::response::{IntoResponse, Redirect, Response};
use axum::routing::get;
use serde::Deserialize;

use super::mashup::background_choices;
use super::{page, render};
use crate::AppState;
use crate::error::{AppError, Result};
use crate::store::db::Db;
use crate::store::ids::StudyId;
use crate::studies::kind::{RatingQuestion, StudyKind};
use crate::studies::mashup::{MashupSettings, pool};
use crate::studies::study::{self, MturkMode};
use crate::studies::{library, rating};
use crate::web::admin::Admin;
use crate::web::extract::{ApiForm, ApiPath};

/// The two forms.
pub(super) fn routes() -> Router<AppState> {
    Router::new().route(
        "/admin/studies/new/{kind}",
        get(form_page).post(form_submit),
    )
}

/// What the admin typed (text, so that a bad number is shown again as typed).
#[derive(Debug, Default, Clone, Deserialize)]
#[serde(default)]
struct NewStudyForm {
    csrf: Option<String>,
    name: String,
    mashup: String,
    question: String,
    library: String,
    pairs: String,
    task: String,
    background: String,
    min_pieces: String,
    min_searches: String,
    compositions: String,
    labels: String,
    sets: String,
    model: String,
    kappa: String,
    tau: String,
    trays: String,
    questions_per_hit: String,
    replication: String,
    mturk_mode: String,
}

impl NewStudyForm {
    /// The forms' first values.
    fn initial() -> Self {
        Self {
            question: "coherence".into(),
            min_pieces: "3".into(),
            min_searches: "1".into(),
            labels: crate::studies::iconset::DEFAULT_LABELS.join(","),
            sets: crate::studies::iconset::DEFAULT_SETS.to_string(),
            kappa: "20".into(),
            tau: "2".into(),
            trays: crate::studies::iconset::pool::DEFAULT_TRAYS.to_string(),
            compositions: pool::DEFAULT_COMPOSITIONS.to_string(),
            questions_per_hit: "50".into(),
            replication: "3".into(),
            mturk_mode: "sandbox".into(),
            ..Self::default()
        }
    }
}

/// An option of a drop-down.
struct Choice {
    value: String,
    label: String,
    selected: bool,
}

#[derive(Template)]
#[template(path = "new_study.html")]
struct NewStudyPage {
    csrf: String,
    rating: bool,
    iconset: bool,
    action: String,
    error: String,
    form: NewStudyForm,
    mashups: Vec<Choice>,
    libraries: Vec<Choice>,
    backgrounds: Vec<Choice>,
}

fn kind_of(kind: &str) -> Result<StudyKind> {
    match StudyKind::parse(kind)? {
        StudyKind::Triplet => Err(AppError::NotFound("form")),
        k => Ok(k),
    }
}

async fn show(
    db: &Db,
    csrf: String,
    kind: StudyKind,
    form: NewStudyForm,
    error: String,
) -> Result<NewStudyPage> {
    let mut mashups = Vec::new();
    for s in study::list(db).await? {
        if s.kind == StudyKind::Mashup {
            let value = s.id.to_string();
            mashups.push(Choice {
                selected: value == form.mashup,
                label: format!("{} (study {})", s.name, s.id),
                value,
            });
        }
    }
    let libraries = library::library_names(db)
        .await?
        .into_iter()
        .map(|l| Choice {
            selected: l == form.library,
            label: l.clone(),
            value: l,
        })
        .collect();
    let mut backgrounds = vec![Choice {
        value: String::new(),
        label: "the worker chooses".into(),
        selected: form.background.is_empty(),
    }];
    backgrounds.extend(background_choices().into_iter().map(|b| Choice {
        selected: b.name == form.background,
        value: b.name.into(),
        label: b.label.into(),
    }));
    Ok(NewStudyPage {
        csrf,
        rating: kind == StudyKind::CompositionRating,
        iconset: kind == StudyKind::Iconset,
        action: format!("/admin/studies/new/{kind}"),
        error,
        form,
        mashups,
        libraries,
        backgrounds,
    })
}

async fn form_page(
    State(state): State<AppState>,
    admin: std::result::Result<Admin, AppError>,
    ApiPath(kind): ApiPath<String>,
) -> Response {
    page(
        async {
            let admin = admin?;
            let kind = kind_of(&kind)?;
            render(
                &show(
                    &state.db,
                    admin.csrf,
                    kind,
                    NewStudyForm::initial(),
                    String::new(),
                )
                .await?,
            )
        }
        .await,
    )
}

/// A whole number typed into the field `label`.
fn number(label: &str, text: &str) -> Result<u32> {
    text.trim().parse().map_err(|_| {
        AppError::BadRequest(format!("{label}: {:?} is not a whole number", text.trim()))
    })
}

/// An optional whole number (empty: `None`).
fn optional_number(label: &str, text: &str) -> Result<Option<u32>> {
    if text.trim().is_empty() {
        Ok(None)
    } else {
        number(label, text).map(Some)
    }
}

fn mturk(text: &str) -> Result<MturkMode> {
    match text {
        "sandbox" | "" => Ok(MturkMode::Sandbox),
        "live" => Ok(MturkMode::Live),
        other => Err(AppError::BadRequest(format!(
            "MTurk: {other:?} is not sandbox or live"
        ))),
    }
}

/// A whole number typed into the field `label`, as a `usize`.
fn count(label: &str, text: &str) -> Result<usize> {
    number(label, text).map(|n| n as usize)
}

/// Checks the icon-set form, computes the explorer and stores the study with it.
async fn create_iconset(
    state: &AppState,
    mut s: crate::studies::study::StudySettings,
    f: &NewStudyForm,
) -> Result<study::PendingPool> {
    use crate::studies::iconset::{self, IconsetSettings};
    s.tuples = number("HITs", &f.trays)?;
    let (library, model) =
        crate::explore::resolve(&state.db, &f.library, Some(f.model.trim())).await?;
    let settings = IconsetSettings {
        labels: f.labels.split(',').map(|l| l.trim().to_string()).collect(),
        sets: number("Sets", &f.sets)?,
        model,
        kappa: count("κ", &f.kappa)?,
        tau: count("τ", &f.tau)?,
    };
    s.iconset = Some(settings.clone());
    let first = library::list_items(&state.db, library)
        .await?
        .first()
        .map(|i| i.id);
    let drawn = iconset::pool::draw(&s, first)?;
    let explorer = iconset::explorer::compute(&state.db, &state.search, library, &settings).await?;
    let pending =
        study::begin_drawn(&state.db, &f.name, library, StudyKind::Iconset, s, drawn).await?;
    iconset::explorer::store(&state.db, pending.id, &explorer).await?;
    Ok(pending)
}

/// Creates the study the form describes; its id.
async fn create(state: &AppState, kind: StudyKind, f: &NewStudyForm) -> Result<StudyId> {
    let db = &state.db;
    let mut s = kind.default_settings();
    s.mturk_mode = mturk(&f.mturk_mode)?;
    let pending = if kind == StudyKind::CompositionRating {
        s.questions_per_hit = number("Questions per HIT", &f.questions_per_hit)?;
        s.replication = number("Replication R", &f.replication)?;
        let source: StudyId = f.mashup.trim().parse().map_err(|_| {
            AppError::BadRequest("From mash-up study: choose a mash-up study".into())
        })?;
        s.question = Some(match f.question.as_str() {
            "coherence" => RatingQuestion::Coherence,
            "preference" => RatingQuestion::Preference,
            other => {
                return Err(AppError::BadRequest(format!(
                    "Question: {other:?} is not coherence or preference"
                )));
            }
        });
        rating::from_mashup::no_known_answers(&mut s);
        let pairs = optional_number("Pairs", &f.pairs)?;
        let lib = match f.library.trim() {
            "" => format!("mashup-{source}-compositions"),
            l => l.to_string(),
        };
        rating::from_mashup::create(db, &f.name, &lib, &[source], pairs, s).await?
    } else if kind == StudyKind::Iconset {
        create_iconset(state, s, f).await?
    } else {
        s.tuples = number("Compositions", &f.compositions)?;
        let background = Some(f.background.clone()).filter(|b| !b.is_empty());
        s.mashup = Some(MashupSettings {
            task: f.task.clone(),
            background,
            min_pieces: number("Minimum pieces", &f.min_pieces)?,
            min_searches: number("Minimum searches", &f.min_searches)?,
        });
        let library = library::ensure_existing(db, &f.library).await?;
        let first = library::list_items(db, library)
            .await?
            .first()
            .map(|i| i.id);
        let drawn = pool::draw(&s, first)?;
        study::begin_drawn(db, &f.name, library, kind, s, drawn).await?
    };
    let id = pending.id;
    pending.build(db, |_, _| {}).await?;
    Ok(id)
}

async fn form_submit(
    State(state): State<AppState>,
    admin: std::result::Result<Admin, AppError>,
    ApiPath(kind): ApiPath<String>,
    form: std::result::Result<ApiForm<NewStudyForm>, AppError>,
) -> Response {
    page(
        async {
            let admin = admin?;
            let kind = kind_of(&kind)?;
            let ApiForm(f) = form?;
            admin.check_csrf(f.csrf.as_deref())?;
            match create(&state, kind, &f).await {
                Ok(id) => Ok(Redirect::to(&format!("/admin/studies/{id}")).into_response()),
                Err(e) if e.status().is_client_error() => {
                    let status = e.status();
                    let shown = show(&state.db, admin.csrf, kind, f, e.public_message()).await?;
                    let mut r = render(&shown)?;
                    *r.status_mut() = if status == StatusCode::NOT_FOUND {
                        StatusCode::BAD_REQUEST
                    } else {
                        status
                    };
                    Ok(r)
                }
                Err(e) => Err(e),
            }
        }
        .await,
    )
}

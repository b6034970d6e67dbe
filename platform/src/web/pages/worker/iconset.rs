//! A worker's icon-set task (Garces et al. 2016 §6.6) as a page of plain forms, so it works
//! without script and the server times every step: the tray of sets (the current set's slots
//! with their icons and a remove button each, the finished sets, the sets to come), and under it
//! the interface of the worker's condition, never named — the explorer (the representative
//! styles; one style's balanced grid, a node's hidden images in a pop-up opened by
//! `explore.js`) or the search ordered by style (one label at a time, by style to the icons of
//! the current set). What the page shows is in the query string (`style`, or `label` and `q`),
//! kept across the forms' posts; a refused step comes back as `error`.

use askama::Template;
use axum::extract::State;
use axum::response::{IntoResponse, Redirect, Response};

use crate::AppState;
use crate::error::{AppError, Result};
use crate::flow::Assignment;
use crate::store::ids::ItemId;
use crate::studies::iconset::log::{self, Action};
use crate::studies::iconset::{Condition, IconsetSettings};
use crate::studies::study::Study;
use crate::web::api::iconset_worker::{
    Icon, condition, iconset_of, index_for, load_explorer, run_search, submit_tray,
};
use crate::web::extract::{ApiForm, ApiPath};
use crate::web::pages::{page, render};

/// One slot of a set on the page.
struct SlotView {
    label: String,
    item: Option<ItemId>,
}

/// One set of the tray.
struct SetView {
    index: usize,
    /// `done`, `current` or `todo`.
    state: &'static str,
    slots: Vec<SlotView>,
}

/// A representative style in the explorer's list.
struct StyleLink {
    index: usize,
    item: ItemId,
    counts: String,
    selected: bool,
}

/// A node of the selected style's grid.
struct CellView {
    item: Option<ItemId>,
    hidden: Vec<ItemId>,
    /// The shown item then the hidden ones (the pop-up's icons).
    all: Vec<ItemId>,
    dialog: String,
}

#[derive(Template)]
#[template(path = "iconset_task.html")]
struct IconsetTaskPage {
    token: String,
    sandbox: bool,
    task: String,
    interface: &'static str,
    sets: Vec<SetView>,
    /// The set being made, from 1.
    current: Option<usize>,
    error: Option<String>,
    /// The view's query string, carried by every form.
    view: String,
    styles: Vec<StyleLink>,
    style: Option<usize>,
    grid: Vec<Vec<CellView>>,
    labels: Vec<String>,
    label: String,
    q: String,
    results: Vec<Icon>,
    matched: usize,
    /// Icons already in a set (each goes into one set only: shown, not pickable).
    used: Vec<ItemId>,
}

impl IconsetTaskPage {
    /// Whether `item` is already in a set.
    fn is_used(&self, item: &ItemId) -> bool {
        self.used.contains(item)
    }
}

/// What the page shows, from its query string (unknown keys ignored, values checked).
#[derive(Debug, Default, Clone, PartialEq, Eq)]
struct View {
    style: Option<usize>,
    label: Option<String>,
    q: Option<String>,
    error: Option<String>,
}

impl View {
    fn parse(query: &str) -> Self {
        let mut v = View::default();
        for (k, value) in form_urlencoded::parse(query.as_bytes()) {
            let value: String = value
                .chars()
                .filter(|c| !c.is_control())
                .take(200)
                .collect();
            match &*k {
                "style" => v.style = value.parse().ok(),
                "label" => v.label = Some(value),
                "q" => v.q = Some(value),
                "error" => v.error = Some(value),
                _ => {}
            }
        }
        v
    }

    /// The query string of this view without its error.
    fn query(&self) -> String {
        let mut out = form_urlencoded::Serializer::new(String::new());
        if let Some(s) = self.style {
            out.append_pair("style", &s.to_string());
        }
        if let Some(l) = &self.label {
            out.append_pair("label", l);
        }
        if let Some(q) = &self.q {
            out.append_pair("q", q);
        }
        out.finish()
    }
}

/// The task page of an active icon-set assignment.
pub(super) async fn render_task(
    state: &AppState,
    token: &str,
    a: &Assignment,
    s: &Study,
    settings: &IconsetSettings,
    sandbox: bool,
    query: Option<&str>,
) -> Result<Response> {
    let view = View::parse(query.unwrap_or(""));
    let c = condition(state, a, s).await?;
    let tray = log::tray(&state.db, settings, a.id).await?;
    let current = tray.current();
    let sets = tray
        .sets
        .iter()
        .enumerate()
        .map(|(i, set)| SetView {
            index: set.index,
            state: match current {
                Some(c) if c == i => "current",
                Some(c) if c < i => "todo",
                _ => "done",
            },
            slots: settings
                .labels
                .iter()
                .zip(&set.slots)
                .map(|(label, item)| SlotView {
                    label: label.clone(),
                    item: *item,
                })
                .collect(),
        })
        .collect();
    let mut p = IconsetTaskPage {
        token: token.to_string(),
        sandbox,
        task: settings.task(),
        interface: if c == Condition::A {
            "explorer"
        } else {
            "search"
        },
        sets,
        current: current.map(|c| c + 1),
        error: view.error.clone(),
        view: view.query(),
        styles: Vec::new(),
        style: None,
        grid: Vec::new(),
        labels: settings.labels.clone(),
        label: String::new(),
        q: view.q.clone().unwrap_or_default(),
        results: Vec::new(),
        matched: 0,
        used: tray
            .sets
            .iter()
            .flat_map(|s| s.slots.iter().flatten().copied())
            .collect(),
    };
    if current.is_none() {
        return render(&p);
    }
    match c {
        Condition::A => {
            let explorer = load_explorer(state, a, s).await?;
            let selected = view.style.filter(|&k| k < explorer.styles.len());
            p.style = selected;
            p.styles = explorer
                .styles
                .iter()
                .enumerate()
                .map(|(index, st)| StyleLink {
                    index,
                    item: st.id,
                    counts: st
                        .labels
                        .iter()
                        .map(|l| format!("{} {}", l.count, l.label))
                        .collect::<Vec<_>>()
                        .join(" · "),
                    selected: selected == Some(index),
                })
                .collect();
            if let Some(k) = selected {
                let grid = &explorer.styles[k].grid;
                p.grid = grid
                    .cells
                    .chunks(grid.cols.max(1))
                    .map(|row| {
                        row.iter()
                            .map(|cell| CellView {
                                item: cell.shown,
                                hidden: cell.hidden.clone(),
                                all: cell.shown.into_iter().chain(cell.hidden.clone()).collect(),
                                dialog: format!("hidden-{}-{}", cell.row, cell.col),
                            })
                            .collect()
                    })
                    .collect();
            }
        }
        Condition::B => {
            // The label asked for, else the first slot of the current set still empty.
            let set = &tray.sets[current.unwrap_or(0)];
            let first_empty = settings
                .labels
                .iter()
                .zip(&set.slots)
                .find(|(_, s)| s.is_none())
                .map_or_else(|| settings.labels[0].clone(), |(l, _)| l.clone());
            let label = view
                .label
                .clone()
                .filter(|l| settings.slot(l).is_some())
                .unwrap_or(first_empty);
            let q = view.q.as_deref().filter(|q| !q.trim().is_empty());
            let answer = run_search(state, a, s, settings, q, &label, None).await?;
            p.label = label;
            p.matched = answer.matched;
            p.results = answer.results;
        }
    }
    render(&p)
}

/// `POST /a/{token}/iconset`: a pick, a removal, a finished set or the submission; back to the
/// page, with the step's error when it was refused.
pub(super) async fn iconset_submit(
    State(state): State<AppState>,
    ApiPath(token): ApiPath<String>,
    form: std::result::Result<ApiForm<Vec<(String, String)>>, AppError>,
) -> Response {
    page(
        async {
            let ApiForm(pairs) = form?;
            let (a, s, settings) = iconset_of(&state, &token).await?;
            let field = |name: &str| {
                pairs
                    .iter()
                    .find(|(k, _)| k == name)
                    .map(|(_, v)| v.as_str())
            };
            let view = View::parse(field("view").unwrap_or(""));
            let back = |error: Option<String>| {
                let mut v = view.clone();
                v.error = error;
                let mut q = v.query();
                if let Some(e) = &v.error {
                    let mut s = form_urlencoded::Serializer::new(q);
                    s.append_pair("error", e);
                    q = s.finish();
                }
                if q.is_empty() {
                    format!("/a/{token}")
                } else {
                    format!("/a/{token}?{q}")
                }
            };
            let step = async {
                match field("action").unwrap_or("") {
                    "add" => {
                        let item = field("item")
                            .and_then(|v| v.parse().ok())
                            .ok_or_else(|| AppError::BadRequest("item: not an item id".into()))?;
                        act(&state, &a, &s, &settings, &Action::Add { item }).await
                    }
                    "remove" => {
                        let label = field("label").unwrap_or("").to_string();
                        act(&state, &a, &s, &settings, &Action::Remove { label }).await
                    }
                    "finish" => act(&state, &a, &s, &settings, &Action::Finish).await,
                    "submit" => submit_tray(&state, &token, &a, &s, &settings).await,
                    other => Err(AppError::BadRequest(format!(
                        "action: {:?} is not add, remove, finish or submit",
                        other.chars().take(20).collect::<String>()
                    ))),
                }
            };
            match step.await {
                Ok(()) => Ok(Redirect::to(&back(None)).into_response()),
                Err(e @ (AppError::BadRequest(_) | AppError::Conflict(_))) => {
                    Ok(Redirect::to(&back(Some(e.public_message()))).into_response())
                }
                Err(e) => Err(e),
            }
        }
        .await,
    )
}

async fn act(
    state: &AppState,
    a: &Assignment,
    s: &Study,
    settings: &IconsetSettings,
    action: &Action,
) -> Result<()> {
    if a.status != "active" {
        return Err(AppError::Conflict(format!(
            "the assignment is {}, not making icon sets",
            a.status
        )));
    }
    condition(state, a, s).await?;
    let index = index_for(state, s, settings, action).await?;
    log::act(
        &state.db,
        s.library,
        settings,
        a.id,
        action,
        index.as_deref(),
    )
    .await?;
    Ok(())
}

/// Whether the assignment of `token` is an icon-set one (for the task page's dispatch).
pub(super) fn is_iconset(s: &Study) -> bool {
    s.kind == crate::studies::kind::StudyKind::Iconset && s.settings.iconset.is_some()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn views_keep_known_keys_only_and_round_trip() {
        let v = View::parse("style=2&label=fish&q=red%20fish&x=1&error=nope");
        assert_eq!(v.style, Some(2));
        assert_eq!(v.label.as_deref(), Some("fish"));
        assert_eq!(v.error.as_deref(), Some("nope"));
        assert_eq!(v.query(), "style=2&label=fish&q=red+fish");
        assert_eq!(View::parse(&v.query()).query(), v.query());
        assert_eq!(View::parse("style=x").style, None);
    }
}

//! The timed paths of the search benchmark: the same searches over HTTP (with an admin
//! session of their own) and through the engine alone, without the database.

use std::sync::Arc;
use std::time::Instant;

use learner::search::Query;

use super::{SearchBenchArgs, Timed};
use crate::AppState;
use crate::error::{AppError, Result};
use crate::search::{self, SearchRequest};
use crate::store::db::{Db, now_ms};
use crate::store::ids::{ItemId, LibraryId, ModelId, random_token};
use crate::web::admin;

/// A new admin account and its session cookie.
pub(super) async fn admin_session(db: &Db) -> Result<String> {
    let username = format!("bench-{}", now_ms());
    let password = random_token();
    admin::create_admin(db, &username, &password).await?;
    let (token, _csrf) = admin::login(db, &username, &password)
        .await?
        .ok_or_else(|| AppError::Internal("the new admin cannot log in".into()))?;
    Ok(format!("{}={token}", admin::COOKIE))
}

/// `clients` HTTP clients sending the searches, each taking the next one until all are done.
pub(super) async fn http_phase(
    base: &str,
    cookie: &str,
    requests: &[SearchRequest],
    clients: usize,
) -> Result<Timed> {
    let mut headers = reqwest::header::HeaderMap::new();
    headers.insert(
        reqwest::header::COOKIE,
        cookie.parse().map_err(AppError::internal)?,
    );
    let client = reqwest::Client::builder()
        .default_headers(headers)
        .build()
        .map_err(AppError::internal)?;
    let urls: Arc<Vec<String>> = Arc::new(
        requests
            .iter()
            .map(|r| {
                let mut q = form_urlencoded::Serializer::new(String::new());
                q.append_pair("library", &r.library);
                q.append_pair("q", r.q.as_deref().unwrap_or(""));
                q.append_pair("near", r.near.as_deref().unwrap_or(""));
                q.append_pair("limit", &r.limit.unwrap_or(48).to_string());
                format!("{base}/api/v1/admin/search?{}", q.finish())
            })
            .collect(),
    );
    // One unmeasured request per client opens its connection.
    for _ in 0..clients {
        client
            .get(&urls[0])
            .send()
            .await
            .map_err(AppError::internal)?;
    }
    let next = Arc::new(std::sync::atomic::AtomicUsize::new(0));
    let t0 = Instant::now();
    let mut tasks = Vec::new();
    for _ in 0..clients {
        let (client, urls, next) = (client.clone(), urls.clone(), next.clone());
        tasks.push(tokio::spawn(async move {
            let (mut lat, mut errors) = (Vec::new(), 0usize);
            loop {
                let i = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                let Some(url) = urls.get(i) else { break };
                let t = Instant::now();
                let ok = match client.get(url).send().await {
                    // The body is read: the time includes the whole JSON answer.
                    Ok(r) if r.status().is_success() => r.bytes().await.is_ok(),
                    Ok(r) => {
                        if errors == 0 {
                            eprintln!(
                                "search: {} {}",
                                r.status(),
                                r.text().await.unwrap_or_default()
                            );
                        }
                        false
                    }
                    Err(_) => false,
                };
                if ok {
                    lat.push(t.elapsed().as_secs_f64() * 1e3);
                } else {
                    errors += 1;
                }
            }
            (lat, errors)
        }));
    }
    let (mut lat, mut errors) = (Vec::new(), 0);
    for t in tasks {
        let (l, e) = t.await.map_err(AppError::internal)?;
        lat.extend(l);
        errors += e;
    }
    Ok(Timed::new(lat, t0.elapsed(), errors))
}

/// The engine alone on the same searches: the built index's `search`, no database.
pub(super) async fn engine_phase(
    state: &AppState,
    lib: LibraryId,
    model: Option<ModelId>,
    requests: &[SearchRequest],
    a: &SearchBenchArgs,
) -> Result<Timed> {
    let built = state
        .search
        .get(
            &state.db,
            search::cache::Key {
                library: lib,
                model,
            },
        )
        .await?;
    let queries: Vec<Query> = requests
        .iter()
        .map(|r| {
            let near = r
                .near
                .as_deref()
                .unwrap_or("")
                .split(',')
                .map(|id| {
                    let id: ItemId = id.parse().map_err(AppError::internal)?;
                    let row = built
                        .row_of(id)
                        .ok_or_else(|| AppError::Internal(format!("item {id} not indexed")))?;
                    Ok(built.index.ids()[row].clone())
                })
                .collect::<Result<Vec<_>>>()?;
            Ok(Query {
                keywords: Some(a.keywords.clone()),
                near,
                limit: a.limit as usize,
                ..Query::default()
            })
        })
        .collect::<Result<_>>()?;
    tokio::task::spawn_blocking(move || {
        let t0 = Instant::now();
        let mut lat = Vec::with_capacity(queries.len());
        for q in &queries {
            let t = Instant::now();
            built.index.search(q).map_err(AppError::internal)?;
            lat.push(t.elapsed().as_secs_f64() * 1e3);
        }
        Ok(Timed::new(lat, t0.elapsed(), 0))
    })
    .await
    .map_err(AppError::internal)?
}

//! The pages' style sheet and scripts, compiled into the binary from `platform/static/` and
//! served under `/static/`, and the Content-Security-Policy of every HTML page.
//!
//! The policy allows scripts and styles from this origin only, so no page may carry an inline
//! `<script>`, `<style>`, `style=` or `on…=` attribute: per-page data travels in `data-*`
//! attributes. Asset URLs carry a hash of their content (`/static/style.css?v=…`), so browsers
//! may cache them for a year and still fetch a changed file after an upgrade.

use std::sync::LazyLock;

use axum::extract::Request;
use axum::http::{HeaderValue, header};
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};
use sha2::{Digest, Sha256};

use crate::error::{AppError, Result};
use crate::web::extract::ApiPath;

/// One embedded file.
struct Asset {
    name: &'static str,
    content_type: &'static str,
    body: &'static [u8],
}

const ASSETS: &[Asset] = &[
    Asset {
        name: "style.css",
        content_type: "text/css; charset=utf-8",
        body: include_bytes!("../../static/style.css"),
    },
    Asset {
        name: "question.js",
        content_type: "text/javascript; charset=utf-8",
        body: include_bytes!("../../static/question.js"),
    },
    Asset {
        name: "dashboard.js",
        content_type: "text/javascript; charset=utf-8",
        body: include_bytes!("../../static/dashboard.js"),
    },
    Asset {
        name: "mashup.js",
        content_type: "text/javascript; charset=utf-8",
        body: include_bytes!("../../static/mashup.js"),
    },
    // Loaded before mashup.js, which hands it the canvas's document.
    Asset {
        name: "mashup_io.js",
        content_type: "text/javascript; charset=utf-8",
        body: include_bytes!("../../static/mashup_io.js"),
    },
    Asset {
        name: "explore.js",
        content_type: "text/javascript; charset=utf-8",
        body: include_bytes!("../../static/explore.js"),
    },
    Asset {
        name: "explore_map.js",
        content_type: "text/javascript; charset=utf-8",
        body: include_bytes!("../../static/explore_map.js"),
    },
    // 32×32 PNG in an ICO container: three dots, a triplet, on the links' blue.
    Asset {
        name: "favicon.ico",
        content_type: "image/x-icon",
        body: include_bytes!("../../static/favicon.ico"),
    },
];

/// Every asset: the files above and the mash-up backgrounds (`bg-NAME.jpg`, owned by
/// [`crate::mashup::backgrounds`]).
static ALL: LazyLock<Vec<Asset>> = LazyLock::new(|| {
    let mut all: Vec<Asset> = ASSETS
        .iter()
        .map(|a| Asset {
            name: a.name,
            content_type: a.content_type,
            body: a.body,
        })
        .collect();
    for b in crate::mashup::backgrounds::BACKGROUNDS {
        if let (Some(jpeg), Some(name)) = (b.jpeg, b.asset_name()) {
            all.push(Asset {
                name: Box::leak(name.into_boxed_str()),
                content_type: "image/jpeg",
                body: jpeg,
            });
        }
    }
    all
});

/// `(name, /static/name?v=HASH)` of every asset, computed once.
static URLS: LazyLock<Vec<(&'static str, String)>> = LazyLock::new(|| {
    ALL.iter()
        .map(|a| {
            let hash = hex::encode(&Sha256::digest(a.body)[..6]);
            (a.name, format!("/static/{}?v={hash}", a.name))
        })
        .collect()
});

/// The versioned URL of an embedded asset, for templates (`{{ crate::web::assets::url("style.css") }}`).
/// An unknown name gives the unversioned path, which answers 404, so a typo shows in tests.
pub fn url(name: &str) -> String {
    URLS.iter()
        .find(|(n, _)| *n == name)
        .map_or_else(|| format!("/static/{name}"), |(_, u)| u.clone())
}

/// `GET /static/{file}`: an embedded asset with its content type. The `v` query parameter only
/// busts caches, so it is not checked.
pub async fn serve(ApiPath(file): ApiPath<String>) -> Result<Response> {
    asset_response(&file, "public, max-age=31536000, immutable")
}

/// `GET /favicon.ico`, where browsers look for it without a `<link rel="icon">` (the JSON
/// API, the stored model reports); the pages link the versioned `/static/favicon.ico`.
pub async fn favicon() -> Result<Response> {
    // Unversioned: cached for a day, not for a year.
    asset_response("favicon.ico", "public, max-age=86400")
}

fn asset_response(file: &str, cache: &'static str) -> Result<Response> {
    let asset = ALL
        .iter()
        .find(|a| a.name == file)
        .ok_or(AppError::NotFound("static file"))?;
    Ok((
        [
            (header::CONTENT_TYPE, asset.content_type),
            (header::CACHE_CONTROL, cache),
        ],
        asset.body,
    )
        .into_response())
}

/// The policy of worker pages. MTurk shows an ExternalQuestion in an iframe on its worker
/// sites, so those may frame the page, and the done page's form posts to MTurk's
/// `/mturk/externalSubmit` (the wildcard also covers the MTurk pages that answer redirects to,
/// which Chromium checks against `form-action` too).
pub const WORKER_CSP: &str = "default-src 'none'; script-src 'self'; style-src 'self'; \
     img-src 'self' data:; connect-src 'self'; form-action 'self' https://www.mturk.com \
     https://workersandbox.mturk.com https://*.mturk.com; base-uri 'none'; \
     frame-ancestors https://*.mturk.com";

/// The policy of admin pages: nothing may frame them (clickjacking of the override buttons),
/// and forms post only here.
pub const ADMIN_CSP: &str = "default-src 'none'; script-src 'self'; style-src 'self'; \
     img-src 'self' data:; connect-src 'self'; form-action 'self'; base-uri 'none'; \
     frame-ancestors 'none'";

/// Middleware: adds the Content-Security-Policy to every HTML response that has none yet (the
/// stored model reports set their own), the admin policy under `/admin`, else the worker one.
pub async fn csp(req: Request, next: Next) -> Response {
    let admin = req.uri().path() == "/admin" || req.uri().path().starts_with("/admin/");
    let mut resp = next.run(req).await;
    let html = resp
        .headers()
        .get(header::CONTENT_TYPE)
        .and_then(|v| v.to_str().ok())
        .is_some_and(|v| v.starts_with("text/html"));
    if html && !resp.headers().contains_key(header::CONTENT_SECURITY_POLICY) {
        resp.headers_mut().insert(
            header::CONTENT_SECURITY_POLICY,
            HeaderValue::from_static(if admin { ADMIN_CSP } else { WORKER_CSP }),
        );
    }
    resp
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn urls_are_versioned_by_content() {
        let u = url("style.css");
        assert!(u.starts_with("/static/style.css?v="), "{u}");
        assert_eq!(u.len(), "/static/style.css?v=".len() + 12);
        assert_ne!(url("question.js"), url("dashboard.js"));
        assert_eq!(url("nope.js"), "/static/nope.js");
        assert!(url("bg-grass.jpg").starts_with("/static/bg-grass.jpg?v="));
    }

    #[test]
    fn policies_forbid_inline_code() {
        for p in [WORKER_CSP, ADMIN_CSP] {
            assert!(!p.contains("unsafe-inline") && !p.contains("unsafe-eval"));
            assert!(p.contains("script-src 'self';") && p.contains("base-uri 'none'"));
        }
        assert!(ADMIN_CSP.ends_with("frame-ancestors 'none'"));
    }
}

//! Running a study's workers from the admin study page, on the real server and both databases:
//! every page, table and export names a worker by their crowd platform's id (masked on screen
//! until clicked); a worker's row blocks/unblocks, approves/rejects and records bonuses; the
//! exports are safe to open in a spreadsheet, filter every file alike and carry the payment
//! files; the page's forms show their errors inline with the input kept; the page has sections
//! with a bar of links and readable UTC times, newest first.

mod exports;
mod forms;
mod rows;

use std::collections::HashMap;

use e2e::platform::*;
use serde_json::{Value, json};

/// A logged-in admin.
struct Admin<'a> {
    c: &'a reqwest::Client,
    base: String,
    cookie: String,
    csrf: String,
}

impl<'a> Admin<'a> {
    async fn login(c: &'a reqwest::Client, base: &str) -> Self {
        let (cookie, csrf) = admin_login(c, base).await;
        Self {
            c,
            base: base.to_string(),
            cookie,
            csrf,
        }
    }

    /// The study page (`query` like `?include_rejected=true` or empty).
    async fn page(&self, study: i64, query: &str) -> String {
        admin_text(
            self.c,
            &format!("{}/admin/studies/{study}{query}", self.base),
            &self.cookie,
        )
        .await
    }

    async fn json(&self, path: &str) -> Value {
        let (status, body) = send(
            self.c
                .get(format!("{}{path}", self.base))
                .header("cookie", &self.cookie),
        )
        .await;
        assert_eq!(status, 200, "GET {path}: {body}");
        body
    }

    /// Posts a form of the study page with the session's CSRF token; (status, body, Location).
    async fn form(&self, path: &str, fields: &[(&str, &str)]) -> (u16, String, String) {
        let mut fields: Vec<(&str, &str)> = fields.to_vec();
        fields.push(("csrf", &self.csrf));
        let resp = self
            .c
            .post(format!("{}{path}", self.base))
            .header("cookie", &self.cookie)
            .form(&fields)
            .send()
            .await
            .expect("form");
        let status = resp.status().as_u16();
        let location = resp
            .headers()
            .get("location")
            .and_then(|v| v.to_str().ok())
            .unwrap_or_default()
            .to_string();
        (status, resp.text().await.expect("body"), location)
    }

    async fn api(&self, path: &str, body: Value) -> (u16, Value) {
        send(
            self.c
                .post(format!("{}{path}", self.base))
                .header("cookie", &self.cookie)
                .header("x-csrf-token", &self.csrf)
                .json(&body),
        )
        .await
    }

    /// An export file; (status, text).
    async fn export(&self, study: i64, file: &str, query: &str) -> (u16, String) {
        let resp = self
            .c
            .get(format!(
                "{}/api/v1/admin/studies/{study}/export/{file}{query}",
                self.base
            ))
            .header("cookie", &self.cookie)
            .send()
            .await
            .expect("export");
        let status = resp.status().as_u16();
        (status, resp.text().await.expect("text"))
    }

    /// The worker table's JSON rows by worker id.
    async fn workers(&self, study: i64) -> HashMap<String, Value> {
        self.json(&format!("/api/v1/admin/studies/{study}/workers"))
            .await
            .as_array()
            .expect("rows")
            .iter()
            .map(|w| {
                (
                    w["worker_id"].as_str().unwrap_or("?").to_string(),
                    w.clone(),
                )
            })
            .collect()
    }
}

/// How a simulated worker goes through their HIT.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Run {
    /// Answers every question as an honest worker would.
    Honest,
    /// Answers every question with the other option (every hidden control wrong).
    Wrong,
    /// Passes the training and answers this many questions.
    Partly(usize),
    /// Only starts (stays in training).
    Start,
}

/// A study's server, client and item styles (what an honest simulated worker "sees").
struct Study<'a> {
    c: &'a reqwest::Client,
    base: &'a str,
    id: i64,
    styles: HashMap<i64, String>,
}

/// Starts a worker with the start request `start` (source and ids), runs their HIT and returns
/// its token. Every questionnaire gets `reason_text`.
async fn run_worker(s: &Study<'_>, start: Value, run: Run, reason_text: &str) -> String {
    let (c, base, study, styles) = (s.c, s.base, s.id, &s.styles);
    let (status, body) = send(
        c.post(format!("{base}/api/v1/studies/{study}/start"))
            .json(&start),
    )
    .await;
    assert_eq!(status, 200, "start {start}: {body}");
    let token = body["token"].as_str().expect("token").to_string();
    if run == Run::Start {
        return token;
    }
    pass_training(c, base, &token, styles, Behaviour::Honest).await;
    let mut answered = 0;
    loop {
        if let Run::Partly(n) = run
            && answered == n
        {
            return token;
        }
        let (status, st) = send(c.get(format!("{base}/api/v1/assignments/{token}"))).await;
        assert_eq!(status, 200, "state: {st}");
        let Some(q) = st.get("question").filter(|q| !q.is_null()) else {
            return token;
        };
        let honest = choose(q, styles, Behaviour::Honest);
        let choice = if run == Run::Wrong {
            if q["left"]["id"].as_i64() == Some(honest) {
                q["right"]["id"].as_i64().expect("id")
            } else {
                q["left"]["id"].as_i64().expect("id")
            }
        } else {
            honest
        };
        let (status, ack) = send(
            c.post(format!("{base}/api/v1/assignments/{token}/answers"))
                .json(&json!({"position": q["position"], "choice": choice, "elapsed_ms": 1500})),
        )
        .await;
        assert_eq!(status, 200, "answer: {ack}");
        answered += 1;
        if ack["ask_reasons"] == true {
            let (status, body) = send(
                c.post(format!("{base}/api/v1/assignments/{token}/reasons"))
                    .json(
                        &json!({"position": q["position"], "reasons": ["colour_palette"],
                                  "text": reason_text}),
                    ),
            )
            .await;
            assert_eq!(status, 200, "reasons: {body}");
        }
    }
}

/// A direct-link start request.
fn direct(participant: &str) -> Value {
    json!({"source": "direct", "worker_id": participant})
}

/// A Prolific start request.
fn prolific(pid: &str) -> Value {
    json!({"worker_id": pid, "prolific_study_id": "STUDY1", "prolific_session_id": format!("S-{pid}")})
}

/// An MTurk (sandbox) start request.
fn mturk(worker: &str, assignment: &str) -> Value {
    json!({"worker_id": worker, "assignment_id": assignment, "hit_id": "HIT1",
           "turk_submit_to": "https://workersandbox.mturk.com"})
}

/// A CSV file as its header and rows of named cells.
fn csv_table(text: &str, header: bool) -> (Vec<String>, Vec<HashMap<String, String>>) {
    let mut r = csv::ReaderBuilder::new()
        .has_headers(header)
        .from_reader(text.as_bytes());
    let names: Vec<String> = if header {
        r.headers()
            .expect("header")
            .iter()
            .map(str::to_string)
            .collect()
    } else {
        Vec::new()
    };
    let rows = r
        .records()
        .map(|rec| {
            let rec = rec.expect("record");
            rec.iter()
                .enumerate()
                .map(|(i, v)| {
                    let name = names.get(i).cloned().unwrap_or_else(|| i.to_string());
                    (name, v.to_string())
                })
                .collect()
        })
        .collect();
    (names, rows)
}

/// The HTML of the study page's section `id`.
fn section<'p>(page: &'p str, id: &str) -> &'p str {
    let start = page
        .find(&format!("<section class=\"study-section\" id=\"{id}\">"))
        .unwrap_or_else(|| panic!("no section {id}"));
    let end = page[start..].find("</section>").expect("section end") + start;
    &page[start..end]
}

/// The HTML of the worker table's row of `assignment`.
fn row(page: &str, assignment: i64) -> &str {
    let start = page
        .find(&format!("<tr id=\"worker-{assignment}\""))
        .unwrap_or_else(|| panic!("no row of assignment {assignment}"));
    let end = page[start..].find("</tr>").expect("row end") + start;
    &page[start..end]
}

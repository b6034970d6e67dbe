//! What the icon-set tests share: the labelled fixture library, the study's creation, reads of
//! the stored log, and the style space recomputed with `learner`.

use std::collections::HashMap;

use e2e::platform::*;
use serde_json::Value;

/// The semantic label of a fixture concept (the thesis's task: face, fish, flower, bird), or
/// `sky` for a few other concepts, or `None` to leave the concept out.
fn label_of(concept: &str) -> Option<&'static str> {
    match concept {
        c if c.ends_with("-face") => Some("face"),
        "fish" | "octopus" => Some("fish"),
        "tulip" | "sunflower" => Some("flower"),
        "bird" | "penguin" => Some("bird"),
        "sun" | "cloud" => Some("sky"),
        _ => None,
    }
}

/// The fixture icons of those concepts in all four styles, labelled by concept (64 items: per
/// style 8 faces, 2 fish, 2 flowers, 2 birds, 2 sky), as the library `icons`, and the admin.
pub(super) fn import_icons(db: &TestDb) {
    let dir = tempfile::tempdir().expect("temp dir");
    let labels = std::fs::read_to_string(e2e::fixture("style/labels.csv")).expect("labels.csv");
    let mut out = String::from("file,style,keywords\n");
    for line in labels.lines().skip(1) {
        let cols: Vec<&str> = line.split(',').collect();
        let (file, concept, words) = (cols[0], cols[2], cols[3]);
        let Some(label) = label_of(concept) else {
            continue;
        };
        let target = dir.path().join(file);
        std::fs::create_dir_all(target.parent().expect("parent")).expect("mkdir");
        std::fs::copy(e2e::fixture(&format!("style/{file}")), &target).expect("copy");
        out.push_str(&format!("{file},{label},{words}\n"));
    }
    let labels_file = dir.path().join("labels.csv");
    std::fs::write(&labels_file, out).expect("labels");
    let printed = import_named(&db.url, "icons", dir.path(), Some(&labels_file));
    assert!(printed.contains("64"), "{printed}");
    create_admin(&db.url);
}

/// `platform study create --kind iconset` over `icons` with `extra` flags.
pub(super) fn create(db: &TestDb, extra: &[&str]) -> std::process::Output {
    let mut args = vec![
        "study",
        "create",
        "--database-url",
        &db.url,
        "--name",
        "icon sets",
        "--library",
        "icons",
    ];
    args.extend_from_slice(extra);
    platform_cmd(&args, &[])
}

/// The study made by a successful [`create`].
pub(super) fn created(out: &std::process::Output) -> i64 {
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout)
        .split_whitespace()
        .nth(1)
        .and_then(|id| id.trim_end_matches(':').parse().ok())
        .expect("study id")
}

/// The flags of the tests' study: two sets of the thesis's four labels, uniform weights, and
/// κ/τ small enough for 56 items of four styles.
pub(super) const GOOD: &[&str] = &[
    "--kind", "iconset", "--model", "uniform", "--kappa", "5", "--tau", "1", "--sets", "2",
    "--tuples", "4",
];

pub(super) async fn rows(db_url: &str, sql: &'static str) -> Vec<sqlx::any::AnyRow> {
    sqlx::any::install_default_drivers();
    let pool = sqlx::AnyPool::connect(db_url).await.expect("connect");
    let rows = sqlx::query(sql).fetch_all(&pool).await.expect(sql);
    pool.close().await;
    rows
}

/// The condition of each assignment token, as stored.
pub(super) async fn conditions(db_url: &str) -> HashMap<String, String> {
    use sqlx::Row;
    rows(
        db_url,
        "SELECT a.token, c.condition FROM iconset_conditions c \
         JOIN assignments a ON a.id = c.assignment_id",
    )
    .await
    .iter()
    .map(|r| (r.get("token"), r.get("condition")))
    .collect()
}

/// Each item's label.
pub(super) async fn labels(db_url: &str) -> HashMap<i64, String> {
    use sqlx::Row;
    rows(db_url, "SELECT id, style FROM items")
        .await
        .iter()
        .map(|r| (r.get("id"), r.get("style")))
        .collect()
}

/// Per token, the time (s) and deletions of each finished set, computed here from the stored
/// events: set 1 runs from the `open` event, set k + 1 from the finish of set k.
pub(super) async fn sets_from_events(db_url: &str) -> HashMap<String, Vec<(f64, usize)>> {
    use sqlx::Row;
    let mut by_token: HashMap<String, Vec<(String, i64, i64)>> = HashMap::new();
    for r in rows(
        db_url,
        "SELECT a.token, e.event, e.set_index, e.created_at FROM iconset_events e \
         JOIN assignments a ON a.id = e.assignment_id ORDER BY e.assignment_id, e.seq",
    )
    .await
    {
        by_token.entry(r.get("token")).or_default().push((
            r.get("event"),
            r.get("set_index"),
            r.get("created_at"),
        ));
    }
    by_token
        .into_iter()
        .map(|(token, events)| {
            let mut start = None;
            let mut deletions = 0;
            let mut sets = Vec::new();
            for (event, _, at) in events {
                match event.as_str() {
                    "open" => start = Some(at),
                    "remove" => deletions += 1,
                    "finish" => {
                        let from = start.expect("a set finished before the task opened");
                        sets.push(((at - from) as f64 / 1000.0, deletions));
                        start = Some(at);
                        deletions = 0;
                    }
                    _ => {}
                }
            }
            (token, sets)
        })
        .collect()
}

/// The library's items in the search's style space under uniform weights, built here with
/// `learner` from the stored features.
pub(super) struct UniformSpace {
    matrix: learner::search::StyleMatrix,
    rows: HashMap<String, usize>,
}

impl UniformSpace {
    /// The mean distance between two of the named items.
    pub(super) fn spread(&self, names: &[&str]) -> f64 {
        let rows: Vec<usize> = names.iter().map(|n| self.rows[*n]).collect();
        let (mut sum, mut pairs) = (0.0, 0);
        for (k, &a) in rows.iter().enumerate() {
            for &b in &rows[k + 1..] {
                sum += self.matrix.distance_to(a, self.matrix.row(b));
                pairs += 1;
            }
        }
        sum / pairs as f64
    }
}

pub(super) async fn uniform_space(db_url: &str) -> UniformSpace {
    use sqlx::Row;
    let stored = rows(db_url, "SELECT name, features FROM items ORDER BY seq").await;
    let columns: Vec<String> = learner::features::catalogue()
        .into_iter()
        .map(|f| f.name.to_string())
        .collect();
    let (mut names, mut values) = (Vec::new(), Vec::new());
    for r in &stored {
        names.push(r.get::<String, _>("name"));
        let f: Vec<f64> = serde_json::from_str(&r.get::<String, _>("features")).expect("json");
        values.extend(f);
    }
    let table = learner::table::FeatureTable::new(columns, names.clone(), values).expect("table");
    let weighting = learner::search::Weighting::uniform(&table);
    let matrix = learner::search::StyleMatrix::build(&table, &weighting).expect("matrix");
    let rows = names.into_iter().enumerate().map(|(i, n)| (n, i)).collect();
    UniformSpace { matrix, rows }
}

pub(super) fn ids(list: &Value) -> Vec<i64> {
    list["results"]
        .as_array()
        .expect("results")
        .iter()
        .map(|r| r["id"].as_i64().expect("id"))
        .collect()
}

//! A composition-rating study made from a mash-up study's submissions (§5.7.3) with the real
//! `platform` binary, on SQLite and PostgreSQL: mash-up workers submit compositions over HTTP in
//! both conditions, `platform study create --kind composition-rating --from-mashup ID` renders
//! them and pairs A with B (balanced, reproducible for a seed), both questions of the paper
//! work, and every wrong use is a clear error that creates nothing.

use std::collections::{BTreeSet, HashMap};

use e2e::both_databases;
use e2e::platform::*;
use serde_json::Value;

mod setup;

use setup::{conditions, mean_abs_diff, pairs, rows};
pub(crate) use setup::{create_study, created_id, mashup_study, submit_compositions};

async fn rating_from_mashup(db: TestDb) {
    let lib = small_library(3);
    import_library(&db, lib.path());
    let mashup = mashup_study(&db, "farm", 6);
    let lonely = mashup_study(&db, "lonely farm", 2);
    let triplets = created_id(&String::from_utf8_lossy(
        &create_study(
            &db,
            &["--name", "triplets", "--library", "fx", "--tuples", "20"],
        )
        .stdout,
    ));
    create_admin(&db.url);
    let server = Server::start(&db.url);
    let base = server.url("");
    let base = base.trim_end_matches('/').to_string();
    submit_compositions(&base, mashup, 5, "m").await;
    submit_compositions(&base, lonely, 1, "l").await;
    let cond = conditions(&db.url, mashup).await;
    let of = |c: &str| {
        cond.iter()
            .filter(|(_, v)| *v == c)
            .map(|(k, _)| *k)
            .collect::<BTreeSet<_>>()
    };
    let (in_a, in_b) = (of("A"), of("B"));
    assert_eq!(
        (in_a.len() + in_b.len(), in_a.len().abs_diff(in_b.len())),
        (5, 1)
    );

    // Wrong uses: one clear line each, no study and no item made.
    let studies = || scalar(&db.url, "SELECT CAST(COUNT(*) AS BIGINT) FROM studies");
    let items = || scalar(&db.url, "SELECT CAST(COUNT(*) AS BIGINT) FROM items");
    let (studies_before, items_before) = (studies().await, items().await);
    let (m, l, t) = (mashup.to_string(), lonely.to_string(), triplets.to_string());
    let rating = ["--name", "r", "--kind", "composition-rating"];
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (vec!["--from-mashup", &t], "not a mash-up study"),
        (vec!["--from-mashup", "99999"], "there is no study 99999"),
        (vec!["--from-mashup", &l], "a pair needs one of each"),
        (
            vec![
                "--from-mashup",
                &m,
                "--compositions",
                ".",
                "--pairs",
                "p.csv",
            ],
            "give one or the other",
        ),
        (
            vec!["--from-mashup", &m, "--tuples", "7"],
            "make 1..=6 distinct pairs",
        ),
        (
            vec!["--from-mashup", &m, "--library", "fx"],
            "holds the clip art of mash-up study",
        ),
        (
            vec!["--from-mashup", &m, "--from-mashup", &m],
            "named twice",
        ),
        (vec![], "needs --from-mashup STUDY_ID"),
    ];
    for (extra, needle) in &cases {
        let mut args = rating.to_vec();
        args.extend_from_slice(extra);
        let out = create_study(&db, &args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            !out.status.success() && err.contains(needle),
            "{extra:?}: {err}"
        );
    }
    let out = create_study(
        &db,
        &[
            "--name",
            "x",
            "--kind",
            "mashup",
            "--task",
            "t",
            "--from-mashup",
            &m,
        ],
    );
    assert!(String::from_utf8_lossy(&out.stderr).contains("are for --kind composition-rating"));
    assert_eq!(
        (studies().await, items().await),
        (studies_before, items_before)
    );

    // Both questions of the paper, one study each, over the same rendered compositions.
    let settings = lib.path().join("rating.json");
    std::fs::write(
        &settings,
        r#"{"controls_per_hit": 0, "training_questions": 0, "questions_per_hit": 3}"#,
    )
    .expect("settings");
    let settings = settings.to_string_lossy().into_owned();
    let mut made = Vec::new();
    for question in ["coherence", "preference"] {
        let out = create_study(
            &db,
            &[
                "--name",
                question,
                "--kind",
                "composition-rating",
                "--from-mashup",
                &m,
                "--question",
                question,
                "--seed",
                "5",
                "--replication",
                "2",
                "--settings",
                &settings,
            ],
        );
        let stdout = String::from_utf8_lossy(&out.stdout);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        // max(3, 2) pairs: every composition is rated.
        assert!(
            stdout.contains("3 main tuples, 6 slots, 0 controls, 0 training"),
            "{stdout}"
        );
        made.push(created_id(&stdout));
    }
    assert_eq!(
        items().await,
        items_before + 5,
        "the second study rendered again"
    );
    let first = pairs(&db.url, made[0]).await;
    let mut sorted = first.clone();
    sorted.sort_unstable();
    let mut second = pairs(&db.url, made[1]).await;
    second.sort_unstable();
    assert_eq!(sorted, second, "the same seed made other pairs");
    // A with B, distinct, every composition used, uses differing by at most one.
    assert_eq!(sorted.iter().collect::<BTreeSet<_>>().len(), 3);
    let mut uses: HashMap<i64, usize> = HashMap::new();
    for &(x, y) in &first {
        assert!(
            in_a.contains(&x) && in_b.contains(&y),
            "({x}, {y}) is not A against B"
        );
        *uses.entry(x).or_default() += 1;
        *uses.entry(y).or_default() += 1;
    }
    assert_eq!(uses.len(), 5, "{uses:?}");
    for side in [&in_a, &in_b] {
        let counts: Vec<usize> = side.iter().map(|c| uses[c]).collect();
        let (lo, hi) = (counts.iter().min().unwrap(), counts.iter().max().unwrap());
        assert!(hi - lo <= 1, "{counts:?}");
    }
    // Another seed is another draw of the same kind of pairs.
    let out = create_study(
        &db,
        &[
            "--name",
            "seed 6",
            "--kind",
            "composition-rating",
            "--from-mashup",
            &m,
            "--seed",
            "6",
            "--tuples",
            "6",
            "--settings",
            &settings,
        ],
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let all = pairs(&db.url, created_id(&String::from_utf8_lossy(&out.stdout))).await;
    assert_eq!(
        all.iter().collect::<BTreeSet<_>>().len(),
        6,
        "every A × B pair once"
    );

    // The items are the server renderer's pictures of the compositions: each is closer to its
    // own composition's PNG export than to any other composition's.
    let c = client();
    let (cookie, _) = admin_login(&c, &base).await;
    let mut exports = HashMap::new();
    for &id in cond.keys() {
        let resp = c
            .get(format!(
                "{base}/api/v1/admin/compositions/{id}/export?format=png"
            ))
            .header("cookie", &cookie)
            .send()
            .await
            .expect("export");
        assert_eq!(resp.status().as_u16(), 200);
        let png = image::load_from_memory(&resp.bytes().await.expect("png")).expect("decode");
        exports.insert(id, learner::render::fit_on_white(&png.to_rgba8(), 400));
    }
    for &id in cond.keys() {
        let name = format!("mashup-{mashup}-composition-{id}");
        let item: i64 = rows(
            &db.url,
            "SELECT name, id, seq FROM items WHERE library_id = \
             (SELECT library_id FROM studies WHERE id = $1)",
            made[0],
        )
        .await
        .into_iter()
        .find(|(n, _, _)| *n == name)
        .map(|(_, id, _)| id)
        .unwrap_or_else(|| panic!("no item {name}"));
        let resp = c
            .get(format!("{base}/media/items/{item}.png"))
            .send()
            .await
            .expect("item");
        let png = image::load_from_memory(&resp.bytes().await.expect("png"))
            .expect("decode")
            .to_rgb8();
        let own = mean_abs_diff(&png, &exports[&id]);
        assert!(
            own < 8.0,
            "composition {id}: mean difference {own} from its export"
        );
        for (&other, picture) in &exports {
            if other != id {
                assert!(
                    own < mean_abs_diff(&png, picture),
                    "{id} looks like {other}"
                );
            }
        }
    }

    // Workers see the study's question over the rendered compositions.
    for (study, prompt) in [
        (made[0], "Which composition has a more coherent style?"),
        (made[1], "Which composition do you like better?"),
    ] {
        let token = start_worker(&c, &base, study, "rater").await;
        let (status, st): (u16, Value) =
            send(c.get(format!("{base}/api/v1/assignments/{token}"))).await;
        assert_eq!(status, 200, "{st}");
        let q = &st["question"];
        let shown: BTreeSet<i64> = [q["left"]["id"].as_i64(), q["right"]["id"].as_i64()]
            .into_iter()
            .flatten()
            .collect();
        assert_eq!(shown.len(), 2, "{st}");
        let page = c
            .get(format!("{base}/a/{token}"))
            .send()
            .await
            .expect("page");
        assert!(page.text().await.expect("body").contains(prompt));
    }
}

both_databases!(
    rating_from_mashup,
    rating_from_mashup_sqlite,
    rating_from_mashup_postgres
);

//! The mash-up study's log, submission and report on real SQLite and PostgreSQL databases,
//! with assignments started through the shared worker flow.

use sqlx::Row;

use super::log::{self, Event};
use super::{Condition, MashupSettings, condition_at, pool, report, submit};
use crate::error::AppError;
use crate::flow::{Source, StartOutcome, StartRequest, start};
use crate::mashup::{Document, Piece};
use crate::store::db::Db;
use crate::store::ids::{AssignmentId, ItemId};
use crate::studies::kind::StudyKind;
use crate::studies::{library, study};

fn task() -> MashupSettings {
    MashupSettings {
        task: "A farm in the morning".into(),
        background: Some("grass".into()),
        min_pieces: 2,
        min_searches: 1,
    }
}

/// A mash-up study of 8 compositions over the benchmark's swatch library; returns the study
/// and the library's items.
async fn mashup_study(db: &Db) -> (study::Study, Vec<ItemId>) {
    // The benchmark's study brings a library of 96 items; the mash-up study uses the same one.
    let bench = crate::cli::bench::prepare(db, 1, 0).await.expect("library");
    let lib = study::load(db, bench).await.expect("bench study").library;
    let items: Vec<ItemId> = library::list_items(db, lib)
        .await
        .expect("items")
        .iter()
        .map(|i| i.id)
        .collect();
    let mut s = pool::defaults(Some(task()));
    s.tuples = 8;
    s.seed = 77;
    let drawn = pool::draw(&s, items.first().copied()).expect("pool");
    let pending = study::begin_drawn(db, "mash-up", lib, StudyKind::Mashup, s, drawn)
        .await
        .expect("create");
    let id = pending.id;
    pending.build(db, |_, _| {}).await.expect("build");
    (study::load(db, id).await.expect("load"), items)
}

async fn assignment(db: &Db, study: &study::Study, worker: &str) -> AssignmentId {
    let req = StartRequest {
        source: Some(Source::Direct),
        worker_id: Some(worker.into()),
        ..StartRequest::default()
    };
    let Ok(StartOutcome::Started { token, .. }) = start(db, study, req).await else {
        panic!("{worker} could not start")
    };
    let row = sqlx::query("SELECT id FROM assignments WHERE token = $1")
        .bind(&token)
        .fetch_one(&db.pool)
        .await
        .expect("assignment");
    AssignmentId(row.get("id"))
}

fn doc(items: &[ItemId]) -> Document {
    let mut d = Document::empty(800, 600, "grass");
    for (i, &item) in items.iter().enumerate() {
        d.pieces.push(Piece {
            item,
            x: 100.0 + 50.0 * i as f64,
            y: 300.0,
            scale: 1.0,
            rotation: 0.0,
        });
    }
    d.validate().expect("valid document");
    d
}

fn bad_request<T: std::fmt::Debug>(r: crate::error::Result<T>, what: &str) {
    assert!(matches!(r, Err(AppError::BadRequest(_))), "{what}: {r:?}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_mashup_hit_is_logged_checked_submitted_and_reported() {
    for (db, _dir) in crate::flow::tests::databases().await {
        let (study, items) = mashup_study(&db).await;
        let seed = study.settings.seed;

        // Conditions: the study's balanced sequence, in the order workers arrive; stable.
        let mut workers = Vec::new();
        for w in 0..4 {
            let a = assignment(&db, &study, &format!("w{w}")).await;
            let c = log::assign_condition(&db, study.id, seed, a)
                .await
                .expect("c");
            assert_eq!(c, condition_at(seed, w), "{:?}", db.backend);
            assert_eq!(
                log::assign_condition(&db, study.id, seed, a).await.unwrap(),
                c
            );
            workers.push((a, c));
        }
        let a_count = workers.iter().filter(|(_, c)| *c == Condition::A).count();
        assert_eq!(a_count, 2);

        let (w0, _) = workers[0];
        let (w1, _) = workers[1];
        let list1: Vec<ItemId> = items[10..30].to_vec();
        let list2: Vec<ItemId> = items[40..60].iter().rev().copied().collect();
        assert_eq!(
            log::record_search(&db, w0, "cow", None, &list1)
                .await
                .unwrap(),
            1
        );
        assert_eq!(
            log::record_search(&db, w0, "hen", Some("animals"), &list2)
                .await
                .unwrap(),
            2
        );
        // Another worker's searches are numbered on their own and are not w0's.
        let other: Vec<ItemId> = items[70..75].to_vec();
        assert_eq!(
            log::record_search(&db, w1, "x", None, &other)
                .await
                .unwrap(),
            1
        );
        for _ in 0..2 {
            log::record_search(&db, w1, "y", None, &other)
                .await
                .unwrap();
        }

        let add = |item: ItemId, search_seq: i64, position: i64| Event::Add {
            item,
            search_seq,
            position,
        };
        // Right: item at its 1-based position in the list the server returned.
        log::record_event(&db, w0, &add(list1[4], 1, 5))
            .await
            .unwrap();
        log::record_event(&db, w0, &add(list2[0], 2, 1))
            .await
            .unwrap();
        log::record_event(&db, w0, &add(list2[11], 2, 12))
            .await
            .unwrap();
        log::record_event(&db, w0, &Event::Remove { item: list2[0] })
            .await
            .unwrap();
        // Faked or stale positions, unknown searches, another worker's search: 400.
        bad_request(
            log::record_event(&db, w0, &add(list1[4], 1, 6)).await,
            "wrong position",
        );
        bad_request(
            log::record_event(&db, w0, &add(list1[4], 2, 5)).await,
            "wrong search",
        );
        bad_request(
            log::record_event(&db, w0, &add(list1[0], 1, 0)).await,
            "position 0",
        );
        bad_request(
            log::record_event(&db, w0, &add(list1[0], 1, 21)).await,
            "past the end",
        );
        bad_request(
            log::record_event(&db, w0, &add(other[0], 3, 1)).await,
            "w1's search",
        );
        bad_request(
            log::record_event(&db, w0, &Event::Remove { item: list2[1] }).await,
            "remove of an item never added",
        );
        let confirm = Event::Search {
            seq: 2,
            q: "hen".into(),
            category: Some("animals".into()),
            results: list2.clone(),
        };
        log::record_event(&db, w0, &confirm).await.unwrap();
        let forged = Event::Search {
            seq: 2,
            q: "hen".into(),
            category: Some("animals".into()),
            results: list1.clone(),
        };
        bad_request(log::record_event(&db, w0, &forged).await, "forged list");

        // Submission: the document must hold exactly the pieces left on the canvas.
        let s = task();
        let lib = study.library;
        let short = doc(&[list1[4]]);
        bad_request(
            submit::submit(&db, w0, lib, &s, &short).await,
            "too few pieces",
        );
        let extra = doc(&[list1[4], list2[11], items[0]]);
        bad_request(
            submit::submit(&db, w0, lib, &s, &extra).await,
            "unlogged piece",
        );
        let mut blank = doc(&[list1[4], list2[11]]);
        blank.background = "blank".into();
        bad_request(submit::submit(&db, w0, lib, &s, &blank).await, "background");
        let good = doc(&[list2[11], list1[4]]);
        let id = submit::submit(&db, w0, lib, &s, &good)
            .await
            .expect("submit");
        assert_eq!(
            submit::submitted_composition(&db, w0).await.unwrap(),
            Some(id)
        );
        let again = submit::submit(&db, w0, lib, &s, &good).await;
        assert!(matches!(again, Err(AppError::Conflict(_))), "{again:?}");
        let stored = crate::mashup::store::get(&db, id).await.expect("stored");
        assert_eq!(stored.document, good);

        // w1 (the other condition) submits two pieces from its third search.
        log::record_event(&db, w1, &add(other[1], 3, 2))
            .await
            .unwrap();
        log::record_event(&db, w1, &add(other[4], 3, 5))
            .await
            .unwrap();
        let mut w1_doc = doc(&[other[1], other[4]]);
        w1_doc.background = "grass".into();
        submit::submit(&db, w1, lib, &s, &w1_doc)
            .await
            .expect("w1 submits");

        // The report: positions as logged, statistics from learner::stats.
        let r = report::report(&db, study.id).await.expect("report");
        let by = |c: Condition| r.conditions.iter().find(|x| x.condition == c).unwrap();
        let (c0, c1) = (workers[0].1, workers[1].1);
        assert_ne!(c0, c1, "the first pair alternates");
        let r0 = by(c0);
        assert_eq!((r0.workers, r0.pieces, r0.searches), (1, 2, 2));
        let i = learner::stats::mean_interval(&[5.0, 12.0], 0.95).unwrap();
        let p = r0.position.as_ref().expect("two pieces");
        assert_eq!((p.mean, p.half_width), (i.mean, i.half_width));
        let r1 = by(c1);
        assert_eq!((r1.workers, r1.pieces, r1.searches), (1, 2, 3));
        let i = learner::stats::mean_interval(&[2.0, 5.0], 0.95).unwrap();
        let p = r1.position.as_ref().expect("two pieces");
        assert_eq!((p.mean, p.low, p.high), (i.mean, i.low, i.high));
    }
}

//! The search against independent references: exact k-NN against a brute-force `f64` scan of
//! the raw features under eq. 5.5, the diversity order's promise, determinism across thread
//! counts, saved indexes, and the errors a user can cause.

use std::path::Path;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::*;
use crate::metric::model::{fit_scaling, weighted_distance};
use crate::table::read_features;

fn random_table(n: usize, p: usize, seed: u64) -> FeatureTable {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    // A few blobs with different spreads, so there are near and far neighbours and clusters.
    let centres: Vec<Vec<f64>> = (0..12)
        .map(|_| (0..p).map(|_| rng.random_range(-5.0..5.0)).collect())
        .collect();
    let mut values = Vec::with_capacity(n * p);
    for i in 0..n {
        let c = &centres[i % centres.len()];
        values.extend(
            c.iter()
                .map(|m| m + rng.random_range(-1.0..1.0) * (1.0 + (i % 3) as f64)),
        );
    }
    FeatureTable::new(
        (0..p).map(|k| format!("f{k}")).collect(),
        (0..n).map(|i| format!("item-{i}")).collect(),
        values,
    )
    .unwrap()
}

/// Standardisation of the table and weights with about a third of them zero.
fn sparse_weighting(table: &FeatureTable, seed: u64) -> Weighting {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let (mean, scale) = fit_scaling(table, &[]);
    Weighting {
        feature_names: table.names().to_vec(),
        mean,
        scale,
        weights: (0..table.dim())
            .map(|_| {
                if rng.random_bool(0.35) {
                    0.0
                } else {
                    rng.random_range(0.02..3.0)
                }
            })
            .collect(),
        uniform: false,
    }
}

/// Brute force in `f64` on the raw features: mean eq.-5.5 distance to the references, sorted
/// with ties by row.
fn reference(
    table: &FeatureTable,
    w: &Weighting,
    refs: &[&[f64]],
    candidates: Option<&[u32]>,
    exclude: &[u32],
) -> Vec<(u32, f64)> {
    let rows: Vec<u32> =
        candidates.map_or_else(|| (0..table.len() as u32).collect(), <[u32]>::to_vec);
    let mut all: Vec<(u32, f64)> = rows
        .into_iter()
        .filter(|r| !exclude.contains(r))
        .map(|r| {
            let d: f64 = refs
                .iter()
                .map(|q| weighted_distance(&w.weights, &w.scale, table.row(r as usize), q))
                .sum::<f64>()
                / refs.len() as f64;
            (r, d)
        })
        .collect();
    all.sort_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)));
    all
}

/// Same ids in the same order, except where the reference distances tie within `f32`
/// precision; distances equal to the reference's.
fn assert_same_ranking(got: &[(u32, f64)], want: &[(u32, f64)], k: usize, what: &str) {
    let want_k = &want[..k.min(want.len())];
    assert_eq!(got.len(), want_k.len(), "{what}: result count");
    let exact: std::collections::HashMap<u32, f64> = want.iter().copied().collect();
    let tol = |d: f64| 1e-5 * (1.0 + d);
    for (i, (g, w)) in got.iter().zip(want_k).enumerate() {
        let g_true = exact[&g.0];
        assert!(
            (g.1 - g_true).abs() <= tol(g_true),
            "{what}: rank {i}: reported {} but d = {g_true}",
            g.1
        );
        if g.0 != w.0 {
            assert!(
                (g_true - w.1).abs() <= tol(w.1),
                "{what}: rank {i}: got row {} (d = {g_true}), want row {} (d = {})",
                g.0,
                w.0,
                w.1
            );
        }
    }
}

#[test]
fn exact_knn_matches_brute_force_on_random_features() {
    for (n, p, seed) in [(300, 7, 1), (10_000, 40, 2), (9_001, 169, 3)] {
        let table = random_table(n, p, seed);
        let w = sparse_weighting(&table, seed);
        let m = StyleMatrix::build(&table, &w).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(seed + 10);
        for trial in 0..8 {
            let refs: Vec<u32> = (0..1 + trial % 3)
                .map(|_| rng.random_range(0..n as u32))
                .collect();
            let raw: Vec<&[f64]> = refs.iter().map(|&r| table.row(r as usize)).collect();
            let projected: Vec<Vec<f32>> = raw.iter().map(|q| m.project(q).unwrap()).collect();
            let k = [1, 10, 50][trial % 3];
            let got = m.nearest(&projected, None, &refs, k);
            let want = reference(&table, &w, &raw, None, &refs);
            assert_same_ranking(&got, &want, k, &format!("n={n} p={p} trial {trial}"));

            let subset: Vec<u32> = (0..n as u32)
                .filter(|r| r % 7 == trial as u32 % 7)
                .collect();
            let got = m.nearest(&projected, Some(&subset), &refs, k);
            let want = reference(&table, &w, &raw, Some(&subset), &refs);
            assert_same_ranking(&got, &want, k, &format!("subset n={n} trial {trial}"));
        }
    }
}

fn fixture_features() -> FeatureTable {
    read_features(
        &Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/metric/fixture-features.csv"),
    )
    .unwrap()
}

fn fixture_labels() -> std::collections::HashMap<String, ItemText> {
    texts::read_item_texts(
        &Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures/style/labels.csv"),
    )
    .unwrap()
}

#[test]
fn exact_knn_matches_brute_force_on_real_features() {
    let table = fixture_features();
    for w in [Weighting::uniform(&table), sparse_weighting(&table, 5)] {
        let m = StyleMatrix::build(&table, &w).unwrap();
        for q in (0..table.len()).step_by(9) {
            let raw = table.row(q);
            let got = m.nearest(&[m.project(raw).unwrap()], None, &[q as u32], 20);
            let want = reference(&table, &w, &[raw], None, &[q as u32]);
            assert_same_ranking(&got, &want, 20, &format!("query {}", table.ids()[q]));
        }
    }
}

#[test]
fn dispatched_and_baseline_scans_are_bit_identical() {
    let table = random_table(2_000, 169, 9);
    let m = StyleMatrix::build(&table, &Weighting::uniform(&table)).unwrap();
    let q = m.row(17).to_vec();
    let mut fast = vec![0.0f32; m.len()];
    let mut slow = vec![0.0f32; m.len()];
    index::squared_distances(m.data(), &q, &mut fast);
    crate::simd::tests::baseline_only(|| index::squared_distances(m.data(), &q, &mut slow));
    assert!(
        fast.iter()
            .zip(&slow)
            .all(|(a, b)| a.to_bits() == b.to_bits())
    );
}

fn build(table: &FeatureTable, texts: Vec<ItemText>, w: &Weighting) -> SearchIndex {
    SearchIndex::build(table, texts, w, &SearchParams::default(), None, &mut |_| {}).unwrap()
}

fn fixture_index() -> SearchIndex {
    let table = fixture_features();
    let texts = texts::texts_for(table.ids(), Some(&fixture_labels()));
    build(&table, texts, &sparse_weighting(&table, 5))
}

fn ids(r: &SearchResults) -> Vec<&str> {
    r.hits.iter().map(|h| h.id.as_str()).collect()
}

#[test]
fn keyword_search_finds_tags_by_prefix_and_typo() {
    let index = fixture_index();
    let q = |text: &str| Query {
        keywords: Some(text.into()),
        limit: 100,
        ..Query::default()
    };
    let exact = index.search(&q("dog")).unwrap();
    assert_eq!(exact.order, Order::Relevance);
    let exact_ids = ids(&exact);
    for style in ["noto", "twemoji", "fluent-emoji", "emojione-monotone"] {
        assert!(
            exact_ids.contains(&format!("{style}/dog-face.svg").as_str()),
            "{exact_ids:?}"
        );
    }
    // Keywords only ("puppy" is a keyword of dog-face, not in its name), by prefix and typo.
    for text in ["pupp", "puppu", "PUPPY"] {
        let found = index.search(&q(text)).unwrap();
        assert!(
            ids(&found).contains(&"noto/dog-face.svg"),
            "{text}: {:?}",
            ids(&found)
        );
    }
    // A category alone lists its items; with words it filters them.
    let animals = index
        .search(&Query {
            category: Some("animals-nature".into()),
            limit: 1000,
            ..Query::default()
        })
        .unwrap();
    assert!(animals.matched > 0 && animals.matched < index.len());
    let food_dogs = index
        .search(&Query {
            keywords: Some("dog".into()),
            category: Some("food-drink".into()),
            ..Query::default()
        })
        .unwrap();
    assert!(
        ids(&food_dogs).iter().all(|id| id.ends_with("hot-dog.svg")),
        "{:?}",
        ids(&food_dogs)
    );
}

#[test]
fn keyword_hits_are_sorted_by_style_against_the_canvas() {
    let table = fixture_features();
    let w = sparse_weighting(&table, 5);
    let index = build(
        &table,
        texts::texts_for(table.ids(), Some(&fixture_labels())),
        &w,
    );
    let canvas = ["noto/cat-face.svg", "noto/banana.svg"];
    let r = index
        .search(&Query {
            keywords: Some("face".into()),
            near: canvas.iter().map(|s| s.to_string()).collect(),
            limit: 1000,
            ..Query::default()
        })
        .unwrap();
    assert_eq!(r.order, Order::Style);
    let keyword_rows: Vec<u32> = index
        .keywords()
        .search(Some("face"), None)
        .unwrap()
        .iter()
        .map(|h| h.0)
        .collect();
    let raw: Vec<&[f64]> = canvas
        .iter()
        .map(|id| table.row(table.index_of(id).unwrap()))
        .collect();
    let excluded: Vec<u32> = canvas.iter().map(|id| index.row_of(id).unwrap()).collect();
    let want = reference(&table, &w, &raw, Some(&keyword_rows), &excluded);
    let got: Vec<(u32, f64)> = r
        .hits
        .iter()
        .map(|h| (h.row, h.distance.unwrap()))
        .collect();
    assert_same_ranking(&got, &want, want.len(), "face by canvas");
    assert!(
        r.hits
            .iter()
            .all(|h| h.score.is_some() && !canvas.contains(&h.id.as_str()))
    );
    // The noto items are nearest a noto canvas.
    assert!(r.hits[0].id.starts_with("noto/"), "{:?}", ids(&r));
}

#[test]
fn example_vectors_rank_like_their_item() {
    let table = fixture_features();
    let index = fixture_index();
    let id = "twemoji/rocket.svg";
    let by_item = index
        .search(&Query {
            near: vec![id.into()],
            ..Query::default()
        })
        .unwrap();
    let by_vector = index
        .search(&Query {
            examples: vec![table.row(table.index_of(id).unwrap()).to_vec()],
            ..Query::default()
        })
        .unwrap();
    // The vector query also finds the item itself, at distance 0.
    assert_eq!(by_vector.hits[0].id, id);
    assert_eq!(by_vector.hits[0].distance, Some(0.0));
    assert_eq!(ids(&by_item)[..49], ids(&by_vector)[1..]);
}

#[test]
fn diversity_deals_seven_top_clusters_first() {
    for (table, labels) in [
        (random_table(5_000, 20, 4), None),
        (fixture_features(), Some(fixture_labels())),
    ] {
        let texts = texts::texts_for(table.ids(), labels.as_ref());
        let index = build(&table, texts, &Weighting::uniform(&table));
        let info = index.diversity().info();
        assert_eq!(info.top_sizes.len(), 7);
        assert!(info.top_sizes.iter().all(|&s| s > 0));
        assert!(info.top_sizes.windows(2).all(|w| w[0] >= w[1]));
        let r = index
            .search(&Query {
                diverse: true,
                ..Query::default()
            })
            .unwrap();
        assert_eq!(r.order, Order::Diversity);
        assert_eq!(r.hits.len(), 50);
        let first: std::collections::HashSet<u16> =
            r.hits[..7].iter().map(|h| h.cluster.unwrap().top).collect();
        assert_eq!(
            first.len(),
            7,
            "{:?}",
            r.hits[..7].iter().map(|h| h.cluster).collect::<Vec<_>>()
        );
        // Each cluster number agrees with the index's own record.
        for h in &r.hits {
            assert_eq!(h.cluster, Some(index.diversity().cluster_of(h.row)));
        }
    }
}

#[test]
fn keyword_hits_in_diversity_order_span_the_clusters_they_fall_in() {
    let index = fixture_index();
    let r = index
        .search(&Query {
            keywords: Some("face".into()),
            diverse: true,
            limit: 500,
            ..Query::default()
        })
        .unwrap();
    assert_eq!(r.hits.len(), r.matched);
    let spanned: std::collections::HashSet<u16> =
        r.hits.iter().map(|h| h.cluster.unwrap().top).collect();
    let first: std::collections::HashSet<u16> = r.hits[..spanned.len()]
        .iter()
        .map(|h| h.cluster.unwrap().top)
        .collect();
    assert_eq!(first, spanned);
}

#[test]
fn same_index_and_results_for_one_and_two_threads_and_every_run() {
    let table = random_table(6_000, 30, 11);
    let w = sparse_weighting(&table, 11);
    let texts = texts::texts_for(table.ids(), None);
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| {
                let index = build(&table, texts.clone(), &w);
                let queries = [
                    Query {
                        diverse: true,
                        limit: 200,
                        ..Query::default()
                    },
                    Query {
                        near: vec!["item-5".into(), "item-77".into()],
                        limit: 200,
                        ..Query::default()
                    },
                    Query {
                        keywords: Some("item".into()),
                        near: vec!["item-9".into()],
                        ..Query::default()
                    },
                ];
                let results: Vec<SearchResults> =
                    queries.iter().map(|q| index.search(q).unwrap()).collect();
                (index.diversity().clone(), results)
            })
    };
    let one = run(1);
    assert_eq!(one, run(2));
    assert_eq!(one, run(2));
}

#[test]
fn saved_index_answers_like_the_built_one_and_knows_its_sources() {
    let dir = tempfile::tempdir().unwrap();
    let features = dir.path().join("features.csv");
    std::fs::copy(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/metric/fixture-features.csv"),
        &features,
    )
    .unwrap();
    let table = read_features(&features).unwrap();
    let params = SearchParams::default();
    let sources = cache::Sources {
        features: &features,
        labels: None,
        model: None,
    };
    let fingerprint = cache::Fingerprint::of(sources, &params, None).unwrap();
    let folder = cache::default_dir(&features);
    assert_eq!(folder, dir.path().join("features.csv.search"));
    let built = SearchIndex::build_in(
        &folder,
        &table,
        texts::texts_for(table.ids(), None),
        &Weighting::uniform(&table),
        &params,
        &mut |_| {},
    )
    .unwrap();
    built.save(&folder, Some(&fingerprint)).unwrap();
    let (loaded, stored) = SearchIndex::load(&folder).unwrap();
    assert_eq!(stored.as_ref(), Some(&fingerprint));
    assert!(loaded.is_uniform());
    for q in [
        Query {
            keywords: Some("noto".into()),
            near: vec!["noto/rocket.svg".into()],
            ..Query::default()
        },
        Query {
            diverse: true,
            ..Query::default()
        },
    ] {
        assert_eq!(built.search(&q).unwrap(), loaded.search(&q).unwrap());
    }
    // Unchanged files keep their hash; a change of contents or parameters is noticed.
    let again = cache::Fingerprint::of(sources, &params, stored.as_ref()).unwrap();
    assert_eq!(fingerprint.staleness(&again), None);
    let other = SearchParams { seed: 1, ..params };
    let changed = cache::Fingerprint::of(sources, &other, stored.as_ref()).unwrap();
    assert_eq!(
        fingerprint.staleness(&changed),
        Some("the clustering parameters changed")
    );
    let mut text = std::fs::read_to_string(&features).unwrap();
    text.push_str(&text.lines().nth(1).unwrap().replacen("noto/", "copy/", 1));
    text.push('\n');
    std::fs::write(&features, text).unwrap();
    let changed = cache::Fingerprint::of(sources, &params, stored.as_ref()).unwrap();
    assert_eq!(
        fingerprint.staleness(&changed),
        Some("the features changed")
    );
    // A damaged file is refused with its name.
    let style = folder.join(cache::STYLE_FILE);
    let bytes = std::fs::read(&style).unwrap();
    std::fs::write(&style, &bytes[..bytes.len() - 10]).unwrap();
    let e = SearchIndex::load(&folder).unwrap_err();
    assert!(matches!(e, Error::InvalidIndex { .. }), "{e}");
    std::fs::write(&style, b"not an index").unwrap();
    assert!(matches!(
        SearchIndex::load(&folder),
        Err(Error::InvalidIndex { .. })
    ));
}

#[test]
fn bad_queries_and_libraries_are_clear_errors() {
    let index = fixture_index();
    let err = |q: Query| index.search(&q).unwrap_err();
    assert!(matches!(err(Query::default()), Error::EmptyQuery(_)));
    assert!(matches!(
        err(Query {
            keywords: Some(" - ".into()),
            ..Query::default()
        }),
        Error::EmptyQuery(_)
    ));
    let e = err(Query {
        near: vec!["noto/rocket.svg".into(), "nope.svg".into()],
        ..Query::default()
    });
    assert!(
        matches!(&e, Error::UnknownItem { id, .. } if id == "nope.svg"),
        "{e}"
    );
    assert!(matches!(
        err(Query {
            examples: vec![vec![0.0; 12]],
            ..Query::default()
        }),
        Error::QueryDimension {
            expected: 169,
            got: 12
        }
    ));
    assert!(matches!(
        err(Query {
            near: vec!["noto/rocket.svg".into()],
            diverse: true,
            ..Query::default()
        }),
        Error::InvalidParameter {
            name: "diverse",
            ..
        }
    ));
    assert!(matches!(
        err(Query {
            diverse: true,
            limit: 0,
            ..Query::default()
        }),
        Error::InvalidParameter { name: "limit", .. }
    ));

    // A weighting for other features; a library without items.
    let table = fixture_features();
    let other = random_table(10, 168, 1);
    let e = SearchIndex::build(
        &table,
        texts::texts_for(table.ids(), None),
        &Weighting::uniform(&other),
        &SearchParams::default(),
        None,
        &mut |_| {},
    )
    .unwrap_err();
    assert!(matches!(e, Error::FeatureMismatch { .. }), "{e}");
    let empty = FeatureTable::new(table.names().to_vec(), vec![], vec![]).unwrap();
    let e = SearchIndex::build(
        &empty,
        vec![],
        &Weighting::uniform(&table),
        &SearchParams::default(),
        None,
        &mut |_| {},
    )
    .unwrap_err();
    assert!(matches!(e, Error::EmptyLibrary), "{e}");
}

/// Condition B of §5.7.3's mash-up study: the same matches as the keyword search, in a random
/// order fixed by the seed.
#[test]
fn shuffled_results_are_the_same_matches_in_a_seeded_order() {
    let index = fixture_index();
    let q = |shuffle: Option<u64>| Query {
        keywords: Some("face".into()),
        shuffle,
        limit: 1000,
        ..Query::default()
    };
    let relevance = index.search(&q(None)).unwrap();
    let shuffled = index.search(&q(Some(5))).unwrap();
    assert_eq!(shuffled.order, Order::Random);
    assert_eq!(shuffled.matched, relevance.matched);
    assert!(relevance.hits.len() > 10, "{}", relevance.hits.len());
    let mut a = ids(&shuffled);
    let mut b = ids(&relevance);
    assert_ne!(a, b, "the random order is the relevance order");
    assert_eq!(
        ids(&index.search(&q(Some(5))).unwrap()),
        a,
        "not reproducible"
    );
    assert_ne!(
        ids(&index.search(&q(Some(6))).unwrap()),
        a,
        "the seed is ignored"
    );
    a.sort_unstable();
    b.sort_unstable();
    assert_eq!(a, b, "not the same matches");
    // A limit takes a prefix of the same kind of order; without keywords, all items.
    let few = index
        .search(&Query {
            limit: 7,
            ..q(Some(5))
        })
        .unwrap();
    assert_eq!(few.hits.len(), 7);
    let all = index
        .search(&Query {
            shuffle: Some(1),
            limit: 5,
            ..Query::default()
        })
        .unwrap();
    assert_eq!((all.matched, all.hits.len()), (index.len(), 5));
    // No random order beside references or the diversity order.
    for bad in [
        Query {
            near: vec!["noto/cat-face.svg".into()],
            ..q(Some(1))
        },
        Query {
            diverse: true,
            ..q(Some(1))
        },
    ] {
        assert!(bad.validate().is_err(), "{bad:?}");
    }
}

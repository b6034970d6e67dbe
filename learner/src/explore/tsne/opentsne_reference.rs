//! t-SNE (learner::explore::tsne) against openTSNE 1.0.4 and scikit-learn 1.9.1 on seeded
//! Gaussian blobs and the fixture icons' standardised features: reference values made by
//! scripts/reference/tsne_reference.py (versions and seed inside the JSON).
//!
//! The margins: trustworthiness (k = 5, 10) at least openTSNE's − [`TRUST_MARGIN`], and the
//! exact `KL(P‖Q)` (dense P at perplexity 30) at most [`KL_FACTOR`] × openTSNE's, both
//! embeddings measured by the same definitions (checked first against scikit-learn's own
//! numbers on openTSNE's embedding).

use std::path::Path;

use serde_json::Value;

use super::quality::{kl_divergence, knn_preservation, trustworthiness};
use super::{TsneKnn, TsneMethod, TsneParams, affinities, tsne};
use crate::table::read_features;

const DATA: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data");
/// Trustworthiness may fall short of openTSNE's by at most this much.
const TRUST_MARGIN: f64 = 0.02;
/// The KL divergence may exceed openTSNE's by at most this factor.
const KL_FACTOR: f64 = 1.1;

fn reference() -> Value {
    let text =
        std::fs::read_to_string(Path::new(DATA).join("explore/tsne_reference.json")).unwrap();
    serde_json::from_str(&text).unwrap()
}

fn case<'a>(reference: &'a Value, name: &str) -> &'a Value {
    reference["cases"]
        .as_array()
        .unwrap()
        .iter()
        .find(|c| c["name"] == name)
        .unwrap()
}

fn floats(v: &Value) -> Vec<f64> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect()
}

/// The case's points as the script gave them to openTSNE (f32 rows).
fn points(case: &Value) -> (Vec<f32>, usize) {
    if let Some(rows) = case["points"].as_array() {
        let dim = rows[0].as_array().unwrap().len();
        let x = rows
            .iter()
            .flat_map(|r| floats(r).into_iter().map(|v| v as f32))
            .collect();
        return (x, dim);
    }
    let table = read_features(&Path::new(DATA).join("metric/fixture-features.csv")).unwrap();
    let columns: Vec<usize> = case["columns"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| {
            let c = c.as_str().unwrap();
            table.names().iter().position(|n| n == c).unwrap()
        })
        .collect();
    let (mean, std) = (floats(&case["mean"]), floats(&case["std"]));
    let mut x = Vec::with_capacity(table.len() * columns.len());
    for i in 0..table.len() {
        let row = table.row(i);
        for (k, &j) in columns.iter().enumerate() {
            x.push(((row[j] - mean[k]) / std[k]) as f32);
        }
    }
    (x, columns.len())
}

fn embedding(v: &Value) -> Vec<[f32; 2]> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|r| {
            let r = floats(r);
            [r[0] as f32, r[1] as f32]
        })
        .collect()
}

fn labels(case: &Value) -> Option<Vec<u64>> {
    case["labels"]
        .as_array()
        .map(|l| l.iter().map(|v| v.as_u64().unwrap()).collect())
}

/// Mean fraction of each point's `k` nearest in the embedding that share its label.
fn label_purity(y: &[[f32; 2]], labels: &[u64], k: usize) -> f64 {
    let mut same = 0;
    for (i, yi) in y.iter().enumerate() {
        let mut d: Vec<(f32, usize)> = y
            .iter()
            .enumerate()
            .filter(|(j, _)| *j != i)
            .map(|(j, yj)| ((yi[0] - yj[0]).powi(2) + (yi[1] - yj[1]).powi(2), j))
            .collect();
        d.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        same += d[..k].iter().filter(|e| labels[e.1] == labels[i]).count();
    }
    same as f64 / (y.len() * k) as f64
}

fn exact_params() -> TsneParams {
    TsneParams {
        method: TsneMethod::Exact,
        ..TsneParams::default()
    }
}

/// Our measures on openTSNE's embedding give scikit-learn's trustworthiness, the script's kNN
/// preservation and the script's exact KL (through our dense P).
#[test]
fn quality_measures_match_sklearn_on_the_opentsne_embeddings() {
    let reference = reference();
    for name in ["blobs", "fixture_standardised"] {
        let case = case(&reference, name);
        let (x, dim) = points(case);
        let theirs = &case["opentsne"];
        let y = embedding(&theirs["embedding"]);
        for k in [5, 10] {
            let t = trustworthiness(&x, dim, &y, k).unwrap();
            let expected = theirs["trustworthiness"][k.to_string()].as_f64().unwrap();
            assert!(
                (t - expected).abs() <= 1e-9,
                "{name}: T({k}) {t} vs sklearn {expected}"
            );
        }
        let kept = knn_preservation(&x, dim, &y, 10).unwrap();
        let expected = theirs["knn_preservation"]["10"].as_f64().unwrap();
        assert!(
            (kept - expected).abs() <= 1e-12,
            "{name}: {kept} vs {expected}"
        );
        let p = affinities(&x, dim, &exact_params()).unwrap();
        let kl = kl_divergence(&p, &y).unwrap();
        let expected = theirs["kl_exact"].as_f64().unwrap();
        assert!(
            (kl - expected).abs() <= 1e-3 * expected,
            "{name}: KL {kl} vs sklearn's P {expected}"
        );
    }
}

/// Ours (default params, dense P and exact gradient at these sizes, or Barnes–Hut) is at least
/// as faithful as openTSNE within the margins, and keeps the blobs apart.
fn assert_as_good_as_opentsne(name: &str, method: TsneMethod) {
    assert_as_good_with(
        name,
        TsneParams {
            method,
            ..TsneParams::default()
        },
    );
}

fn assert_as_good_with(name: &str, params: TsneParams) {
    let method = params.method;
    let reference = reference();
    let case = case(&reference, name);
    let (x, dim) = points(case);
    let (y, info) = tsne(&x, dim, &params, &mut |_, _| {}).unwrap();
    assert_eq!(info.iterations, 750);
    let theirs = &case["opentsne"];
    for k in [5, 10] {
        let ours = trustworthiness(&x, dim, &y, k).unwrap();
        let open = theirs["trustworthiness"][k.to_string()].as_f64().unwrap();
        assert!(
            ours >= open - TRUST_MARGIN,
            "{name} {method:?}: T({k}) {ours} vs openTSNE {open}"
        );
    }
    let p = affinities(&x, dim, &exact_params()).unwrap();
    let ours = kl_divergence(&p, &y).unwrap();
    let open = theirs["kl_exact"].as_f64().unwrap();
    assert!(
        ours <= KL_FACTOR * open,
        "{name} {method:?}: KL {ours} vs openTSNE {open}"
    );
    if method == TsneMethod::Exact {
        // The reported KL is the exact one.
        assert!(
            (info.kl_divergence - ours).abs() <= 1e-6 * ours,
            "{}",
            info.kl_divergence
        );
    }
    if let Some(labels) = labels(case) {
        let purity = label_purity(&y, &labels, 10);
        let open = theirs["label_purity"]["10"].as_f64().unwrap();
        assert!(
            purity >= 0.99 && purity >= open - 0.01,
            "{name}: purity {purity} vs {open}"
        );
    }
}

#[test]
fn exact_tsne_is_as_good_as_opentsne_on_blobs() {
    assert_as_good_as_opentsne("blobs", TsneMethod::Exact);
}

#[test]
fn barnes_hut_tsne_is_as_good_as_opentsne_on_blobs() {
    assert_as_good_as_opentsne("blobs", TsneMethod::BarnesHut);
}

#[test]
fn exact_tsne_is_as_good_as_opentsne_on_fixture_icons() {
    assert_as_good_as_opentsne("fixture_standardised", TsneMethod::Exact);
}

#[test]
fn barnes_hut_tsne_is_as_good_as_opentsne_on_fixture_icons() {
    assert_as_good_as_opentsne("fixture_standardised", TsneMethod::BarnesHut);
}

#[test]
fn fft_tsne_is_as_good_as_opentsne_on_blobs() {
    assert_as_good_as_opentsne("blobs", TsneMethod::Fft);
}

#[test]
fn fft_tsne_is_as_good_as_opentsne_on_fixture_icons() {
    assert_as_good_as_opentsne("fixture_standardised", TsneMethod::Fft);
}

/// The FFT gradient over approximate neighbours (the large-input default) on the blobs.
#[test]
fn fft_tsne_with_approximate_neighbours_is_as_good_as_opentsne_on_blobs() {
    assert_as_good_with(
        "blobs",
        TsneParams {
            method: TsneMethod::Fft,
            knn: TsneKnn::Approximate,
            ..TsneParams::default()
        },
    );
}

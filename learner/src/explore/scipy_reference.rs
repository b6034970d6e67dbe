//! Ward clustering (learner::explore) against scipy's `linkage(X, 'ward')` on the fixture icons'
//! standardised features and on a seeded random set: reference values made by
//! scripts/reference/ward_reference.py (scipy and numpy versions inside the JSON).

use std::collections::HashMap;
use std::path::Path;

use crate::explore::{Linkage, ward};
use crate::table::read_features;
use serde_json::Value;

const DATA: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data");

fn reference() -> Value {
    let text =
        std::fs::read_to_string(Path::new(DATA).join("explore/ward_reference.json")).unwrap();
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

/// Rebuilds the script's inputs bit for bit: the kept columns, `(x − mean) / std` with numpy's
/// stored mean and std (one correctly rounded subtraction and division, as numpy does).
fn fixture_points(case: &Value) -> (Vec<f64>, usize) {
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
            x.push((row[j] - mean[k]) / std[k]);
        }
    }
    (x, columns.len())
}

fn random_points(case: &Value) -> (Vec<f64>, usize) {
    let rows: Vec<Vec<f64>> = case["points"]
        .as_array()
        .unwrap()
        .iter()
        .map(floats)
        .collect();
    let dim = rows[0].len();
    (rows.concat(), dim)
}

/// Identical merge pairs and sizes, heights within 1e-9 relative, and `cut(k)` equal to
/// `fcluster(Z, k, 'maxclust')` up to a one-to-one relabelling.
fn assert_matches_scipy(case: &Value, tree: &Linkage) {
    let name = case["name"].as_str().unwrap();
    assert_eq!(
        case["distinct_heights"], true,
        "{name}: the reference has tied heights"
    );
    let expected = case["linkage"].as_array().unwrap();
    assert_eq!(tree.merges().len(), expected.len(), "{name}");
    for (i, (m, row)) in tree.merges().iter().zip(expected).enumerate() {
        let row = floats(row);
        assert_eq!(
            (m.a, m.b, m.size),
            (row[0] as usize, row[1] as usize, row[3] as usize),
            "{name}: merge {i}"
        );
        let relative = (m.height - row[2]).abs() / row[2].abs().max(f64::MIN_POSITIVE);
        assert!(
            relative <= 1e-9,
            "{name}: merge {i} height {} vs scipy {}",
            m.height,
            row[2]
        );
    }
    for (k, labels) in case["maxclust"].as_object().unwrap() {
        let k: usize = k.parse().unwrap();
        let ours = tree.cut(k).unwrap();
        let theirs: Vec<u64> = labels
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_u64().unwrap())
            .collect();
        let mut forward = HashMap::new();
        let mut backward = HashMap::new();
        for (o, t) in ours.iter().zip(&theirs) {
            assert_eq!(*forward.entry(*o).or_insert(*t), *t, "{name}: k = {k}");
            assert_eq!(*backward.entry(*t).or_insert(*o), *o, "{name}: k = {k}");
        }
        assert_eq!(forward.len(), k, "{name}: k = {k}");
    }
}

#[test]
fn ward_matches_scipy_on_standardised_fixture_features() {
    let reference = reference();
    let case = case(&reference, "fixture_standardised");
    let (x, dim) = fixture_points(case);
    assert_eq!((x.len() / dim, dim), (200, 164));
    let tree = ward(&x, dim).unwrap();
    assert_matches_scipy(case, &tree);
}

#[test]
fn ward_matches_scipy_on_seeded_random_points() {
    let reference = reference();
    let case = case(&reference, "random");
    let (x, dim) = random_points(case);
    let tree = ward(&x, dim).unwrap();
    assert_matches_scipy(case, &tree);
    // The tree survives JSON and stays the same tree.
    let back: Linkage = serde_json::from_str(&serde_json::to_string(&tree).unwrap()).unwrap();
    assert_eq!(back, tree);
}

//! The grid's numerical building blocks against scipy and numpy: reference values made by
//! scripts/reference/grid_reference.py (versions inside the JSON).

use std::path::Path;

use serde_json::Value;

use super::isomap::{dijkstra, knn_graph, mds};
use super::{linear_assignment, spearman};

fn reference() -> Value {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/explore/grid_reference.json");
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

fn floats(v: &Value) -> Vec<f64> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect()
}

#[test]
fn grid_lap_matches_scipy_linear_sum_assignment() {
    let r = reference();
    for case in r["lap"].as_array().unwrap() {
        let name = case["name"].as_str().unwrap();
        let (n, m) = (
            case["rows"].as_u64().unwrap() as usize,
            case["cols"].as_u64().unwrap() as usize,
        );
        let cost = floats(&case["cost"]);
        let a = linear_assignment(&cost, n, m).unwrap();
        let total = case["total"].as_f64().unwrap();
        assert!(
            (a.total - total).abs() <= 1e-9 * total.abs().max(1.0),
            "{name}: {} vs scipy {total}",
            a.total
        );
        if case["unique"] == true {
            let expected: Vec<usize> = case["col"]
                .as_array()
                .unwrap()
                .iter()
                .map(|c| c.as_u64().unwrap() as usize)
                .collect();
            assert_eq!(a.col, expected, "{name}");
        }
    }
}

#[test]
fn grid_spearman_matches_scipy() {
    let r = reference();
    for case in r["spearman"].as_array().unwrap() {
        let rho = spearman(&floats(&case["a"]), &floats(&case["b"])).unwrap();
        let expected = case["rho"].as_f64().unwrap();
        assert!(
            (rho - expected).abs() < 1e-12,
            "{}: {rho} vs scipy {expected}",
            case["name"]
        );
    }
}

#[test]
fn grid_isomap_mds_matches_numpy() {
    let r = reference();
    let case = &r["isomap"];
    let points: Vec<f32> = case["points"]
        .as_array()
        .unwrap()
        .iter()
        .flat_map(|p| floats(p).into_iter().map(|x| x as f32))
        .collect();
    let n = points.len() / 3;
    let graph = knn_graph(&points, 3, n, case["k"].as_u64().unwrap() as usize);
    let geodesics: Vec<Vec<f64>> = (0..n).map(|s| dijkstra(&graph, s)).collect();
    let sum: f64 = geodesics.iter().flatten().sum();
    let expected = case["geodesic_sum"].as_f64().unwrap();
    assert!(
        (sum - expected).abs() < 1e-9 * expected,
        "geodesics: {sum} vs scipy {expected}"
    );
    let sq: Vec<f64> = geodesics.iter().flatten().map(|d| d * d).collect();
    let (vectors, values) = mds(&sq, n, 0);
    let ev = floats(&case["eigenvalues"]);
    for k in 0..2 {
        assert!(
            (values[k] - ev[k]).abs() < 1e-9 * ev[0],
            "eigenvalue {k}: {} vs numpy {}",
            values[k],
            ev[k]
        );
        let v = floats(&case["eigenvectors"][k]);
        let worst = vectors[k]
            .iter()
            .zip(&v)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(worst < 1e-7, "eigenvector {k}: max difference {worst}");
    }
}

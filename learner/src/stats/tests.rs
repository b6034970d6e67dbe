//! Agreement with SciPy on the committed reference values
//! (`fixtures/stats/ttest_reference.json`, written by `scripts/reference/stats_reference.py`).

use super::*;
use serde_json::Value;

const TOLERANCE: f64 = 1e-10;

fn reference() -> Value {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../fixtures/stats/ttest_reference.json"
    );
    let text = std::fs::read_to_string(path).expect("the committed SciPy reference");
    serde_json::from_str(&text).unwrap()
}

fn num(v: &Value, key: &str) -> f64 {
    v[key].as_f64().unwrap_or_else(|| panic!("{key} in {v}"))
}

/// Relative agreement, with an absolute floor for values that are (close to) zero, and
/// underflow to zero accepted below 1e-300.
fn close(got: f64, expected: f64, what: &str) {
    let ok = if expected == 0.0 {
        got.abs() < 1e-300
    } else {
        (got - expected).abs() <= TOLERANCE * expected.abs().max(1e-12)
    };
    assert!(ok, "{what}: got {got:e}, SciPy {expected:e}");
}

#[test]
fn t_test_and_interval_agree_with_scipy() {
    let reference = reference();
    let samples = reference["samples"].as_array().unwrap();
    assert!(samples.len() >= 10);
    for s in samples {
        let name = s["name"].as_str().unwrap();
        let x: Vec<f64> = s["x"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_f64().unwrap())
            .collect();
        let test = one_sample_t_test(&x, &TTestParams::default()).unwrap();
        close(test.interval.mean, num(s, "mean"), &format!("{name} mean"));
        close(test.interval.sd, num(s, "sd"), &format!("{name} sd"));
        close(test.t, num(s, "t"), &format!("{name} t"));
        assert_eq!(test.df, num(s, "df"), "{name} df");
        close(test.p, num(s, "p"), &format!("{name} p"));
        close(
            test.effect_size,
            num(s, "effect_size"),
            &format!("{name} d"),
        );
        close(
            test.interval.low,
            num(s, "ci_low"),
            &format!("{name} ci low"),
        );
        close(
            test.interval.high,
            num(s, "ci_high"),
            &format!("{name} ci high"),
        );
        let alone = mean_interval(&x, 0.95).unwrap();
        assert_eq!(alone, test.interval, "{name}");
    }
}

#[test]
fn t_distribution_agrees_with_scipy() {
    let reference = reference();
    let rows = reference["distribution"].as_array().unwrap();
    let mut checked = 0;
    for row in rows {
        let df = num(row, "df");
        let dist = StudentT::new(df).unwrap();
        if row.get("t").is_some() {
            let t = num(row, "t");
            close(dist.sf(t), num(row, "sf"), &format!("sf({t}; {df})"));
            close(dist.cdf(t), num(row, "cdf"), &format!("cdf({t}; {df})"));
        } else {
            let p = num(row, "p");
            close(
                dist.ppf(p).unwrap(),
                num(row, "ppf"),
                &format!("ppf({p}; {df})"),
            );
        }
        checked += 1;
    }
    assert!(checked > 150);
}

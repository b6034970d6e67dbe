//! End-to-end tests of `learner index` and `learner search` (issue 17) on the committed features
//! of the 200 fixture icons, checked against a brute-force f64 evaluation of eq. 5.5 written
//! here, independently of the library's `f32` scan.

use std::ffi::OsStr;
use std::fs;
use std::path::{Path, PathBuf};
use std::process::Output;

use e2e::{fixture, learner, workspace_root};
use serde_json::Value;

fn os(s: &str) -> &OsStr {
    OsStr::new(s)
}

fn metric_data(file: &str) -> PathBuf {
    workspace_root()
        .join("learner/tests/data/metric")
        .join(file)
}

/// A library: the fixture features, a model trained on the fixture triplets, the labels.
struct Library {
    dir: tempfile::TempDir,
    features: PathBuf,
    model: PathBuf,
}

impl Library {
    fn new() -> Self {
        let dir = tempfile::tempdir().expect("temp dir");
        let features = metric_data("fixture-features.csv");
        let model = dir.path().join("model.json");
        let run = learner(&[
            os("train"),
            os("--features"),
            features.as_os_str(),
            os("--triplets"),
            metric_data("fixture-triplets.csv").as_os_str(),
            os("--lambda"),
            os("1"),
            os("--out"),
            model.as_os_str(),
        ]);
        assert!(run.status.success(), "{}", stderr(&run));
        Self {
            dir,
            features,
            model,
        }
    }

    /// `learner search` on this library with its own index folder (the features file is
    /// shared by tests running at the same time).
    fn search(&self, extra: &[&str]) -> Output {
        let index = self.dir.path().join("index");
        let mut args = vec![
            os("search"),
            os("--features"),
            self.features.as_os_str(),
            os("--model"),
            self.model.as_os_str(),
            os("--tags"),
            fixture_labels(),
            os("--index"),
            index.as_os_str(),
            os("--quiet"),
        ];
        args.extend(extra.iter().map(|s| os(s)));
        learner(&args)
    }
}

fn fixture_labels() -> &'static OsStr {
    static LABELS: std::sync::OnceLock<PathBuf> = std::sync::OnceLock::new();
    LABELS
        .get_or_init(|| fixture("style/labels.csv"))
        .as_os_str()
}

fn stderr(run: &Output) -> String {
    String::from_utf8_lossy(&run.stderr).into_owned()
}

fn json_results(run: &Output) -> Vec<Value> {
    assert!(run.status.success(), "{}", stderr(run));
    let out: Value = serde_json::from_slice(&run.stdout).expect("--json prints JSON");
    out["results"].as_array().expect("results array").clone()
}

/// Features by id, in file order.
fn read_features(path: &Path) -> (Vec<String>, Vec<String>, Vec<Vec<f64>>) {
    let mut reader = csv::Reader::from_path(path).expect("features csv");
    let names = reader
        .headers()
        .unwrap()
        .iter()
        .skip(1)
        .map(String::from)
        .collect();
    let (mut ids, mut rows) = (Vec::new(), Vec::new());
    for record in reader.records() {
        let record = record.unwrap();
        ids.push(record[0].to_string());
        rows.push(record.iter().skip(1).map(|v| v.parse().unwrap()).collect());
    }
    (names, ids, rows)
}

/// Every item but the references, by mean eq.-5.5 distance to them
/// (`d(x, y) = sqrt(Σ_k w_k (x̂_k − ŷ_k)²)`, `x̂ = (x − mean) / scale`), in f64, ties by file
/// order.
fn brute_force(features: &Path, model: &Path, near: &[&str]) -> Vec<(String, f64)> {
    let (names, ids, rows) = read_features(features);
    let m: Value = serde_json::from_slice(&fs::read(model).unwrap()).unwrap();
    let vec = |key: &str| -> Vec<f64> {
        m[key]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_f64().unwrap())
            .collect()
    };
    let (mean, scale, w) = (vec("mean"), vec("scale"), vec("weights"));
    let model_names: Vec<&str> = m["feature_names"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_str().unwrap())
        .collect();
    assert_eq!(
        model_names, names,
        "the model follows the features' columns"
    );
    let d = |a: &[f64], b: &[f64]| -> f64 {
        (0..a.len())
            .map(|k| w[k] * ((a[k] - mean[k]) / scale[k] - (b[k] - mean[k]) / scale[k]).powi(2))
            .sum::<f64>()
            .sqrt()
    };
    let refs: Vec<usize> = near
        .iter()
        .map(|id| ids.iter().position(|x| x == id).expect("reference id"))
        .collect();
    let mut all: Vec<(usize, f64)> = (0..ids.len())
        .filter(|i| !refs.contains(i))
        .map(|i| {
            let mean_d =
                refs.iter().map(|&r| d(&rows[i], &rows[r])).sum::<f64>() / refs.len() as f64;
            (i, mean_d)
        })
        .collect();
    all.sort_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)));
    all.into_iter().map(|(i, d)| (ids[i].clone(), d)).collect()
}

/// The CLI's results are the reference's first ones: the same distances at each rank, and at
/// each rank an item whose reference distance is that one (the index stores `f32`, so items at
/// equal distance may come in either order).
fn assert_matches_reference(results: &[Value], reference: &[(String, f64)]) {
    let tol = |d: f64| 1e-4 * d.max(1.0);
    for (rank, r) in results.iter().enumerate() {
        let id = r["id"].as_str().expect("id");
        let got = r["distance"].as_f64().expect("distance");
        let want = reference[rank].1;
        assert!(
            (got - want).abs() <= tol(want),
            "rank {rank}: {id} at {got}, reference {} at {want}",
            reference[rank].0
        );
        let own = reference
            .iter()
            .find(|(x, _)| x == id)
            .unwrap_or_else(|| panic!("{id} is a reference item or unknown"))
            .1;
        assert!(
            (own - want).abs() <= tol(want),
            "rank {rank}: {id} (reference distance {own}) where the reference has {} at {want}",
            reference[rank].0
        );
        assert!(r.get("cluster").is_none(), "no cluster outside --diverse");
    }
}

#[test]
fn search_json_matches_a_brute_force_reference() {
    let lib = Library::new();
    // One reference ("more like this") and a canvas of three, in two styles.
    for near in [
        vec!["noto/dog-face.svg"],
        vec![
            "twemoji/bicycle.svg",
            "noto/rocket.svg",
            "fluent-emoji/cat-face.svg",
        ],
    ] {
        let run = lib.search(&["--near", &near.join(","), "--limit", "25", "--json"]);
        let results = json_results(&run);
        assert_eq!(results.len(), 25);
        let reference = brute_force(&lib.features, &lib.model, &near);
        assert_matches_reference(&results, &reference);
    }
}

#[test]
fn search_keyword_hits_are_ordered_by_style_like_the_reference() {
    let lib = Library::new();
    let near = ["noto/dog-face.svg"];
    let results = json_results(&lib.search(&[
        "--query", "dog", "--near", near[0], "--limit", "50", "--json",
    ]));
    let ids: Vec<&str> = results.iter().map(|r| r["id"].as_str().unwrap()).collect();
    // The other three styles' dog faces match, the reference itself is left out.
    for style in ["twemoji", "fluent-emoji", "emojione-monotone"] {
        assert!(
            ids.contains(&format!("{style}/dog-face.svg").as_str()),
            "{ids:?}"
        );
    }
    assert!(!ids.contains(&near[0]));
    assert!(results.len() < 200, "keywords restrict the library");
    // Each hit at its reference distance, in non-decreasing order.
    let reference = brute_force(&lib.features, &lib.model, &near);
    let mut last = 0.0;
    for r in &results {
        let id = r["id"].as_str().unwrap();
        let d = r["distance"].as_f64().unwrap();
        let want = reference.iter().find(|(x, _)| x == id).unwrap().1;
        assert!(
            (d - want).abs() <= 1e-4 * want.max(1.0),
            "{id}: {d} vs {want}"
        );
        assert!(d >= last - 1e-9, "{id} out of order");
        last = d;
    }
}

#[test]
fn search_diverse_gives_each_result_its_cluster() {
    let lib = Library::new();
    let results = json_results(&lib.search(&["--diverse", "--limit", "30", "--json"]));
    assert_eq!(results.len(), 30);
    let clusters: Vec<u64> = results
        .iter()
        .map(|r| {
            assert!(
                r.get("distance").is_none(),
                "no distance without references"
            );
            r["cluster"].as_u64().expect("cluster of each result")
        })
        .collect();
    // §5.7.3: the first results deal one item from each of the seven top clusters.
    let mut first: Vec<u64> = clusters[..7].to_vec();
    first.sort_unstable();
    first.dedup();
    assert_eq!(first.len(), 7, "{clusters:?}");
    let mut ids: Vec<&str> = results.iter().map(|r| r["id"].as_str().unwrap()).collect();
    ids.sort_unstable();
    ids.dedup();
    assert_eq!(ids.len(), 30, "no item twice");
}

#[test]
fn search_index_is_built_once_and_rebuilt_when_the_model_changes() {
    let lib = Library::new();
    let index = lib.dir.path().join("index");
    let run = learner(&[
        os("index"),
        os("--features"),
        lib.features.as_os_str(),
        os("--model"),
        lib.model.as_os_str(),
        os("--tags"),
        fixture_labels(),
        os("--index"),
        index.as_os_str(),
        os("--quiet"),
    ]);
    assert!(run.status.success(), "{}", stderr(&run));
    assert!(index.join("style.bin").is_file());
    let first = lib.search(&["--near", "noto/rocket.svg", "--json"]);
    assert!(!stderr(&first).contains("rebuilding"), "{}", stderr(&first));
    // Another model (λ = 10: sparser weights) makes the saved index stale.
    let run = learner(&[
        os("train"),
        os("--features"),
        lib.features.as_os_str(),
        os("--triplets"),
        metric_data("fixture-triplets.csv").as_os_str(),
        os("--lambda"),
        os("10"),
        os("--out"),
        lib.model.as_os_str(),
    ]);
    assert!(run.status.success(), "{}", stderr(&run));
    let second = lib.search(&["--near", "noto/rocket.svg", "--json"]);
    assert!(
        stderr(&second).contains("the model changed"),
        "{}",
        stderr(&second)
    );
    let reference = brute_force(&lib.features, &lib.model, &["noto/rocket.svg"]);
    assert_matches_reference(&json_results(&second), &reference);
}

/// Exit status 1 and one line `error: …` naming the problem; no panic, nothing on stdout.
fn assert_clear_error(run: &Output, expected: &str) {
    let err = stderr(run);
    assert_eq!(run.status.code(), Some(1), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    assert!(run.stdout.is_empty());
    let last = err.lines().last().unwrap_or("");
    assert!(
        last.starts_with("error: ") && last.contains(expected),
        "expected an error line with '{expected}', got: {err}"
    );
}

#[test]
fn bad_search_input_is_a_one_line_error_with_status_1() {
    let lib = Library::new();
    assert_clear_error(&lib.search(&["--query", ""]), "empty query");
    assert_clear_error(&lib.search(&["--query", " , ; "]), "empty query");
    assert_clear_error(&lib.search(&[]), "empty query");
    assert_clear_error(
        &lib.search(&["--near", "noto/rocket.svg,noto/unicorn.svg"]),
        "unknown item 'noto/unicorn.svg'",
    );

    // A model whose features are not the library's: the first 100 columns only.
    let dir = lib.dir.path();
    let narrow = dir.join("narrow.csv");
    let text = fs::read_to_string(&lib.features).unwrap();
    let cut: String = text
        .lines()
        .map(|l| l.split(',').take(101).collect::<Vec<_>>().join(",") + "\n")
        .collect();
    fs::write(&narrow, cut).unwrap();
    // A library without features: the header only, and no file at all.
    let header_only = dir.join("empty.csv");
    fs::write(
        &header_only,
        text.lines().next().unwrap().to_string() + "\n",
    )
    .unwrap();
    let missing = dir.join("missing.csv");
    for (features, expected) in [
        (&narrow, "model has 169 features, file has 100"),
        (&header_only, "no data rows"),
        (&missing, "cannot read"),
    ] {
        let run = learner(&[
            os("search"),
            os("--features"),
            features.as_os_str(),
            os("--model"),
            lib.model.as_os_str(),
            os("--near"),
            os("noto/rocket.svg"),
            os("--quiet"),
        ]);
        assert_clear_error(&run, expected);
    }
}

//! End-to-end tests of `learner taxonomy` and `learner map` (issue 18) on the committed features
//! of the 200 fixture icons: the JSON formats, the contact sheets, the pruning rule and the
//! representatives checked against an independent f64 evaluation of the learned metric, the
//! static map page in Chromium, and the errors a user meets.

use std::collections::HashMap;
use std::ffi::OsStr;
use std::fs;
use std::path::{Path, PathBuf};
use std::process::Output;

use e2e::browser::{Viewport, browser};
use e2e::{fixture, learner, workspace_root};
use fantoccini::{Client, Locator};
use serde_json::Value;

fn features() -> PathBuf {
    workspace_root().join("learner/tests/data/metric/fixture-features.csv")
}

/// `learner <command> --features … --item-labels fixtures/style/labels.csv --items
/// fixtures/style --quiet` plus `extra`.
fn explore(command: &str, extra: &[&str]) -> Output {
    let (f, labels, items) = (features(), fixture("style/labels.csv"), fixture("style"));
    let mut args: Vec<&OsStr> = vec![
        OsStr::new(command),
        OsStr::new("--features"),
        f.as_os_str(),
        OsStr::new("--item-labels"),
        labels.as_os_str(),
        OsStr::new("--items"),
        items.as_os_str(),
        OsStr::new("--quiet"),
    ];
    args.extend(extra.iter().map(OsStr::new));
    learner(&args)
}

fn stderr(run: &Output) -> String {
    String::from_utf8_lossy(&run.stderr).into_owned()
}

fn read_json(path: &Path) -> Value {
    serde_json::from_slice(&fs::read(path).expect("result JSON")).expect("valid JSON")
}

/// The fixture items' style rows under uniform weights (features standardised over the
/// library with the population standard deviation; constant features dropped), in f64.
fn uniform_rows() -> HashMap<String, Vec<f64>> {
    let mut reader = csv::Reader::from_path(features()).expect("features csv");
    let (mut ids, mut rows) = (Vec::new(), Vec::<Vec<f64>>::new());
    for record in reader.records() {
        let record = record.unwrap();
        ids.push(record[0].to_string());
        rows.push(record.iter().skip(1).map(|v| v.parse().unwrap()).collect());
    }
    let (n, p) = (rows.len() as f64, rows[0].len());
    let mut out: Vec<Vec<f64>> = vec![Vec::new(); rows.len()];
    for k in 0..p {
        let mean = rows.iter().map(|r| r[k]).sum::<f64>() / n;
        let sd = (rows.iter().map(|r| (r[k] - mean).powi(2)).sum::<f64>() / n).sqrt();
        if sd > 1e-12 {
            for (o, r) in out.iter_mut().zip(&rows) {
                o.push((r[k] - mean) / sd);
            }
        }
    }
    ids.into_iter().zip(out).collect()
}

/// The group column of the fixture labels.
fn groups() -> HashMap<String, String> {
    let mut reader = csv::Reader::from_path(fixture("style/labels.csv")).expect("labels");
    let header = reader.headers().unwrap().clone();
    let (file, group) = (
        header.iter().position(|h| h == "file").unwrap(),
        header.iter().position(|h| h == "group").unwrap(),
    );
    reader
        .records()
        .map(|r| {
            let r = r.unwrap();
            (r[file].to_string(), r[group].to_string())
        })
        .collect()
}

#[test]
fn taxonomy_keeps_branches_with_every_label_and_their_nearest_representative() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("taxonomy.json");
    let run = explore(
        "taxonomy",
        &[
            "--label-column",
            "group",
            "--labels",
            "animals-nature,travel-places",
            "--kappa",
            "12",
            "--tau",
            "2",
            "--out",
            out.to_str().unwrap(),
        ],
    );
    assert!(run.status.success(), "{}", stderr(&run));
    let t = read_json(&out);
    let group = groups();
    let wanted = |id: &str| ["animals-nature", "travel-places"].contains(&group[id].as_str());
    let library = group.keys().filter(|id| wanted(id)).count();
    assert_eq!(t["items"], library);
    assert_eq!(t["clustered_on"], "items");
    let reps = t["representatives"].as_array().expect("representatives");
    assert!(reps.len() >= 2, "{t}");
    let rows = uniform_rows();
    let mut covered = 0;
    for r in reps {
        let members: Vec<&str> = r["members"]
            .as_array()
            .unwrap()
            .iter()
            .map(|m| m.as_str().unwrap())
            .collect();
        let count = r["count"].as_u64().unwrap() as usize;
        covered += count;
        assert_eq!(members.len(), count);
        // The pruning rule: more than κ items, more than τ of each requested label.
        assert!(count > 12, "{r}");
        for label in ["animals-nature", "travel-places"] {
            let n = members.iter().filter(|m| group[**m] == label).count();
            assert!(n > 2, "{label}: {r}");
            assert_eq!(r["labels"][label], n);
        }
        // The representative is the member nearest the members' centroid (f64, here).
        let dim = rows[members[0]].len();
        let mut centroid = vec![0.0; dim];
        for m in &members {
            for (c, v) in centroid.iter_mut().zip(&rows[*m]) {
                *c += v / count as f64;
            }
        }
        let d = |id: &str| -> f64 {
            rows[id]
                .iter()
                .zip(&centroid)
                .map(|(a, b)| (a - b).powi(2))
                .sum()
        };
        let nearest = members.iter().min_by(|a, b| d(a).total_cmp(&d(b))).unwrap();
        let chosen = r["id"].as_str().unwrap();
        assert!(
            (d(chosen) - d(nearest)).abs() <= 1e-6 * d(nearest).max(1.0),
            "{chosen} at {} but {nearest} at {}",
            d(chosen),
            d(nearest)
        );
    }
    assert_eq!(
        covered + t["unassigned"].as_u64().unwrap() as usize,
        library
    );
    assert_eq!(t["tree"]["count"], library);
    // The contact sheet: one row per representative style.
    let sheet = image::open(dir.path().join("taxonomy.png")).expect("contact sheet");
    let cell = 96 + 12;
    assert_eq!(sheet.height(), 12 + reps.len() as u32 * cell);
}

#[test]
fn taxonomy_and_map_reject_bad_input_with_one_line_errors() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("t.json");
    let out = out.to_str().unwrap();
    for (command, extra, needle) in [
        (
            "taxonomy",
            vec![
                "--label-column",
                "group",
                "--labels",
                "unicorn",
                "--out",
                out,
            ],
            "unicorn",
        ),
        (
            "taxonomy",
            vec!["--kappa", "1000", "--out", out],
            "prune every branch",
        ),
        (
            "taxonomy",
            vec!["--label-column", "nope", "--out", out],
            "no `nope` column",
        ),
        (
            "map",
            vec!["--perplexity", "90", "--out", out],
            "perplexity",
        ),
        ("map", vec!["--per-label", "0", "--out", out], "per_label"),
    ] {
        let run = explore(command, &extra);
        assert_eq!(
            run.status.code(),
            Some(1),
            "{command} {extra:?}: {}",
            stderr(&run)
        );
        let err = stderr(&run);
        assert!(err.contains(needle), "{command} {extra:?}: {err}");
        assert_eq!(err.trim().lines().count(), 1, "{err}");
    }
    // A model whose features are not the table's (the last column dropped from the table).
    let model = dir.path().join("model.json");
    let train = learner(&[
        OsStr::new("train"),
        OsStr::new("--features"),
        features().as_os_str(),
        OsStr::new("--triplets"),
        workspace_root()
            .join("learner/tests/data/metric/fixture-triplets.csv")
            .as_os_str(),
        OsStr::new("--lambda"),
        OsStr::new("1"),
        OsStr::new("--out"),
        model.as_os_str(),
    ]);
    assert!(train.status.success(), "{}", stderr(&train));
    let other = dir.path().join("other.csv");
    let text = fs::read_to_string(features()).unwrap();
    let cut: String = text
        .lines()
        .map(|l| l.rsplit_once(',').unwrap().0.to_owned() + "\n")
        .collect();
    fs::write(&other, cut).unwrap();
    let run = learner(&[
        OsStr::new("taxonomy"),
        OsStr::new("--features"),
        other.as_os_str(),
        OsStr::new("--model"),
        model.as_os_str(),
    ]);
    assert_eq!(run.status.code(), Some(1), "{}", stderr(&run));
    assert!(stderr(&run).contains("model.json"), "{}", stderr(&run));
}

#[test]
fn map_writes_points_a_sheet_and_a_page_that_zooms_and_searches() {
    let dir = tempfile::tempdir().unwrap();
    let (out, html) = (dir.path().join("map.json"), dir.path().join("page"));
    let args = [
        "--label-column",
        "style",
        "--per-label",
        "20",
        "--perplexity",
        "10",
        "--iterations",
        "300",
        "--out",
        out.to_str().unwrap(),
        "--html",
        html.to_str().unwrap(),
    ];
    let run = explore("map", &args);
    assert!(run.status.success(), "{}", stderr(&run));
    let map = read_json(&out);
    let points = map["points"].as_array().expect("points");
    // 20 representatives of each of the 4 styles.
    assert_eq!(points.len(), 80);
    let mut per_style: HashMap<&str, usize> = HashMap::new();
    for p in points {
        assert!(p["x"].as_f64().unwrap().is_finite() && p["y"].as_f64().is_some());
        *per_style.entry(p["label"].as_str().unwrap()).or_default() += 1;
        let id = p["id"].as_str().unwrap();
        assert!(id.starts_with(p["label"].as_str().unwrap()), "{id}");
    }
    assert!(per_style.values().all(|&n| n == 20), "{per_style:?}");
    // Same seed, same map.
    let again = dir.path().join("again.json");
    let mut second = args.to_vec();
    second[9] = again.to_str().unwrap();
    second.truncate(10);
    assert!(explore("map", &second).status.success());
    assert_eq!(read_json(&again)["points"], map["points"]);
    assert!(image::open(dir.path().join("map.png")).is_ok());
    for f in [
        "index.html",
        "map.js",
        "map.css",
        "points.js",
        "atlas-0.png",
    ] {
        assert!(html.join(f).is_file(), "{f}");
    }
    page_in_chromium(&html);
}

fn page_in_chromium(html: &Path) {
    let rt = tokio::runtime::Runtime::new().unwrap();
    rt.block_on(async {
        let profile = tempfile::tempdir().unwrap();
        let Some((_driver, c)) = browser(profile.path(), Viewport::Desktop).await else {
            return;
        };
        let url = format!("file://{}", html.join("index.html").display());
        c.goto(&url).await.expect("open the page");
        assert_eq!(status(&c).await, "80 items · 80 in view");
        // Zoom in on the centre: fewer points in view.
        c.execute(
            "const m = document.getElementById('map'); const r = m.getBoundingClientRect();
             for (let i = 0; i < 8; i++) m.dispatchEvent(new WheelEvent('wheel', {deltaY: -300,
               clientX: r.left + r.width / 2, clientY: r.top + r.height / 2, bubbles: true,
               cancelable: true}));",
            vec![],
        )
        .await
        .expect("zoom");
        let zoomed = status(&c).await;
        let in_view: usize = zoomed
            .split(" · ")
            .nth(1)
            .and_then(|s| s.split(' ').next())
            .and_then(|s| s.parse().ok())
            .expect("in view count");
        assert!(in_view < 80, "{zoomed}");
        // Search by style name: 20 of the 80 match.
        let search = c.find(Locator::Id("search")).await.expect("search box");
        search.send_keys("twemoji").await.expect("type");
        assert!(status(&c).await.starts_with("20 of 80 match"));
        c.find(Locator::Id("reset"))
            .await
            .unwrap()
            .click()
            .await
            .unwrap();
        assert!(status(&c).await.ends_with("80 in view"));
        c.close().await.expect("close");
    });
}

async fn status(c: &Client) -> String {
    c.find(Locator::Id("status"))
        .await
        .expect("status")
        .text()
        .await
        .expect("text")
}

#[test]
fn grid_lays_out_a_taxonomy_branch_without_losing_an_item() {
    let dir = tempfile::tempdir().unwrap();
    let taxonomy = dir.path().join("taxonomy.json");
    let filter = [
        "--label-column",
        "group",
        "--labels",
        "animals-nature,travel-places",
    ];
    let mut args = filter.to_vec();
    args.extend(["--kappa", "12", "--out", taxonomy.to_str().unwrap()]);
    let run = explore("taxonomy", &args);
    assert!(run.status.success(), "{}", stderr(&run));
    let t = read_json(&taxonomy);
    let branch = &t["representatives"][0];
    let members: Vec<&str> = branch["members"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| m.as_str().unwrap())
        .collect();
    let side = (members.len() as f64).sqrt().floor() as usize;
    let out = dir.path().join("grid.json");
    let mut alone = Vec::new();
    for layout in ["balanced", "som", "isomatch", "random"] {
        let mut args = filter.to_vec();
        let (rows, cols) = (side.to_string(), side.to_string());
        args.extend([
            "--taxonomy",
            taxonomy.to_str().unwrap(),
            "--branch",
            branch["id"].as_str().unwrap(),
            "--rows",
            &rows,
            "--cols",
            &cols,
            "--layout",
            layout,
            "--out",
            out.to_str().unwrap(),
        ]);
        let run = explore("grid", &args);
        assert!(run.status.success(), "{layout}: {}", stderr(&run));
        let g = read_json(&out);
        assert_eq!(
            (g["rows"].as_u64(), g["cols"].as_u64()),
            (Some(side as u64), Some(side as u64))
        );
        let nodes = g["nodes"].as_array().unwrap();
        assert_eq!(nodes.len(), side * side);
        // Shown + hidden = the branch, each item once.
        let mut placed: Vec<&str> = Vec::new();
        for node in nodes {
            if let Some(id) = node["id"].as_str() {
                placed.push(id);
                // Single: one item shown (with any others hidden behind it); multi: the
                // raw SOM's node that has not chosen.
                let state = node["state"].as_str().unwrap();
                assert!(state == "single" || state == "multi", "{node}");
                if layout == "balanced" {
                    assert_eq!(state, "single", "{node}");
                }
            } else {
                assert_eq!(node["state"], "empty");
                assert!(node["label"].is_null());
            }
            placed.extend(
                node["hidden"]
                    .as_array()
                    .unwrap()
                    .iter()
                    .map(|h| h.as_str().unwrap()),
            );
        }
        placed.sort_unstable();
        let mut expected = members.clone();
        expected.sort_unstable();
        assert_eq!(placed, expected, "{layout}");
        if layout == "balanced" {
            // At least as many items as nodes: every node shows one (Algorithms 3–4).
            assert_eq!(g["cost"]["empty"], 0, "{g}");
            assert!(nodes.iter().all(|n| !n["id"].is_null()));
        }
        assert!(g["quality"]["dpq16"].as_f64().is_some(), "{g}");
        assert!(image::open(dir.path().join("grid.png")).is_ok());
        alone.push((layout, g["cost"].clone(), g["quality"].clone()));
    }
    // --compare reports all four layouts on the same branch, each as its own run measures it
    // (same seed), and prints the table.
    let mut args = filter.to_vec();
    let (rows, cols) = (side.to_string(), side.to_string());
    args.extend([
        "--taxonomy",
        taxonomy.to_str().unwrap(),
        "--branch",
        branch["id"].as_str().unwrap(),
        "--rows",
        &rows,
        "--cols",
        &cols,
        "--layout",
        "som",
        "--compare",
        "--out",
        out.to_str().unwrap(),
    ]);
    let run = explore("grid", &args);
    assert!(run.status.success(), "{}", stderr(&run));
    let g = read_json(&out);
    assert_eq!(g["layout"], "som");
    let comparison = g["comparison"].as_array().expect("comparison");
    assert_eq!(comparison.len(), 4, "{g}");
    assert_eq!(comparison[0]["layout"], "som", "the chosen layout first");
    for (layout, cost, quality) in &alone {
        let row = comparison
            .iter()
            .find(|c| c["layout"] == *layout)
            .unwrap_or_else(|| panic!("{layout} missing: {g}"));
        assert_eq!((&row["cost"], &row["quality"]), (cost, quality), "{layout}");
    }
    let table = stderr(&run);
    assert!(
        ["balanced", "som", "isomatch", "random", "Spearman", "DPQ16"]
            .iter()
            .all(|w| table.contains(w)),
        "{table}"
    );
    // A grid larger than the branch, and a branch that is not in the taxonomy.
    let mut args = filter.to_vec();
    args.extend([
        "--taxonomy",
        taxonomy.to_str().unwrap(),
        "--branch",
        branch["id"].as_str().unwrap(),
        "--rows",
        "40",
        "--cols",
        "40",
    ]);
    let run = explore("grid", &args);
    assert_eq!(run.status.code(), Some(1));
    assert!(stderr(&run).contains("1600 cells"), "{}", stderr(&run));
    let mut args = filter.to_vec();
    args.extend([
        "--taxonomy",
        taxonomy.to_str().unwrap(),
        "--branch",
        "no/such.svg",
        "--rows",
        "2",
        "--cols",
        "2",
    ]);
    let run = explore("grid", &args);
    assert_eq!(run.status.code(), Some(1));
    assert!(
        stderr(&run).contains("no representative style `no/such.svg`"),
        "{}",
        stderr(&run)
    );
}

//! End-to-end tests of the `learner` binary on the committed fixtures and on malformed input.

use std::ffi::OsStr;
use std::fs;
use std::path::Path;

use e2e::{fixture, learner};

fn os(s: &str) -> &OsStr {
    OsStr::new(s)
}

fn read_csv(path: &Path) -> (Vec<String>, Vec<Vec<String>>) {
    let mut reader = csv::Reader::from_path(path).expect("open csv");
    let headers = reader.headers().unwrap().iter().map(String::from).collect();
    let rows = reader
        .records()
        .map(|r| r.unwrap().iter().map(String::from).collect())
        .collect();
    (headers, rows)
}

#[test]
fn features_of_the_style_fixture_set() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("features.csv");
    let run = learner(&[
        os("features"),
        fixture("style").as_os_str(),
        os("--out"),
        out.as_os_str(),
        os("--quiet"),
    ]);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let (headers, rows) = read_csv(&out);
    assert_eq!(headers.len(), 170);
    assert_eq!(headers[0], "id");
    assert_eq!(rows.len(), 200);
    assert!(rows.iter().any(|r| r[0] == "noto/dog-face.svg"));
    for row in &rows {
        for v in &row[1..] {
            let x: f64 = v
                .parse()
                .unwrap_or_else(|_| panic!("{} has non-number {v}", row[0]));
            assert!(x.is_finite());
        }
    }
    // Styles must differ: the monotone set has no saturation, Noto does.
    let saturation = headers
        .iter()
        .position(|h| h == "colour_saturation_mean")
        .expect("colour_saturation_mean column");
    let mean_sat = |style: &str| {
        let vals: Vec<f64> = rows
            .iter()
            .filter(|r| r[0].starts_with(style))
            .map(|r| r[saturation].parse().unwrap())
            .collect();
        vals.iter().sum::<f64>() / vals.len() as f64
    };
    assert!(mean_sat("emojione-monotone/") < 0.01);
    assert!(mean_sat("noto/") > 0.2);
}

#[test]
fn output_is_identical_for_any_thread_count() {
    let dir = tempfile::tempdir().unwrap();
    let run = |jobs: &str, name: &str| {
        let out = dir.path().join(name);
        let r = learner(&[
            os("features"),
            fixture("style/twemoji").as_os_str(),
            os("--jobs"),
            os(jobs),
            os("--out"),
            out.as_os_str(),
            os("--quiet"),
        ]);
        assert!(r.status.success());
        fs::read(out).unwrap()
    };
    assert_eq!(run("1", "one.csv"), run("2", "two.csv"));
}

#[test]
fn iconify_sets_give_prefixed_ids_and_category_tags_in_jsonl() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("f.jsonl");
    let set = fixture("iconify/noto-subset/icons.json");
    let run = learner(&[
        os("features"),
        set.as_os_str(),
        os("--format"),
        os("jsonl"),
        os("--out"),
        out.as_os_str(),
    ]);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let lines: Vec<serde_json::Value> = fs::read_to_string(&out)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    let ids: Vec<&str> = lines.iter().map(|l| l["id"].as_str().unwrap()).collect();
    // The hidden icon "0" is skipped; plain aliases are tags, not items.
    assert_eq!(
        ids,
        [
            "noto:counterclockwise-arrows-button",
            "noto:dog-face",
            "noto:person",
            "noto:red-heart",
            "noto:sun"
        ]
    );
    let person = &lines[2];
    let tags: Vec<&str> = person["tags"]
        .as_array()
        .unwrap()
        .iter()
        .map(|t| t.as_str().unwrap())
        .collect();
    assert_eq!(tags, ["person", "adult", "people & body"]);
    assert_eq!(person["features"].as_object().unwrap().len(), 169);
}

#[test]
fn sidecar_tags_reach_jsonl() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("f.jsonl");
    let run = learner(&[
        os("features"),
        fixture("style").as_os_str(),
        os("--tags"),
        fixture("style/labels.csv").as_os_str(),
        os("--format"),
        os("jsonl"),
        os("--out"),
        out.as_os_str(),
        os("--quiet"),
    ]);
    assert!(run.status.success());
    let text = fs::read_to_string(&out).unwrap();
    let dog: serde_json::Value = text
        .lines()
        .map(|l| serde_json::from_str::<serde_json::Value>(l).unwrap())
        .find(|v| v["id"] == "noto/dog-face.svg")
        .unwrap();
    assert!(dog["tags"].as_array().unwrap().iter().any(|t| t == "puppy"));
}

#[test]
fn bad_items_are_reported_and_the_rest_still_processed() {
    let dir = tempfile::tempdir().unwrap();
    let lib = dir.path().join("library");
    fs::create_dir(&lib).unwrap();
    for name in ["sun.svg", "snail.svg"] {
        fs::copy(fixture("style/noto").join(name), lib.join(name)).unwrap();
    }
    let svg = |body: &str, view_box: &str| {
        format!(r#"<svg xmlns="http://www.w3.org/2000/svg" viewBox="{view_box}">{body}</svg>"#)
    };
    fs::write(
        lib.join("malformed.svg"),
        "<svg xmlns='http://www.w3.org/2000/svg'><rect",
    )
    .unwrap();
    fs::write(
        lib.join("zero-viewbox.svg"),
        svg("<rect width='1' height='1'/>", "0 0 0 0"),
    )
    .unwrap();
    fs::write(
        lib.join("huge-viewbox.svg"),
        svg("<rect width='1e12' height='1e12'/>", "0 0 1e12 1e12"),
    )
    .unwrap();
    fs::write(
        lib.join("external.svg"),
        svg(
            "<image href='secret.png' width='5' height='5'/>",
            "0 0 10 10",
        ),
    )
    .unwrap();
    fs::write(
        lib.join("nested.svg"),
        svg(&("<g>".repeat(5000) + &"</g>".repeat(5000)), "0 0 10 10"),
    )
    .unwrap();
    fs::write(lib.join("blank.svg"), svg("", "0 0 10 10")).unwrap();
    fs::write(lib.join("big.svg"), vec![b' '; 21 * 1024 * 1024]).unwrap();
    fs::write(lib.join("corrupt.png"), b"\x89PNG\r\n\x1a\nnot really").unwrap();
    image::GrayImage::new(7100, 7100)
        .save(lib.join("huge.png"))
        .unwrap();

    let out = dir.path().join("f.csv");
    let run = learner(&[
        os("features"),
        lib.as_os_str(),
        os("--out"),
        out.as_os_str(),
        os("--quiet"),
    ]);
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{stderr}");
    let (_, rows) = read_csv(&out);
    let ids: Vec<&str> = rows.iter().map(|r| r[0].as_str()).collect();
    assert_eq!(ids, ["snail.svg", "sun.svg"]);
    assert!(stderr.contains("9 item(s) failed"), "{stderr}");
    for (file, reason) in [
        ("malformed.svg", "invalid SVG"),
        ("zero-viewbox.svg", "unusable size"),
        ("huge-viewbox.svg", "unusable size"),
        ("external.svg", "external file 'secret.png'"),
        ("nested.svg", "nested 5001 deep"),
        ("blank.svg", "blank"),
        ("big.svg", "over the limit of 20971520 bytes"),
        ("corrupt.png", "cannot decode image"),
        ("huge.png", "50.4 megapixels, over the limit of 50"),
    ] {
        let line = stderr
            .lines()
            .find(|l| l.contains(file))
            .unwrap_or_else(|| panic!("{file} not reported: {stderr}"));
        assert!(
            line.contains(reason),
            "{file}: expected '{reason}' in '{line}'"
        );
    }
    let strict = learner(&[
        os("features"),
        lib.as_os_str(),
        os("--out"),
        out.as_os_str(),
        os("--quiet"),
        os("--strict"),
    ]);
    assert_eq!(strict.status.code(), Some(1));
}

#[test]
fn no_usable_input_is_a_clear_error_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("f.csv");
    let run = learner(&[
        os("features"),
        dir.path().as_os_str(),
        os("--out"),
        out.as_os_str(),
    ]);
    assert_eq!(run.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&run.stderr).contains("no SVG, PNG, JPEG or Iconify items"));
    assert!(!out.exists());
}

#[test]
fn render_shows_the_canvas_and_the_mask_overlay() {
    let dir = tempfile::tempdir().unwrap();
    let (plain, masked) = (dir.path().join("plain.png"), dir.path().join("mask.png"));
    let svg = fixture("style/twemoji/bicycle.svg");
    assert!(
        learner(&[
            os("render"),
            svg.as_os_str(),
            os("--out"),
            plain.as_os_str()
        ])
        .status
        .success()
    );
    assert!(
        learner(&[
            os("render"),
            svg.as_os_str(),
            os("--mask"),
            os("--out"),
            masked.as_os_str()
        ])
        .status
        .success()
    );
    let (a, b) = (
        image::open(&plain).unwrap().to_rgb8(),
        image::open(&masked).unwrap().to_rgb8(),
    );
    assert_eq!(a.dimensions(), (400, 400));
    assert_eq!(b.dimensions(), (400, 400));
    // Far corner: outside Ω, white paper dimmed in the overlay.
    assert_eq!(a.get_pixel(0, 0).0, [255; 3]);
    assert_eq!(b.get_pixel(0, 0).0, [153; 3]);
    let set = fixture("iconify/noto-subset/icons.json");
    let icon = dir.path().join("sun.png");
    let run = learner(&[
        os("render"),
        set.as_os_str(),
        os("--icon"),
        os("sun"),
        os("--out"),
        icon.as_os_str(),
    ]);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let missing = learner(&[
        os("render"),
        set.as_os_str(),
        os("--icon"),
        os("moon"),
        os("--out"),
        icon.as_os_str(),
    ]);
    assert!(String::from_utf8_lossy(&missing.stderr).contains("no icon 'moon'"));
}

/// A reader that goes away (`learner triplets … | head -0`) ends the command quietly: no panic,
/// no error message, and the output file is still complete.
#[test]
fn closed_stdout_is_not_a_panic() {
    let dir = tempfile::tempdir().expect("temp dir");
    let out = dir.path().join("t.csv");
    let mut child = std::process::Command::new(e2e::binary("learner", "learner"))
        .args([
            os("triplets"),
            os("--labels"),
            fixture("style/labels.csv").as_os_str(),
            os("--n"),
            os("200"),
            os("--seed"),
            os("3"),
            os("--out"),
            out.as_os_str(),
        ])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("spawn learner");
    // Close the read end before the command writes its summary line.
    drop(child.stdout.take());
    let output = child.wait_with_output().expect("wait");
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert!(
        output.status.success(),
        "status {:?}: {stderr}",
        output.status
    );
    let rows = fs::read_to_string(&out)
        .expect("triplets written")
        .lines()
        .count();
    assert_eq!(rows, 201, "header and 200 triplets");
}

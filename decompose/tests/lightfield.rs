//! `decompose lightfield` and `decompose eval-lightfield` end to end on the committed tiny
//! rendered light field (`fixtures/lightfield/tiny`: 5×5 views of 48×48, exact ground truth).

use std::path::{Path, PathBuf};

use decompose::io::{LoadOptions, load_rgb};

mod common;
use common::{decompose, os};

fn tiny() -> PathBuf {
    common::fixture("lightfield/tiny")
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        if e.path().is_file() {
            std::fs::copy(e.path(), to.join(e.file_name())).unwrap();
        }
    }
}

#[test]
fn lightfield_writes_every_view_under_its_input_name() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let o = decompose(&[
        os("lightfield"),
        tiny().as_os_str(),
        os("--out"),
        out.as_os_str(),
        os("--linear-output"),
        os("--quiet"),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for sub in ["reflectance", "shading"] {
        let names: Vec<String> = std::fs::read_dir(out.join(sub))
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        assert_eq!(names.len(), 50, "{sub}: 25 PNG + 25 TIFF");
        assert!(out.join(sub).join("input_Cam024.png").is_file());
    }
    for f in [
        "reflectance_sheet.png",
        "shading_sheet.png",
        "views.gif",
        "disparity.pfm",
    ] {
        assert!(out.join(f).is_file(), "{f}");
    }
    let stats: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("stats.json")).unwrap()).unwrap();
    assert_eq!(stats["grid"], serde_json::json!([5, 5]));
    assert_eq!(stats["disparity"], "the folder's gt_disp_lowres.pfm");
    assert_eq!(stats["run"]["views"].as_array().unwrap().len(), 25);
    // The fixture's disparity is precise enough for the crease cue, which is on by default.
    assert_eq!(stats["run"]["crease_cue"], true);
    // The float TIFFs multiply back to the (sRGB-decoded) input, view by view.
    let lin = LoadOptions {
        linear: true,
        ..Default::default()
    };
    for cam in ["input_Cam000", "input_Cam012", "input_Cam024"] {
        let input = load_rgb(tiny().join(format!("{cam}.png")), LoadOptions::default()).unwrap();
        let r = load_rgb(out.join(format!("reflectance/{cam}.tiff")), lin).unwrap();
        let s = load_rgb(out.join(format!("shading/{cam}.tiff")), lin).unwrap();
        for i in 0..input.len() {
            for c in 0..3 {
                let (a, b) = (r.px(i)[c] * s.px(i)[0], input.px(i)[c]);
                assert!(
                    (a - b).abs() <= 1e-4 + 1e-4 * b,
                    "{cam} pixel {i}: {a} vs {b}"
                );
            }
        }
    }
    // A second run into the same folder is refused without --force and replaces it with it.
    let again = decompose(&[
        os("lightfield"),
        tiny().as_os_str(),
        os("--out"),
        out.as_os_str(),
        os("-q"),
    ]);
    assert!(!again.status.success());
    assert!(String::from_utf8_lossy(&again.stderr).contains("--force"));
    let forced = decompose(&[
        os("lightfield"),
        tiny().as_os_str(),
        os("--out"),
        out.as_os_str(),
        os("-q"),
        os("--force"),
        os("--no-occlusion-cue"),
    ]);
    assert!(
        forced.status.success(),
        "{}",
        String::from_utf8_lossy(&forced.stderr)
    );
    assert!(!out.join("reflectance/input_Cam000.tiff").exists());
    let forced_stats: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("stats.json")).unwrap()).unwrap();
    // The crease cue's step keeps its default, but without the occlusion cue it is not used.
    assert!(
        forced_stats["params"]
            .as_str()
            .unwrap()
            .contains("crease_step: Some(0.01)")
    );
    assert_eq!(forced_stats["run"]["crease_cue"], false);
    // The per-ray data term by default: γ = 2, κ_c = 0.1, μ = 3e-2; crease pairs weighted 0.01,
    // their shading step bounded by 1.1.
    for needle in [
        "gamma: 2.0",
        "centre_weight: 0.1",
        "mu: 0.03",
        "crease_weight: 0.01",
        "crease_shading_step: Some(1.1)",
        "unlit_from_centre: true",
    ] {
        assert!(
            forced_stats["params"].as_str().unwrap().contains(needle),
            "{needle}"
        );
    }
    // The options that are off by default reach the method and say so in stats.json.
    let options = dir.path().join("options");
    let o = decompose(&[
        os("lightfield"),
        tiny().as_os_str(),
        os("--out"),
        options.as_os_str(),
        os("-q"),
        os("--shear"),
        os("--retinex-prior"),
        os("--white-black-cue"),
        os("--no-unlit-fill"),
        os("--unlit-own-fill"),
        os("--no-crease-cue"),
        os("--dark-surfaces"),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let stats: serde_json::Value =
        serde_json::from_slice(&std::fs::read(options.join("stats.json")).unwrap()).unwrap();
    let params = stats["params"].as_str().unwrap();
    for needle in [
        "shear: true",
        "level_prior: CentreRetinex",
        "white_black_cue: true",
        "unlit_as_missing: false",
        "unlit_from_centre: false",
        "crease_step: None",
        "gamma: 2.0",
        "centre_weight: 0.1",
        "mu: 0.03",
    ] {
        assert!(params.contains(needle), "{needle} not in {params}");
    }
    assert_eq!(stats["run"]["unlit_ray_fraction"], 0.0);
    assert!(options.join("reflectance/input_Cam012.png").is_file());
    // The thesis' data term as an ablation (at the thesis' μ); it and the old dark-surface flag
    // (now the default, still accepted) exclude each other.
    let thesis = dir.path().join("thesis");
    let input = tiny();
    let run = |extra: &[&str]| {
        let mut args = vec![
            os("lightfield"),
            input.as_os_str(),
            os("--out"),
            thesis.as_os_str(),
            os("-q"),
            os("--force"),
        ];
        args.extend(extra.iter().map(|a| os(a)));
        decompose(&args)
    };
    let o = run(&["--thesis-data-term"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let stats: serde_json::Value =
        serde_json::from_slice(&std::fs::read(thesis.join("stats.json")).unwrap()).unwrap();
    for needle in ["gamma: 0.0", "centre_weight: 0.0", "mu: 0.01"] {
        assert!(
            stats["params"].as_str().unwrap().contains(needle),
            "{needle}"
        );
    }
    let o = run(&["--thesis-data-term", "--dark-surfaces"]);
    assert!(!o.status.success());
    assert!(
        String::from_utf8_lossy(&o.stderr).contains("cannot be used with"),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    // Without a disparity file: nothing is estimated, the occlusion cue is off and the data
    // term is the thesis' one; with an option that needs one, it is estimated, and the same
    // holds.
    let bare = dir.path().join("bare");
    copy_dir(&tiny(), &bare);
    std::fs::remove_file(bare.join("gt_disp_lowres.pfm")).unwrap();
    for (extra, source, estimated) in [
        (
            None,
            "none (without a disparity file the occlusion cue is off)",
            false,
        ),
        (
            Some("--shear"),
            "estimated from the epipolar-plane images",
            true,
        ),
    ] {
        let out = dir.path().join(format!("bare-out-{estimated}"));
        let mut args = vec![
            os("lightfield"),
            bare.as_os_str(),
            os("--out"),
            out.as_os_str(),
            os("-q"),
        ];
        args.extend(extra.map(os));
        let o = decompose(&args);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let stats: serde_json::Value =
            serde_json::from_slice(&std::fs::read(out.join("stats.json")).unwrap()).unwrap();
        assert_eq!(stats["disparity"], source);
        assert_eq!(stats["run"]["occlusion_cue"], false);
        let params = stats["params"].as_str().unwrap();
        for needle in ["occlusion_cue: false", "gamma: 0.0", "centre_weight: 0.0"] {
            assert!(params.contains(needle), "{needle} not in {params}");
        }
        assert_eq!(out.join("disparity.pfm").is_file(), estimated);
    }
}

/// Runs on a broken copy of the fixture; the error must name `needle` and leave no output.
fn fails_naming(break_it: impl Fn(&Path), extra: &[&str], needle: &str) {
    let dir = tempfile::tempdir().unwrap();
    let lf = dir.path().join("lf");
    copy_dir(&tiny(), &lf);
    break_it(&lf);
    let out = dir.path().join("out");
    let mut args = vec![
        os("lightfield"),
        lf.as_os_str(),
        os("--out"),
        out.as_os_str(),
        os("-q"),
    ];
    args.extend(extra.iter().map(|s| os(s)));
    let o = decompose(&args);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success(), "should fail for {needle}");
    assert!(err.contains(needle), "{needle:?} not in {err:?}");
    assert!(!err.contains("panicked"), "{err}");
    let left: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(left, ["lf"], "no output or partial folder may remain");
}

#[test]
fn bad_light_fields_fail_naming_the_file_and_leave_nothing_behind() {
    fails_naming(
        |lf| std::fs::remove_file(lf.join("input_Cam007.png")).unwrap(),
        &[],
        "input_Cam007.png",
    );
    fails_naming(
        |lf| {
            let small = image::RgbImage::new(40, 48);
            small.save(lf.join("input_Cam003.png")).unwrap();
        },
        &[],
        "input_Cam003.png",
    );
    fails_naming(
        |lf| std::fs::write(lf.join("parameters.cfg"), "[extrinsics]\nnum_cams_x = 5\n").unwrap(),
        &[],
        "parameters.cfg",
    );
    fails_naming(
        |lf| std::fs::write(lf.join("gt_disp_lowres.pfm"), b"Pf\n48 48\n-1\n").unwrap(),
        &[],
        "gt_disp_lowres.pfm",
    );
    fails_naming(
        |lf| {
            for e in std::fs::read_dir(lf).unwrap() {
                let path = e.unwrap().path();
                if path.extension().is_some_and(|x| x == "png") {
                    let (w, h) = image::image_dimensions(&path).unwrap();
                    image::RgbImage::new(w, h).save(&path).unwrap();
                }
            }
        },
        &[],
        "black in every view",
    );
    fails_naming(|_| {}, &["--grid", "9x"], "--grid");
    fails_naming(|_| {}, &["--grid", "3x3"], "needs 9");
}

#[test]
fn more_coherent_across_views_than_per_view_methods_on_the_rendered_fixture() {
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("scores.json");
    let o = decompose(&[
        os("eval-lightfield"),
        os("--truth"),
        tiny().as_os_str(),
        os("--methods"),
        os("ours,retinex,clustering"),
        os("--json"),
        json.as_os_str(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
    let scene = &v["tiny"];
    let get = |m: &str, k: &str| scene[m]["scores"][k].as_f64().unwrap();
    let ours = (get("ours", "lmse"), get("ours", "incoherence"));
    for baseline in ["per-view retinex", "per-view clustering"] {
        let b = (get(baseline, "lmse"), get(baseline, "incoherence"));
        assert!(
            ours.1 < 0.5 * b.1,
            "incoherence: ours {} vs {baseline} {}",
            ours.1,
            b.1
        );
        assert!(ours.0 <= b.0, "LMSE: ours {} vs {baseline} {}", ours.0, b.0);
    }
    // Without the fixture's disparity file, as for a folder that has none: the method gets the
    // disparity estimated from the EPIs (scoring still uses the truth), and must still win.
    let estimated = dir.path().join("estimated.json");
    let o = decompose(&[
        os("eval-lightfield"),
        os("--truth"),
        tiny().as_os_str(),
        os("--methods"),
        os("ours"),
        os("--estimate-disparity"),
        os("--json"),
        estimated.as_os_str(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let e: serde_json::Value = serde_json::from_slice(&std::fs::read(&estimated).unwrap()).unwrap();
    let est = |k: &str| e["tiny"]["ours"]["scores"][k].as_f64().unwrap();
    let retinex = (
        get("per-view retinex", "lmse"),
        get("per-view retinex", "incoherence"),
    );
    assert!(
        est("incoherence") < 0.5 * retinex.1 && est("lmse") <= retinex.0,
        "estimated disparity: ours {} / {} vs per-view Retinex {retinex:?}",
        est("lmse"),
        est("incoherence")
    );
}

#[test]
fn edits_reach_every_view_and_leave_the_rest_of_the_image_alone() {
    let dir = tempfile::tempdir().unwrap();
    // A region on the centre view: its left half.
    let region = dir.path().join("region.png");
    image::GrayImage::from_fn(48, 48, |x, _| image::Luma([if x < 24 { 255 } else { 0 }]))
        .save(&region)
        .unwrap();
    let out = dir.path().join("recoloured");
    let o = decompose(&[
        os("edit-lightfield"),
        os("recolour"),
        tiny().as_os_str(),
        os("--out"),
        out.as_os_str(),
        os("--region"),
        region.as_os_str(),
        os("--hue"),
        os("120"),
        os("-q"),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(out.join("edited_sheet.png").is_file());
    for cam in ["input_Cam000", "input_Cam012", "input_Cam024"] {
        let before = image::open(tiny().join(format!("{cam}.png")))
            .unwrap()
            .to_rgb8();
        let after = image::open(out.join(format!("{cam}.png")))
            .unwrap()
            .to_rgb8();
        let (mut changed_left, mut changed_right) = (0, 0);
        for (x, y, p) in after.enumerate_pixels() {
            let q = before.get_pixel(x, y);
            let differs = p.0.iter().zip(q.0).any(|(a, b)| a.abs_diff(b) > 2);
            // Disparities are at most a couple of pixels between neighbouring views: stay clear
            // of the region's edge.
            if differs && x < 16 {
                changed_left += 1;
            }
            if differs && x >= 34 {
                changed_right += 1;
            }
        }
        assert!(
            changed_left > 100,
            "{cam}: the region was not recoloured ({changed_left})"
        );
        assert_eq!(changed_right, 0, "{cam}: pixels outside the region changed");
    }
    let relit = dir.path().join("relit");
    let o = decompose(&[
        os("edit-lightfield"),
        os("relight"),
        tiny().as_os_str(),
        os("--out"),
        relit.as_os_str(),
        os("--curve"),
        os("0:0,1:0.5"),
        os("-q"),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let lin = |p: PathBuf| load_rgb(p, LoadOptions::default()).unwrap();
    for cam in ["input_Cam000", "input_Cam024"] {
        let (a, b) = (
            lin(relit.join(format!("{cam}.png"))),
            lin(tiny().join(format!("{cam}.png"))),
        );
        // Halving every view's shading halves the linear image, in every view alike.
        for (x, y) in a.data().iter().zip(b.data()) {
            assert!((x - 0.5 * y).abs() < 0.01, "{cam}: {x} vs half of {y}");
        }
    }
}

use std::path::Path;

use super::*;
use crate::io::{Depth, Encoding, save};

/// A 4×3 view filled with `value` in every channel (linear 16-bit PNG, read back with
/// `linear: true`).
fn write_view(dir: &Path, name: &str, value: f32, w: u32, h: u32) {
    let img = Image::from_vec(w, h, 3, vec![value; (w * h * 3) as usize]).unwrap();
    save(dir.join(name), &img, Encoding::Linear, Depth::Sixteen).unwrap();
}

const LINEAR: LoadOptions = LoadOptions {
    linear: true,
    max_pixels: 1 << 20,
};

const CFG_2X3: &str = "[intrinsics]\nimage_resolution_x_px = 4\nimage_resolution_y_px = 3\n\
    # comment\n[extrinsics]\nnum_cams_x = 3\nnum_cams_y = 2\nbaseline_mm = 90\n\n[meta]\n\
    disp_min = -1.5\ndisp_max = 2\n";

fn hci_folder(dir: &Path) {
    std::fs::write(dir.join("parameters.cfg"), CFG_2X3).unwrap();
    for i in 0..6 {
        write_view(
            dir,
            &format!("input_Cam{i:03}.png"),
            0.1 * (i + 1) as f32,
            4,
            3,
        );
    }
}

fn view_value(f: &LightFieldFolder, row: usize, col: usize) -> f32 {
    f.field.view_data(f.field.view_index(row, col))[0]
}

#[test]
fn hci_folder_is_read_row_major_with_its_parameters_and_disparity() {
    let dir = tempfile::tempdir().unwrap();
    hci_folder(dir.path());
    let disp = Image::from_fn::<1>(4, 3, |x, y| [x as f32 - 0.5 * y as f32]);
    pfm::write(&dir.path().join("gt_disp_lowres.pfm"), &disp).unwrap();
    let f = load_folder(dir.path(), None, LINEAR).unwrap();
    assert_eq!((f.field.rows(), f.field.cols()), (2, 3));
    assert_eq!(f.names[4], "input_Cam004.png");
    // Camera 4 is row 1, column 1; values were written as 0.1·(index+1) in 16 bits.
    assert!((view_value(&f, 1, 1) - 0.5).abs() < 1e-4);
    assert!((view_value(&f, 0, 2) - 0.3).abs() < 1e-4);
    let p = f.parameters.unwrap();
    assert_eq!(p.resolution, Some((4, 3)));
    assert_eq!(p.disparity_range, Some((-1.5, 2.0)));
    assert_eq!(p.values["extrinsics.baseline_mm"], "90");
    assert_eq!(f.disparity.unwrap(), disp);
}

#[test]
fn a_missing_or_odd_sized_view_is_named() {
    let dir = tempfile::tempdir().unwrap();
    hci_folder(dir.path());
    std::fs::remove_file(dir.path().join("input_Cam003.png")).unwrap();
    let e = load_folder(dir.path(), None, LINEAR)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("input_Cam003.png") && e.contains("missing"),
        "{e}"
    );

    write_view(dir.path(), "input_Cam003.png", 0.2, 4, 4);
    let e = load_folder(dir.path(), None, LINEAR)
        .unwrap_err()
        .to_string();
    assert!(e.contains("input_Cam003.png") && e.contains("4x4"), "{e}");

    std::fs::write(dir.path().join("input_Cam003.png"), b"not a png").unwrap();
    let e = load_folder(dir.path(), None, LINEAR)
        .unwrap_err()
        .to_string();
    assert!(e.contains("input_Cam003.png"), "{e}");
}

#[test]
fn malformed_parameters_and_disparity_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    hci_folder(dir.path());
    let cfg = dir.path().join("parameters.cfg");
    for (text, needle) in [
        ("[extrinsics]\nnum_cams_x = 3\n", "num_cams_y"),
        ("[extrinsics\nnum_cams_x = 3\n", "unclosed"),
        (
            "[extrinsics]\nnum_cams_x = three\nnum_cams_y = 2\n",
            "not a number",
        ),
        (
            "[extrinsics]\nnum_cams_x = 0\nnum_cams_y = 2\n",
            "view count",
        ),
        ("[extrinsics]\nnum_cams_x 3\n", "key = value"),
    ] {
        std::fs::write(&cfg, text).unwrap();
        let e = load_folder(dir.path(), None, LINEAR)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("parameters.cfg") && e.contains(needle),
            "{text:?}: {e}"
        );
    }
    std::fs::write(&cfg, CFG_2X3).unwrap();
    let pfm_path = dir.path().join("gt_disp_lowres.pfm");
    std::fs::write(&pfm_path, b"Pf\n4 3\n-1\n\0\0\0\0").unwrap();
    let e = load_folder(dir.path(), None, LINEAR)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("gt_disp_lowres.pfm") && e.contains("data bytes"),
        "{e}"
    );
    pfm::write(&pfm_path, &Image::new(3, 3, 1)).unwrap();
    let e = load_folder(dir.path(), None, LINEAR)
        .unwrap_err()
        .to_string();
    assert!(e.contains("3x3"), "{e}");
}

#[test]
fn pfm_rows_run_bottom_to_top_in_either_byte_order() {
    // 1×2 grey map: file row 0 is the bottom image row.
    let mut le = b"Pf\n1 2\n-1.0\n".to_vec();
    le.extend_from_slice(&1.5f32.to_le_bytes());
    le.extend_from_slice(&(-2.0f32).to_le_bytes());
    let img = pfm::decode(&le, Path::new("x.pfm")).unwrap();
    assert_eq!(img.data(), &[-2.0, 1.5]);
    let mut be = b"Pf\n1 2\n1.0\n".to_vec();
    be.extend_from_slice(&1.5f32.to_be_bytes());
    be.extend_from_slice(&(-2.0f32).to_be_bytes());
    assert_eq!(pfm::decode(&be, Path::new("x.pfm")).unwrap(), img);
    let rgb = Image::from_fn::<3>(3, 2, |x, y| [x as f32, y as f32, -1.0]);
    let back = pfm::decode(&pfm::encode(&rgb).unwrap(), Path::new("y.pfm")).unwrap();
    assert_eq!(back, rgb);
    for bytes in [
        &b"P6\n1 1\n-1\n"[..],
        b"Pf\n0 1\n-1\n",
        b"Pf\n1 1\n0\n",
        b"Pf\n1",
    ] {
        assert!(matches!(
            pfm::decode(bytes, Path::new("z.pfm")),
            Err(Error::Format { .. })
        ));
    }
}

#[test]
fn grid_folders_use_row_col_suffixes_or_natural_order() {
    let dir = tempfile::tempdir().unwrap();
    // 1-based suffixes, listed in an order that differs from the grid's.
    for (r, c) in [(1, 1), (1, 2), (2, 1), (2, 2)] {
        let v = (r * 10 + c) as f32 / 100.0;
        write_view(dir.path(), &format!("lytro_{r:02}_{c:02}.png"), v, 4, 3);
    }
    let f = load_folder(
        dir.path(),
        Some(FolderLayout::Grid { rows: 2, cols: 2 }),
        LINEAR,
    )
    .unwrap();
    assert!((view_value(&f, 1, 0) - 0.21).abs() < 1e-4);
    assert_eq!(f.names[1], "lytro_01_02.png");
    // The folder is not HCI: without a grid the error says what to give.
    let e = load_folder(dir.path(), None, LINEAR)
        .unwrap_err()
        .to_string();
    assert!(e.contains("--grid"), "{e}");
    let e = load_folder(
        dir.path(),
        Some(FolderLayout::Grid { rows: 1, cols: 2 }),
        LINEAR,
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("outside the 1x2 grid"), "{e}");

    let plain = tempfile::tempdir().unwrap();
    for (i, name) in ["v10.png", "v2.png", "v1.png", "v3.png"].iter().enumerate() {
        write_view(plain.path(), name, (i + 1) as f32 / 10.0, 4, 3);
    }
    let f = load_folder(
        plain.path(),
        Some(FolderLayout::Grid { rows: 2, cols: 2 }),
        LINEAR,
    )
    .unwrap();
    assert_eq!(f.names, ["v1.png", "v2.png", "v3.png", "v10.png"]);
    let e = load_folder(
        plain.path(),
        Some(FolderLayout::Grid { rows: 3, cols: 3 }),
        LINEAR,
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("has 4 images") && e.contains("needs 9"), "{e}");
}

#[test]
fn natural_order_compares_digit_runs_as_numbers() {
    let mut names = vec!["f10", "f9", "f010b", "f1", "g", "f10a"];
    names.sort_by(|a, b| natural_cmp(a, b));
    assert_eq!(names, ["f1", "f9", "f10", "f10a", "f010b", "g"]);
}

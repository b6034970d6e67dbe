use std::path::{Path, PathBuf};

use super::complete::{local_decomposition, poisson_blend};
use super::state::{PixelSource, Scratch};
use super::*;
use crate::color::luminance;
use crate::image::{Image, Mask};
use crate::io::save_float_tiff;
use crate::video::frames::FrameOptions;

/// Writes `frames` as float TIFFs (exact linear values) and opens them as a source.
fn source_of(dir: &Path, frames: &[Image]) -> FrameSource {
    for (t, f) in frames.iter().enumerate() {
        save_float_tiff(dir.join(format!("{t:06}.tiff")), f).unwrap();
    }
    FrameSource::open(dir, &FrameOptions::default()).unwrap()
}

/// Albedo palette of the synthetic sequences.
const PALETTE: [[f32; 3]; 4] = [
    [0.8, 0.25, 0.2],
    [0.2, 0.6, 0.3],
    [0.25, 0.3, 0.85],
    [0.85, 0.8, 0.3],
];

/// Blocks of the palette, 8 px wide, in scene coordinates.
fn albedo(x: i32, y: i32) -> [f32; 3] {
    PALETTE[((x.div_euclid(8) + 3 * y.div_euclid(8)).rem_euclid(4)) as usize]
}

/// A smooth light fixed on the screen.
fn shade(x: u32, y: u32, w: u32, h: u32) -> f32 {
    let (u, v) = (x as f32 / w as f32, y as f32 / h as f32);
    0.35 + 0.55 * (1.0 - 0.6 * (u - 0.3).powi(2) - 0.8 * (v - 0.4).powi(2))
}

/// `n` frames of `w`×`h`: the albedo blocks move right by `dx` px per frame under a fixed
/// light; returns (frames, true reflectance).
fn translating(n: usize, w: u32, h: u32, dx: i32) -> (Vec<Image>, Vec<Image>) {
    let refl: Vec<Image> = (0..n)
        .map(|t| Image::from_fn(w, h, |x, y| albedo(x as i32 - dx * t as i32, y as i32)))
        .collect();
    (lit(&refl), refl)
}

/// The frames that the reflectances `refl` give under the fixed light [`shade`].
fn lit(refl: &[Image]) -> Vec<Image> {
    refl.iter()
        .map(|r| {
            let (w, h) = r.dims();
            Image::from_fn(w, h, |x, y| {
                r.rgb((y * w + x) as usize).map(|v| v * shade(x, y, w, h))
            })
        })
        .collect()
}

/// The defaults, with segments of at least 16 pixels instead of 256: the test frames have
/// 500–1300 pixels, where `min = 256` would leave two or three clusters of mixed albedos.
fn params() -> VideoParams {
    let mut p = VideoParams::default();
    p.segment.min_size = 16;
    p
}

fn run(frames: &[Image], params: &VideoParams) -> (Vec<OwnedFrame>, VideoStats, tempfile::TempDir) {
    let dir = tempfile::tempdir().unwrap();
    let src_dir = dir.path().join("frames");
    std::fs::create_dir(&src_dir).unwrap();
    let source = source_of(&src_dir, frames);
    let mut out: Vec<OwnedFrame> = Vec::new();
    let stats = decompose_video(
        &source,
        &Strokes::default(),
        params,
        &dir.path().join("scratch"),
        &mut out,
        &mut |_| {},
    )
    .unwrap();
    (out, stats, dir)
}

fn assert_product(frames: &[Image], out: &[OwnedFrame]) {
    assert_eq!(out.len(), frames.len());
    for (t, (f, o)) in frames.iter().zip(out).enumerate() {
        assert_eq!(o.index, t);
        for i in 0..f.len() {
            let s = o.shading.px(i)[0];
            assert!(s.is_finite() && s > 0.0, "frame {t} pixel {i}: shading {s}");
            for c in 0..3 {
                let (p, v) = (o.reflectance.px(i)[c] * s, f.px(i)[c]);
                assert!(
                    (p - v).abs() <= 1e-5 * v.abs().max(1e-3),
                    "frame {t} pixel {i} channel {c}: R×S = {p}, I = {v}"
                );
            }
        }
    }
}

/// Mean |Δ log luminance| of the reflectance between consecutive frames, after moving frame
/// t + 1 back by the true shift `dx` (pixels whose source leaves the frame are skipped).
fn flicker(refl: &[&Image], dx: i32) -> f64 {
    let (mut sum, mut n) = (0.0, 0usize);
    let lum = |img: &Image, i: usize| f64::from(luminance(img.rgb(i)).max(1e-6)).ln();
    for pair in refl.windows(2) {
        let (w, h) = pair[0].dims();
        for y in 0..h as i32 {
            for x in 0..w as i32 {
                let x1 = x + dx;
                if !(0..w as i32).contains(&x1) {
                    continue;
                }
                let i0 = (y * w as i32 + x) as usize;
                let i1 = (y * w as i32 + x1) as usize;
                sum += (lum(pair[1], i1) - lum(pair[0], i0)).abs();
                n += 1;
            }
        }
    }
    sum / n as f64
}

/// The relative spread `max / min − 1` of `frame`'s shading over the pixels of `region` (a
/// constant-shading stroke makes it small).
fn shading_spread(frame: &OwnedFrame, region: &Mask) -> f32 {
    let (lo, hi) = (0..region.data().len())
        .filter(|&i| region.at(i))
        .map(|i| frame.shading.px(i)[0])
        .fold((f32::MAX, 0.0f32), |(a, b), v| (a.min(v), b.max(v)));
    hi / lo - 1.0
}

fn per_frame_retinex(frames: &[Image]) -> Vec<crate::Decomposition> {
    frames
        .iter()
        .map(|f| {
            crate::retinex::decompose(
                f,
                None,
                &Strokes::default(),
                &RetinexParams::default(),
                &mut |_| {},
            )
            .unwrap()
            .0
        })
        .collect()
}

mod black;
mod equations;
mod fixture;
mod fusion;
mod levels;
mod sequences;

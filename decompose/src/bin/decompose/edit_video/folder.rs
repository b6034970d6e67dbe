//! Reading the output folder of `decompose video` for the video edits:
//!
//! ```text
//! DIR/reflectance/000000.png …   reflectance frames (sRGB unless stats.json says linear)
//! DIR/shading/000000.png …       shading frames (grey; scaled as stats.json says)
//! DIR/labels/000000.png …        16-bit grey PNG: cluster id + 1, 0 = unassigned
//! DIR/stats.json                 optional: output_encoding, shading_scale, first_lit_frame
//! ```
//!
//! The three folders must hold the same frames (same count, same names, same size). From
//! `stats.json`, when present: `"output_encoding": "linear"` reads the PNGs as linear
//! samples, and the shading files are multiplied back by `"shading_scale"` (one number for the
//! whole video, or `frames[i].shading_scale` per frame), so that `R × S` is the input again;
//! `"first_lit_frame"` is the frame the edits are decided on (0 without it).

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};

use decompose::io::LoadOptions;
use decompose::video::frames::{FrameOptions, FrameSource};
use decompose::{Image, Labels};

/// One frame's layers, read from disk.
pub(crate) struct FrameLayers {
    pub(crate) reflectance: Image,
    pub(crate) shading: Image,
    pub(crate) labels: Labels,
}

impl FrameLayers {
    pub(crate) fn frame(&self) -> Result<decompose::video::edit::Frame<'_>> {
        Ok(decompose::video::edit::Frame::new(
            &self.reflectance,
            &self.shading,
            &self.labels,
        )?)
    }
}

/// A `decompose video` output folder, read one frame at a time.
pub(crate) struct VideoFolder {
    reflectance: FrameSource,
    shading: FrameSource,
    labels: FrameSource,
    shading_scale: Vec<f32>,
    first_lit: usize,
}

fn open_sub(dir: &Path, sub: &str, load: LoadOptions) -> Result<FrameSource> {
    let path = dir.join(sub);
    if !path.is_dir() {
        bail!(
            "{} is missing: expected the output folder of `decompose video` (reflectance/, \
             shading/, labels/)",
            path.display()
        );
    }
    FrameSource::open(
        &path,
        &FrameOptions {
            load,
            ..Default::default()
        },
    )
    .with_context(|| format!("reading {}", path.display()))
}

fn stem(p: &Path) -> String {
    p.file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default()
}

impl VideoFolder {
    pub(crate) fn open(dir: &Path) -> Result<Self> {
        if !dir.is_dir() {
            bail!(
                "{} is not a folder (give the output folder of `decompose video`)",
                dir.display()
            );
        }
        let stats_path = dir.join("stats.json");
        let stats: Option<serde_json::Value> = if stats_path.exists() {
            let text = std::fs::read_to_string(&stats_path)
                .with_context(|| format!("reading {}", stats_path.display()))?;
            Some(
                serde_json::from_str(&text)
                    .with_context(|| format!("{} is not valid JSON", stats_path.display()))?,
            )
        } else {
            None
        };
        let linear = stats
            .as_ref()
            .and_then(|s| s["output_encoding"].as_str())
            .is_some_and(|e| e == "linear");
        let load = LoadOptions {
            linear,
            ..Default::default()
        };
        let reflectance = open_sub(dir, "reflectance", load)?;
        let shading = open_sub(dir, "shading", load)?;
        let labels = open_sub(dir, "labels", load)?;
        let n = reflectance.len();
        for (name, src) in [("shading", &shading), ("labels", &labels)] {
            if src.len() != n {
                bail!(
                    "{}: {n} reflectance frames but {} {name} frames",
                    dir.display(),
                    src.len()
                );
            }
            if src.size() != reflectance.size() {
                bail!(
                    "{}: {name} frames are {:?} pixels but reflectance frames are {:?}",
                    dir.display(),
                    src.size(),
                    reflectance.size()
                );
            }
            for i in 0..n {
                if stem(src.path(i)) != stem(reflectance.path(i)) {
                    bail!(
                        "{}: frame {i} is {} in reflectance/ but {} in {name}/",
                        dir.display(),
                        reflectance.path(i).display(),
                        src.path(i).display()
                    );
                }
            }
        }
        let shading_scale = shading_scales(stats.as_ref(), n)
            .with_context(|| format!("reading {}", stats_path.display()))?;
        let first_lit = first_lit_frame(stats.as_ref(), n)
            .with_context(|| format!("reading {}", stats_path.display()))?;
        Ok(Self {
            reflectance,
            shading,
            labels,
            shading_scale,
            first_lit,
        })
    }

    /// The frame the edits are decided on: the first frame with light, where the
    /// decomposition started (frame 0 unless the video opens on black frames).
    pub(crate) fn first_lit(&self) -> usize {
        self.first_lit
    }

    pub(crate) fn len(&self) -> usize {
        self.reflectance.len()
    }

    pub(crate) fn size(&self) -> (u32, u32) {
        self.reflectance.size()
    }

    /// Reflectance and labels of frame `i` (the cluster table needs no shading).
    pub(crate) fn reflectance_and_labels(&self, i: usize) -> Result<(Image, Labels)> {
        let r = self.reflectance.frame(i)?;
        let path = self.labels.path(i);
        let labels = decompose::video::labels_io::load_labels(path).with_context(|| {
            format!(
                "{}: the labels/ files (16-bit cluster ids) are needed; the false-colour \
                 clusters/ images cannot be read back as labels",
                path.display()
            )
        })?;
        Ok((r, labels))
    }

    /// All three layers of frame `i`, the shading in the decomposition's linear scale.
    pub(crate) fn frame(&self, i: usize) -> Result<FrameLayers> {
        let (reflectance, labels) = self.reflectance_and_labels(i)?;
        let rgb = self.shading.frame(i)?;
        let k = self.shading_scale[i];
        let mut shading = Image::new(rgb.width(), rgb.height(), 1);
        for p in 0..rgb.len() {
            let [a, b, c] = rgb.rgb(p);
            shading.px_mut(p)[0] = (a + b + c) / 3.0 * k;
        }
        Ok(FrameLayers {
            reflectance,
            shading,
            labels,
        })
    }
}

/// The shading scale of every frame from stats.json (1 without it).
fn shading_scales(stats: Option<&serde_json::Value>, n: usize) -> Result<Vec<f32>> {
    let check = |v: f64, what: &str| -> Result<f32> {
        if v.is_finite() && v > 0.0 {
            Ok(v as f32)
        } else {
            bail!("{what} = {v} is not a positive number")
        }
    };
    let Some(stats) = stats else {
        return Ok(vec![1.0; n]);
    };
    if let Some(v) = stats["shading_scale"].as_f64() {
        return Ok(vec![check(v, "shading_scale")?; n]);
    }
    if let Some(frames) = stats["frames"].as_array() {
        let per: Vec<Option<f64>> = frames.iter().map(|f| f["shading_scale"].as_f64()).collect();
        if per.iter().any(Option::is_some) {
            if per.len() != n {
                bail!("frames holds {} entries for {n} frames", per.len());
            }
            return per
                .iter()
                .enumerate()
                .map(|(i, v)| match v {
                    Some(v) => check(*v, &format!("frames[{i}].shading_scale")),
                    None => bail!("frames[{i}] has no shading_scale"),
                })
                .collect();
        }
    }
    Ok(vec![1.0; n])
}

/// The path of output frame `i`.
pub(crate) fn frame_name(i: usize) -> PathBuf {
    PathBuf::from(format!("{i:06}.png"))
}

/// `first_lit_frame` from stats.json (0 without it or without stats.json).
fn first_lit_frame(stats: Option<&serde_json::Value>, n: usize) -> Result<usize> {
    let value = stats.map(|s| &s["first_lit_frame"]);
    match value {
        None | Some(serde_json::Value::Null) => Ok(0),
        Some(v) => match v.as_u64() {
            Some(t) if (t as usize) < n => Ok(t as usize),
            _ => bail!("first_lit_frame = {v} is not a frame number below {n}"),
        },
    }
}

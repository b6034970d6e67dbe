//! `parameters.cfg` of the HCI 4D light-field benchmark: an INI file with `[intrinsics]`,
//! `[extrinsics]` and `[meta]` sections of `key = value` lines (`#` or `;` start a comment).

use std::collections::BTreeMap;
use std::path::Path;

use crate::error::{Error, Result};

/// The fields of `parameters.cfg` this crate uses, plus every value as read.
#[derive(Clone, Debug, PartialEq)]
pub struct HciParameters {
    /// `[extrinsics] num_cams_x`: views per row of the grid.
    pub num_cams_x: usize,
    /// `[extrinsics] num_cams_y`: views per column.
    pub num_cams_y: usize,
    /// `[intrinsics] image_resolution_x_px / image_resolution_y_px`, when given.
    pub resolution: Option<(u32, u32)>,
    /// `[meta] disp_min / disp_max` (pixels per view step), when given.
    pub disparity_range: Option<(f64, f64)>,
    /// Every `section.key` with its raw value.
    pub values: BTreeMap<String, String>,
}

impl HciParameters {
    /// Parses the file's text; `path` labels errors.
    pub fn parse(text: &str, path: &Path) -> Result<Self> {
        let bad = |line: usize, message: String| Error::Format {
            path: path.to_path_buf(),
            message: format!("line {line}: {message}"),
        };
        let mut values = BTreeMap::new();
        let mut section = String::new();
        for (i, raw) in text.lines().enumerate() {
            let line = raw.trim();
            if line.is_empty() || line.starts_with('#') || line.starts_with(';') {
                continue;
            }
            if let Some(rest) = line.strip_prefix('[') {
                let name = rest
                    .strip_suffix(']')
                    .ok_or_else(|| bad(i + 1, format!("unclosed section header {line:?}")))?;
                section = name.trim().to_string();
                continue;
            }
            let (key, value) = line
                .split_once('=')
                .ok_or_else(|| bad(i + 1, format!("expected `key = value`, found {line:?}")))?;
            let key = key.trim();
            if key.is_empty() {
                return Err(bad(i + 1, "empty key".into()));
            }
            values.insert(format!("{section}.{key}"), value.trim().to_string());
        }
        let missing = |key: &str| Error::Format {
            path: path.to_path_buf(),
            message: format!("has no {key} (the view grid)"),
        };
        let number = |key: &str| -> Result<Option<f64>> {
            values
                .get(key)
                .map(|v| {
                    v.parse::<f64>()
                        .ok()
                        .filter(|x| x.is_finite())
                        .ok_or_else(|| Error::Format {
                            path: path.to_path_buf(),
                            message: format!("{key} = {v:?} is not a number"),
                        })
                })
                .transpose()
        };
        let count = |key: &str| -> Result<usize> {
            let v = number(key)?.ok_or_else(|| missing(key))?;
            if (1.0..=1000.0).contains(&v) && v.fract() == 0.0 {
                Ok(v as usize)
            } else {
                Err(Error::Format {
                    path: path.to_path_buf(),
                    message: format!("{key} = {v} is not a view count between 1 and 1000"),
                })
            }
        };
        let num_cams_x = count("extrinsics.num_cams_x")?;
        let num_cams_y = count("extrinsics.num_cams_y")?;
        let resolution = match (
            number("intrinsics.image_resolution_x_px")?,
            number("intrinsics.image_resolution_y_px")?,
        ) {
            (Some(w), Some(h)) if w >= 1.0 && h >= 1.0 => Some((w as u32, h as u32)),
            _ => None,
        };
        let disparity_range = match (number("meta.disp_min")?, number("meta.disp_max")?) {
            (Some(a), Some(b)) => Some((a, b)),
            _ => None,
        };
        Ok(Self {
            num_cams_x,
            num_cams_y,
            resolution,
            disparity_range,
            values,
        })
    }
}

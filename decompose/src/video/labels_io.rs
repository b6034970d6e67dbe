//! Cluster labels as lossless 16-bit grey PNG files (`decompose video`'s `labels/000000.png`,
//! read back by the video edits): the sample of a pixel is its cluster id + 1, and 0 marks a
//! pixel without a cluster ([`Labels::NONE`]). Ids up to 65534 fit.

use std::path::Path;

use image::{DynamicImage, ImageBuffer, Luma};

use crate::decomposition::Labels;
use crate::error::{Error, Result};

/// Largest cluster id a label file can hold.
pub const MAX_LABEL: u32 = u16::MAX as u32 - 1;

/// Writes labels as a 16-bit grey PNG (id + 1; 0 = none). Errors: [`Error::InvalidParam`] for
/// an id above [`MAX_LABEL`] or a data length that does not match the size, [`Error::Codec`]
/// when the file cannot be written.
pub fn save_labels(path: impl AsRef<Path>, labels: &Labels) -> Result<()> {
    let path = path.as_ref();
    let mut data = Vec::with_capacity(labels.data.len());
    for &l in &labels.data {
        data.push(if l == Labels::NONE {
            0
        } else if l <= MAX_LABEL {
            (l + 1) as u16
        } else {
            return Err(Error::param(
                "label",
                l,
                "a 16-bit label file holds cluster ids up to 65534",
            ));
        });
    }
    let buf = ImageBuffer::<Luma<u16>, _>::from_raw(labels.width, labels.height, data).ok_or_else(
        || {
            Error::param(
                "labels.data",
                labels.data.len(),
                "does not match width × height",
            )
        },
    )?;
    buf.save_with_format(path, image::ImageFormat::Png)
        .map_err(|e| Error::Codec {
            path: path.to_path_buf(),
            message: e.to_string(),
        })
}

/// Reads a label file written by [`save_labels`]. `count` of the result is the largest id + 1
/// (ids are taken to be `0..count`). Errors: [`Error::Io`]/[`Error::Codec`] for a file that
/// cannot be read, [`Error::Format`] for anything but a 16-bit grey image.
pub fn load_labels(path: impl AsRef<Path>) -> Result<Labels> {
    let path = path.as_ref();
    let img = image::ImageReader::open(path)
        .map_err(|source| Error::Io {
            path: path.to_path_buf(),
            source,
        })?
        .with_guessed_format()
        .map_err(|source| Error::Io {
            path: path.to_path_buf(),
            source,
        })?
        .decode()
        .map_err(|e| Error::Codec {
            path: path.to_path_buf(),
            message: e.to_string(),
        })?;
    let DynamicImage::ImageLuma16(buf) = img else {
        return Err(Error::Format {
            path: path.to_path_buf(),
            message: format!(
                "a label file is a 16-bit grey PNG, this one is {:?}",
                img.color()
            ),
        });
    };
    let (width, height) = buf.dimensions();
    let data: Vec<u32> = buf
        .into_raw()
        .into_iter()
        .map(|v| if v == 0 { Labels::NONE } else { v as u32 - 1 })
        .collect();
    let count = data
        .iter()
        .filter(|&&l| l != Labels::NONE)
        .max()
        .map_or(0, |&m| m as usize + 1);
    Ok(Labels {
        width,
        height,
        data,
        count,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn labels_round_trip_exactly_with_none_and_the_largest_id() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("l.png");
        let data = vec![0, 1, Labels::NONE, 7, MAX_LABEL, 300, 2, Labels::NONE];
        let labels = Labels {
            width: 4,
            height: 2,
            data,
            count: MAX_LABEL as usize + 1,
        };
        save_labels(&p, &labels).unwrap();
        assert_eq!(load_labels(&p).unwrap(), labels);
        // Stored as id + 1 with 0 for none, in 16 bits.
        let raw = image::open(&p).unwrap().into_luma16().into_raw();
        assert_eq!(raw, vec![1, 2, 0, 8, 65535, 301, 3, 0]);
    }

    #[test]
    fn ids_that_do_not_fit_and_other_files_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("l.png");
        let big = Labels {
            width: 1,
            height: 1,
            data: vec![MAX_LABEL + 1],
            count: MAX_LABEL as usize + 2,
        };
        assert!(matches!(
            save_labels(&p, &big),
            Err(Error::InvalidParam { .. })
        ));
        let rgb = dir.path().join("rgb.png");
        image::RgbImage::new(2, 2).save(&rgb).unwrap();
        assert!(matches!(load_labels(&rgb), Err(Error::Format { .. })));
    }
}

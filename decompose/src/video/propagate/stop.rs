//! The stopping condition of §3.5.3 (see the module docs of `propagate`).

use crate::error::{Error, Result};
use crate::image::Mask;

use super::check_alpha_m;

/// The stopping condition of §3.5.3: `true` when more than the fraction `alpha` (`α`, 0.8 in
/// the thesis) of the pixels of some `m×m` window (`M` = 30, 20, 10 over the three passes) are
/// unassigned. `assigned` marks the assigned pixels (e.g. [`super::Propagation::assigned_mask`]).
///
/// Every window position inside the frame is tried; a frame narrower or shorter than `m` uses
/// its full width or height. Counts come from an integral image, so the cost is O(pixels).
///
/// Errors with [`Error::EmptyImage`] for a frame without pixels and [`Error::InvalidParam`]
/// when `m` is 0 or `alpha` is outside [0, 1].
pub fn should_stop(assigned: &Mask, m: u32, alpha: f64) -> Result<bool> {
    check_alpha_m(alpha, m)?;
    let (w, h) = assigned.dims();
    if w == 0 || h == 0 {
        return Err(Error::EmptyImage {
            width: w,
            height: h,
        });
    }
    let (w, h) = (w as usize, h as usize);
    let (mw, mh) = ((m as usize).min(w), (m as usize).min(h));
    // sat[(y)(w+1) + x]: unassigned pixels in rows < y and columns < x.
    let stride = w + 1;
    let mut sat = vec![0u32; stride * (h + 1)];
    let data = assigned.data();
    for y in 0..h {
        let mut row = 0u32;
        for x in 0..w {
            row += u32::from(!data[y * w + x]);
            sat[(y + 1) * stride + x + 1] = sat[y * stride + x + 1] + row;
        }
    }
    let limit = alpha * (mw * mh) as f64;
    for y in 0..=h - mh {
        for x in 0..=w - mw {
            let count = sat[(y + mh) * stride + x + mw] + sat[y * stride + x]
                - sat[y * stride + x + mw]
                - sat[(y + mh) * stride + x];
            if count as f64 > limit {
                return Ok(true);
            }
        }
    }
    Ok(false)
}

//! A synthetic light field with exact ground truth for tests and benchmarks: a Lambertian
//! background plane at disparity 0 (the focus plane) and a square card floating in front of it
//! at disparity +1, each textured with a [`crate::synthetic::scene`]. Integer disparities make
//! every view an exact shift of the centre view's layers, so `input = reflectance × shading`
//! holds exactly in every view and the card occludes the background differently per view.

use super::LightField;
use super::disparity::corresponding;
use super::eval::LightFieldTruth;
use crate::synthetic::scene;

/// `(input, truth)` of a `rows × cols` light field of `width × height` views.
pub fn card_in_front_of_a_wall(
    rows: usize,
    cols: usize,
    width: u32,
    height: u32,
    seed: u64,
) -> (LightField, LightFieldTruth) {
    let wall = scene(width, height, seed);
    let card = scene(width, height, seed.wrapping_add(1));
    let centre = (rows / 2, cols / 2);
    // The card covers the middle half of the centre view.
    let (x0, x1) = (width as f32 * 0.25, width as f32 * 0.75);
    let (y0, y1) = (height as f32 * 0.25, height as f32 * 0.75);
    let card_disparity = 1.0;
    let mut input = LightField::new(rows, cols, width, height, 3);
    let mut reflectance = input.clone();
    let mut shading = LightField::new(rows, cols, width, height, 1);
    let mut disparity = shading.clone();
    for r in 0..rows {
        for c in 0..cols {
            let v = input.view_index(r, c);
            for y in 0..height {
                for x in 0..width {
                    let (cx, cy) =
                        corresponding(x as f32, y as f32, card_disparity, (r, c), centre);
                    let on_card = cx >= x0 && cx < x1 && cy >= y0 && cy < y1;
                    let (layer, sx, sy, d) = if on_card {
                        (&card, cx as u32, cy as u32, card_disparity)
                    } else {
                        (&wall, x, y, 0.0)
                    };
                    let p = (y * width + x) as usize;
                    let q = (sy * width + sx) as usize;
                    input.view_data_mut(v)[3 * p..3 * p + 3].copy_from_slice(layer.input.px(q));
                    reflectance.view_data_mut(v)[3 * p..3 * p + 3]
                        .copy_from_slice(layer.reflectance.px(q));
                    shading.view_data_mut(v)[p] = layer.shading.px(q)[0];
                    disparity.view_data_mut(v)[p] = d;
                }
            }
        }
    }
    (
        input,
        LightFieldTruth {
            reflectance,
            shading,
            disparity,
            mask: None,
        },
    )
}

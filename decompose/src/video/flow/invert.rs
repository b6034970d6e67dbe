//! The backward flow from a forward one, for when only `t → t + 1` was computed.

use rayon::prelude::*;

use super::Flow;
use super::plane::bilinear;

/// The flow from `next` back to `prev`, given the flow `forward` from `prev` to `next`
/// (`next(x + u, y + v) ≈ prev(x, y)`), by the fixed point `b(y) = −f(y + b(y))`: a point `y`
/// of `next` came from `y + b(y)` in `prev`, which the forward flow moved by `f(y + b(y))`. Starts
/// from `b = −f` and takes `iterations` steps, sampling `f` bilinearly (borders replicated).
/// Exact for a constant flow after one step; for a smooth flow each step shrinks the error by
/// about the flow's gradient. Where the forward flow folds (occlusions) the point is not
/// unique and the result is one of its preimages, or none (a value that is not one); callers
/// check the backward warp photometrically.
pub fn invert(forward: &Flow, iterations: usize) -> Flow {
    let (w, h) = (forward.width as usize, forward.height as usize);
    let mut u: Vec<f32> = forward.u.iter().map(|v| -v).collect();
    let mut v: Vec<f32> = forward.v.iter().map(|v| -v).collect();
    if w == 0 || h == 0 {
        return Flow::zeros(forward.width, forward.height);
    }
    for _ in 0..iterations {
        let (nu, nv): (Vec<f32>, Vec<f32>) = (0..w * h)
            .into_par_iter()
            .map(|i| {
                let (x, y) = ((i % w) as f32 + u[i], (i / w) as f32 + v[i]);
                let (mut fu, mut fv) = ([0.0f32], [0.0f32]);
                bilinear(&forward.u, w, h, 1, x, y, &mut fu);
                bilinear(&forward.v, w, h, 1, x, y, &mut fv);
                (-fu[0], -fv[0])
            })
            .unzip();
        u = nu;
        v = nv;
    }
    Flow {
        width: forward.width,
        height: forward.height,
        u,
        v,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The largest distance between `x` and where `forward` then `backward` take it, over the
    /// pixels at least `border` pixels inside.
    fn round_trip_error(forward: &Flow, backward: &Flow, border: u32) -> f32 {
        let (w, h) = forward.dims();
        let mut worst = 0.0f32;
        for y in border..h - border {
            for x in border..w - border {
                let [fu, fv] = forward.get(x, y);
                let (nx, ny) = (x as f32 + fu, y as f32 + fv);
                let (mut bu, mut bv) = ([0.0f32], [0.0f32]);
                bilinear(&backward.u, w as usize, h as usize, 1, nx, ny, &mut bu);
                bilinear(&backward.v, w as usize, h as usize, 1, nx, ny, &mut bv);
                let (ex, ey) = (nx + bu[0] - x as f32, ny + bv[0] - y as f32);
                worst = worst.max((ex * ex + ey * ey).sqrt());
            }
        }
        worst
    }

    #[test]
    fn a_translation_inverts_exactly() {
        let f = Flow::from_fn(40, 30, |_, _| [2.5, -1.25]);
        let b = invert(&f, 1);
        assert!(b.u().iter().all(|&u| (u + 2.5).abs() < 1e-6));
        assert!(b.v().iter().all(|&v| (v - 1.25).abs() < 1e-6));
    }

    #[test]
    fn a_rotation_and_a_zoom_invert_to_their_inverse() {
        // 3° about the centre and 4% zoom: forward then backward must come back to the start,
        // which `−f` alone does not.
        let (w, h) = (80u32, 60u32);
        let (cx, cy) = (40.0f32, 30.0f32);
        let (a, z) = (3f32.to_radians(), 1.04f32);
        let f = Flow::from_fn(w, h, |x, y| {
            let (dx, dy) = (x as f32 - cx, y as f32 - cy);
            let (rx, ry) = (
                z * (a.cos() * dx - a.sin() * dy),
                z * (a.sin() * dx + a.cos() * dy),
            );
            [rx - dx, ry - dy]
        });
        let naive = invert(&f, 0);
        let b = invert(&f, 5);
        let (e0, e5) = (round_trip_error(&f, &naive, 8), round_trip_error(&f, &b, 8));
        assert!(e0 > 0.1, "the naive inverse should be off: {e0}");
        assert!(e5 < 0.01, "round trip after 5 steps: {e5} px");
    }
}

//! Completion of a stopping frame (§3.6): the constrained local decomposition (eq. 3.8), the
//! Poisson blend of its result into the frame with a Dirichlet boundary (eq. 3.9), and the
//! clustering update (eq. 3.10). The readings of the issue are in the module docs of `method`.

use crate::decomposition::{Labels, SHADING_FLOOR};
use crate::error::Result;
use crate::grid::Grid;
use crate::image::{Image, Mask};
use crate::retinex::RetinexParams;
use crate::solver::{LinearSystem, SolverParams};
use crate::video::propagate::{ClusterTables, colour8};
use crate::video::segment::felzenszwalb;

use super::VideoParams;
use super::state::{FrameState, PixelSource};

/// Eq. 3.8: the log shading `s` over `region` that minimises the local Retinex energy of
/// eq. 3.12 (`λ_l`, `ω`, `T` of `retinex`) plus `λ_c Σ (s_p − ŝ_p)²` over the region's pixels
/// with a known log shading `ŝ_p` (`known[p]` finite). A connected piece of the region with no
/// known pixel is anchored at its brightest pixel as white (`r = 0`, weight `λ_a`), the gauge
/// of the first frame. Returns `s` per pixel of the frame, NaN outside the region.
pub(crate) fn local_decomposition(
    input: &Image,
    region: &Mask,
    known: &[f64],
    retinex: &RetinexParams,
    lambda_c: f64,
) -> Result<Vec<f64>> {
    let g = Grid::new(input, region);
    let n = g.pixel.len();
    let mut out = vec![f64::NAN; g.w * g.h];
    if n == 0 {
        return Ok(out);
    }
    let u = |p: usize| g.index[p] as usize;
    let mut sys = LinearSystem::new(n);
    for (p, q) in g.pairs() {
        let (a, b) = (u(p), u(q));
        sys.add(&[(a, 1.0), (b, -1.0)], 0.0, retinex.lambda_l);
        if g.chroma_dist2(p, q) < retinex.t {
            // r_p = r_q ⇔ s_p − s_q = i_p − i_q (eq. 3.12's reflectance term).
            sys.add(
                &[(a, 1.0), (b, -1.0)],
                g.log_y[p] - g.log_y[q],
                retinex.lambda_l * retinex.omega,
            );
        }
    }
    let mut anchored = vec![false; n];
    for &p in &g.pixel {
        if known[p].is_finite() {
            sys.add(&[(u(p), 1.0)], known[p], lambda_c);
            anchored[u(p)] = true;
        }
    }
    anchor_free_components(
        &mut sys,
        &mut anchored,
        |k| {
            let p = g.pixel[k];
            (g.y[p], g.log_y[p])
        },
        retinex.lambda_a,
    );
    let (x, _) = sys.solve(&retinex.solver)?;
    for (k, &p) in g.pixel.iter().enumerate() {
        out[p] = x[k];
    }
    Ok(out)
}

/// Adds, to every group of unknowns (linked by equations) without an anchored unknown, the
/// equation `x = value` at the unknown with the largest `key` (`key_value(k) = (key, value)`).
fn anchor_free_components(
    sys: &mut LinearSystem,
    anchored: &mut [bool],
    key_value: impl Fn(usize) -> (f64, f64),
    weight: f64,
) {
    let comps = sys.components();
    let n = anchored.len();
    let mut has = vec![false; n];
    let mut best: Vec<Option<usize>> = vec![None; n];
    for (k, &c) in comps.iter().enumerate() {
        has[c] |= anchored[k];
        if best[c].is_none_or(|b| key_value(k).0 > key_value(b).0) {
            best[c] = Some(k);
        }
    }
    for c in 0..n {
        if let (false, Some(k)) = (has[c], best[c]) {
            sys.add(&[(k, 1.0)], key_value(k).1, weight);
            anchored[k] = true;
        }
    }
}

/// Eq. 3.9: Poisson blending. On the `hole` pixels, the field `s` whose 4-neighbour
/// differences are closest in least squares to those of `guidance`, with `s = boundary` held
/// exactly on every pixel outside the hole (the Dirichlet condition; those values are not
/// unknowns). `guidance` must be finite on the hole and its 4-neighbours. A neighbour outside
/// the hole whose `boundary` is not finite (a pixel that is not assigned yet) gives no
/// equation: the hole's edge there is free (Neumann). A connected piece of
/// the hole that touches no boundary pixel keeps `guidance` up to nothing (its constant is
/// fixed at one pixel). Returns the whole frame: `boundary` outside the hole, bit for bit.
pub(crate) fn poisson_blend(
    w: usize,
    h: usize,
    hole: &[bool],
    guidance: &[f64],
    boundary: &[f64],
    solver: &SolverParams,
) -> Result<Vec<f64>> {
    let mut index = vec![u32::MAX; w * h];
    let mut pixel = Vec::new();
    for (p, &inside) in hole.iter().enumerate() {
        if inside {
            index[p] = pixel.len() as u32;
            pixel.push(p);
        }
    }
    let mut out = boundary.to_vec();
    if pixel.is_empty() {
        return Ok(out);
    }
    let mut sys = LinearSystem::new(pixel.len());
    let mut anchored = vec![false; pixel.len()];
    for p in 0..w * h {
        let right = (p % w + 1 < w).then_some(p + 1);
        let down = (p + w < w * h).then_some(p + w);
        for q in [right, down].into_iter().flatten() {
            let g = guidance[p] - guidance[q];
            match (hole[p], hole[q]) {
                (true, true) => {
                    sys.add(
                        &[(index[p] as usize, 1.0), (index[q] as usize, -1.0)],
                        g,
                        1.0,
                    );
                }
                (true, false) if boundary[q].is_finite() => {
                    sys.add(&[(index[p] as usize, 1.0)], g + boundary[q], 1.0);
                    anchored[index[p] as usize] = true;
                }
                (false, true) if boundary[p].is_finite() => {
                    sys.add(&[(index[q] as usize, 1.0)], boundary[p] - g, 1.0);
                    anchored[index[q] as usize] = true;
                }
                _ => {}
            }
        }
    }
    anchor_free_components(&mut sys, &mut anchored, |k| (0.0, guidance[pixel[k]]), 1.0);
    let (x, _) = sys.solve(solver)?;
    for (k, &p) in pixel.iter().enumerate() {
        out[p] = x[k];
    }
    Ok(out)
}

/// `true` within Chebyshev distance `r` of a `true` pixel (separable running maximum).
pub(crate) fn dilate(w: usize, h: usize, m: &[bool], r: usize) -> Vec<bool> {
    let mut rows = vec![false; w * h];
    for y in 0..h {
        for x in 0..w {
            let (a, b) = (x.saturating_sub(r), (x + r).min(w - 1));
            rows[y * w + x] = m[y * w + a..=y * w + b].iter().any(|&v| v);
        }
    }
    let mut out = vec![false; w * h];
    for y in 0..h {
        let (a, b) = (y.saturating_sub(r), (y + r).min(h - 1));
        for x in 0..w {
            out[y * w + x] = (a..=b).any(|yy| rows[yy * w + x]);
        }
    }
    out
}

/// Completes the unassigned pixels marked in `hole` (§3.6) and updates the cluster tables;
/// returns the number of pixels completed. Other unassigned pixels are left as they are.
pub(crate) fn complete_frame(
    input: &Image,
    state: &mut FrameState,
    hole: &[bool],
    tables: &mut ClusterTables,
    params: &VideoParams,
) -> Result<usize> {
    let (w, h) = (state.width as usize, state.height as usize);
    let hole: Vec<bool> = (0..w * h)
        .map(|p| hole[p] && state.source[p] == PixelSource::Unassigned)
        .collect();
    let count = hole.iter().filter(|&&v| v).count();
    if count == 0 {
        return Ok(0);
    }
    let region = dilate(w, h, &hole, params.completion_margin as usize);
    let region = Mask::from_vec(state.width, state.height, region)?;
    let known: Vec<f64> = (0..w * h)
        .map(|p| {
            if state.source[p] == PixelSource::Unassigned {
                f64::NAN
            } else {
                f64::from(state.shading[p]).ln()
            }
        })
        .collect();
    let local = local_decomposition(input, &region, &known, &params.retinex, params.lambda_c)?;
    let blended = poisson_blend(w, h, &hole, &local, &known, &params.retinex.solver)?;
    let floor = (input.max() * SHADING_FLOOR).max(f32::MIN_POSITIVE);
    for p in 0..w * h {
        if hole[p] {
            let s = blended[p].clamp(-80.0, 80.0).exp() as f32;
            state.shading[p] = if s.is_finite() { s.max(floor) } else { floor };
            state.source[p] = PixelSource::Completion;
        }
    }
    update_clusters(input, state, &hole, tables, params)?;
    Ok(count)
}

/// Eq. 3.10, the clustering update: the completed pixels' reflectance is segmented
/// (Felzenszwalb–Huttenlocher over the hole's bounding box); each segment's completed pixels
/// join an adjacent existing cluster ([`join_cluster`]) or become a new cluster. Then their
/// colours and reflectances enter the tables `𝓡_k`, `𝓘_k` ([`ClusterTables::update`]).
fn update_clusters(
    input: &Image,
    state: &mut FrameState,
    hole: &[bool],
    tables: &mut ClusterTables,
    params: &VideoParams,
) -> Result<()> {
    let (w, h) = (state.width as usize, state.height as usize);
    let refl = state.reflectance(input);
    let (mut x0, mut y0, mut x1, mut y1) = (w, h, 0, 0);
    for p in (0..w * h).filter(|&p| hole[p]) {
        let (x, y) = (p % w, p / w);
        (x0, y0, x1, y1) = (x0.min(x), y0.min(y), x1.max(x), y1.max(y));
    }
    let crop = Image::from_fn((x1 - x0 + 1) as u32, (y1 - y0 + 1) as u32, |x, y| {
        refl.rgb((y as usize + y0) * w + x as usize + x0)
    });
    let segments = felzenszwalb(&crop, &params.segment)?;
    let cw = crop.width() as usize;
    let at = |p: usize| (p / w - y0) * cw + (p % w - x0);

    // Per segment: the completed pixels' reflectance sum and the labelled neighbours.
    let mut sum = vec![[0.0f64; 3]; segments.count];
    let mut cnt = vec![0usize; segments.count];
    let mut neighbours: Vec<Vec<u32>> = vec![Vec::new(); segments.count];
    for p in (0..w * h).filter(|&p| hole[p]) {
        let s = segments.data[at(p)] as usize;
        for (a, v) in sum[s].iter_mut().zip(refl.rgb(p)) {
            *a += f64::from(v);
        }
        cnt[s] += 1;
        let (x, y) = (p % w, p / w);
        let adj = [
            (x > 0).then(|| p - 1),
            (x + 1 < w).then(|| p + 1),
            (y > 0).then(|| p - w),
            (y + 1 < h).then(|| p + w),
        ];
        for q in adj.into_iter().flatten() {
            if !hole[q] && state.labels[q] != Labels::NONE {
                neighbours[s].push(state.labels[q]);
            }
        }
    }
    let mut next = tables.cluster_count() as u32;
    let mut label_of = vec![Labels::NONE; segments.count];
    for s in 0..segments.count {
        if cnt[s] == 0 {
            continue;
        }
        let mean = sum[s].map(|v| v / cnt[s] as f64);
        neighbours[s].sort_unstable();
        neighbours[s].dedup();
        label_of[s] = match join_cluster(tables, &neighbours[s], mean, params) {
            Some(k) => k,
            None => {
                next += 1;
                next - 1
            }
        };
    }
    let mut fresh = vec![Labels::NONE; w * h];
    for p in (0..w * h).filter(|&p| hole[p]) {
        let l = label_of[segments.data[at(p)] as usize];
        state.labels[p] = l;
        fresh[p] = l;
    }
    let fresh = Labels {
        width: state.width,
        height: state.height,
        data: fresh,
        count: next as usize,
    };
    tables.update(input, &refl, &fresh)
}

/// The existing cluster a completed segment of mean reflectance `mean` joins, among the
/// clusters `adjacent` to it: the one whose reflectance histogram `𝓡_k` holds the largest
/// fraction of its pixels within the Parzen radius `d` of the segment's quantised mean (eq.
/// 3.6's window, applied to the reflectance); when no histogram has a pixel there, the one of
/// nearest mean reflectance if closer than the merge threshold. `None`: a new cluster.
fn join_cluster(
    tables: &ClusterTables,
    adjacent: &[u32],
    mean: [f64; 3],
    params: &VideoParams,
) -> Option<u32> {
    let q = colour8(mean.map(|v| v as f32)).map(f64::from);
    let d2 = params.propagate.d * params.propagate.d;
    let by_histogram = adjacent
        .iter()
        .filter_map(|&k| {
            let hist = tables.reflectance_histogram(k)?;
            let inside: u64 = hist
                .iter()
                .filter(|(v, _)| {
                    (0..3)
                        .map(|c| (f64::from(v[c]) - q[c]).powi(2))
                        .sum::<f64>()
                        <= d2
                })
                .map(|(_, n)| n)
                .sum();
            (inside > 0).then(|| (inside as f64 / tables.pixels(k).max(1) as f64, k))
        })
        .max_by(|a, b| a.0.total_cmp(&b.0).then(b.1.cmp(&a.1)));
    if let Some((_, k)) = by_histogram {
        return Some(k);
    }
    adjacent
        .iter()
        .filter_map(|&k| {
            let m = tables.mean_reflectance(k)?;
            let d2: f64 = (0..3).map(|c| (f64::from(m[c]) - mean[c]).powi(2)).sum();
            Some((d2.sqrt(), k))
        })
        .min_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)))
        .filter(|&(d, _)| d < params.merge.threshold)
        .map(|(_, k)| k)
}

//! "Intrinsic Images by Clustering" (Garces, Muñoz, López-Moreno & Gutierrez, EGSR 2012;
//! thesis ch. 2).
//!
//! Pipeline, with the thesis' numbering:
//! 1. Features {β, a, b} per pixel (eq. 2.2): (a, b) from CIELab of the linear input; β is
//!    `λ·(σ(μ(ℓ − L_max)) − σ(μ(L_min − ℓ)))`, with σ the logistic function, ℓ = L*/max(L*),
//!    so very dark pixels get β ≈ −λ, very bright ones β ≈ +λ and the rest β ≈ 0: black and
//!    white albedo, whose chroma is meaningless, are split from coloured pixels. (The thesis
//!    names μ, λ, L_min and L_max; this exact form of the step is our reading of eq. 2.2.)
//! 2. k-means on the features gives `k` segments (§2.3.1), see [`crate::kmeans`].
//! 3. Clusters are the 8-connected components of each segment; clusters smaller than `p`
//!    pixels join the neighbour of closest mean chroma; adjacent clusters whose mean RGB
//!    distance across the border is below `D` are merged (§2.3.2).
//! 4. One unknown per cluster, `x_i = ln f_i`, where the shading is `S = f_i·Y` inside
//!    cluster i (Y = linear luminance). Equations (§2.4):
//!    - continuity of shading at every border between clusters i and j (eq. 2.5):
//!      `x_i − x_j = mean(ln Y_j^b − ln Y_i^b)` over the border's pixel pairs, where ln Y^b is
//!      the log luminance of each side at the border, from `border_window` (3) pixels going away
//!      from the border on that side;
//!    - equal reflectance for clusters of the same segment whose mean luminances differ by
//!      less than `T_L` (eq. 2.7), one equation per RGB channel:
//!      `x_i − x_j = ln ρ_i^c − ln ρ_j^c`, ρ^c = ΣI^c / ΣY over the cluster;
//!    - the gauge `Σ x_i = 0` (eq. 2.8).
//! 5. Shading `S = f_i·Y`, a 5×5 median at cluster borders, `R = I / S`.
//!
//! Deliberate deviations, all documented on the parameters:
//! - The system is solved through sparse normal equations and Cholesky ([`crate::solver`])
//!   instead of Jacobi-preconditioned QMR; the result is the same least-squares solution.
//! - The gauge equation is applied per connected group of clusters (the paper's single
//!   equation leaves the system singular when the clusters form several groups, e.g. objects
//!   separated by a mask), by subtracting the group mean after the solve; this is exactly the
//!   least-squares solution with the gauge as a hard constraint.
//! - The thesis averages the luminance of the 3-pixel windows (eq. 2.5). A plain average sits
//!   1.5 pixels away from the border on each side, and on a smooth shading gradient that bias
//!   compounds over the many borders k-means cuts into it (Lab a, b vary with lightness; the
//!   ramp of Fig. 2.1b comes out with a 37 % reflectance drift). We fit a line to the window's
//!   log luminance instead and extrapolate it to the border: same samples, no bias on ramps.
//! - Border equations are weighted by √(border pixel pairs), so that a long shared border
//!   counts more than a one-pixel contact (the paper weights all equations equally), and take
//!   the median rather than the mean of the per-pair steps along the border.
//! - Reflectance equations link each cluster to at most `max_reflectance_partners` clusters of
//!   its segment nearest in mean luminance (within `T_L`), rather than to all of them, which
//!   keeps the normal matrix sparse on textured images with thousands of clusters.
//! - Mixed (anti-aliased) pixels at albedo edges: the border window starts `border_skip` (2)
//!   pixels away from the border where the cluster is thick enough. k-means also cuts thin
//!   fringe clusters between two albedos; in a chain albedo | fringe | albedo the two border
//!   equations carry the whole albedo step into the shading. Such strips (`bridge_ratio`) are
//!   bridged: the clusters on both sides get a direct border equation across the strip (the
//!   walk crosses at most 4 pixels) and the strip's own border equations get weight 10⁻³.
//!   Optionally (`thin_ratio`, off by default) strips are merged into a neighbour instead.
//! - Defaults of these additions were chosen on the MIT development objects (see the
//!   parameter docs); the thesis parameters keep their published values.
//! - k-means fits its centres on a seeded subsample (see [`crate::kmeans`]).

mod params;
mod regions;

use std::time::Instant;

use rayon::prelude::*;

pub use params::ClusteringParams;

use crate::color::{linear_to_lab, luminance};
use crate::decomposition::{Decomposition, Labels, check_input};
use crate::error::Result;
use crate::image::{Image, Mask, resolve_mask};
use crate::kmeans::{KMeansInfo, KMeansParams, kmeans};
use crate::progress::{Progress, ProgressFn};
use crate::solver::{LinearSystem, SolverInfo, zero_mean_per_component};
use regions::{PixelData, components8, graph, merge_similar, merge_small, merge_thin};

/// Number of equations of each kind in the linear system.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct EquationCounts {
    /// Shading continuity at borders (eq. 2.5).
    pub boundary: usize,
    /// Same-segment reflectance equalities, one per channel (eq. 2.7).
    pub reflectance: usize,
    /// Gauge equations, one per connected group of clusters (eq. 2.8).
    pub regularisation: usize,
}

/// Wall-clock time of each stage, in milliseconds.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct Timings {
    /// Feature computation.
    pub features_ms: f64,
    /// k-means.
    pub kmeans_ms: f64,
    /// Connected components and merges.
    pub clusters_ms: f64,
    /// Building the equations.
    pub system_ms: f64,
    /// Factorisation and solve.
    pub solve_ms: f64,
    /// Shading, median filter and reflectance.
    pub compose_ms: f64,
    /// Everything.
    pub total_ms: f64,
}

/// What a clustering run did.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct ClusteringInfo {
    /// Non-empty k-means segments.
    pub segments: usize,
    /// Connected components before merging.
    pub clusters_initial: usize,
    /// After merging clusters smaller than p.
    pub clusters_after_small_merge: usize,
    /// After merging thin (fringe) clusters.
    pub clusters_after_thin_merge: usize,
    /// Final clusters (unknowns of the system).
    pub clusters: usize,
    /// Equations by kind.
    pub equations: EquationCounts,
    /// k-means report.
    pub kmeans: KMeansInfo,
    /// Linear solver report.
    pub solver: SolverInfo,
    /// Stage timings.
    pub timings: Timings,
}

/// Result of [`decompose`].
#[derive(Clone, Debug)]
pub struct ClusteringOutput {
    /// Reflectance and shading.
    pub decomposition: Decomposition,
    /// Final clusters.
    pub clusters: Labels,
    /// k-means segments.
    pub segments: Labels,
    /// What happened.
    pub info: ClusteringInfo,
}

fn ms(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

fn logistic(x: f32) -> f32 {
    1.0 / (1.0 + (-x).exp())
}

/// The {β, a, b} feature of every pixel (eq. 2.2), for pixels inside the mask.
pub fn features(input: &Image, mask: &Mask, params: &ClusteringParams) -> Vec<[f32; 3]> {
    let lab: Vec<[f32; 3]> = (0..input.len())
        .into_par_iter()
        .map(|i| linear_to_lab(input.rgb(i)))
        .collect();
    feature_from_lab(&lab, mask, params)
}

fn feature_from_lab(lab: &[[f32; 3]], mask: &Mask, params: &ClusteringParams) -> Vec<[f32; 3]> {
    let sel = || {
        lab.iter()
            .enumerate()
            .filter(|(i, _)| mask.at(*i))
            .map(|x| x.1)
    };
    let max_l = sel().map(|p| p[0]).fold(0.0f32, f32::max).max(1e-6);
    let max_ab = sel()
        .map(|p| p[1].abs().max(p[2].abs()))
        .fold(0.0f32, f32::max);
    // A grey image has no chroma; keep β meaningful with a unit floor.
    let lambda = (params.lambda_fraction * max_ab).max(1e-3);
    lab.iter()
        .enumerate()
        .filter(|(i, _)| mask.at(*i))
        .map(|(_, p)| {
            let l = p[0] / max_l;
            let beta = lambda
                * (logistic(params.mu * (l - params.l_max_fraction))
                    - logistic(params.mu * (params.l_min_fraction - l)));
            [beta, p[1], p[2]]
        })
        .collect()
}

/// Decomposes `input` (linear RGB) with the clustering method; `mask` limits the work (None:
/// the whole image).
pub fn decompose(
    input: &Image,
    mask: Option<&Mask>,
    params: &ClusteringParams,
    progress: ProgressFn,
) -> Result<ClusteringOutput> {
    let t_all = Instant::now();
    params.validate()?;
    let mask = resolve_mask(input.dims(), mask)?;
    check_input(input, &mask)?;
    let (w, h) = (input.width() as usize, input.height() as usize);
    let mut info = ClusteringInfo::default();

    progress(Progress {
        stage: "features",
        fraction: 0.0,
    });
    let t = Instant::now();
    let rgb: Vec<[f32; 3]> = (0..input.len()).map(|i| input.rgb(i)).collect();
    let lab: Vec<[f32; 3]> = rgb.par_iter().map(|&p| linear_to_lab(p)).collect();
    let y: Vec<f32> = rgb.iter().map(|&p| luminance(p).max(0.0)).collect();
    let ab: Vec<[f32; 2]> = lab.iter().map(|p| [p[1], p[2]]).collect();
    let feats = feature_from_lab(&lab, &mask, params);
    drop(lab);
    info.timings.features_ms = ms(t);

    progress(Progress {
        stage: "k-means",
        fraction: 0.1,
    });
    let t = Instant::now();
    let (seg_labels, _, kinfo) = kmeans(
        &feats,
        &KMeansParams {
            k: params.k,
            seed: params.seed,
            ..Default::default()
        },
    )?;
    drop(feats);
    let mut seg = vec![Labels::NONE; input.len()];
    let mut it = seg_labels.into_iter();
    for (i, s) in seg.iter_mut().enumerate() {
        if mask.at(i) {
            *s = it.next().unwrap_or(0);
        }
    }
    info.segments = kinfo.clusters;
    info.kmeans = kinfo;
    info.timings.kmeans_ms = ms(t);

    progress(Progress {
        stage: "clusters",
        fraction: 0.3,
    });
    let t = Instant::now();
    let px = PixelData {
        w,
        h,
        rgb: &rgb,
        ab: &ab,
        y: &y,
    };
    let (mut labels, count) = components8(&seg, w, h);
    info.clusters_initial = count;
    let count = merge_small(&mut labels, count, &px, params.min_cluster_pixels);
    info.clusters_after_small_merge = count;
    let count = merge_thin(&mut labels, count, &px, params.thin_ratio as f64);
    info.clusters_after_thin_merge = count;
    let max_i = input.max() as f64;
    let count = merge_similar(
        &mut labels,
        count,
        &px,
        params.merge_threshold as f64 * max_i,
    );
    info.clusters = count;
    let (regions, borders) = graph(&labels, count, &px);
    // Majority segment of every cluster.
    let k = params.k;
    let mut votes = vec![0u32; count * k];
    for (i, &l) in labels.iter().enumerate() {
        if l != Labels::NONE {
            votes[l as usize * k + seg[i] as usize] += 1;
        }
    }
    let cluster_seg: Vec<usize> = (0..count)
        .map(|c| {
            let v = &votes[c * k..(c + 1) * k];
            (0..k)
                .max_by_key(|&s| (v[s], std::cmp::Reverse(s)))
                .unwrap_or(0)
        })
        .collect();
    drop(votes);
    info.timings.clusters_ms = ms(t);

    progress(Progress {
        stage: "system",
        fraction: 0.5,
    });
    let t = Instant::now();
    let max_y = y
        .iter()
        .enumerate()
        .filter(|(i, _)| mask.at(*i))
        .map(|p| *p.1)
        .fold(0.0f32, f32::max) as f64;
    let y_floor = (max_y * 1e-4).max(1e-12);
    let mut sys = LinearSystem::new(count);
    // Eq. 2.5: border continuity. Each side's log luminance is sampled over `border_window`
    // pixels going away from the border and extrapolated to the border by a line fit.
    let inside = |x: isize, yy: isize, l: u32| {
        x >= 0
            && yy >= 0
            && x < w as isize
            && yy < h as isize
            && labels[yy as usize * w + x as usize] == l
    };
    let side_value = |p: usize, dx: isize, dy: isize, l: u32| -> f64 {
        let (x0, y0) = ((p % w) as isize, (p / w) as isize);
        // Skip mixed pixels next to the border when the cluster is thick enough there.
        let far = (params.border_skip + params.border_window - 1) as isize;
        let skip = if inside(x0 + far * dx, y0 + far * dy, l) {
            params.border_skip
        } else {
            0
        };
        let (mut x, mut yy) = (x0 + skip as isize * dx, y0 + skip as isize * dy);
        let (mut n, mut st, mut sv, mut stt, mut stv) = (0.0f64, 0.0, 0.0, 0.0, 0.0);
        for t in skip..skip + params.border_window {
            if x < 0 || yy < 0 || x >= w as isize || yy >= h as isize {
                break;
            }
            let q = yy as usize * w + x as usize;
            if labels[q] != l {
                break;
            }
            let v = (y[q] as f64).max(y_floor).ln();
            let t = t as f64;
            n += 1.0;
            st += t;
            sv += v;
            stt += t * t;
            stv += t * v;
            x += dx;
            yy += dy;
        }
        let mean_v = sv / n.max(1.0);
        let var_t = stt - st * st / n.max(1.0);
        if n < 2.0 || var_t <= 0.0 {
            return mean_v;
        }
        let slope = (stv - st * sv / n) / var_t;
        // The border lies half a pixel before sample t = 0.
        mean_v + slope * (-0.5 - st / n)
    };
    let edge_index: regions::PairMap<usize> = borders
        .iter()
        .enumerate()
        .map(|(e, (key, _))| (*key, e))
        .collect();
    let mut edge_diffs: Vec<Vec<f64>> = vec![Vec::new(); borders.len()];
    // Thin clusters (strips about `bridge_ratio` pixels wide: anti-aliased fringes) are
    // bridged: the clusters on both sides get a direct equation across the strip.
    let thin: Vec<bool> = {
        let mut border_total = vec![0usize; count];
        for ((a, b), bd) in &borders {
            border_total[*a as usize] += bd.pairs;
            border_total[*b as usize] += bd.pairs;
        }
        (0..count)
            .map(|c| {
                params.bridge_ratio > 0.0
                    && (regions[c].pixels as f64)
                        < params.bridge_ratio as f64 * border_total[c] as f64
            })
            .collect()
    };
    let mut bridges: regions::PairMap<Vec<f64>> = regions::PairMap::default();
    let at = |x: isize, yy: isize| -> Option<usize> {
        (x >= 0 && yy >= 0 && x < w as isize && yy < h as isize)
            .then(|| yy as usize * w + x as usize)
    };
    for p in 0..labels.len() {
        let l = labels[p];
        if l == Labels::NONE {
            continue;
        }
        for (dx, dy) in [(1isize, 0isize), (-1, 0), (0, 1), (0, -1)] {
            let (px0, py0) = ((p % w) as isize, (p / w) as isize);
            let Some(q) = at(px0 + dx, py0 + dy) else {
                continue;
            };
            let m = labels[q];
            if m == Labels::NONE || m == l {
                continue;
            }
            if thin[m as usize] && !thin[l as usize] {
                // Walk across the strip; bridge to the thick cluster beyond it.
                let (mut x, mut yy) = (px0 + dx, py0 + dy);
                for _ in 0..4 {
                    x += dx;
                    yy += dy;
                    let Some(r) = at(x, yy) else { break };
                    let k2 = labels[r];
                    if k2 == m {
                        continue;
                    }
                    if k2 != Labels::NONE && k2 != l && !thin[k2 as usize] {
                        let yp = side_value(p, -dx, -dy, l);
                        let yr = side_value(r, dx, dy, k2);
                        let diff = if l < k2 { yr - yp } else { yp - yr };
                        bridges
                            .entry((l.min(k2), l.max(k2)))
                            .or_default()
                            .push(diff);
                    }
                    break;
                }
            }
            // Ordinary border equation, each pair once (from its smaller pixel index).
            if q < p {
                continue;
            }
            let (sx, sy) = if q > p { (dx, dy) } else { (-dx, -dy) };
            // p's side goes away from q (−d), q's side goes away from p (+d).
            let yp = side_value(p, -sx, -sy, l);
            let yq = side_value(q, sx, sy, m);
            let diff = if l < m { yq - yp } else { yp - yq };
            edge_diffs[edge_index[&(l.min(m), l.max(m))]].push(diff);
        }
    }
    let robust = |d: &mut Vec<f64>| {
        if params.border_median {
            let k = d.len() / 2;
            *d.select_nth_unstable_by(k, f64::total_cmp).1
        } else {
            d.iter().sum::<f64>() / d.len() as f64
        }
    };
    for (e, ((a, b), border)) in borders.iter().enumerate() {
        let d = &mut edge_diffs[e];
        if d.is_empty() {
            continue;
        }
        let rhs = robust(d);
        let mut weight = (border.pairs as f64).powf(params.border_weight_exponent as f64);
        if thin[*a as usize] || thin[*b as usize] {
            // A fringe only needs a value; its borders must not carry the albedo step.
            weight *= 1e-3;
        }
        if sys.add(&[(*a as usize, 1.0), (*b as usize, -1.0)], rhs, weight) {
            info.equations.boundary += 1;
        }
    }
    let mut bridge_list: Vec<_> = bridges.into_iter().collect();
    bridge_list.sort_unstable_by_key(|b| b.0);
    for ((a, b), mut d) in bridge_list {
        let rhs = robust(&mut d);
        let weight = (d.len() as f64 / 2.0).powf(params.border_weight_exponent as f64);
        if sys.add(&[(a as usize, 1.0), (b as usize, -1.0)], rhs, weight) {
            info.equations.boundary += 1;
        }
    }
    // Eq. 2.7: same-segment reflectance equalities.
    let mut by_seg: Vec<Vec<usize>> = vec![Vec::new(); k];
    for c in 0..count {
        by_seg[cluster_seg[c]].push(c);
    }
    let rho = |c: usize, ch: usize| regions[c].sum_rgb[ch] / regions[c].sum_y;
    let t_l = params.t_l as f64 * max_y;
    for members in &mut by_seg {
        members.sort_by(|&a, &b| {
            regions[a]
                .mean_y()
                .total_cmp(&regions[b].mean_y())
                .then(a.cmp(&b))
        });
        for (ai, &a) in members.iter().enumerate() {
            for &b in members[ai + 1..]
                .iter()
                .take(params.max_reflectance_partners)
            {
                if regions[b].mean_y() - regions[a].mean_y() >= t_l {
                    break;
                }
                for ch in 0..3 {
                    let rhs = rho(a, ch).ln() - rho(b, ch).ln();
                    if sys.add(&[(a, 1.0), (b, -1.0)], rhs, 1.0) {
                        info.equations.reflectance += 1;
                    }
                }
            }
        }
    }
    let comps = sys.components();
    info.equations.regularisation = {
        let mut roots: Vec<usize> = comps.clone();
        roots.sort_unstable();
        roots.dedup();
        roots.len()
    };
    info.timings.system_ms = ms(t);

    progress(Progress {
        stage: "solve",
        fraction: 0.6,
    });
    let t = Instant::now();
    let (mut x, sinfo) = sys.solve(&params.solver)?;
    zero_mean_per_component(&mut x, &comps);
    info.solver = sinfo;
    info.timings.solve_ms = ms(t);

    progress(Progress {
        stage: "compose",
        fraction: 0.9,
    });
    let t = Instant::now();
    let f: Vec<f32> = x.iter().map(|v| v.exp() as f32).collect();
    let mut shading = Image::new(w as u32, h as u32, 1);
    for (i, &l) in labels.iter().enumerate() {
        if l != Labels::NONE {
            shading.px_mut(i)[0] = f[l as usize] * y[i].max(y_floor as f32);
        }
    }
    let shading = median_at_borders(&shading, &labels, w, h, params.median_size);
    let decomposition = Decomposition::from_shading(input, shading, &mask);
    info.timings.compose_ms = ms(t);
    info.timings.total_ms = ms(t_all);
    progress(Progress {
        stage: "done",
        fraction: 1.0,
    });
    Ok(ClusteringOutput {
        decomposition,
        clusters: Labels {
            width: w as u32,
            height: h as u32,
            data: labels,
            count,
        },
        segments: Labels {
            width: w as u32,
            height: h as u32,
            data: seg,
            count: k,
        },
        info,
    })
}

/// Replaces the shading of pixels on a cluster border (a 4-neighbour in another cluster) by the
/// median of the in-mask shading in a `size`×`size` window (§2.4).
fn median_at_borders(s: &Image, labels: &[u32], w: usize, h: usize, size: usize) -> Image {
    let r = (size / 2) as isize;
    let border: Vec<usize> = (0..labels.len())
        .filter(|&p| {
            let l = labels[p];
            if l == Labels::NONE {
                return false;
            }
            let (x, y) = (p % w, p / w);
            (x + 1 < w && labels[p + 1] != l && labels[p + 1] != Labels::NONE)
                || (x > 0 && labels[p - 1] != l && labels[p - 1] != Labels::NONE)
                || (y + 1 < h && labels[p + w] != l && labels[p + w] != Labels::NONE)
                || (y > 0 && labels[p - w] != l && labels[p - w] != Labels::NONE)
        })
        .collect();
    let values: Vec<(usize, f32)> = border
        .par_iter()
        .map_init(
            || Vec::with_capacity(size * size),
            |win, &p| {
                let (x, y) = ((p % w) as isize, (p / w) as isize);
                win.clear();
                for dy in -r..=r {
                    for dx in -r..=r {
                        let (nx, ny) = (x + dx, y + dy);
                        if nx >= 0 && ny >= 0 && nx < w as isize && ny < h as isize {
                            let q = ny as usize * w + nx as usize;
                            if labels[q] != Labels::NONE {
                                win.push(s.px(q)[0]);
                            }
                        }
                    }
                }
                let m = win.len() / 2;
                let (_, v, _) = win.select_nth_unstable_by(m, f32::total_cmp);
                (p, *v)
            },
        )
        .collect();
    let mut out = s.clone();
    for (p, v) in values {
        out.px_mut(p)[0] = v;
    }
    out
}

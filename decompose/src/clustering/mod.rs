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
//! - Defaults chosen by leave-one-object-out cross-validation over the MIT development objects
//!   and the rendered tuning scenes (issue 19; figures in `docs/intrinsic-clustering.md`):
//!   the chroma of step 1 is the chromaticity of the linear RGB rather than Lab (a, b), which
//!   shrink with lightness and so split a cast shadow from the lit part of the same paint;
//!   `k` = 30, `λ` = 0.5, no merge by `D`.
//! - The system is solved through sparse normal equations and Cholesky ([`crate::solver`])
//!   instead of Jacobi-preconditioned QMR, and robustly: two further passes of iteratively
//!   reweighted least squares with an L1 loss ([`ClusteringParams::robust_iterations`]) let the
//!   consistent equations outvote a continuity equation across a crease or shadow edge. The
//!   three per-channel equations of eq. 2.7 share their left-hand side and are solved as one
//!   (exactly the same least-squares problem).
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
//! - Objects cut apart by the mask (the MIT and rendered masks drop the mixed pixels along
//!   silhouettes) form groups of clusters that no border equation links. The thesis links
//!   them only through eq. 2.7, to whatever other surface has the same chroma and a similar
//!   mean luminance, or leaves each to its own gauge (eq. 2.8), which makes every isolated
//!   single-cluster object white. Here eq. 2.7 stays inside a border-connected group, and each
//!   group's level is set so that its 98th-percentile shading matches the largest group's:
//!   every object is assumed lit head-on somewhere about as brightly as the main surfaces
//!   ([`ClusteringParams::group_highlight_quantile`]).
//! - Mixed (anti-aliased) pixels at albedo edges: the border window starts `border_skip` (2)
//!   pixels away from the border where the cluster is thick enough. k-means also cuts thin
//!   fringe clusters between two albedos; in a chain albedo | fringe | albedo the two border
//!   equations carry the whole albedo step into the shading. Such strips (`bridge_ratio`) are
//!   bridged: the clusters on both sides get a direct border equation across the strip (the
//!   walk crosses at most 4 pixels) and the strip's own border equations get weight 10⁻³.
//!   Optionally (`thin_ratio`, off by default) strips are merged into a neighbour instead.
//! - Defaults of these additions were first chosen on the MIT development objects; the
//!   fringe, skip and border-weight additions were then kept by the cross-validation above,
//!   which also moved three thesis parameters (`k`, `λ`, `D`) off their published values.
//! - k-means fits its centres on a seeded subsample (see [`crate::kmeans`]).

mod features;
mod groups;
mod median;
mod params;
mod regions;
mod system;

use std::time::Instant;

use rayon::prelude::*;

pub use features::features;
pub use params::ClusteringParams;

use crate::color::{linear_to_lab, luminance};
use crate::decomposition::{Decomposition, Labels, check_input};
use crate::error::Result;
use crate::image::{Image, Mask, resolve_mask};
use crate::kmeans::{KMeansInfo, KMeansParams, kmeans};
use crate::progress::{Progress, ProgressFn};
use crate::solver::{SolverInfo, zero_mean_per_component};
use features::{chroma_source, feature_from_lab};
use groups::match_group_highlights;
use median::median_at_borders;
use regions::{PixelData, components8, graph, merge_similar, merge_small, merge_thin};

/// Number of equations of each kind in the linear system.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct EquationCounts {
    /// Shading continuity at borders (eq. 2.5).
    pub boundary: usize,
    /// Same-segment reflectance equalities (eq. 2.7; the three channels as one equation).
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
    let feats = feature_from_lab(&chroma_source(&lab, &rgb, params), &mask, params);
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
            restarts: params.kmeans_restarts.max(1),
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
    let (count, small_graph) = merge_small(&mut labels, count, &px, params.min_cluster_pixels);
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
    // A merge that joins nothing leaves the labels as they were, so the graph of the last
    // small-cluster round still holds when the count did not change.
    let (regions, borders) = match small_graph {
        Some(g) if count == info.clusters_after_small_merge => g,
        _ => graph(&labels, count, &px),
    };
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
    let sys = system::build(
        &system::SystemInput {
            w,
            h,
            labels: &labels,
            y: &y,
            regions: &regions,
            borders: &borders,
            cluster_seg: &cluster_seg,
            k,
            max_y,
            y_floor,
        },
        params,
        &mut info.equations,
    );
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
    let (mut x, sinfo) = solve_robust(&sys, params)?;
    zero_mean_per_component(&mut x, &comps);
    if let Some(q) = params.group_highlight_quantile {
        match_group_highlights(&mut x, &comps, &labels, &y, y_floor, q);
    }
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

/// Solves the cluster system by iteratively reweighted least squares (not in the thesis,
/// which solves it once): after every solve each equation's weight is scaled by
/// `δ / max(|residual|, δ)` (an L1 loss; Cauchy `1 / (1 + (r/δ)²)` with `robust_cauchy`), so
/// that an equation that contradicts the others — a continuity equation across a crease or a
/// shadow edge, a reflectance equation between two different paints — stops pulling the
/// clusters around it once the consistent equations agree.
fn solve_robust(
    sys: &crate::solver::LinearSystem,
    params: &ClusteringParams,
) -> Result<(Vec<f64>, SolverInfo)> {
    let delta = params.robust_delta as f64;
    sys.solve_irls(&params.solver, params.robust_iterations, |r| {
        if params.robust_cauchy {
            1.0 / (1.0 + (r / delta).powi(2))
        } else {
            delta / r.abs().max(delta)
        }
    })
}

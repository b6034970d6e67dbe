//! The linear system of §2.4: shading continuity at cluster borders (eq. 2.5) and
//! same-segment reflectance equalities (eq. 2.7), one unknown `ln f_i` per cluster. The gauge
//! (eq. 2.8) is applied after the solve, see [`crate::solver::zero_mean_per_component`].

use super::regions::{self, Borders, Region};
use super::{ClusteringParams, EquationCounts};
use crate::decomposition::Labels;
use crate::solver::LinearSystem;

/// What the equations are built from.
pub(super) struct SystemInput<'a> {
    pub w: usize,
    pub h: usize,
    /// Final cluster per pixel.
    pub labels: &'a [u32],
    /// Linear luminance per pixel.
    pub y: &'a [f32],
    pub regions: &'a [Region],
    pub borders: &'a Borders,
    /// Majority k-means segment per cluster.
    pub cluster_seg: &'a [usize],
    /// Number of segments.
    pub k: usize,
    /// Largest luminance inside the mask.
    pub max_y: f64,
    /// Luminance floor for logarithms.
    pub y_floor: f64,
}

/// Builds the border and reflectance equations; counts them in `counts`.
pub(super) fn build(
    input: &SystemInput,
    params: &ClusteringParams,
    counts: &mut EquationCounts,
) -> LinearSystem {
    let SystemInput {
        w,
        h,
        labels,
        y,
        regions,
        borders,
        cluster_seg,
        k,
        max_y,
        y_floor,
    } = *input;
    let count = regions.len();
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
        for ((a, b), bd) in borders {
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
            counts.boundary += 1;
        }
    }
    let mut bridge_list: Vec<_> = bridges.into_iter().collect();
    bridge_list.sort_unstable_by_key(|b| b.0);
    for ((a, b), mut d) in bridge_list {
        let rhs = robust(&mut d);
        let weight = (d.len() as f64 / 2.0).powf(params.border_weight_exponent as f64);
        if sys.add(&[(a as usize, 1.0), (b as usize, -1.0)], rhs, weight) {
            counts.boundary += 1;
        }
    }
    // Border-connected groups (objects cut apart by the mask or the image edge).
    let mut group = regions::Dsu::new(count);
    if params.reflectance_within_groups {
        for ((a, b), _) in borders {
            group.union(*a, *b);
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
                if params.reflectance_within_groups && group.find(a as u32) != group.find(b as u32)
                {
                    continue;
                }
                // The paper's three equations, one per channel, share their left-hand side
                // `x_a − x_b`: in least squares they are exactly one equation with the mean
                // right-hand side and three times the weight (a third of the rows to solve).
                let rhs = (0..3)
                    .map(|ch| rho(a, ch).ln() - rho(b, ch).ln())
                    .sum::<f64>()
                    / 3.0;
                if sys.add(&[(a, 1.0), (b, -1.0)], rhs, 3.0) {
                    counts.reflectance += 1;
                }
            }
        }
    }
    sys
}

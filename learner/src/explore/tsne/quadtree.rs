//! The 2-D quadtree of the Barnes–Hut gradient (Barnes & Hut 1986; van der Maaten 2014, §4.2).
//!
//! Built top-down over a permutation of the points: a node holds a contiguous range of it, and
//! a node with more than [`LEAF`] points is split into its four quadrants (the permutation is
//! partitioned stably, so the tree is a function of the coordinates alone). Leaves are summed
//! point by point, so only whole cells far enough away are approximated, and `θ = 0` gives the
//! exact sum. Coincident points end in one leaf at [`MAX_DEPTH`].

/// Points a leaf may hold before it is split.
const LEAF: usize = 8;
/// Depth at which splitting stops (coincident or nearly coincident points).
const MAX_DEPTH: usize = 40;
/// Enough for an explicit depth-first stack: at most three pending siblings per level.
const STACK: usize = 4 * MAX_DEPTH + 8;

#[derive(Clone, Copy, Debug)]
struct Node {
    /// Centre of mass.
    com: [f64; 2],
    /// Side length of the node's square.
    side: f64,
    /// Points inside.
    count: u32,
    /// Index of the first of four consecutive children; 0 for a leaf.
    children: u32,
    /// The node's range of the permutation.
    start: u32,
    end: u32,
}

/// A quadtree over 2-D points.
pub(super) struct QuadTree {
    nodes: Vec<Node>,
    order: Vec<u32>,
}

/// Repulsion on one point: `Σ_j w_ij² (y_i − y_j)` and `Σ_j w_ij`, `w = 1/(1 + ‖y_i − y_j‖²)`.
pub(super) struct Repulsion {
    pub force: [f64; 2],
    pub z: f64,
}

impl QuadTree {
    pub(super) fn new(y: &[[f64; 2]]) -> Self {
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for p in y {
            for d in 0..2 {
                lo[d] = lo[d].min(p[d]);
                hi[d] = hi[d].max(p[d]);
            }
        }
        let side = (hi[0] - lo[0]).max(hi[1] - lo[1]).max(f64::MIN_POSITIVE) * (1.0 + 1e-9);
        let centre = [(lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0];
        let mut tree = QuadTree {
            nodes: Vec::with_capacity(2 * y.len() / LEAF + 16),
            order: (0..y.len() as u32).collect(),
        };
        let mut scratch = vec![0u32; y.len()];
        tree.nodes.push(Node {
            com: [0.0; 2],
            side,
            count: y.len() as u32,
            children: 0,
            start: 0,
            end: y.len() as u32,
        });
        tree.split(0, centre, 0, y, &mut scratch);
        tree
    }

    /// Splits node `at` (centre `centre`) if it holds too many points, and sets its centre of
    /// mass.
    fn split(
        &mut self,
        at: usize,
        centre: [f64; 2],
        depth: usize,
        y: &[[f64; 2]],
        scratch: &mut [u32],
    ) {
        let Node {
            start, end, side, ..
        } = self.nodes[at];
        let (start, end) = (start as usize, end as usize);
        if end - start <= LEAF || depth >= MAX_DEPTH {
            let mut com = [0.0; 2];
            for &j in &self.order[start..end] {
                com[0] += y[j as usize][0];
                com[1] += y[j as usize][1];
            }
            let count = (end - start).max(1) as f64;
            self.nodes[at].com = [com[0] / count, com[1] / count];
            return;
        }
        let quadrant =
            |p: [f64; 2]| usize::from(p[0] >= centre[0]) | usize::from(p[1] >= centre[1]) << 1;
        let mut counts = [0usize; 4];
        for &j in &self.order[start..end] {
            counts[quadrant(y[j as usize])] += 1;
        }
        let mut offset = [start; 4];
        for q in 1..4 {
            offset[q] = offset[q - 1] + counts[q - 1];
        }
        let bounds = offset;
        for &j in &self.order[start..end] {
            let q = quadrant(y[j as usize]);
            scratch[offset[q]] = j;
            offset[q] += 1;
        }
        self.order[start..end].copy_from_slice(&scratch[start..end]);
        let first = self.nodes.len();
        self.nodes[at].children = first as u32;
        let half = side / 2.0;
        for (&count, &begin) in counts.iter().zip(&bounds) {
            self.nodes.push(Node {
                com: [0.0; 2],
                side: half,
                count: count as u32,
                children: 0,
                start: begin as u32,
                end: (begin + count) as u32,
            });
        }
        let mut com = [0.0; 2];
        for (q, &count) in counts.iter().enumerate() {
            let c = [
                centre[0] + if q & 1 == 1 { half / 2.0 } else { -half / 2.0 },
                centre[1] + if q & 2 == 2 { half / 2.0 } else { -half / 2.0 },
            ];
            if count > 0 {
                self.split(first + q, c, depth + 1, y, scratch);
                let child = self.nodes[first + q];
                com[0] += child.com[0] * count as f64;
                com[1] += child.com[1] * count as f64;
            }
        }
        let count = (end - start) as f64;
        self.nodes[at].com = [com[0] / count, com[1] / count];
    }

    /// The repulsion on point `i`, approximating a cell of side `s` at distance `d` from `y_i` by
    /// its centre of mass when `s < θ·d`.
    pub(super) fn repulsion(&self, i: usize, y: &[[f64; 2]], theta: f64) -> Repulsion {
        let yi = y[i];
        let theta2 = theta * theta;
        let (mut fx, mut fy, mut z) = (0.0, 0.0, 0.0);
        let mut stack = [0u32; STACK];
        let mut top = 1;
        while top > 0 {
            top -= 1;
            let node = &self.nodes[stack[top] as usize];
            if node.count == 0 {
                continue;
            }
            if node.children == 0 {
                for &j in &self.order[node.start as usize..node.end as usize] {
                    let j = j as usize;
                    if j == i {
                        continue;
                    }
                    let (dx, dy) = (yi[0] - y[j][0], yi[1] - y[j][1]);
                    let w = 1.0 / (1.0 + dx * dx + dy * dy);
                    z += w;
                    fx += w * w * dx;
                    fy += w * w * dy;
                }
                continue;
            }
            let (dx, dy) = (yi[0] - node.com[0], yi[1] - node.com[1]);
            let d2 = dx * dx + dy * dy;
            if node.side * node.side < theta2 * d2 {
                let w = 1.0 / (1.0 + d2);
                let m = f64::from(node.count);
                z += m * w;
                fx += m * w * w * dx;
                fy += m * w * w * dy;
            } else {
                for c in 0..4 {
                    stack[top] = node.children + c;
                    top += 1;
                }
            }
        }
        Repulsion { force: [fx, fy], z }
    }
}

//! The whole Ward tree over a library's leaves (items, or k-means centres standing for groups
//! of items), with the per-branch counts the pruning of §6.5.1 needs.

use super::super::Linkage;

/// Node `v < leaves` is a leaf; node `leaves + i` is merge `i` of the linkage.
pub(super) struct FullTree<'a> {
    pub leaves: usize,
    linkage: &'a Linkage,
    /// Items of each leaf.
    pub leaf_items: Vec<Vec<usize>>,
    /// Items under each node.
    pub count: Vec<usize>,
    /// Items of each required label under each node, `nodes × required`.
    required_counts: Vec<usize>,
    required: usize,
}

impl<'a> FullTree<'a> {
    /// Counts bottom-up. `labels` is each item's label; `required` the labels τ applies to.
    pub fn new(
        linkage: &'a Linkage,
        leaf_items: Vec<Vec<usize>>,
        labels: &[u32],
        required: &[u32],
    ) -> Self {
        let leaves = leaf_items.len();
        debug_assert_eq!(leaves, linkage.n());
        let nodes = 2 * leaves - 1;
        let r = required.len();
        let mut count = vec![0usize; nodes];
        let mut required_counts = vec![0usize; nodes * r];
        for (leaf, items) in leaf_items.iter().enumerate() {
            count[leaf] = items.len();
            for &item in items {
                if let Some(k) = required.iter().position(|&l| l == labels[item]) {
                    required_counts[leaf * r + k] += 1;
                }
            }
        }
        for (i, m) in linkage.merges().iter().enumerate() {
            let v = leaves + i;
            count[v] = count[m.a] + count[m.b];
            for k in 0..r {
                required_counts[v * r + k] =
                    required_counts[m.a * r + k] + required_counts[m.b * r + k];
            }
        }
        Self {
            leaves,
            linkage,
            leaf_items,
            count,
            required_counts,
            required: r,
        }
    }

    pub fn root(&self) -> usize {
        2 * self.leaves - 2
    }

    pub fn children(&self, v: usize) -> Option<(usize, usize)> {
        (v >= self.leaves).then(|| {
            let m = &self.linkage.merges()[v - self.leaves];
            (m.a, m.b)
        })
    }

    pub fn height(&self, v: usize) -> f64 {
        if v < self.leaves {
            0.0
        } else {
            self.linkage.merges()[v - self.leaves].height
        }
    }

    /// Items of each required label under `v`.
    pub fn required_counts(&self, v: usize) -> &[usize] {
        &self.required_counts[v * self.required..(v + 1) * self.required]
    }

    /// The pruning rule of §6.5.1: more than κ items, and more than τ of every required label.
    pub fn kept(&self, v: usize, kappa: usize, tau: usize) -> bool {
        self.count[v] > kappa && self.required_counts(v).iter().all(|&c| c > tau)
    }

    /// Every item under `v`, in leaf order.
    pub fn items(&self, v: usize) -> Vec<usize> {
        let mut out = Vec::with_capacity(self.count[v]);
        let mut stack = vec![v];
        while let Some(u) = stack.pop() {
            match self.children(u) {
                Some((a, b)) => {
                    stack.push(b);
                    stack.push(a);
                }
                None => out.extend_from_slice(&self.leaf_items[u]),
            }
        }
        out
    }
}

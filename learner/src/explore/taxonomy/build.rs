//! Building the taxonomy: Ward (exact, or on k-means centres), the pruning walk, and each kept
//! branch's representative (the item nearest its centroid, §6.5.1).

use std::collections::HashMap;

use rayon::prelude::*;

use super::tree::FullTree;
use super::{Reduction, Stage, TaxonNode, Taxonomy, TaxonomyParams};
use crate::explore::library::StyleLibrary;
use crate::explore::{Linkage, MAX_POINTS, ward, ward_weighted};
use crate::search::kmeans::kmeans;
use crate::{Error, Result};

/// Branches whose representatives are found between two progress reports.
const CHUNK: usize = 64;

/// The pruned style taxonomy of `library` (§6.5.1). `required` are the label indices every kept
/// branch must hold more than τ items of (empty: κ alone prunes). `progress(stage, done,
/// total)` reports the long stages.
///
/// Errors: fewer than 2 items, bad parameters, a required label the library does not have, or
/// κ/τ that prune every branch (the message gives the library's counts).
pub fn taxonomy(
    library: &StyleLibrary,
    required: &[u32],
    params: &TaxonomyParams,
    progress: &mut dyn FnMut(Stage, usize, usize),
) -> Result<Taxonomy> {
    validate(library, required, params)?;
    let n = library.len();
    let (linkage, leaf_items, reduction) = if n <= params.max_exact {
        progress(Stage::Ward, 0, 1);
        let linkage = ward(library.points(), library.dim())?;
        progress(Stage::Ward, 1, 1);
        (linkage, (0..n).map(|i| vec![i]).collect(), None)
    } else {
        reduce_then_ward(library, params, progress)?
    };
    let tree = FullTree::new(&linkage, leaf_items, library.labels(), required);
    let root = tree.root();
    if !tree.kept(root, params.kappa, params.tau) {
        let per_label = required
            .iter()
            .zip(tree.required_counts(root))
            .map(|(&l, c)| format!(", {c} of them `{}`", library.label_names()[l as usize]))
            .collect();
        return Err(Error::PrunedEverything {
            kappa: params.kappa,
            tau: params.tau,
            items: n,
            per_label,
        });
    }
    let shown = kept_branches(&tree, params);
    let total = shown.len();
    let mut nodes: Vec<TaxonNode> = Vec::with_capacity(total);
    progress(Stage::Representatives, 0, total);
    for chunk in shown.chunks(CHUNK) {
        let stats: Vec<TaxonNode> = chunk
            .par_iter()
            .map(|branch| describe(&tree, library, branch))
            .collect();
        nodes.extend(stats);
        progress(Stage::Representatives, nodes.len(), total);
    }
    for (i, branch) in shown.iter().enumerate() {
        if let Some(parent) = branch.parent {
            nodes[parent].children.push(i);
        }
    }
    let mut representatives: Vec<usize> = (0..nodes.len())
        .filter(|&i| nodes[i].children.is_empty())
        .collect();
    representatives.sort_by(|&a, &b| nodes[b].count.cmp(&nodes[a].count).then(a.cmp(&b)));
    let covered: usize = representatives.iter().map(|&i| nodes[i].count).sum();
    Ok(Taxonomy {
        items: n,
        params: *params,
        required: required.to_vec(),
        reduction,
        nodes,
        representatives,
        unassigned: n - covered,
    })
}

fn validate(library: &StyleLibrary, required: &[u32], params: &TaxonomyParams) -> Result<()> {
    if library.len() < 2 {
        return Err(Error::NotEnoughData {
            what: "a style taxonomy (items)",
            needed: 2,
            got: library.len(),
        });
    }
    if !(2..=MAX_POINTS).contains(&params.max_exact) {
        return Err(Error::InvalidParameter {
            name: "max_exact",
            value: params.max_exact.to_string(),
            reason: "exact Ward clusters between 2 and 40,000 items",
        });
    }
    if !(2..=params.max_exact.min(u16::MAX as usize)).contains(&params.centres) {
        return Err(Error::InvalidParameter {
            name: "centres",
            value: params.centres.to_string(),
            reason: "the k-means reduction needs between 2 and max_exact (at most 65,535) centres",
        });
    }
    if params.kmeans_iterations == 0 {
        return Err(Error::InvalidParameter {
            name: "kmeans_iterations",
            value: "0".into(),
            reason: "the k-means reduction needs at least one iteration",
        });
    }
    if let Some(&l) = required
        .iter()
        .find(|&&l| l as usize >= library.label_names().len())
    {
        return Err(Error::InvalidParameter {
            name: "required",
            value: l.to_string(),
            reason: "a required label must be one of the library's labels",
        });
    }
    Ok(())
}

/// k-means on the rows (padded to the kernel's lanes), then weighted Ward on the non-empty
/// centres.
fn reduce_then_ward(
    library: &StyleLibrary,
    params: &TaxonomyParams,
    progress: &mut dyn FnMut(Stage, usize, usize),
) -> Result<(Linkage, Vec<Vec<usize>>, Option<Reduction>)> {
    let dim = library.dim();
    let all: Vec<usize> = (0..library.len()).collect();
    let (padded, stride) = library.padded_rows(&all);
    drop(all);
    let iterations = params.kmeans_iterations;
    progress(Stage::KMeans, 0, iterations);
    let clusters = kmeans(
        &padded,
        stride,
        params.centres,
        params.seed,
        iterations,
        &mut |i| progress(Stage::KMeans, i, iterations),
    );
    drop(padded);
    let mut groups: Vec<Vec<usize>> = vec![Vec::new(); clusters.info.k];
    for (item, &c) in clusters.assignment.iter().enumerate() {
        groups[c as usize].push(item);
    }
    let mut centres = Vec::new();
    let mut leaf_items = Vec::new();
    for (c, items) in groups.into_iter().enumerate() {
        if !items.is_empty() {
            centres.extend_from_slice(&clusters.centroids[c * stride..c * stride + dim]);
            leaf_items.push(items);
        }
    }
    let weights: Vec<usize> = leaf_items.iter().map(Vec::len).collect();
    progress(Stage::Ward, 0, 1);
    let linkage = ward_weighted(&centres, dim, &weights)?;
    progress(Stage::Ward, 1, 1);
    let reduction = Reduction {
        centres: leaf_items.len(),
        kmeans: clusters.info,
    };
    Ok((linkage, leaf_items, Some(reduction)))
}

/// A kept branch to show, with its parent among the shown ones.
struct Shown {
    node: usize,
    parent: Option<usize>,
    leaf: bool,
}

/// The shown branches in depth-first order: the root, every kept branch whose two children are
/// both kept, and every kept branch with no kept child (a representative style).
fn kept_branches(tree: &FullTree, params: &TaxonomyParams) -> Vec<Shown> {
    let kept = |v: usize| tree.kept(v, params.kappa, params.tau);
    let mut out: Vec<Shown> = Vec::new();
    let mut stack = vec![(tree.root(), None::<usize>)];
    while let Some((v, parent)) = stack.pop() {
        let kids: Vec<usize> = tree
            .children(v)
            .map(|(a, b)| [a, b].into_iter().filter(|&c| kept(c)).collect())
            .unwrap_or_default();
        let shown = parent.is_none() || kids.len() != 1;
        let next_parent = if shown {
            out.push(Shown {
                node: v,
                parent,
                leaf: kids.is_empty(),
            });
            Some(out.len() - 1)
        } else {
            parent
        };
        for &c in kids.iter().rev() {
            stack.push((c, next_parent));
        }
    }
    out
}

/// Count, labels and representative (the item nearest the centroid; ties to the lower item
/// index) of one shown branch.
fn describe(tree: &FullTree, library: &StyleLibrary, branch: &Shown) -> TaxonNode {
    let mut items = tree.items(branch.node);
    items.sort_unstable();
    let dim = library.dim();
    let mut centroid = vec![0.0f64; dim];
    for &i in &items {
        for (c, &x) in centroid.iter_mut().zip(library.row(i)) {
            *c += f64::from(x);
        }
    }
    let inv = 1.0 / items.len() as f64;
    centroid.iter_mut().for_each(|c| *c *= inv);
    let distance = |i: usize| -> f64 {
        library
            .row(i)
            .iter()
            .zip(&centroid)
            .map(|(&x, c)| (f64::from(x) - c).powi(2))
            .sum()
    };
    let representative = items
        .iter()
        .map(|&i| (distance(i), i))
        .min_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)))
        .map_or(0, |(_, i)| i);
    let mut by_label: HashMap<u32, usize> = HashMap::new();
    for &i in &items {
        *by_label.entry(library.labels()[i]).or_default() += 1;
    }
    let mut label_counts: Vec<(u32, usize)> = by_label.into_iter().collect();
    label_counts.sort_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(&b.0)));
    TaxonNode {
        count: items.len(),
        height: tree.height(branch.node),
        representative,
        label_counts,
        children: Vec::new(),
        members: if branch.leaf { items } else { Vec::new() },
    }
}

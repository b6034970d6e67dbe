//! The items a style map shows when it does not show every item (§5.7.1): each label's items
//! clustered by k-means in the style space, and the item nearest each centre kept (100 per
//! category in the paper), so that every style of every category has a point.

use crate::explore::library::StyleLibrary;
use crate::search::kmeans::kmeans;
use crate::{Error, Result};

/// Lloyd iterations of each label's k-means at most.
const ITERATIONS: usize = 30;

/// Indices of up to `per_label` representatives of each label (all of a label's items when it
/// has no more), in increasing index order. Deterministic for a seed.
pub fn representatives_per_label(
    library: &StyleLibrary,
    per_label: usize,
    seed: u64,
) -> Result<Vec<usize>> {
    if per_label == 0 || per_label > u16::MAX as usize {
        return Err(Error::InvalidParameter {
            name: "per_label",
            value: per_label.to_string(),
            reason: "a map keeps between 1 and 65,535 representatives per label",
        });
    }
    let mut by_label: Vec<Vec<usize>> = vec![Vec::new(); library.label_names().len()];
    for (i, &l) in library.labels().iter().enumerate() {
        by_label[l as usize].push(i);
    }
    let mut out = Vec::new();
    for (label, items) in by_label.iter().enumerate() {
        if items.len() <= per_label {
            out.extend_from_slice(items);
            continue;
        }
        let (rows, stride) = library.padded_rows(items);
        let clusters = kmeans(
            &rows,
            stride,
            per_label,
            seed ^ label as u64,
            ITERATIONS,
            &mut |_| {},
        );
        // The member nearest each centre (ties to the earlier item).
        let mut best: Vec<Option<(f32, usize)>> = vec![None; clusters.info.k];
        for (k, (&c, &d)) in clusters
            .assignment
            .iter()
            .zip(&clusters.distance)
            .enumerate()
        {
            let slot = &mut best[c as usize];
            if slot.is_none_or(|(bd, _)| d < bd) {
                *slot = Some((d, items[k]));
            }
        }
        out.extend(best.into_iter().flatten().map(|(_, i)| i));
    }
    out.sort_unstable();
    out.dedup();
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn explore_map_representatives_cover_each_label() {
        // Label 0: 40 points in 4 tight groups; label 1: 3 points (all kept).
        let mut x = Vec::new();
        let mut labels = Vec::new();
        for i in 0..40 {
            x.extend([(i % 4) as f32 * 10.0 + (i / 4) as f32 * 0.01, 0.0]);
            labels.push(0);
        }
        for i in 0..3 {
            x.extend([100.0 + i as f32, 5.0]);
            labels.push(1);
        }
        let ids = (0..43).map(|i| format!("i{i}")).collect();
        let lib = StyleLibrary::new(ids, x, 2, labels, vec!["a".into(), "b".into()]).unwrap();
        let reps = representatives_per_label(&lib, 4, 0).unwrap();
        assert_eq!(reps.len(), 7);
        assert!(reps.ends_with(&[40, 41, 42]));
        let mut groups: Vec<usize> = reps[..4].iter().map(|i| i % 4).collect();
        groups.sort_unstable();
        assert_eq!(groups, vec![0, 1, 2, 3], "{reps:?}");
        assert_eq!(reps, representatives_per_label(&lib, 4, 0).unwrap());
        assert!(representatives_per_label(&lib, 0, 0).is_err());
        assert_eq!(representatives_per_label(&lib, 100, 0).unwrap().len(), 43);
    }
}

//! Gradient-magnitude histograms (§5.3 "Shading", eq. 5.3).
//!
//! PLACEHOLDER: filled in by the family's implementation.

use super::{Family, FeatureInfo, Prepared};

/// Number of features in this family.
pub const COUNT: usize = 32;

/// Names and docs, in output order.
pub fn catalogue() -> Vec<FeatureInfo> {
    (0..COUNT)
        .map(|i| FeatureInfo {
            name: Box::leak(format!("shading_placeholder_{i}").into_boxed_str()),
            family: Family::Shading,
            doc: "placeholder",
        })
        .collect()
}

/// Writes this family's features of `p` into `out` (length [`COUNT`]).
pub fn compute(p: &Prepared, out: &mut [f64]) {
    let _ = p;
    out.fill(0.0);
}

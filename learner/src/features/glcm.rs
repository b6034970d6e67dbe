//! The 22 Haralick/GLCM statistics (§5.3 "Texture").
//!
//! PLACEHOLDER: filled in by the family's implementation.

use super::{Family, FeatureInfo, Prepared};

/// Number of features in this family.
pub const COUNT: usize = 22;

/// Names and docs, in output order.
pub fn catalogue() -> Vec<FeatureInfo> {
    (0..COUNT)
        .map(|i| FeatureInfo {
            name: Box::leak(format!("glcm_placeholder_{i}").into_boxed_str()),
            family: Family::Texture,
            doc: "placeholder",
        })
        .collect()
}

/// Writes this family's features of `p` into `out` (length [`COUNT`]).
pub fn compute(p: &Prepared, out: &mut [f64]) {
    let _ = p;
    out.fill(0.0);
}

//! The style map of §5.7.1: a library (or a few representatives of each label) placed in 2-D
//! by t-SNE of their rows in the learned style space, so that items of one style sit together.

mod representatives;

use serde::{Deserialize, Serialize};

pub use representatives::representatives_per_label;

use super::library::StyleLibrary;
use super::tsne::{TsneInfo, TsneParams, tsne};
use crate::Result;

/// Parameters of the style map.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MapParams {
    /// Representatives kept per label (k-means in the style space, §5.7.1: 100 per category in
    /// the paper); `None` maps every item.
    pub per_label: Option<usize>,
    /// The t-SNE; its seed also seeds the representatives' k-means.
    pub tsne: TsneParams,
}

impl Default for MapParams {
    fn default() -> Self {
        Self {
            per_label: Some(100),
            tsne: TsneParams::default(),
        }
    }
}

/// Items placed in the plane.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StyleMap {
    /// Indices into the library of the mapped items, increasing.
    pub items: Vec<usize>,
    /// Position of each mapped item.
    pub positions: Vec<[f32; 2]>,
    /// The t-SNE run.
    pub info: TsneInfo,
}

/// The style map of `library`. `progress(iteration, total)` reports the t-SNE's iterations.
///
/// Errors: those of [`representatives_per_label`] and [`tsne`] (too few items for the
/// perplexity, too many, bad parameters).
pub fn style_map(
    library: &StyleLibrary,
    params: &MapParams,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<StyleMap> {
    params.tsne.validate()?;
    let items = match params.per_label {
        Some(k) => representatives_per_label(library, k, params.tsne.seed)?,
        None => (0..library.len()).collect(),
    };
    let dim = library.dim();
    let points: Vec<f32> = if items.len() == library.len() {
        library.points().to_vec()
    } else {
        items
            .iter()
            .flat_map(|&i| library.row(i))
            .copied()
            .collect()
    };
    let (positions, info) = tsne(&points, dim, &params.tsne, progress)?;
    Ok(StyleMap {
        items,
        positions,
        info,
    })
}

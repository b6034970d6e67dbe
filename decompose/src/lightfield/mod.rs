//! Intrinsic light fields (Garces, Echevarria, Zhang, Wu, Zhou & Gutierrez, "Intrinsic Light
//! Field Images", CGF 2017 / arXiv 1608.04342; thesis ch. 4, Algorithm 2).
//!
//! A light field is a grid of `rows × cols` sub-aperture views of one scene, all of one size.
//! Decomposing each view on its own gives reflectance that changes from view to view; the
//! method filters the whole 4D volume at once so that reflectance and shading stay coherent
//! across views.

mod field;
mod tvl1;

pub use field::LightField;
pub use tvl1::{TvL1Info, TvL1Params, objective, tv_l1, tv_l1_with_progress};

//! Intrinsic light fields (Garces, Echevarria, Zhang, Wu, Zhou & Gutierrez, "Intrinsic Light
//! Field Images", CGF 2017 / arXiv 1608.04342; thesis ch. 4, Algorithm 2).
//!
//! A light field is a grid of `rows × cols` sub-aperture views of one scene, all of one size.
//! Decomposing each view on its own gives reflectance that changes from view to view; the
//! method filters the whole 4D volume at once so that reflectance and shading stay coherent
//! across views.

pub mod cues;
pub mod depth;
pub mod disparity;
pub mod edit;
pub mod eval;
mod field;
pub mod io;
pub mod method;
pub mod propagate;
pub mod retinex;
pub mod synthetic;
pub mod tvl1;

pub use field::LightField;
pub use method::{LightFieldDecomposition, LightFieldInfo, LightFieldParams, decompose};

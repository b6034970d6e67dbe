//! Intrinsic decomposition of single images into reflectance and shading, `I = R × S` per
//! pixel and channel (Garces, thesis ch. 2 and §3.4).
//!
//! Three methods share one sparse least-squares solver ([`solver`]) and return the same
//! [`Decomposition`]:
//! - [`clustering`]: "Intrinsic Images by Clustering" (Garces et al., EGSR 2012; thesis ch. 2);
//! - [`retinex`]: the closed-form Retinex with non-local texture constraints of Zhao et al.
//!   2012 (thesis §3.4, eqs. 3.12–3.15);
//! - [`color_retinex`]: Color Retinex (Grosse et al. 2009), the MIT benchmark's baseline.
//!
//! Beyond single images: [`lightfield`] (thesis ch. 4) and [`video`] (thesis ch. 3, in
//! progress).
//!
//! Around them: image files ([`io`]), error measures ([`metrics`]: LMSE, scale-invariant MSE,
//! WHDR), synthetic ground truth ([`synthetic`]), editing applications ([`edit`]) and plots
//! ([`plot`]), and the process figures benchmarks report ([`process`]: CPU time, peak memory).
//! The library never prints; long runs report through a [`progress`] callback.
//!
//! ```
//! use decompose::{clustering, synthetic};
//!
//! let truth = synthetic::scene(48, 40, 1);
//! let out = clustering::decompose(
//!     &truth.input,
//!     None,
//!     &clustering::ClusteringParams::default(),
//!     &mut |_| {},
//! )?;
//! let d = &out.decomposition;
//! // The product of the layers is the input.
//! let back = d.reconstruct();
//! for (a, b) in back.data().iter().zip(truth.input.data()) {
//!     assert!((a - b).abs() <= 1e-4 * b.max(1e-3));
//! }
//! # Ok::<(), decompose::Error>(())
//! ```

pub mod clustering;
pub mod color;
pub mod color_retinex;
pub mod decomposition;
pub mod edit;
pub mod error;
mod grid;
pub mod image;
pub mod io;
pub mod kmeans;
pub mod lightfield;
pub mod metrics;
pub mod plot;
pub mod process;
pub mod progress;
pub mod retinex;
pub mod solver;
pub mod synthetic;
pub mod video;

pub use decomposition::{Decomposition, Labels};
pub use error::{Error, Result};
pub use image::{Image, Mask};
pub use progress::Progress;

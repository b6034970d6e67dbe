//! The learned style metric of Garces et al. 2014, §5.5–5.6.
//!
//! A weighted Euclidean distance over standardised style features,
//! `d(x, y) = sqrt((x − y)ᵀ diag(w) (x − y))` with `w ≥ 0` (eq. 5.5), whose weights are learned
//! from relative-similarity triplets through the logistic model
//! `P(q = 1 | A, B, C) = σ(d(A, C) − d(A, B))` (eq. 5.6) by minimising
//! `E(w) = −Σ log P(q_i) + λ‖w‖₁` (eq. 5.8). Evaluation (eq. 5.9) lives in [`crate::eval`].
//!
//! * [`objective`]: `E(w)` and its gradient in one parallel pass, with the smoothed root.
//! * [`solver`]: a projected L-BFGS as an argmin `Solver` (default) and NLopt's L-BFGS.
//! * [`cv`]: λ by grouped k-fold cross-validation over a log grid.
//! * [`train`]: the whole recipe, producing a [`Model`] (`model.json`).
//! * [`simulate`]: a simulated crowd with a known sparse `w*`, for end-to-end checks.
//!
//! Deliberate choices, each explained where it is made: features are standardised with the
//! mean/standard deviation of the training items (stored in the model); training starts from the
//! maximum-likelihood uniform metric `w = c·1`; after training, weights below 0.02 are set to
//! zero as in the paper.
//!
//! ```
//! use learner::metric::simulate::{simulate, SimulationParams};
//! use learner::metric::train::{train, LambdaChoice, TrainParams};
//! use learner::triplets::TripletSet;
//!
//! let sim = simulate(&SimulationParams { triplets: 2000, ..Default::default() })?;
//! let set = TripletSet {
//!     triplets: sim.triplets.clone(),
//!     skipped: 0,
//!     skip_examples: vec![],
//!     has_workers: true,
//! };
//! let params = TrainParams { lambda: LambdaChoice::Fixed(5.0), ..Default::default() };
//! let model = train(&sim.table, &set, &params, &mut |_| {})?;
//! assert!(model.solver.converged);
//! assert!(model.nonzero < sim.dim);
//! # Ok::<(), learner::Error>(())
//! ```

pub mod cv;
pub mod model;
pub mod objective;
pub mod simulate;
pub mod solver;
pub mod train;

pub use model::Model;

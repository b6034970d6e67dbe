//! The style map of §5.7.1: a library (or a few representatives of each label) placed in 2-D
//! by t-SNE of their rows in the learned style space, so that items of one style sit together.

mod representatives;

pub use representatives::representatives_per_label;

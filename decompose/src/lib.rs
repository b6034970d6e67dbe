//! Intrinsic decomposition of images, videos and 4D light fields into reflectance and shading
//! (Garces et al., "Intrinsic Images by Clustering", EGSR 2012; "Intrinsic Video and
//! Applications", SIGGRAPH 2014; "Intrinsic Light Fields", 2016).
//!
//! This crate is laid down by the workspace issue; the algorithms arrive with the decompose issue.

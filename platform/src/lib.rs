//! The rating-study platform: triplet studies ("Is A more similar in style to B or to C?"),
//! quality control, dashboard and exports, plus style search and exploration on top of the
//! learned metric.
//!
//! This crate is laid down by the workspace issue; the server arrives with the platform issue.

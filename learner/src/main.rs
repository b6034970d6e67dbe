//! The `learner` command line.
fn main() {}

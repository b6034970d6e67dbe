//! Intrinsic video (Ye, Garces, Liu, Dai & Gutierrez, SIGGRAPH 2014; thesis ch. 3).

pub mod flow;

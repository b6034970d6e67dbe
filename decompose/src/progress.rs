//! Progress reporting: the library never prints, long work calls a user callback.

/// One progress report: a named stage and how far the whole run is, in [0, 1].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Progress {
    /// The stage that just started.
    pub stage: &'static str,
    /// Fraction of the run done.
    pub fraction: f32,
}

/// A progress sink; `&mut |_| {}` ignores reports.
pub type ProgressFn<'a> = &'a mut dyn FnMut(Progress);

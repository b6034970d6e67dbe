//! Runtime CPU dispatch for the per-pixel loops.
//!
//! The release build targets baseline x86-64 (SSE2), so it runs on any 64-bit PC; there, an
//! `i32` multiply has no vector instruction and a loop over `f32` moves 4 lanes at a time.
//! Functions defined with [`vectorised_fn!`] are compiled a second time for AVX2 and the copy is
//! chosen at run time when the CPU has it (via [`pulp`], which faer already brings in), so the
//! same autovectorised loops move 8 lanes.
//!
//! Results are bit for bit the same on both paths: Rust never fuses a multiply and an add on
//! its own, and these loops are element-wise or keep their sequential order, so only the vector
//! width changes (`learner features` outputs were compared on 1,300 images).
//!
//! Only code inlined into the dispatched function gets the wider instructions, and the inliner
//! will not pull a large closure (or a function item's call shim) into it. So the macro wraps
//! the body in a `Kernel` whose `run` is `#[inline(always)]`, and helpers the body calls should
//! be `#[inline(always)]` too.

/// A loop nest to run with [`vectorised`]; `run` must be `#[inline(always)]`.
pub trait Kernel {
    /// What the kernel returns.
    type Output;
    /// Runs the kernel.
    fn run(self) -> Self::Output;
}

/// Runs `kernel` compiled for the widest vector instructions this CPU supports.
pub fn vectorised<K: Kernel>(kernel: K) -> K::Output {
    #[cfg(test)]
    if tests::BASELINE_ONLY.with(std::cell::Cell::get) {
        return kernel.run();
    }
    pulp::Arch::new().dispatch(Dispatched(kernel))
}

/// Adapts a [`Kernel`] to pulp's dispatch.
struct Dispatched<K>(K);

impl<K: Kernel> pulp::WithSimd for Dispatched<K> {
    type Output = K::Output;

    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _simd: S) -> Self::Output {
        self.0.run()
    }
}

/// `fn name<'a>(arg: Type, …) -> Output { body }`, with the body run through [`vectorised`].
/// The function takes exactly one lifetime parameter, which the argument types may use.
macro_rules! vectorised_fn {
    (
        $(#[$meta:meta])*
        $vis:vis fn $name:ident<$lt:lifetime>($($arg:ident: $ty:ty),* $(,)?) -> $ret:ty $body:block
    ) => {
        $(#[$meta])*
        $vis fn $name<$lt>($($arg: $ty),*) -> $ret {
            struct Args<$lt> {
                $($arg: $ty),*
            }
            impl<$lt> $crate::simd::Kernel for Args<$lt> {
                type Output = $ret;
                #[inline(always)]
                fn run(self) -> $ret {
                    let Args { $($arg),* } = self;
                    $body
                }
            }
            $crate::simd::vectorised(Args { $($arg),* })
        }
    };
}
pub(crate) use vectorised_fn;

#[cfg(test)]
pub(crate) mod tests {
    use std::cell::Cell;
    use std::path::Path;

    thread_local! {
        /// Set by [`baseline_only`]: [`super::vectorised`] then runs the kernel as compiled for
        /// baseline x86-64.
        pub(super) static BASELINE_ONLY: Cell<bool> = const { Cell::new(false) };
    }

    /// Runs `f` with every vectorised function on its baseline x86-64 path.
    pub(crate) fn baseline_only<R>(f: impl FnOnce() -> R) -> R {
        BASELINE_ONLY.with(|flag| flag.set(true));
        let result = f();
        BASELINE_ONLY.with(|flag| flag.set(false));
        result
    }

    /// Every feature of every fixture image has the same bits on the dispatched (AVX2 where the
    /// CPU has it, as on the CI machines) and the baseline path.
    #[test]
    fn dispatched_and_baseline_features_are_bit_identical() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures/style");
        let mut compared = 0;
        for entry in walkdir::WalkDir::new(&root).sort_by_file_name() {
            let path = entry.expect("readable fixture tree").into_path();
            if path.extension().is_none_or(|e| e != "svg") {
                continue;
            }
            let svg = std::fs::read(&path).expect("readable fixture");
            let canvas = crate::render::render_svg(&svg).expect("fixtures render");
            let fast = crate::features::extract(canvas.clone()).expect("features");
            let slow = baseline_only(|| crate::features::extract(canvas)).expect("features");
            for (k, (a, b)) in fast.iter().zip(&slow).enumerate() {
                assert_eq!(a.to_bits(), b.to_bits(), "{} feature {k}", path.display());
            }
            compared += 1;
        }
        assert!(compared >= 20, "only {compared} fixtures found");
    }
}

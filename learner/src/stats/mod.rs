//! Statistics of the paper's user studies (Garces et al. 2014, §5.7.3 and Appendix 5.B).
//!
//! The composition-rating study reports, per condition pair, the rate at which workers chose the
//! style-sorted composition, tested with a one-sample, one-sided Student t-test against chance
//! (0.5) over workers, with an effect size and a 95% confidence interval; the mash-up study
//! reports the mean result-list position of the pieces used with a 95% t confidence interval
//! ("24 ± 4.4 with the metric, 40 ± 7.1 without").
//!
//! Everything is computed here from first principles (the regularised incomplete beta function
//! by its continued fraction, the t quantile by inverting the CDF) so that no statistics crate is
//! needed; `scripts/reference/stats_reference.py` checks it against SciPy.
//!
//! ```
//! use learner::stats::{one_sample_t_test, TTestParams};
//! let rates = [0.7, 0.65, 0.8, 0.6, 0.75];
//! let test = one_sample_t_test(&rates, &TTestParams::default())?;
//! assert!(test.p < 0.01 && test.df == 4.0);
//! # Ok::<(), learner::Error>(())
//! ```

mod special;
mod student_t;
mod ttest;

pub use special::{ln_gamma, regularized_incomplete_beta};
pub use student_t::StudentT;
pub use ttest::{Alternative, MeanInterval, TTest, TTestParams, mean_interval, one_sample_t_test};

#[cfg(test)]
mod tests;

//! The one-sample t-test and the t confidence interval of a mean (Appendix 5.B).

use super::student_t::StudentT;
use crate::{Error, Result};

/// Which alternative hypothesis the p-value is for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Alternative {
    /// H1: mean > μ0 (the paper's test: workers prefer the style-sorted condition).
    Greater,
    /// H1: mean < μ0.
    Less,
    /// H1: mean ≠ μ0.
    TwoSided,
}

/// Parameters of [`one_sample_t_test`]. The defaults are the paper's (Appendix 5.B).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TTestParams {
    /// μ0, the mean under the null hypothesis: 0.5, chance in a two-alternative forced choice.
    pub mu0: f64,
    /// The alternative: [`Alternative::Greater`], one-sided.
    pub alternative: Alternative,
    /// Level of the two-sided confidence interval of the mean: 0.95.
    pub confidence: f64,
}

impl Default for TTestParams {
    fn default() -> Self {
        Self {
            mu0: 0.5,
            alternative: Alternative::Greater,
            confidence: 0.95,
        }
    }
}

/// A mean with its two-sided Student t confidence interval, mean ± t_{(1+c)/2, n−1} · s/√n.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct MeanInterval {
    /// Number of values.
    pub n: usize,
    /// Their mean.
    pub mean: f64,
    /// Sample standard deviation s (divisor n − 1).
    pub sd: f64,
    /// Confidence level c.
    pub confidence: f64,
    /// t_{(1+c)/2, n−1} · s/√n: the paper's "24 ± 4.4".
    pub half_width: f64,
    /// mean − half_width.
    pub low: f64,
    /// mean + half_width.
    pub high: f64,
}

/// The result of a one-sample t-test.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct TTest {
    /// The null mean μ0.
    pub mu0: f64,
    /// The alternative the p-value is for.
    pub alternative: Alternative,
    /// t = (mean − μ0) / (s/√n).
    pub t: f64,
    /// Degrees of freedom, n − 1.
    pub df: f64,
    /// The p-value under `alternative`.
    pub p: f64,
    /// Cohen's d for one sample, (mean − μ0)/s: the paper's "effect size".
    pub effect_size: f64,
    /// The mean with its two-sided confidence interval (also for a one-sided test).
    pub interval: MeanInterval,
}

/// Checks the sample and returns (mean, s). Two passes: the mean, then the squared deviations
/// from it, which keeps s exact for samples with a large common offset.
fn moments(x: &[f64], what: &'static str) -> Result<(f64, f64)> {
    if x.len() < 2 {
        return Err(Error::NotEnoughData {
            what,
            needed: 2,
            got: x.len(),
        });
    }
    if let Some(bad) = x.iter().find(|v| !v.is_finite()) {
        return Err(Error::InvalidParameter {
            name: "sample value",
            value: bad.to_string(),
            reason: "values must be finite",
        });
    }
    let n = x.len() as f64;
    let mean = x.iter().sum::<f64>() / n;
    let ss: f64 = x.iter().map(|v| (v - mean) * (v - mean)).sum();
    Ok((mean, (ss / (n - 1.0)).sqrt()))
}

fn check_confidence(confidence: f64) -> Result<()> {
    if confidence > 0.0 && confidence < 1.0 {
        Ok(())
    } else {
        Err(Error::InvalidParameter {
            name: "confidence",
            value: confidence.to_string(),
            reason: "a confidence level must be strictly between 0 and 1",
        })
    }
}

/// The mean of `x` with its two-sided t confidence interval at level `confidence` (e.g. 0.95).
///
/// Needs at least two finite values. A sample without spread has a zero-width interval.
pub fn mean_interval(x: &[f64], confidence: f64) -> Result<MeanInterval> {
    check_confidence(confidence)?;
    let (mean, sd) = moments(x, "a confidence interval of a mean")?;
    interval_from(x.len(), mean, sd, confidence)
}

fn interval_from(n: usize, mean: f64, sd: f64, confidence: f64) -> Result<MeanInterval> {
    let quantile = StudentT::new(n as f64 - 1.0)?.ppf((1.0 + confidence) / 2.0)?;
    let half_width = quantile * sd / (n as f64).sqrt();
    Ok(MeanInterval {
        n,
        mean,
        sd,
        confidence,
        half_width,
        low: mean - half_width,
        high: mean + half_width,
    })
}

/// The one-sample Student t-test of H0: mean = μ0 (SciPy's `ttest_1samp`), with Cohen's d and
/// the mean's confidence interval.
///
/// Needs at least two finite values that are not all equal (without spread, t is undefined).
pub fn one_sample_t_test(x: &[f64], params: &TTestParams) -> Result<TTest> {
    if !params.mu0.is_finite() {
        return Err(Error::InvalidParameter {
            name: "mu0",
            value: params.mu0.to_string(),
            reason: "the null mean must be finite",
        });
    }
    check_confidence(params.confidence)?;
    let (mean, sd) = moments(x, "a t-test")?;
    // All values equal: the spread is zero (the computed s may be a rounding residue of the
    // mean, e.g. 3 × 0.7, which would give a meaningless huge t).
    if x.iter().all(|v| *v == x[0]) {
        return Err(Error::ZeroVariance {
            n: x.len(),
            value: x[0],
        });
    }
    let n = x.len() as f64;
    let df = n - 1.0;
    let t = (mean - params.mu0) / (sd / n.sqrt());
    let dist = StudentT::new(df)?;
    let p = match params.alternative {
        Alternative::Greater => dist.sf(t),
        Alternative::Less => dist.cdf(t),
        Alternative::TwoSided => (2.0 * dist.sf(t.abs())).min(1.0),
    };
    Ok(TTest {
        mu0: params.mu0,
        alternative: params.alternative,
        t,
        df,
        p,
        effect_size: (mean - params.mu0) / sd,
        interval: interval_from(x.len(), mean, sd, params.confidence)?,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bad_samples_are_errors() {
        let params = TTestParams::default();
        assert!(matches!(
            one_sample_t_test(&[0.7], &params),
            Err(Error::NotEnoughData { got: 1, .. })
        ));
        assert!(matches!(
            one_sample_t_test(&[0.7, 0.7, 0.7], &params),
            Err(Error::ZeroVariance { n: 3, .. })
        ));
        assert!(one_sample_t_test(&[0.7, f64::NAN], &params).is_err());
        assert!(mean_interval(&[1.0, 2.0], 1.0).is_err());
        assert_eq!(mean_interval(&[3.0, 3.0], 0.95).unwrap().half_width, 0.0);
    }

    #[test]
    fn the_sign_of_t_follows_the_mean() {
        let params = TTestParams::default();
        let above = one_sample_t_test(&[0.6, 0.7, 0.8], &params).unwrap();
        let below = one_sample_t_test(&[0.4, 0.3, 0.2], &params).unwrap();
        assert!(above.t > 0.0 && above.p < 0.5 && below.t < 0.0 && below.p > 0.5);
        assert!((above.p + below.p - 1.0).abs() < 1e-14);
    }
}

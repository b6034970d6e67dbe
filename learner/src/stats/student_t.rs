//! Student's t distribution: CDF, survival function and quantile.

use super::special::incomplete_beta_pair;
use crate::{Error, Result};

/// Student's t distribution with `df` degrees of freedom (ν).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StudentT {
    df: f64,
}

impl StudentT {
    /// The distribution with ν = `df` degrees of freedom; ν must be finite and positive.
    pub fn new(df: f64) -> Result<Self> {
        if !(df.is_finite() && df > 0.0) {
            return Err(Error::InvalidParameter {
                name: "df",
                value: df.to_string(),
                reason: "the degrees of freedom must be finite and positive",
            });
        }
        Ok(Self { df })
    }

    /// ν.
    pub fn df(&self) -> f64 {
        self.df
    }

    /// P(T ≤ t).
    pub fn cdf(&self, t: f64) -> f64 {
        if t.is_nan() {
            return f64::NAN;
        }
        let tail = self.lower_tail_of_abs(t);
        if t < 0.0 { tail } else { 1.0 - tail }
    }

    /// P(T > t), computed without the cancellation of 1 − cdf(t) so that small p-values keep
    /// their relative precision.
    pub fn sf(&self, t: f64) -> f64 {
        if t.is_nan() {
            return f64::NAN;
        }
        let tail = self.lower_tail_of_abs(t);
        if t > 0.0 { tail } else { 1.0 - tail }
    }

    /// P(T < −|t|) = ½ I_{ν/(ν+t²)}(ν/2, ½).
    fn lower_tail_of_abs(&self, t: f64) -> f64 {
        let nu = self.df;
        let t = t.abs();
        if t.is_infinite() {
            return 0.0;
        }
        // x = ν/(ν + t²) and y = t²/(ν + t²), each computed directly (no 1 − x).
        let (x, y) = if t > 1e100 {
            let x = (nu / t) / t;
            (x, 1.0 - x)
        } else {
            let t2 = t * t;
            (nu / (nu + t2), t2 / (nu + t2))
        };
        0.5 * incomplete_beta_pair(nu / 2.0, 0.5, x, y)
    }

    /// The quantile t with P(T ≤ t) = `p`, for 0 < p < 1 (±∞ at 0 and 1), by bisection on
    /// the survival function to the last bit of the bracket.
    pub fn ppf(&self, p: f64) -> Result<f64> {
        if !(0.0..=1.0).contains(&p) {
            return Err(Error::InvalidParameter {
                name: "p",
                value: p.to_string(),
                reason: "a probability must be between 0 and 1",
            });
        }
        Ok(if p == 0.0 {
            f64::NEG_INFINITY
        } else if p == 1.0 {
            f64::INFINITY
        } else if p == 0.5 {
            0.0
        } else if p < 0.5 {
            -self.upper_quantile(p)
        } else {
            self.upper_quantile(1.0 - p)
        })
    }

    /// The t ≥ 0 with sf(t) = q, 0 < q < ½.
    fn upper_quantile(&self, q: f64) -> f64 {
        let (mut lo, mut hi) = (0.0_f64, 1.0_f64);
        while self.sf(hi) > q {
            lo = hi;
            hi *= 2.0;
            if hi.is_infinite() {
                return f64::INFINITY;
            }
        }
        loop {
            let mid = lo + (hi - lo) / 2.0;
            if mid <= lo || mid >= hi {
                return mid;
            }
            if self.sf(mid) > q {
                lo = mid;
            } else {
                hi = mid;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cauchy_is_t_with_one_degree_of_freedom() {
        // ν = 1: F(t) = ½ + atan(t)/π.
        let cauchy = StudentT::new(1.0).unwrap();
        for &t in &[-30.0, -2.0, -0.1, 0.0, 0.4, 3.0, 1e6] {
            let expected = 0.5 + f64::atan(t) / std::f64::consts::PI;
            assert!((cauchy.cdf(t) - expected).abs() < 1e-14, "t = {t}");
        }
        let q = cauchy.ppf(0.975).unwrap();
        let expected = (std::f64::consts::PI * 0.475).tan();
        assert!((q - expected).abs() < 1e-12 * expected);
    }

    #[test]
    fn quantile_inverts_the_cdf_and_is_symmetric() {
        let t = StudentT::new(7.0).unwrap();
        for &p in &[1e-12, 0.01, 0.3, 0.5, 0.9, 0.999] {
            let q = t.ppf(p).unwrap();
            assert!((t.cdf(q) - p).abs() < 1e-13 * p.max(1e-3), "p = {p}");
        }
        for &p in &[0.125, 0.25, 0.375] {
            assert_eq!(t.ppf(p).unwrap(), -t.ppf(1.0 - p).unwrap());
        }
    }

    #[test]
    fn bad_parameters_are_errors() {
        assert!(StudentT::new(0.0).is_err());
        assert!(StudentT::new(f64::NAN).is_err());
        assert!(StudentT::new(3.0).unwrap().ppf(1.5).is_err());
    }
}

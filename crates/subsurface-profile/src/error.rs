//! The one error type of the crate.

use thiserror::Error;

/// Bad input to any constructor or generator of this crate.
///
/// `Display` is always a single line that starts with the name of the offending
/// field, so a front end can prefix it with its own flag syntax (`--samples: ...`).
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ProfileError {
    /// A value that must be finite was NaN or infinite.
    #[error("{field}: must be finite (got {value})")]
    NonFinite {
        /// The offending field (`sigma_a.g`).
        field: String,
        /// The value given.
        value: f64,
    },
    /// A value that must be strictly positive was not.
    #[error("{field}: must be > 0 (got {value})")]
    NotPositive {
        /// The offending field (`sigma_a.g`).
        field: String,
        /// The value given.
        value: f64,
    },
    /// A value that must be zero or positive was negative.
    #[error("{field}: must be >= 0 (got {value})")]
    Negative {
        /// The offending field (`sigma_a.g`).
        field: String,
        /// The value given.
        value: f64,
    },
    /// A value fell outside its closed range.
    #[error("{field}: must be in {min}..={max} (got {value})")]
    OutOfRange {
        /// The offending field (`sigma_a.g`).
        field: String,
        /// Lower bound, inclusive.
        min: f64,
        /// Upper bound, inclusive.
        max: f64,
        /// The value given.
        value: f64,
    },
    /// The separable kernel needs an odd tap count in 3..=63.
    #[error("samples: must be odd and in 3..=63 (got {0})")]
    Samples(u32),
    /// A count (Gaussians, grid points, LUT texels, ...) outside what is supported.
    #[error("{field}: must be in {min}..={max} (got {value})")]
    Count {
        /// The offending field.
        field: String,
        /// Smallest count supported.
        min: usize,
        /// Largest count supported.
        max: usize,
        /// The count given.
        value: usize,
    },
    /// Buffers or lists whose lengths disagree.
    #[error("{field}: expected length {expected} (got {got})")]
    Length {
        /// The offending field.
        field: String,
        /// The length it must have.
        expected: usize,
        /// The length given.
        got: usize,
    },
    /// Any other rule, stated in `reason`.
    #[error("{field}: {reason}")]
    Invalid {
        /// The offending field (`sigma_a.g`).
        field: String,
        /// The rule broken, on one line.
        reason: String,
    },
    /// No preset of that name.
    #[error("material: unknown name {name:?} (known: {known})")]
    UnknownMaterial {
        /// The name asked for.
        name: String,
        /// The preset names, comma-separated.
        known: String,
    },
}

/// `Result` with [`ProfileError`] as its default error.
pub type Result<T, E = ProfileError> = std::result::Result<T, E>;

/// `Ok(value)` where `ok`, else the error `err` builds for `field`.
fn check<T>(
    field: &str,
    value: T,
    ok: bool,
    err: impl FnOnce(String) -> ProfileError,
) -> Result<T> {
    if ok {
        Ok(value)
    } else {
        Err(err(field.to_owned()))
    }
}

/// Rejects NaN and infinities.
pub(crate) fn finite(field: &str, value: f64) -> Result<f64> {
    check(field, value, value.is_finite(), |field| {
        ProfileError::NonFinite { field, value }
    })
}

/// Finite and strictly positive.
pub(crate) fn positive(field: &str, value: f64) -> Result<f64> {
    finite(field, value)?;
    check(field, value, value > 0.0, |field| {
        ProfileError::NotPositive { field, value }
    })
}

/// Finite and `>= 0`.
pub(crate) fn non_negative(field: &str, value: f64) -> Result<f64> {
    finite(field, value)?;
    check(field, value, value >= 0.0, |field| ProfileError::Negative {
        field,
        value,
    })
}

/// Finite and inside `min..=max`.
pub(crate) fn in_range(field: &str, value: f64, min: f64, max: f64) -> Result<f64> {
    finite(field, value)?;
    check(field, value, (min..=max).contains(&value), |field| {
        ProfileError::OutOfRange {
            field,
            min,
            max,
            value,
        }
    })
}

/// `count` inside `min..=max`.
pub(crate) fn count(field: &str, value: usize, min: usize, max: usize) -> Result<usize> {
    check(field, value, (min..=max).contains(&value), |field| {
        ProfileError::Count {
            field,
            min,
            max,
            value,
        }
    })
}

/// Channel suffixes used in field names (`strength.g`).
pub(crate) const CHANNELS: [&str; 3] = ["r", "g", "b"];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn display_is_one_line_and_names_the_field() {
        let errors = [
            ProfileError::Samples(4),
            positive("sigma_a.g", -1.0).unwrap_err(),
            finite("eta", f64::NAN).unwrap_err(),
            in_range("eta", 0.5, 1.0, 10.0).unwrap_err(),
        ];
        for e in &errors {
            let s = e.to_string();
            assert!(!s.contains('\n'), "{s}");
        }
        assert_eq!(
            errors[0].to_string(),
            "samples: must be odd and in 3..=63 (got 4)"
        );
        assert!(errors[1].to_string().starts_with("sigma_a.g: "));
        assert!(errors[2].to_string().starts_with("eta: must be finite"));
        assert!(errors[3].to_string().starts_with("eta: must be in 1..=10"));
    }
}

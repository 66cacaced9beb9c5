//! Options that check themselves. Every stage's config (`SirenConfig`, `HyperConfig`,
//! `MetaDataConfig`, `OwnDataOptions`, `FitOptions`, `HyperFitOptions`, `PoseRefineOptions`,
//! `MetaOptions`, `AvatarFit`) implements [`Check`]: [`Check::check`] refuses an out-of-range
//! value with [`Error::Option`](crate::Error::Option), which names the option and its bound, and
//! the library calls it where the options enter (`fit_avatar`, `meta_train`, `MetaData::generate`,
//! `OwnData::prepare`), so a caller's bad value is an error, never a panic or a silent clamp.

use crate::error::{Error, Result};

/// A config that refuses values out of range (a config is checked as a whole, before use).
pub trait Check: Sized {
    /// `Err(Error::Option)` naming the first option out of range.
    fn check(&self) -> Result<()>;

    /// The config itself once it has passed [`Check::check`].
    fn checked(self) -> Result<Self> {
        self.check()?;
        Ok(self)
    }
}

/// `option` must be at least `min`.
pub(crate) fn at_least<T: PartialOrd + std::fmt::Display>(
    option: &'static str,
    value: T,
    min: T,
) -> Result<()> {
    if value >= min {
        Ok(())
    } else {
        Err(Error::option(option, &value, format!("at least {min}")))
    }
}

/// `option` must lie in `lo..=hi`.
pub(crate) fn within<T: PartialOrd + std::fmt::Display>(
    option: &'static str,
    value: T,
    lo: T,
    hi: T,
) -> Result<()> {
    if value >= lo && value <= hi {
        Ok(())
    } else {
        Err(Error::option(option, &value, format!("from {lo} to {hi}")))
    }
}

/// `option` must be finite and at least 0 (NaN refused).
pub(crate) fn non_negative(option: &'static str, value: f64) -> Result<()> {
    if value.is_finite() && value >= 0.0 {
        Ok(())
    } else {
        Err(Error::option(option, &value, "finite and at least 0"))
    }
}

/// `option` must be finite and above 0 (NaN refused).
pub(crate) fn positive(option: &'static str, value: f64) -> Result<()> {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        Err(Error::option(option, &value, "finite and above 0"))
    }
}

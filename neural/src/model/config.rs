//! The model stage's configs check themselves (`config::Check`): the sizes of the networks.
//! The same checks refuse a file whose header names sizes no network of this build has.

use crate::config::Check;
use crate::error::Result;
use crate::model::hyper::HyperConfig;
use crate::model::siren::SirenConfig;

impl Check for SirenConfig {
    /// 1 to 64 layers of 1 to 4,096.
    fn check(&self) -> Result<()> {
        SirenConfig::check(self)
    }
}

impl Check for HyperConfig {
    /// The SDF's sizes, heads 1 to 4,096 wide, a rank of 1 to 4,096.
    fn check(&self) -> Result<()> {
        HyperConfig::check(self)
    }
}

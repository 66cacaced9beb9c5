//! Where the program keeps what it can rebuild: chosen here, once per process, and passed to
//! the library crates (which read no environment). The skinning fields live in
//! `$XDG_CACHE_HOME/avatar-studio/fields`, else `~/.cache/avatar-studio/fields`; with neither
//! variable set nothing is cached and every field is built.

use avatar_core::canonical::FieldCache;
use std::path::PathBuf;
use std::sync::OnceLock;

/// The skinning-field cache of this process.
pub fn field_cache() -> &'static FieldCache {
    static CACHE: OnceLock<FieldCache> = OnceLock::new();
    CACHE.get_or_init(|| {
        let base = std::env::var_os("XDG_CACHE_HOME")
            .map(PathBuf::from)
            .or_else(|| std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".cache")));
        match base {
            Some(base) => FieldCache::in_dir(base.join("avatar-studio").join("fields")),
            None => FieldCache::none(),
        }
    })
}

//! Where the program keeps what it can rebuild: chosen here, once per process, and passed to
//! the library crates (which read no environment). The folder is
//! `$XDG_CACHE_HOME/avatar-studio`, else `~/.cache/avatar-studio` (an empty variable counts as
//! unset). The skinning fields live in its `fields`; with neither variable set nothing is
//! cached and every field is built. The studio's demo capture, scans and unsaved avatars live
//! in it too, or under the temporary folder without it (`studio::demo::cache_dir`).

use avatar_core::canonical::FieldCache;
use std::path::PathBuf;
use std::sync::OnceLock;

/// The program's cache folder, if the environment names one.
pub fn cache_dir() -> Option<PathBuf> {
    let set = |name: &str| std::env::var_os(name).filter(|v| !v.is_empty()).map(PathBuf::from);
    set("XDG_CACHE_HOME")
        .or_else(|| set("HOME").map(|h| h.join(".cache")))
        .map(|base| base.join("avatar-studio"))
}

/// The skinning-field cache of this process.
pub fn field_cache() -> &'static FieldCache {
    static CACHE: OnceLock<FieldCache> = OnceLock::new();
    CACHE.get_or_init(|| match cache_dir() {
        Some(dir) => FieldCache::in_dir(dir.join("fields")),
        None => FieldCache::none(),
    })
}

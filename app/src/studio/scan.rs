//! An OBJ scan opened in the studio like a capture folder: `import scan`'s recipe (the scan seen
//! by a ring of virtual depth cameras, every frame with the scan's body fitting) writes a
//! capture into the studio's cache, never beside the scan. The capture is keyed by the scan and
//! its fitting (paths, sizes, modification times), so reopening a scan does not import it again
//! and an edited scan is imported afresh.

use crate::error::{Context, Result, StudioError};
use crate::studio::demo::cache_dir;
use avatar_core::capture::scan::{ScanViews, import_scan};
use std::hash::{Hash, Hasher};
use std::path::{Path, PathBuf};

/// Whether a path names an OBJ scan (by its extension).
pub fn is_scan(path: &Path) -> bool {
    path.extension().and_then(|e| e.to_str()).is_some_and(|e| e.eq_ignore_ascii_case("obj"))
}

/// The names a scan's body fitting (a pose JSON, as `import scan --fitting` takes) may have
/// beside it, in the order they are looked for.
pub fn fitting_names(scan: &Path) -> Vec<String> {
    let stem = scan.file_stem().and_then(|s| s.to_str()).unwrap_or("scan");
    vec![
        format!("{stem}.pose.json"),
        format!("{stem}.fitting.json"),
        format!("{stem}.json"),
        "pose.json".into(),
        "fitting.json".into(),
    ]
}

/// The scan's body fitting: the first of [`fitting_names`] that exists in the scan's folder.
pub fn fitting_beside(scan: &Path) -> Result<PathBuf> {
    let folder = scan.parent().unwrap_or(Path::new("."));
    let names = fitting_names(scan);
    names.iter().map(|n| folder.join(n)).find(|p| p.is_file()).ok_or_else(|| {
        StudioError::file(scan, format!("a scan needs its body fitting (a pose JSON, as `avatar-studio import scan --fitting` takes) beside it, named {}", names.join(", ")))
    })
}

/// Identity of a file's version: its full path, size and modification time.
fn hash_file(path: &Path, h: &mut impl Hasher) -> Result<()> {
    let meta = std::fs::metadata(path)
        .map_err(|e| StudioError::file(path, format!("cannot read it: {e}")))?;
    std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf()).hash(h);
    meta.len().hash(h);
    meta.modified().ok().hash(h);
    Ok(())
}

/// The capture folder of `scan` (imported into the cache on first use; the scan and its
/// fitting are only read). Errors name the file and the problem (`import_scan`'s checks: a
/// scan that is not an OBJ surface, in millimetres, or not on the fitted body).
pub fn scan_capture(scan: &Path) -> Result<PathBuf> {
    if !scan.is_file() {
        return Err(StudioError::file(scan, "no such scan file"));
    }
    let fitting = fitting_beside(scan)?;
    let mut h = std::collections::hash_map::DefaultHasher::new();
    hash_file(scan, &mut h)?;
    hash_file(&fitting, &mut h)?;
    let key = h.finish();
    let root = cache_dir();
    let dir = root.join(format!("scan-{key:016x}"));
    if dir.join("capture.json").is_file() {
        return Ok(dir);
    }
    // Imported beside its final name and renamed into place: an interrupted import leaves no
    // half capture under the final name.
    std::fs::create_dir_all(&root)
        .map_err(|e| StudioError::file(&root, format!("cannot create the cache folder: {e}")))?;
    let tmp = root.join(format!(".scan-{key:016x}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&tmp);
    let imported = import_scan(
        scan,
        &fitting,
        &tmp,
        avatar_core::body::open_body_ref(),
        &ScanViews::default(),
    );
    if let Err(e) = imported {
        let _ = std::fs::remove_dir_all(&tmp);
        return Err(e)
            .context(format!("Could not turn the scan {} into a capture", scan.display()));
    }
    if std::fs::rename(&tmp, &dir).is_err() {
        // Another studio imported the same scan meanwhile: use its capture.
        let _ = std::fs::remove_dir_all(&tmp);
        if !dir.join("capture.json").is_file() {
            return Err(StudioError::file(&dir, "cannot move the imported scan into place"));
        }
    }
    Ok(dir)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scans_are_told_by_their_extension_and_the_fitting_is_found_beside() {
        assert!(is_scan(Path::new("a/b/Person.OBJ")) && is_scan(Path::new("x.obj")));
        assert!(!is_scan(Path::new("capture")) && !is_scan(Path::new("pose.obj.json")));
        let dir = tempfile::tempdir().unwrap();
        let scan = dir.path().join("person.obj");
        let e = fitting_beside(&scan).unwrap_err().to_string();
        assert!(
            e.contains("person.obj") && e.contains("person.pose.json") && e.contains("pose.json"),
            "{e}"
        );
        std::fs::write(dir.path().join("pose.json"), "{}").unwrap();
        assert_eq!(fitting_beside(&scan).unwrap(), dir.path().join("pose.json"));
        std::fs::write(dir.path().join("person.json"), "{}").unwrap();
        assert_eq!(
            fitting_beside(&scan).unwrap(),
            dir.path().join("person.json"),
            "the scan's own fitting first"
        );
    }
}

//! The output-path guard: before a command (or the studio) writes, it checks that the output is
//! none of its inputs (the same file after resolving links, hard links included; any existing
//! file inside an input capture folder) and that the output's extension names what is written
//! (`export --out x.fbx` must not write glTF under an .fbx name). User data is never overwritten
//! by a slip of the command line.

use crate::error::{Error, Result};
use std::path::{Path, PathBuf};

/// What a command reads.
#[derive(Debug, Clone, Default)]
pub struct Inputs {
    files: Vec<PathBuf>,
    /// Capture folders: every existing file under them is input data.
    folders: Vec<PathBuf>,
}

impl Inputs {
    pub fn new() -> Inputs {
        Inputs::default()
    }

    /// An input file (a path that does not exist is kept: the command refuses it later).
    pub fn file(mut self, path: impl AsRef<Path>) -> Inputs {
        self.files.push(path.as_ref().to_path_buf());
        self
    }

    /// An optional input file.
    pub fn maybe_file(self, path: Option<impl AsRef<Path>>) -> Inputs {
        match path {
            Some(p) => self.file(p),
            None => self,
        }
    }

    /// A capture folder (or its capture.json): every file in it, and the SMPL model its manifest
    /// names when that lies outside the folder.
    pub fn capture(mut self, dir_or_manifest: impl AsRef<Path>) -> Inputs {
        let p = dir_or_manifest.as_ref();
        let dir = if p.is_file() {
            p.parent().unwrap_or(Path::new(".")).to_path_buf()
        } else {
            p.to_path_buf()
        };
        if let Some(model) = manifest_body_model(&dir) {
            self.files.push(model);
        }
        self.folders.push(dir);
        self
    }

    /// Refuse `out` as an output file: one of the inputs, inside an input capture folder, an
    /// existing folder, or an extension that is not one of `extensions` (lowercase, no dot).
    pub fn check_file(&self, out: &Path, extensions: &[&str]) -> Result<()> {
        let ext =
            out.extension().map(|e| e.to_string_lossy().to_ascii_lowercase()).unwrap_or_default();
        if !extensions.is_empty() && !extensions.contains(&ext.as_str()) {
            let want: Vec<String> = extensions.iter().map(|e| format!(".{e}")).collect();
            let got = if ext.is_empty() {
                "no extension".to_string()
            } else {
                format!("the extension .{ext}")
            };
            return Err(Error::file(
                out,
                format!(
                    "output has {got} but {} is written here: name it {}",
                    want.join(" or "),
                    want.join(" or ")
                ),
            ));
        }
        if out.is_dir() {
            return Err(Error::file(out, "output is a folder, a file is written here"));
        }
        self.check_not_input(out)
    }

    /// Refuse `out` as an output folder: an existing file, an input capture folder or a folder
    /// inside one. (Files written into it are checked with [`Inputs::check_file`].)
    pub fn check_folder(&self, out: &Path) -> Result<()> {
        if out.exists() && !out.is_dir() {
            return Err(Error::file(
                out,
                "output must be a folder but this is an existing file; refusing to replace it",
            ));
        }
        let resolved = resolve(out);
        for dir in &self.folders {
            if resolved.starts_with(resolve(dir)) {
                return Err(Error::file(
                    out,
                    format!(
                        "output folder lies in the input capture folder {}; refusing to write into input data",
                        dir.display()
                    ),
                ));
            }
        }
        Ok(())
    }

    fn check_not_input(&self, out: &Path) -> Result<()> {
        if !out.exists() {
            // A file that does not exist yet cannot be an input.
            return Ok(());
        }
        for input in &self.files {
            if same_file::is_same_file(out, input).unwrap_or(false) {
                return Err(Error::file(
                    out,
                    format!(
                        "output is the input {}; refusing to overwrite it (choose another output name)",
                        input.display()
                    ),
                ));
            }
        }
        let resolved = resolve(out);
        for dir in &self.folders {
            if resolved.starts_with(resolve(dir)) {
                return Err(Error::file(
                    out,
                    format!(
                        "output is a file of the input capture {}; refusing to overwrite capture data",
                        dir.display()
                    ),
                ));
            }
        }
        Ok(())
    }
}

/// The path with links resolved: the whole path when it exists, else its parent's (a new file
/// in a linked folder resolves to where it will be written).
fn resolve(p: &Path) -> PathBuf {
    if let Ok(c) = p.canonicalize() {
        return c;
    }
    match (p.parent().filter(|d| !d.as_os_str().is_empty()), p.file_name()) {
        (Some(parent), Some(name)) => resolve(parent).join(name),
        (None, Some(name)) => {
            std::env::current_dir().map(|d| d.join(name)).unwrap_or_else(|_| p.to_path_buf())
        }
        _ => p.to_path_buf(),
    }
}

/// The SMPL model file a capture's manifest names (None for the embedded body or an unreadable
/// manifest: opening the capture reports that).
fn manifest_body_model(dir: &Path) -> Option<PathBuf> {
    let path = dir.join(crate::capture::manifest::MANIFEST_FILE);
    if std::fs::metadata(&path).ok()?.len() > crate::capture::manifest::MAX_MANIFEST_BYTES {
        return None;
    }
    let value: serde_json::Value = serde_json::from_slice(&std::fs::read(&path).ok()?).ok()?;
    let name = value.get("body_model")?.as_str()?;
    if name.is_empty() || name == "open_body" {
        return None;
    }
    Some(if Path::new(name).is_absolute() { PathBuf::from(name) } else { dir.join(name) })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inputs_links_and_capture_files_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let cap = dir.path().join("cap");
        std::fs::create_dir_all(cap.join("depth")).unwrap();
        std::fs::write(cap.join("capture.json"), r#"{"body_model": "../smpl.npz"}"#).unwrap();
        std::fs::write(cap.join("depth/000001.png"), b"png").unwrap();
        std::fs::write(dir.path().join("smpl.npz"), b"npz").unwrap();
        let clip = dir.path().join("clip.json");
        std::fs::write(&clip, b"{}").unwrap();
        let link = dir.path().join("link.json");
        std::os::unix::fs::symlink(&clip, &link).unwrap();
        let inputs = Inputs::new().capture(&cap).file(&clip);
        for (out, ext) in [
            (cap.join("capture.json"), "json"),
            (cap.join("depth/000001.png"), "png"),
            (clip.clone(), "json"),
            (link, "json"),
            (dir.path().join("smpl.npz"), "npz"),
        ] {
            let e = inputs.check_file(&out, &[ext]).unwrap_err().to_string();
            assert!(e.contains(&*out.to_string_lossy()) && e.contains("refusing"), "{e}");
        }
        // New files, even next to the inputs, are fine; a wrong extension is not.
        inputs.check_file(&dir.path().join("a.avatar"), &["avatar"]).unwrap();
        inputs.check_file(&cap.join("new.avatar"), &["avatar"]).unwrap();
        let e = inputs.check_file(&dir.path().join("x.fbx"), &["glb"]).unwrap_err().to_string();
        assert!(e.contains("x.fbx") && e.contains(".glb"), "{e}");
        assert!(inputs.check_folder(&cap.join("depth")).is_err());
        assert!(inputs.check_folder(&clip).is_err());
        inputs.check_folder(&dir.path().join("meshes")).unwrap();
    }
}

//! A studio's own meta-training data: a folder of subjects, each in one or more outfits, each
//! outfit with capture folders (our format) and/or clothed scans with their body fittings.
//! Discovery walks the folder and checks every item once (the files read, the fitting of the
//! right body model, a scan that lies on its fitted body); an item that fails is refused by name
//! with the reason and the rest go on. docs/own-data.md describes the convention:
//!
//! ```text
//! DIR/
//!   <subject>/
//!     subject.json              optional: {"body_model": {"smpl": "path/to/SMPL.npz"}}, the
//!                               model the subject's scan fittings were made with
//!     <outfit>/
//!       <take>/capture.json     a capture folder (depth PNGs and fittings; it names its own
//!                               body model)
//!       <name>.obj + <name>.json  a clothed scan (metres, Y up) and its body fitting (pose file)
//! ```
//!
//! Names starting with a dot are skipped; other files (textures, .mtl) are ignored. One subject
//! has one body model: an item fitted with another than the subject's first item is refused.

pub mod check;

use crate::capture::manifest::BodyModelRef;
use crate::capture::open::load_body_model;
use crate::error::{Error, Result};
use serde::Deserialize;
use std::fmt;
use std::path::{Path, PathBuf};

/// The optional per-subject file.
pub const SUBJECT_FILE: &str = "subject.json";
/// A folder holding this is prepared meta-training data, not a folder of own data.
pub const PREPARED_MANIFEST: &str = "meta-data.json";

/// What an accepted item is.
#[derive(Debug, Clone, PartialEq)]
pub enum ItemKind {
    /// A capture folder with this many frames in its manifest.
    Capture { frames: usize },
    /// A clothed scan (OBJ) and its fitting (JSON pose file).
    Scan { fitting: PathBuf, vertices: usize, faces: usize },
}

/// One checked item: a capture folder or a scan.
#[derive(Debug, Clone, PartialEq)]
pub struct Item {
    /// The capture folder or the OBJ file.
    pub path: PathBuf,
    pub kind: ItemKind,
    /// The SMPL model of its fittings (`None`: the embedded open body).
    pub body_file: Option<PathBuf>,
}

/// Items of one subject in one outfit: a meta-training group.
#[derive(Debug, Clone, PartialEq)]
pub struct OutfitGroup {
    pub subject: String,
    pub outfit: String,
    pub items: Vec<Item>,
}

/// An item (or a subject's file) left out, with the reason.
#[derive(Debug, Clone, PartialEq)]
pub struct Refused {
    pub path: PathBuf,
    pub reason: String,
}

impl fmt::Display for Refused {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.path.display(), self.reason)
    }
}

impl Refused {
    pub fn of(path: &Path, e: &impl fmt::Display) -> Refused {
        // The error usually names the file already; keep only the problem then.
        let text = e.to_string();
        let prefix = format!("{}: ", path.display());
        let reason = text.strip_prefix(&prefix).map(str::to_string).unwrap_or(text);
        Refused { path: path.to_path_buf(), reason }
    }
}

/// What a data folder holds.
#[derive(Debug, Clone, PartialEq)]
pub struct Discovery {
    pub root: PathBuf,
    /// Groups with at least one accepted item, subjects and outfits in name order.
    pub groups: Vec<OutfitGroup>,
    pub refused: Vec<Refused>,
}

impl Discovery {
    pub fn items(&self) -> usize {
        self.groups.iter().map(|g| g.items.len()).sum()
    }

    pub fn subjects(&self) -> usize {
        let mut names: Vec<&str> = self.groups.iter().map(|g| g.subject.as_str()).collect();
        names.dedup();
        names.len()
    }

    /// What was found, per subject and outfit, then every refused item with its reason.
    pub fn summary(&self) -> String {
        let mut s = format!(
            "{}: {} subjects, {} subject-outfit groups, {} items accepted, {} refused\n",
            self.root.display(),
            self.subjects(),
            self.groups.len(),
            self.items(),
            self.refused.len()
        );
        for g in &self.groups {
            let (mut captures, mut frames, mut scans) = (0, 0, 0);
            for item in &g.items {
                match item.kind {
                    ItemKind::Capture { frames: n } => {
                        captures += 1;
                        frames += n;
                    }
                    ItemKind::Scan { .. } => scans += 1,
                }
            }
            let body = match g.items.first().and_then(|i| i.body_file.as_ref()) {
                Some(f) => format!("SMPL model {}", f.display()),
                None => "open body".to_string(),
            };
            s += &format!(
                "  {} / {}: {captures} captures ({frames} frames), {scans} scans; {body}\n",
                g.subject, g.outfit
            );
        }
        if !self.refused.is_empty() {
            s += "refused:\n";
            for r in &self.refused {
                s += &format!("  {r}\n");
            }
        }
        s
    }
}

/// Whether `dir` is a folder of own data: a folder with at least one subfolder and no prepared
/// meta-training data (`meta-data.json`) in it.
pub fn looks_like_own_data(dir: &Path) -> bool {
    if !dir.is_dir() || dir.join(PREPARED_MANIFEST).exists() {
        return false;
    }
    sorted_entries(dir).is_ok_and(|e| e.iter().any(|p| p.is_dir()))
}

#[derive(Deserialize)]
struct SubjectFile {
    #[serde(default)]
    body_model: BodyModelRef,
}

/// Walk `root` (see the module's documentation). Errors only when `root` cannot be read or
/// holds no subject folder; every bad item is a [`Refused`] entry.
pub fn discover(root: &Path) -> Result<Discovery> {
    if root.join(crate::capture::MANIFEST_FILE).is_file() {
        return Err(Error::file(
            root,
            "this is one capture folder; own data is a folder of subjects: DIR/<subject>/<outfit>/<capture> (docs/own-data.md)",
        ));
    }
    let subjects: Vec<PathBuf> = sorted_entries(root)?.into_iter().filter(|p| p.is_dir()).collect();
    if subjects.is_empty() {
        return Err(Error::file(
            root,
            "no subject folders: own data is laid out as DIR/<subject>/<outfit>/ with capture folders or NAME.obj + NAME.json scans (docs/own-data.md)",
        ));
    }
    let mut found = Discovery { root: root.to_path_buf(), groups: Vec::new(), refused: Vec::new() };
    for subject_dir in subjects {
        discover_subject(&subject_dir, &mut found);
    }
    Ok(found)
}

fn discover_subject(dir: &Path, found: &mut Discovery) {
    let subject = file_name(dir);
    let refuse = |found: &mut Discovery, path: &Path, reason: String| {
        found.refused.push(Refused { path: path.to_path_buf(), reason })
    };
    // The scans' body model (captures name their own).
    let subject_file = dir.join(SUBJECT_FILE);
    let scan_body_file = if subject_file.is_file() {
        match read_subject_file(&subject_file) {
            Ok(r) => r.resolve(dir),
            Err(e) => return skip_subject(found, &subject_file, &e),
        }
    } else {
        None
    };
    let scan_body = match load_body_model(
        scan_body_file.as_deref(),
        &format!("named in {}", subject_file.display()),
    ) {
        Ok(b) => b,
        Err(e) => return skip_subject(found, &subject_file, &e),
    };
    let outfits = match sorted_entries(dir) {
        Ok(e) => e.into_iter().filter(|p| p.is_dir()).collect::<Vec<_>>(),
        Err(e) => return refuse(found, dir, e.to_string()),
    };
    if outfits.is_empty() {
        return refuse(found, dir, "no outfit folders in the subject folder".into());
    }
    // The subject's body model: its first accepted item's.
    let mut subject_body: Option<Option<PathBuf>> = None;
    for outfit_dir in outfits {
        let mut group = OutfitGroup {
            subject: subject.clone(),
            outfit: file_name(&outfit_dir),
            items: Vec::new(),
        };
        let entries = match sorted_entries(&outfit_dir) {
            Ok(e) => e,
            Err(e) => {
                refuse(found, &outfit_dir, e.to_string());
                continue;
            }
        };
        let before = found.refused.len();
        for path in &entries {
            let item = if path.is_dir() {
                if !path.join(crate::capture::MANIFEST_FILE).is_file() {
                    refuse(
                        found,
                        path,
                        "not a capture folder (no capture.json); scans lie in the outfit folder as NAME.obj with NAME.json".into(),
                    );
                    continue;
                }
                check::capture(path)
            } else if has_extension(path, "obj") {
                let fitting = path.with_extension("json");
                if !fitting.is_file() {
                    refuse(
                        found,
                        path,
                        format!(
                            "a scan without its body fitting: expected {} beside it",
                            file_name(&fitting)
                        ),
                    );
                    continue;
                }
                check::scan(path, &fitting, &scan_body, scan_body_file.as_deref())
            } else if has_extension(path, "json") {
                if !entries.iter().any(|p| {
                    p.is_file() && has_extension(p, "obj") && p.with_extension("json") == *path
                }) {
                    refuse(
                        found,
                        path,
                        "a fitting without its scan: no OBJ of the same name beside it".into(),
                    );
                }
                continue;
            } else {
                continue;
            };
            match item {
                Ok(item) => {
                    let first = subject_body.get_or_insert_with(|| item.body_file.clone());
                    if *first != item.body_file {
                        let name = |b: &Option<PathBuf>| match b {
                            Some(f) => format!("the SMPL model {}", f.display()),
                            None => "the open body".to_string(),
                        };
                        refuse(
                            found,
                            path,
                            format!(
                                "fitted with {} but the subject's first item with {}: one subject, one body model",
                                name(&item.body_file),
                                name(first)
                            ),
                        );
                        continue;
                    }
                    group.items.push(item);
                }
                Err(e) => found.refused.push(Refused::of(path, &e)),
            }
        }
        if group.items.is_empty() {
            if found.refused.len() == before {
                refuse(
                    found,
                    &outfit_dir,
                    "no capture folders or scans in the outfit folder".into(),
                );
            }
        } else {
            found.groups.push(group);
        }
    }
}

fn skip_subject(found: &mut Discovery, subject_file: &Path, e: &Error) {
    let mut r = Refused::of(subject_file, e);
    r.reason += "; the subject's items are skipped";
    found.refused.push(r);
}

fn read_subject_file(path: &Path) -> Result<BodyModelRef> {
    let size = std::fs::metadata(path).map_err(|e| Error::io(path, e))?.len();
    if size > 1 << 20 {
        return Err(Error::file(path, "over 1 MB: not a subject file"));
    }
    let text = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    let file: SubjectFile = serde_json::from_slice(&text).map_err(|e| {
        Error::file(
            path,
            format!("not a subject file ({e}); expected {{\"body_model\": {{\"smpl\": PATH}}}}"),
        )
    })?;
    Ok(file.body_model)
}

/// Entries of a folder in name order, names starting with a dot left out.
fn sorted_entries(dir: &Path) -> Result<Vec<PathBuf>> {
    let mut out = Vec::new();
    for entry in std::fs::read_dir(dir).map_err(|e| Error::io(dir, e))? {
        let entry = entry.map_err(|e| Error::io(dir, e))?;
        if !entry.file_name().to_string_lossy().starts_with('.') {
            out.push(entry.path());
        }
    }
    out.sort();
    Ok(out)
}

fn file_name(p: &Path) -> String {
    p.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default()
}

fn has_extension(p: &Path, ext: &str) -> bool {
    p.extension().is_some_and(|e| e.eq_ignore_ascii_case(ext))
}

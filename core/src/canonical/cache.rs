//! On-disk cache of skinning fields, keyed by a hash of the body's rest surface, its skinning
//! weights (two models with one template but other weights differ) and the build options. Stored compactly: the 6 largest weights of each node (joint u8 + weight u16).
//! A corrupt or stale cache file is rebuilt, never trusted and never a panic. The folder is the
//! caller's choice, passed in ([`FieldCache`]); the program picks it once (avatar-studio:
//! `$XDG_CACHE_HOME/avatar-studio/fields`, `app/src/cache.rs`).

use super::field::{FieldOptions, SkinningField};
use crate::body::{BodyModel, NUM_JOINTS};
use crate::error::{Error, Result};
use glam::Vec3;
use std::hash::{Hash, Hasher};
use std::path::{Path, PathBuf};

const MAGIC: &[u8; 4] = b"ASSF";
const VERSION: u32 = 1;
const TOP: usize = 6;

/// Where skinning fields are kept between runs, chosen by the program and passed down to
/// whatever builds a field (opening a capture, loading an avatar, the evaluation). A field read
/// from or written to the cache is its compact form, so every run with one cache fits and
/// poses the same avatar; [`FieldCache::none`] builds every field at full precision.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct FieldCache(Option<PathBuf>);

impl FieldCache {
    /// No cache: every field is built.
    pub fn none() -> FieldCache {
        FieldCache(None)
    }

    /// Fields cached in `dir` (created when first written).
    pub fn in_dir(dir: impl Into<PathBuf>) -> FieldCache {
        FieldCache(Some(dir.into()))
    }

    pub fn dir(&self) -> Option<&Path> {
        self.0.as_deref()
    }
}

fn key(rest: &[Vec3], body: &BodyModel, options: &FieldOptions) -> u64 {
    // FNV-1a over the exact bytes: stable across runs and platforms (unlike DefaultHasher seeds).
    struct Fnv(u64);
    impl Hasher for Fnv {
        fn finish(&self) -> u64 {
            self.0
        }
        fn write(&mut self, bytes: &[u8]) {
            for b in bytes {
                self.0 = (self.0 ^ *b as u64).wrapping_mul(0x100_0000_01b3);
            }
        }
    }
    let mut h = Fnv(0xcbf2_9ce4_8422_2325);
    for p in rest {
        p.to_array().map(f32::to_bits).hash(&mut h);
    }
    body.faces.hash(&mut h);
    for w in &body.weights {
        w.map(f32::to_bits).hash(&mut h);
    }
    (
        options.cells_along_height,
        options.margin.to_bits(),
        options.fixed_band.to_bits(),
        options.smoothing_iterations,
    )
        .hash(&mut h);
    VERSION.hash(&mut h);
    h.finish()
}

/// The field for this body shape: from the cache when present and valid, else built and cached.
/// Returns the field and a warning when a cache file had to be discarded.
pub fn cached_field(
    body: &BodyModel,
    rest: &[Vec3],
    options: &FieldOptions,
    cache_dir: Option<&Path>,
) -> Result<(SkinningField, Option<String>)> {
    let Some(dir) = cache_dir else {
        return Ok((SkinningField::build(body, rest, options)?, None));
    };
    let path = dir.join(format!("skinning-field-{:016x}.bin", key(rest, body, options)));
    let mut warning = None;
    if path.exists() {
        match read_field(&path) {
            Ok(f) => return Ok((f, None)),
            Err(e) => {
                warning = Some(format!("discarded a bad skinning-field cache ({e}); rebuilding"))
            }
        }
    }
    let built = SkinningField::build(body, rest, options)?;
    // The field returned is the cache's compact form, the one a later run reads back: a first
    // run and every later one fit the same avatar (with the full-precision field the first run
    // of a capture differed from the rest).
    let bytes = encode(&built);
    let field = decode(&bytes, &path)?;
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    // Caching is an optimisation: failing to write the cache is not an error for the user.
    if let Err(e) = crate::io::write_bytes_atomic(&path, &bytes) {
        warning = Some(format!("could not write the skinning-field cache: {e}"));
    }
    Ok((field, warning))
}

/// A field in the cache's compact form.
fn encode(f: &SkinningField) -> Vec<u8> {
    let mut out = Vec::with_capacity(64 + f.num_nodes() * TOP * 3);
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&VERSION.to_le_bytes());
    for d in f.dims {
        out.extend_from_slice(&(d as u32).to_le_bytes());
    }
    for v in f.origin.to_array().into_iter().chain([f.cell]) {
        out.extend_from_slice(&v.to_le_bytes());
    }
    for w in f.weights.chunks_exact(NUM_JOINTS) {
        let mut idx: Vec<usize> = (0..NUM_JOINTS).collect();
        idx.sort_by(|&a, &b| w[b].total_cmp(&w[a]));
        for &j in &idx[..TOP] {
            out.push(j as u8);
            out.extend_from_slice(&((w[j].clamp(0.0, 1.0) * 65535.0).round() as u16).to_le_bytes());
        }
    }
    out
}

pub fn read_field(path: &Path) -> Result<SkinningField> {
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    decode(&bytes, path)
}

/// A field from the cache's compact form (`path`: the file it stands for, in errors).
fn decode(bytes: &[u8], path: &Path) -> Result<SkinningField> {
    let bad = |m: &str| Error::file(path, m.to_string());
    if bytes.len() < 36 || &bytes[..4] != MAGIC {
        return Err(bad("not a skinning-field cache file"));
    }
    let u32_at = |o: usize| u32::from_le_bytes(bytes[o..o + 4].try_into().unwrap());
    let f32_at = |o: usize| f32::from_le_bytes(bytes[o..o + 4].try_into().unwrap());
    if u32_at(4) != VERSION {
        return Err(bad("skinning-field cache of another version"));
    }
    let dims = [u32_at(8) as usize, u32_at(12) as usize, u32_at(16) as usize];
    let origin = Vec3::new(f32_at(20), f32_at(24), f32_at(28));
    let cell = f32_at(32);
    let n = dims.iter().product::<usize>();
    if dims.iter().any(|&d| !(2..=4096).contains(&d))
        || !(cell > 0.0)
        || !origin.is_finite()
        || bytes.len() != 36 + n * TOP * 3
    {
        return Err(bad("truncated or inconsistent skinning-field cache"));
    }
    let mut weights = vec![0f32; n * NUM_JOINTS];
    for (i, node) in bytes[36..].chunks_exact(TOP * 3).enumerate() {
        let mut sum = 0.0;
        for e in node.chunks_exact(3) {
            let j = e[0] as usize;
            if j >= NUM_JOINTS {
                return Err(bad("joint index out of range in the skinning-field cache"));
            }
            let w = u16::from_le_bytes([e[1], e[2]]) as f32 / 65535.0;
            weights[i * NUM_JOINTS + j] += w;
            sum += w;
        }
        if sum > 0.0 {
            weights[i * NUM_JOINTS..(i + 1) * NUM_JOINTS].iter_mut().for_each(|w| *w /= sum);
        }
    }
    Ok(SkinningField { origin, cell, dims, weights })
}

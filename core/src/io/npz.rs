//! Reading numeric arrays from numpy `.npz` archives (SMPL models, AMASS fittings).
//! Any float or integer dtype is accepted and converted; Fortran order is handled; errors name
//! the file and the key.

use crate::error::{Error, Result};
use npyz::{DType, Order, TypeChar, npz::NpzArchive};
use std::io::{Cursor, Read, Seek};
use std::path::{Path, PathBuf};

/// Largest array read (values): SMPL-X's pose blend shapes (10475 x 3 x 486) fit.
pub const MAX_ARRAY_VALUES: usize = 1 << 24;

/// A numeric array read from an npz: values in C (row-major) order plus its shape.
#[derive(Debug, Clone)]
pub struct Array {
    pub shape: Vec<usize>,
    pub data: Vec<f64>,
}

impl Array {
    pub fn len(&self) -> usize {
        self.data.len()
    }
    pub fn is_empty(&self) -> bool {
        self.data.is_empty()
    }
}

/// An open npz archive that remembers where it came from for error messages.
pub struct Npz<R: Read + Seek> {
    archive: NpzArchive<R>,
    origin: PathBuf,
}

impl Npz<std::io::BufReader<std::fs::File>> {
    pub fn open(path: impl AsRef<Path>) -> Result<Self> {
        let path = path.as_ref();
        let archive = NpzArchive::open(path).map_err(|e| {
            if e.kind() == std::io::ErrorKind::NotFound {
                Error::io(path, e)
            } else {
                Error::file(path, format!("not a readable .npz archive ({e})"))
            }
        })?;
        Ok(Npz { archive, origin: path.to_path_buf() })
    }
}

impl<'a> Npz<Cursor<&'a [u8]>> {
    pub fn from_bytes(bytes: &'a [u8], origin: impl AsRef<Path>) -> Result<Self> {
        let archive = NpzArchive::new(Cursor::new(bytes))
            .map_err(|e| Error::file(&origin, format!("not a readable .npz archive ({e})")))?;
        Ok(Npz { archive, origin: origin.as_ref().to_path_buf() })
    }
}

impl<R: Read + Seek> Npz<R> {
    pub fn origin(&self) -> &Path {
        &self.origin
    }

    pub fn names(&self) -> Vec<String> {
        self.archive.array_names().map(str::to_owned).collect()
    }

    pub fn has(&self, key: &str) -> bool {
        self.archive.array_names().any(|n| n == key)
    }

    /// Read a numeric array, or `None` if the key is absent.
    pub fn get(&mut self, key: &str) -> Result<Option<Array>> {
        let origin = self.origin.clone();
        let bad = |msg: String| Error::file(&origin, format!("array '{key}': {msg}"));
        let Some(file) = self.archive.by_name(key).map_err(|e| bad(format!("unreadable ({e})")))?
        else {
            return Ok(None);
        };
        let shape: Vec<usize> = file.shape().iter().map(|&d| d as usize).collect();
        // The header's shape is checked before anything is inflated (a small zip entry can
        // claim gigabytes).
        let expected = shape
            .iter()
            .try_fold(1usize, |a, &d| a.checked_mul(d))
            .filter(|&n| n <= MAX_ARRAY_VALUES);
        let Some(expected) = expected else {
            return Err(bad(format!(
                "shape {shape:?} is larger than any model or motion array ({MAX_ARRAY_VALUES} values at most)"
            )));
        };
        let order = file.order();
        let DType::Plain(ts) = file.dtype() else {
            return Err(bad("structured dtype is not a numeric array".into()));
        };
        let bytes = ts.num_bytes().unwrap_or(0);
        let data: Vec<f64> = match (ts.type_char(), bytes) {
            (TypeChar::Float, 8) => {
                file.into_vec::<f64>().map_err(|e| bad(format!("truncated or corrupt ({e})")))?
            }
            (TypeChar::Float, 4) => conv(file.into_vec::<f32>(), &bad)?,
            (TypeChar::Float, 2) => {
                return Err(bad("float16 is not supported; save as float32".into()));
            }
            (TypeChar::Int, 8) => conv(
                file.into_vec::<i64>()
                    .map(|v| v.into_iter().map(|x| x as f64).collect::<Vec<f64>>()),
                &bad,
            )?,
            (TypeChar::Int, 4) => conv(file.into_vec::<i32>(), &bad)?,
            (TypeChar::Int, 2) => conv(file.into_vec::<i16>(), &bad)?,
            (TypeChar::Int, 1) => conv(file.into_vec::<i8>(), &bad)?,
            (TypeChar::Uint, 8) => conv(
                file.into_vec::<u64>()
                    .map(|v| v.into_iter().map(|x| x as f64).collect::<Vec<f64>>()),
                &bad,
            )?,
            (TypeChar::Uint, 4) => conv(file.into_vec::<u32>(), &bad)?,
            (TypeChar::Uint, 2) => conv(file.into_vec::<u16>(), &bad)?,
            (TypeChar::Uint, 1) => conv(file.into_vec::<u8>(), &bad)?,
            (TypeChar::Bool, _) => conv(
                file.into_vec::<bool>()
                    .map(|v| v.into_iter().map(|b| b as u8 as f64).collect::<Vec<f64>>()),
                &bad,
            )?,
            (TypeChar::Object, _) => {
                return Err(bad("pickled object array; convert it to a numeric array".into()));
            }
            (other, _) => return Err(bad(format!("unsupported dtype {other:?}"))),
        };
        if data.len() != expected {
            return Err(bad(format!(
                "holds {} values but its shape {shape:?} needs {expected}",
                data.len()
            )));
        }
        let data = match order {
            Order::C => data,
            Order::Fortran => fortran_to_c(&data, &shape),
        };
        Ok(Some(Array { shape, data }))
    }

    /// Read a numeric array that must be present.
    pub fn require(&mut self, key: &str) -> Result<Array> {
        self.get(key)?.ok_or_else(|| {
            Error::file(
                &self.origin,
                format!("missing array '{key}' (found: {})", self.names().join(", ")),
            )
        })
    }

    /// Read a string array (AMASS `gender`), if present and textual.
    pub fn get_string(&mut self, key: &str) -> Option<String> {
        let file = self.archive.by_name(key).ok()??;
        let DType::Plain(ts) = file.dtype() else { return None };
        match ts.type_char() {
            TypeChar::UnicodeStr => file.into_vec::<String>().ok()?.into_iter().next(),
            TypeChar::ByteStr | TypeChar::RawData => {
                let v = file.into_vec::<Vec<u8>>().ok()?;
                v.into_iter()
                    .next()
                    .map(|b| String::from_utf8_lossy(&b).trim_end_matches('\0').to_string())
            }
            _ => None,
        }
    }
}

fn conv<T: Into<f64>>(
    r: std::io::Result<Vec<T>>,
    bad: &dyn Fn(String) -> Error,
) -> Result<Vec<f64>> {
    r.map(|v| v.into_iter().map(Into::into).collect())
        .map_err(|e| bad(format!("truncated or corrupt ({e})")))
}

fn fortran_to_c(data: &[f64], shape: &[usize]) -> Vec<f64> {
    let n = data.len();
    let mut out = vec![0.0; n];
    let rank = shape.len();
    let mut idx = vec![0usize; rank];
    for (f_index, &value) in data.iter().enumerate() {
        // Decompose the Fortran index (first axis fastest), then compose the C index.
        let mut rem = f_index;
        for (a, &dim) in shape.iter().enumerate() {
            idx[a] = rem % dim.max(1);
            rem /= dim.max(1);
        }
        let mut c_index = 0;
        for (a, &dim) in shape.iter().enumerate() {
            c_index = c_index * dim + idx[a];
        }
        out[c_index] = value;
    }
    out
}

/// Write float32 arrays to an npz archive (atomic). Byte-reproducible: fixed zip timestamps,
/// no compression, so the same arrays always give the same file.
pub fn write_f32_npz(
    path: impl AsRef<Path>,
    arrays: &[(&str, Vec<usize>, Vec<f32>)],
) -> Result<()> {
    use npyz::WriterBuilder;
    let path = path.as_ref();
    crate::io::write_atomic(path, |w| {
        let mut buf = Cursor::new(Vec::new());
        {
            let mut npz = npyz::npz::NpzWriter::new(&mut buf);
            for (name, shape, data) in arrays {
                let shape: Vec<u64> = shape.iter().map(|&d| d as u64).collect();
                let mut writer = npz
                    .array::<f32>(name, npz_entry_options())?
                    .default_dtype()
                    .shape(&shape)
                    .begin_nd()?;
                writer.extend(data.iter().copied())?;
                writer.finish()?;
            }
        }
        std::io::Write::write_all(w, &buf.into_inner())
    })
}

fn npz_entry_options() -> npyz::zip::write::FileOptions {
    npyz::zip::write::FileOptions::default()
        .compression_method(npyz::zip::CompressionMethod::Stored)
        .last_modified_time(npyz::zip::DateTime::default())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fortran_order_is_transposed_to_c() {
        // 2x3 matrix [[0,1,2],[3,4,5]] stored column-major is 0,3,1,4,2,5.
        let f = [0.0, 3.0, 1.0, 4.0, 2.0, 5.0];
        assert_eq!(fortran_to_c(&f, &[2, 3]), vec![0.0, 1.0, 2.0, 3.0, 4.0, 5.0]);
    }

    #[test]
    fn f32_round_trip_and_missing_key_named() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.npz");
        write_f32_npz(&path, &[("x", vec![2, 2], vec![1.0, 2.0, 3.0, 4.5])]).unwrap();
        let mut npz = Npz::open(&path).unwrap();
        let a = npz.require("x").unwrap();
        assert_eq!(a.shape, vec![2, 2]);
        assert_eq!(a.data, vec![1.0, 2.0, 3.0, 4.5]);
        let err = npz.require("y").unwrap_err().to_string();
        assert!(err.contains("a.npz") && err.contains("'y'"), "{err}");
    }
}

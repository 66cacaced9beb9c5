//! 16-bit depth PNGs: value / depth_scale = metres along the optical axis, 0 = no measurement.

use crate::error::{Error, Result};
use image::{ImageBuffer, Luma};
use std::path::Path;

/// A decoded depth image in metres (0 = no depth), row-major.
#[derive(Debug, Clone, PartialEq)]
pub struct DepthImage {
    pub width: u32,
    pub height: u32,
    pub metres: Vec<f32>,
}

impl DepthImage {
    pub fn at(&self, u: u32, v: u32) -> f32 {
        self.metres[(v * self.width + u) as usize]
    }

    /// Number of pixels with a measurement.
    pub fn valid_pixels(&self) -> usize {
        self.metres.iter().filter(|&&z| z > 0.0).count()
    }
}

/// Write depths in metres as a 16-bit PNG (atomic). Depths that do not fit in 16 bits at this
/// scale are an error rather than silently clipped.
pub fn write_depth_png(
    path: impl AsRef<Path>,
    metres: &[f32],
    width: u32,
    height: u32,
    depth_scale: f32,
) -> Result<()> {
    let path = path.as_ref();
    if metres.len() != (width * height) as usize {
        return Err(Error::invalid(format!(
            "{}: {} depth values for a {width}x{height} image",
            path.display(),
            metres.len()
        )));
    }
    let mut raw = Vec::with_capacity(metres.len());
    for (i, &z) in metres.iter().enumerate() {
        let v = if z > 0.0 && z.is_finite() { (z * depth_scale).round() } else { 0.0 };
        if v > u16::MAX as f32 {
            return Err(Error::invalid(format!(
                "{}: depth {z} m at pixel {} does not fit in 16 bits at depth scale {depth_scale}",
                path.display(),
                i
            )));
        }
        raw.push(v as u16);
    }
    let img: ImageBuffer<Luma<u16>, Vec<u16>> =
        ImageBuffer::from_raw(width, height, raw).expect("size checked above");
    let mut bytes = Vec::new();
    img.write_to(&mut std::io::Cursor::new(&mut bytes), image::ImageFormat::Png)
        .map_err(|e| Error::file(path, format!("cannot encode PNG: {e}")))?;
    crate::io::write_bytes_atomic(path, &bytes)
}

/// Open a PNG and check its size from the header before anything is decoded: the image must be
/// `expected` (width, height) when given, and within the capture limits always.
fn open_png(
    path: &Path,
    expected: Option<(u32, u32)>,
    what: &str,
) -> Result<image::codecs::png::PngDecoder<std::io::BufReader<std::fs::File>>> {
    use crate::capture::manifest::{MAX_IMAGE_PIXELS, MAX_IMAGE_SIDE};
    use image::ImageDecoder;
    let file = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
    let decoder = image::codecs::png::PngDecoder::new(std::io::BufReader::new(file))
        .map_err(|e| Error::file(path, format!("not a readable PNG {what}: {e}")))?;
    let (w, h) = decoder.dimensions();
    if let Some((ew, eh)) = expected
        && (w, h) != (ew, eh)
    {
        return Err(Error::file(
            path,
            format!("image is {w}x{h}, the capture's intrinsics say {ew}x{eh}"),
        ));
    }
    if w > MAX_IMAGE_SIDE || h > MAX_IMAGE_SIDE || w as u64 * h as u64 > MAX_IMAGE_PIXELS {
        return Err(Error::file(
            path,
            format!(
                "image is {w}x{h}: larger than a capture image may be ({MAX_IMAGE_PIXELS} pixels, {MAX_IMAGE_SIDE} a side)"
            ),
        ));
    }
    Ok(decoder)
}

/// Read a 16-bit depth PNG. 8-bit or colour images are refused: they cannot hold depth.
pub fn read_depth_png(path: impl AsRef<Path>, depth_scale: f32) -> Result<DepthImage> {
    read_depth_png_sized(path, depth_scale, None)
}

/// [`read_depth_png`] for an image that must be `expected` (width, height): the size is read
/// from the PNG header first, so an oversized image is refused before it is decoded.
pub fn read_depth_png_sized(
    path: impl AsRef<Path>,
    depth_scale: f32,
    expected: Option<(u32, u32)>,
) -> Result<DepthImage> {
    let path = path.as_ref();
    let decoder = open_png(path, expected, "depth image")?;
    let img = image::DynamicImage::from_decoder(decoder)
        .map_err(|e| Error::file(path, format!("not a readable PNG depth image: {e}")))?;
    let img = match img {
        image::DynamicImage::ImageLuma16(g) => g,
        other => {
            return Err(Error::file(
                path,
                format!(
                    "depth images must be 16-bit single-channel PNGs, this one is {:?}",
                    other.color()
                ),
            ));
        }
    };
    let (width, height) = img.dimensions();
    let metres = img.into_raw().into_iter().map(|v| v as f32 / depth_scale).collect();
    Ok(DepthImage { width, height, metres })
}

/// Read an optional 8-bit (or 16-bit) mask: non-zero = person.
pub fn read_mask_png(path: impl AsRef<Path>) -> Result<(u32, u32, Vec<bool>)> {
    read_mask_png_sized(path, None)
}

/// [`read_mask_png`] for a mask that must be `expected` (width, height), checked before decoding.
pub fn read_mask_png_sized(
    path: impl AsRef<Path>,
    expected: Option<(u32, u32)>,
) -> Result<(u32, u32, Vec<bool>)> {
    let path = path.as_ref();
    let decoder = open_png(path, expected, "mask image")?;
    let img = image::DynamicImage::from_decoder(decoder)
        .map_err(|e| Error::file(path, format!("not a readable mask image: {e}")))?;
    let g = img.to_luma16();
    let (w, h) = g.dimensions();
    Ok((w, h, g.into_raw().into_iter().map(|v| v > 0).collect()))
}

/// Write a mask as an 8-bit PNG (atomic).
pub fn write_mask_png(
    path: impl AsRef<Path>,
    mask: &[bool],
    width: u32,
    height: u32,
) -> Result<()> {
    let path = path.as_ref();
    let raw: Vec<u8> = mask.iter().map(|&m| if m { 255 } else { 0 }).collect();
    let img: ImageBuffer<Luma<u8>, Vec<u8>> = ImageBuffer::from_raw(width, height, raw)
        .ok_or_else(|| Error::invalid(format!("{}: mask size mismatch", path.display())))?;
    let mut bytes = Vec::new();
    img.write_to(&mut std::io::Cursor::new(&mut bytes), image::ImageFormat::Png)
        .map_err(|e| Error::file(path, format!("cannot encode PNG: {e}")))?;
    crate::io::write_bytes_atomic(path, &bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_at_mm_and_tum_scale() {
        let dir = tempfile::tempdir().unwrap();
        let depth = vec![0.0, 1.2345, 2.5, 9.0, 0.0, 3.3331];
        for scale in [1000.0, 5000.0] {
            let p = dir.path().join(format!("d{scale}.png"));
            write_depth_png(&p, &depth, 3, 2, scale).unwrap();
            let back = read_depth_png(&p, scale).unwrap();
            assert_eq!((back.width, back.height), (3, 2));
            for (a, b) in depth.iter().zip(&back.metres) {
                assert!((a - b).abs() <= 0.5 / scale + 1e-6, "{a} vs {b}");
            }
            assert_eq!(back.valid_pixels(), 4);
        }
        // 20 m does not fit at the TUM scale (65535 / 5000 = 13.1 m).
        let err = write_depth_png(dir.path().join("far.png"), &[20.0], 1, 1, 5000.0)
            .unwrap_err()
            .to_string();
        assert!(err.contains("16 bits"), "{err}");
    }

    #[test]
    fn corrupt_and_8bit_images_are_refused_by_name() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("corrupt.png");
        std::fs::write(&p, b"\x89PNG\r\n\x1a\nthis is not a png").unwrap();
        let err = read_depth_png(&p, 1000.0).unwrap_err().to_string();
        assert!(err.contains("corrupt.png") && err.contains("PNG"), "{err}");
        let p8 = dir.path().join("eight.png");
        write_mask_png(&p8, &[true, false], 2, 1).unwrap();
        let err = read_depth_png(&p8, 1000.0).unwrap_err().to_string();
        assert!(err.contains("eight.png") && err.contains("16-bit"), "{err}");
        let err = read_depth_png(dir.path().join("missing.png"), 1000.0).unwrap_err().to_string();
        assert!(err.contains("missing.png"), "{err}");
    }
}

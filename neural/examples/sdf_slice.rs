//! A vertical slice of an avatar's canonical SDF (zero pose) as a PNG: inside dark, outside
//! light, the zero level black, 1 pixel = 5 mm. Shows how thick a garment's walls are.
//!   cargo run --example sdf_slice -- AVATAR OUT.png [z|x|y] [OFFSET_M] [CAPTURE FRAME]
//! (y: a horizontal slice seen from above, the body's front down the image).
//! With CAPTURE and FRAME: the SDF conditioned on that frame's pose (a training pose) instead.
use avatar_core::body::BodyParams;
use avatar_core::canonical::FieldCache;
use avatar_neural::MetaAvatar;
use glam::Vec3;

/// Where these runs cache skinning fields (a fixed folder under the temporary directory).
fn field_cache() -> FieldCache {
    FieldCache::in_dir(std::env::temp_dir().join("avatar-studio-fields"))
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let avatar = MetaAvatar::load(&args[1], &field_cache())?;
    let axis = args.get(3).map_or("z", |s| s.as_str());
    let offset: f32 = args.get(4).and_then(|s| s.parse().ok()).unwrap_or(0.0);
    let params = match (args.get(5), args.get(6)) {
        (Some(capture), Some(frame)) => {
            let capture = avatar_core::capture::Capture::open(capture)?;
            let frame: usize = frame.parse()?;
            BodyParams {
                betas: avatar.header.betas.clone(),
                ..capture.frames[frame].params.clone()
            }
        }
        _ => BodyParams { betas: avatar.header.betas.clone(), ..Default::default() },
    };
    let sdf = avatar.sdf_at(&params);
    let centre = avatar.header.normalisation.centre;
    let (w, h, px) = (240usize, 400usize, 0.005f32);
    let points: Vec<Vec3> = (0..h)
        .flat_map(|r| (0..w).map(move |c| (r, c)))
        .map(|(r, c)| {
            let u = (c as f32 - w as f32 / 2.0) * px;
            let v = (h as f32 / 2.0 - r as f32) * px;
            if axis == "x" {
                centre + Vec3::new(offset, v, u)
            } else if axis == "y" {
                // Seen from above: front (+z) down the image.
                centre + Vec3::new(u, offset, -v)
            } else {
                centre + Vec3::new(u, v, offset)
            }
        })
        .collect();
    let f = sdf.sdf(&points);
    let img: Vec<u8> = f
        .iter()
        .map(|&d| {
            if d.abs() < 0.003 {
                0
            } else if d < 0.0 {
                90
            } else {
                (255.0 - (d * 400.0).min(60.0)) as u8
            }
        })
        .collect();
    let buf: image::GrayImage =
        image::ImageBuffer::from_raw(w as u32, h as u32, img).expect("sized above");
    buf.save(&args[2])?;
    Ok(())
}

//! The static SDF avatar: fitted to the demo capture, saved and reloaded it gives identical SDF
//! values; a file of another version or a truncated file is refused with a clear error.

use avatar_core::avatar::AvatarSource;
use avatar_core::canonical::FieldCache;
use avatar_neural::data::capture_points::CapturePoints;
use avatar_neural::*;
use glam::Vec3;
use std::path::Path;

/// Where these runs cache skinning fields (a fixed folder under the temporary directory).
fn field_cache() -> FieldCache {
    FieldCache::in_dir(std::env::temp_dir().join("avatar-studio-fields"))
}

fn fitted() -> StaticAvatar {
    let demo = Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/demo");
    let options = FitOptions { steps: 15, batch: 500, off_surface: 500, ..FitOptions::default() };
    let mut last = f32::NAN;
    let capture = CapturePoints::open(&demo, 2, &field_cache()).unwrap();
    let (avatar, report) = StaticAvatar::fit_points(
        &capture,
        SirenConfig { hidden: 32, layers: 2 },
        None,
        &options,
        None,
        &mut |_, l, _| last = l,
    );
    assert_eq!(report.frames, 2);
    assert!(report.points > 5000, "{} points", report.points);
    assert!(last.is_finite());
    avatar
}

#[test]
fn save_and_reload_give_identical_sdf_values_and_bad_files_are_refused() {
    let avatar = fitted();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("me.avatar");
    avatar.save(&path).unwrap();
    let back = StaticAvatar::load(&path, &field_cache()).unwrap();
    let probe: Vec<Vec3> = (0..200)
        .map(|i| {
            Vec3::new(
                (i as f32 * 0.37).sin() * 0.5,
                (i as f32 * 0.11).cos() * 0.9,
                (i as f32 * 0.23).sin() * 0.2,
            )
        })
        .collect();
    let (a, b) = (avatar.sdf_metres(&probe), back.sdf_metres(&probe));
    assert_eq!(a, b);
    assert_eq!(back.betas(), avatar.betas());

    let mut bytes = std::fs::read(&path).unwrap();
    let text = String::from_utf8_lossy(&bytes).to_string();
    let at = text.find("\"version\":1").unwrap();
    bytes[at + 10] = b'7';
    let other = dir.path().join("other.avatar");
    std::fs::write(&other, &bytes).unwrap();
    let err = StaticAvatar::load(&other, &field_cache()).err().unwrap().to_string();
    assert!(err.contains("other.avatar") && err.contains("version 7"), "{err}");

    let bytes = std::fs::read(&path).unwrap();
    let cut = dir.path().join("cut.avatar");
    std::fs::write(&cut, &bytes[..bytes.len() - 100]).unwrap();
    let err = StaticAvatar::load(&cut, &field_cache()).err().unwrap().to_string();
    assert!(err.contains("cut.avatar") && err.contains("truncated"), "{err}");

    let junk = dir.path().join("junk.avatar");
    std::fs::write(&junk, b"hello").unwrap();
    let err = StaticAvatar::load(&junk, &field_cache()).err().unwrap().to_string();
    assert!(
        err.contains("junk.avatar") && err.contains("not an Avatar Studio weights file"),
        "{err}"
    );
}

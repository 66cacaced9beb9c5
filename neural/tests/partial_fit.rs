//! A cancelled fit gives a partial avatar that records the steps that ran ("partial: 29 of 100
//! steps"), keeps it through save and load, and a finished fit is not marked partial.

use avatar_core::canonical::FieldCache;
use avatar_neural::data::capture_points::CapturePoints;
use avatar_neural::model::encoder::PoseEncoding;
use avatar_neural::*;
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};

/// Where these runs cache skinning fields (a fixed folder under the temporary directory).
fn field_cache() -> FieldCache {
    FieldCache::in_dir(std::env::temp_dir().join("avatar-studio-fields"))
}

#[test]
fn cancelled_fits_record_the_steps_that_ran() {
    let demo = Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/demo");
    let capture = CapturePoints::open(&demo, 1, &field_cache()).unwrap();
    let config = HyperConfig {
        siren: SirenConfig { hidden: 16, layers: 2 },
        head_hidden: 8,
        rank: Some(2),
        encoding: PoseEncoding::Hierarchical,
    };
    let init = Init::Scratch { config, seed: 0 };
    let options = HyperFitOptions {
        steps: 100,
        surface_per_pose: 100,
        off_per_pose: 100,
        ..HyperFitOptions::default()
    };
    // 100 steps log every second step: a cancel requested while step 28 reports stops after it.
    let cancel = AtomicBool::new(false);
    let (avatar, _) =
        MetaAvatar::fit_points(&capture, &init, &options, Some(&cancel), &mut |step, _, _| {
            if step == 28 {
                cancel.store(true, Ordering::Relaxed);
            }
        });
    let partial = avatar.header.partial.expect("a cancelled fit is partial");
    assert_eq!(partial.to_string(), "partial: 29 of 100 steps");
    assert_eq!(avatar.header.steps, 29);

    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("partial.avatar");
    avatar.save(&path).unwrap();
    let back = AnyAvatar::load(&path, &field_cache()).unwrap();
    assert_eq!(back.partial(), Some(partial));

    let static_cancel = AtomicBool::new(false);
    let fit = FitOptions { steps: 100, batch: 100, off_surface: 100, ..FitOptions::default() };
    let (s, _) = StaticAvatar::fit_points(
        &capture,
        config.siren,
        None,
        &fit,
        Some(&static_cancel),
        &mut |step, _, _| {
            if step == 10 {
                static_cancel.store(true, Ordering::Relaxed);
            }
        },
    );
    assert_eq!(
        s.header.partial.map(|p| p.to_string()).as_deref(),
        Some("partial: 11 of 100 steps")
    );

    let short = HyperFitOptions { steps: 3, ..options };
    let (done, _) = MetaAvatar::fit_points(
        &capture,
        &init,
        &short,
        Some(&AtomicBool::new(false)),
        &mut |_, _, _| {},
    );
    assert_eq!((done.header.partial, done.header.steps), (None, 3));
}

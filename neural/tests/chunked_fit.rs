//! `fit_avatar`, the one entry point of both kinds: a fit in chunks shows the partial avatar
//! after each chunk but the last, reports every step range once and in order, announces a plan
//! that holds what runs and each phase as it starts, and a cancel at a
//! chunk's end keeps the avatar of the steps that ran. A static fit in one chunk of the
//! `fit_avatar` recipe is `StaticAvatar::fit_points` with `static_equivalent` options.

use avatar_core::canonical::FieldCache;
use avatar_neural::avatar::{AvatarFit, FitEvent, FitKind, FitPhase, FitPlan, fit_avatar};
use avatar_neural::data::capture_points::CapturePoints;
use avatar_neural::model::encoder::PoseEncoding;
use avatar_neural::*;
use glam::Vec3;
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};

/// Where these runs cache skinning fields (a fixed folder under the temporary directory).
fn field_cache() -> FieldCache {
    FieldCache::in_dir(std::env::temp_dir().join("avatar-studio-fields"))
}

fn capture() -> CapturePoints {
    CapturePoints::open(
        &Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/demo"),
        2,
        &field_cache(),
    )
    .unwrap()
}

#[test]
fn chunked_fits_show_partial_avatars_and_stop_at_a_chunk() {
    let capture = capture();
    let config = HyperConfig {
        siren: SirenConfig { hidden: 16, layers: 2 },
        head_hidden: 8,
        rank: Some(2),
        encoding: PoseEncoding::Hierarchical,
    };
    let options = HyperFitOptions {
        steps: 7,
        surface_per_pose: 50,
        off_per_pose: 50,
        ..HyperFitOptions::default()
    };
    for kind in [
        FitKind::Meta(Init::Scratch { config, seed: 0 }),
        FitKind::Static { siren: config.siren, init: None },
    ] {
        let fit = AvatarFit { kind, options: options.clone(), chunk: 3, cancel: None, trace: None };
        let (mut steps, mut partials) = (Vec::new(), Vec::new());
        let (mut plan, mut phases) = (None, Vec::new());
        let (avatar, report) = fit_avatar(&capture, &fit, &mut |e| match e {
            FitEvent::Plan(p) => plan = Some(p),
            FitEvent::Phase(p) => phases.push(p),
            FitEvent::Progress { step, steps: total, .. } => {
                assert_eq!(total, 7);
                steps.push(step);
            }
            FitEvent::Partial { done, avatar } => {
                assert_eq!(
                    avatar.partial().map(|p| p.steps_done),
                    Some(done),
                    "a partial avatar says how far it got"
                );
                partials.push(done);
            }
        })
        .unwrap();
        assert_eq!(steps, (0..7).collect::<Vec<_>>(), "every step logged once, in order");
        assert_eq!(partials, [3, 6], "after each chunk but the last");
        // The plan holds what ran (the time left is reckoned from it), each phase announced.
        assert_eq!(plan, Some(FitPlan { steps: 7, partials: 2, ..FitPlan::default() }));
        use FitPhase::{Partial, Training};
        assert_eq!(phases, [Training, Partial, Training, Partial, Training]);
        assert_eq!(avatar.partial(), None);
        assert_eq!(report.frames, 2);

        let cancel = AtomicBool::new(false);
        let fit = AvatarFit { cancel: Some(&cancel), ..fit };
        let (avatar, _) = fit_avatar(&capture, &fit, &mut |e| {
            if let FitEvent::Partial { .. } = e {
                cancel.store(true, Ordering::Relaxed);
            }
        })
        .unwrap();
        assert_eq!(
            avatar.partial().map(|p| p.to_string()).as_deref(),
            Some("partial: 3 of 7 steps")
        );
    }
}

#[test]
fn the_static_recipe_is_static_equivalent() {
    let capture = capture();
    let siren = SirenConfig { hidden: 16, layers: 2 };
    let options = HyperFitOptions {
        steps: 4,
        surface_per_pose: 40,
        off_per_pose: 40,
        ..HyperFitOptions::default()
    };
    let fit = AvatarFit {
        kind: FitKind::Static { siren, init: None },
        options: options.clone(),
        chunk: 0,
        cancel: None,
        trace: None,
    };
    let (AnyAvatar::Static(a), _) = fit_avatar(&capture, &fit, &mut |_| {}).unwrap() else {
        panic!("a static avatar")
    };
    let (b, _) = StaticAvatar::fit_points(
        &capture,
        siren,
        None,
        &options.static_equivalent(),
        None,
        &mut |_, _, _| {},
    );
    let probe: Vec<Vec3> = (0..20).map(|i| Vec3::new(0.01 * i as f32, 1.0, 0.05)).collect();
    assert_eq!(a.sdf_metres(&probe), b.sdf_metres(&probe));
}

#[test]
fn fit_avatar_refuses_options_out_of_range_by_name_before_a_step() {
    let capture = capture();
    let model = MetaModel::shipped();
    let mut steps = 0;
    for (options, option) in [
        (HyperFitOptions { surface_per_pose: 0, ..HyperFitOptions::default() }, "surface_per_pose"),
        (HyperFitOptions { lr_heads: f64::NAN, ..HyperFitOptions::default() }, "lr_heads"),
    ] {
        let fit = AvatarFit {
            kind: FitKind::Meta(Init::MetaLearned(&model)),
            options,
            chunk: 0,
            cancel: None,
            trace: None,
        };
        let err = fit_avatar(&capture, &fit, &mut |_| steps += 1).err().expect("refused");
        assert!(matches!(&err, Error::Option { option: o, .. } if *o == option), "{err}");
    }
    let fit = AvatarFit {
        kind: FitKind::Static { siren: SirenConfig { hidden: 0, layers: 4 }, init: None },
        options: HyperFitOptions::default(),
        chunk: 0,
        cancel: None,
        trace: None,
    };
    let err = fit_avatar(&capture, &fit, &mut |_| steps += 1).err().expect("refused");
    assert!(err.to_string().contains("siren.hidden"), "{err}");
    assert_eq!(steps, 0, "no event before the check");
}

//! The neural crate's own errors: a device this build lacks, an avatar file of an unknown kind
//! (naming the file); core's errors pass through unchanged and convert back for core's traits.

use avatar_core::canonical::FieldCache;
use avatar_neural::compute::Compute;
use avatar_neural::{AnyAvatar, Error, weights_file};

/// Where these runs cache skinning fields (a fixed folder under the temporary directory).
fn field_cache() -> FieldCache {
    FieldCache::in_dir(std::env::temp_dir().join("avatar-studio-fields"))
}

#[test]
fn neural_errors_say_what_and_where() {
    match Compute::parse("tpu") {
        Err(e @ Error::Device { .. }) => {
            assert_eq!(e.to_string(), "--device \"tpu\": expected cpu, gpu or cpu-burn")
        }
        other => panic!("{:?}", other.map(|_| ())),
    }
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("odd.avatar");
    let header = serde_json::json!({ "format": "avatar-studio-avatar", "version": 1, "kind": "point-cloud" });
    weights_file::write(&path, &header, &[]).unwrap();
    let Err(e) = AnyAvatar::load(&path, &field_cache()) else { panic!("an unknown kind loads") };
    assert!(matches!(e, Error::AvatarKind { .. }), "{e:?}");
    let text = e.to_string();
    assert!(
        text.starts_with(&path.display().to_string())
            && text.contains("\"point-cloud\" is not an avatar this build can load"),
        "{text}"
    );
    // Core's traits (eval::Predictor) see the same message, still naming the file.
    let core: avatar_core::Error = e.into();
    assert_eq!(core.to_string(), text);

    let missing = dir.path().join("missing.avatar");
    let Err(e) = AnyAvatar::load(&missing, &field_cache()) else { panic!("a missing file loads") };
    assert!(
        matches!(e, Error::Core(avatar_core::Error::Io { .. }))
            && e.to_string().contains("missing.avatar"),
        "{e:?}"
    );
}

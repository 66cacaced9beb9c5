//! The .deb's description, checked in every `cargo test` (CI also packages the test build's
//! binary from it and installs it: scripts/test.sh, packaging/README.md): every file that
//! `[package.metadata.deb]` in app/Cargo.toml installs exists, each icon is a PNG of the size
//! its folder names, and the desktop entry launches the binary with the icon and the window's
//! app id.

use std::path::{Path, PathBuf};

fn app_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The `[package.metadata.deb]` table's lines of app/Cargo.toml.
fn deb_section() -> Vec<String> {
    let manifest = std::fs::read_to_string(app_dir().join("Cargo.toml")).unwrap();
    let lines: Vec<String> = manifest.lines().map(str::to_string).collect();
    let start = lines
        .iter()
        .position(|l| l.trim() == "[package.metadata.deb]")
        .expect("app/Cargo.toml has [package.metadata.deb]");
    lines[start + 1..]
        .iter()
        .take_while(|l| !l.trim_start().starts_with('[') || l.trim_start().starts_with("[\""))
        .cloned()
        .collect()
}

/// The quoted strings of a line.
fn strings(line: &str) -> Vec<String> {
    line.split('"').skip(1).step_by(2).map(str::to_string).collect()
}

#[test]
fn every_file_the_package_installs_exists() {
    let section = deb_section();
    let assets: Vec<Vec<String>> =
        section.iter().map(|l| l.trim()).filter(|l| l.starts_with("[\"")).map(strings).collect();
    assert!(assets.len() >= 10, "{assets:?}");
    let mut icons = 0;
    for a in &assets {
        assert_eq!(a.len(), 3, "source, destination, mode: {a:?}");
        if a[0] == "target/release/avatar-studio" {
            assert_eq!((a[1].as_str(), a[2].as_str()), ("usr/bin/", "755"));
            continue;
        }
        let src = app_dir().join(&a[0]);
        assert!(src.is_file(), "{} (installed to {}) is missing", src.display(), a[1]);
        if let Some(size) =
            a[1].strip_prefix("usr/share/icons/hicolor/").and_then(|d| d.split('/').next())
        {
            let n: u32 = size.split('x').next().unwrap().parse().unwrap();
            assert_eq!(image::image_dimensions(&src).unwrap(), (n, n), "{}", src.display());
            assert!(
                src.ends_with(Path::new(size).join("avatar-studio.png")),
                "{} goes to the {size} folder",
                src.display()
            );
            icons += 1;
        }
    }
    assert!(icons >= 6, "the icon in the usual sizes ({icons})");
    let license = section
        .iter()
        .find(|l| l.starts_with("license-file"))
        .map(|l| strings(l))
        .expect("license-file");
    assert!(app_dir().join(&license[0]).is_file(), "{license:?}");
    let desktop = assets.iter().find(|a| a[0].ends_with(".desktop")).expect("a desktop entry");
    assert_eq!(desktop[1], "usr/share/applications/");
}

#[test]
fn the_desktop_entry_launches_the_studio() {
    let text =
        std::fs::read_to_string(app_dir().join("../packaging/avatar-studio.desktop")).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("[Desktop Entry]"));
    let entries: std::collections::HashMap<&str, &str> = lines
        .filter(|l| !l.trim().is_empty())
        .map(|l| l.split_once('=').unwrap_or_else(|| panic!("not a key=value line: {l:?}")))
        .collect();
    for key in ["Type", "Name", "Exec", "Icon", "Categories"] {
        assert!(entries.contains_key(key), "missing {key}");
    }
    assert_eq!(entries["Type"], "Application");
    assert_eq!(
        entries["Exec"].split_whitespace().next(),
        Some("avatar-studio"),
        "the installed binary"
    );
    assert_eq!(entries["Icon"], "avatar-studio", "the icon's name in hicolor");
    // The window's app id (studio::native_options) is what desktops match the entry by.
    assert_eq!(entries.get("StartupWMClass"), Some(&"avatar-studio"));
    let app_id = avatar_studio::studio::native_options().viewport.app_id;
    assert_eq!(app_id.as_deref(), Some("avatar-studio"));
    assert!(entries["Categories"].ends_with(';'), "a desktop list ends with ;");
}

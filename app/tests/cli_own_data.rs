//! Own data on the command line: `synth --own-data` writes the layout, `meta-train --dry-run`
//! lists it and names each bad item, a tiny `meta-train` skips them and says how many, and
//! `fit --model` fine-tunes from the trained prior, which the avatar and `check` name.

use std::ffi::OsStr;
use std::path::Path;
use std::process::{Command, Output};

fn studio(args: &[&dyn AsRef<OsStr>]) -> Output {
    let mut c = Command::new(env!("CARGO_BIN_EXE_avatar-studio"));
    for a in args {
        c.arg(a);
    }
    c.output().unwrap()
}

fn ok(o: &Output) -> (String, String) {
    let (out, err) = (
        String::from_utf8_lossy(&o.stdout).into_owned(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    );
    assert!(o.status.success(), "{out}\n{err}");
    (out, err)
}

#[test]
fn own_data_is_listed_trained_on_and_fitted_from() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("data");
    ok(&studio(&[
        &"synth",
        &"--out",
        &data,
        &"--seed",
        &"1",
        &"--subjects",
        &"2",
        &"--outfits",
        &"tshirt_shorts",
        &"--clips",
        &"walk",
        &"--frames-per-clip",
        &"2",
        &"--own-data",
        &"scans",
    ]));
    ok(&studio(&[
        &"synth",
        &"--out",
        &data,
        &"--seed",
        &"1",
        &"--outfits",
        &"tshirt_shorts",
        &"--clips",
        &"walk",
        &"--frames-per-clip",
        &"3",
        &"--own-data",
        &"captures",
        &"--no-ground-truth",
    ]));
    let outfit = data.join("s0001/tshirt_shorts");
    assert!(outfit.join("walk_0001.obj").is_file() && outfit.join("walk_0001.json").is_file());
    assert!(outfit.join("walk/capture.json").is_file());
    // Bad items: a scan without its fitting, a broken OBJ, an unreadable capture.
    std::fs::copy(outfit.join("walk_0000.obj"), outfit.join("lonely.obj")).unwrap();
    std::fs::write(outfit.join("broken.obj"), "v 0 0 0\nf 1 2 7\n").unwrap();
    std::fs::copy(outfit.join("walk_0000.json"), outfit.join("broken.json")).unwrap();
    std::fs::create_dir_all(outfit.join("take2")).unwrap();
    std::fs::write(outfit.join("take2/capture.json"), "not json").unwrap();

    let (out, err) = ok(&studio(&[&"meta-train", &"--data", &data, &"--dry-run"]));
    assert!(err.contains("s0001 / tshirt_shorts: 1 captures (3 frames), 2 scans"), "{err}");
    assert!(err.contains("s0002 / tshirt_shorts: 0 captures (0 frames), 2 scans"), "{err}");
    for bad in ["lonely.obj", "broken.obj", "take2"] {
        assert!(err.lines().any(|l| l.contains(bad)), "{bad} named in {err}");
    }
    assert!(out.contains("5 items in 2 subject-outfit groups would be used, 3 refused"), "{out}");

    let run = dir.path().join("run");
    let (out, err) = ok(&studio(&[
        &"meta-train",
        &"--data",
        &data,
        &"--out",
        &run,
        &"--sdf-iterations",
        &"2",
        &"--hyper-iterations",
        &"2",
    ]));
    assert!(err.contains("5 items used (7 samples in 2 groups), 3 skipped"), "{err}");
    assert!(out.contains("meta-model.bin"), "{out}");
    // Run again (a resume): the prepared samples are reused while the items are unchanged.
    let (_, err) = ok(&studio(&[
        &"meta-train",
        &"--data",
        &data,
        &"--out",
        &run,
        &"--sdf-iterations",
        &"2",
        &"--hyper-iterations",
        &"2",
    ]));
    assert!(err.contains("7 samples in 2 groups; the items are unchanged"), "{err}");

    let model = run.join("meta-model.bin");
    // A two-step fit of the walk from the meta-model file `from` into `out`.
    let walk = outfit.join("walk");
    let fit = |from: &Path, out: &Path, extra: &[&str]| {
        let mut args: Vec<&dyn AsRef<OsStr>> = vec![
            &"fit",
            &walk,
            &"--frames",
            &"3",
            &"--steps",
            &"2",
            &"--model",
            &from,
            &"--out",
            &out,
        ];
        args.extend(extra.iter().map(|e| e as &dyn AsRef<OsStr>));
        studio(&args)
    };
    let names_the_prior = |avatar: &Path| {
        let (out, _) = ok(&studio(&[&"check", &avatar]));
        assert!(
            out.contains("fine-tuned from the prior") && out.contains("meta-train seed 0"),
            "{out}"
        );
    };
    let avatar = dir.path().join("a.avatar");
    let (out, _) = ok(&fit(&model, &avatar, &["--refine-poses", "off"]));
    assert!(out.contains("from the prior") && out.contains("meta-model.bin"), "{out}");
    names_the_prior(&avatar);

    // Alg. 2 alone on the own data, from the static meta-SDF of the prior built into the
    // program: the model says so, and so does an avatar fitted from it.
    let from_shipped = dir.path().join("from-shipped");
    let (_, err) = ok(&studio(&[
        &"meta-train",
        &"--data",
        &data,
        &"--out",
        &from_shipped,
        &"--sdf-from",
        &"shipped",
        &"--hyper-iterations",
        &"2",
    ]));
    assert!(err.contains("Alg. 1 skipped, static meta-SDF from shipped"), "{err}");
    let hybrid = dir.path().join("h.avatar");
    ok(&fit(&from_shipped.join("meta-model.bin"), &hybrid, &["--refine-poses", "off"]));
    let (out, _) = ok(&studio(&[&"check", &hybrid]));
    assert!(
        out.contains("meta-train seed 0 (static meta-SDF of the prior shipped (sha256 ")
            && out.contains("), 2 iterations"),
        "{out}"
    );

    // The static SDF started from that prior's static SDF names it too.
    let fixed = dir.path().join("s.avatar");
    let (out, _) = ok(&fit(&model, &fixed, &["--static"]));
    assert!(out.contains("static SDF") && out.contains("meta-model.bin"), "{out}");
    names_the_prior(&fixed);

    // A model file that is not a meta-model is refused by name; nothing is written.
    let again = dir.path().join("b.avatar");
    let o = fit(&avatar, &again, &[]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        !o.status.success() && err.contains("a.avatar") && err.contains("not a meta-model"),
        "{err}"
    );
    assert!(!again.exists());
    // --dry-run needs own data.
    let o = studio(&[&"meta-train", &"--data", &dir.path().join("none"), &"--dry-run"]);
    assert!(!o.status.success());
}

//! Corrupted pose files, motion clips and body models.

use super::*;

impl Corpus<'_> {
    pub(super) fn poses_and_motions(&mut self) {
        let pose: Value = serde_json::from_slice(&std::fs::read(&self.f.pose).unwrap()).unwrap();
        let mut pose_files: Vec<(String, Vec<u8>)> = vec![
            ("empty".into(), Vec::new()),
            ("not-json".into(), b"pose: 0".to_vec()),
            ("truncated".into(), b"{\"pose\": [0, 0,".to_vec()),
        ];
        let pose_edits: Vec<(&str, &str, Option<Value>)> = vec![
            ("pose-71", "pose", Some(json!(vec![0.0; 71]))),
            ("pose-string", "pose/3", Some(json!("x"))),
            ("pose-null", "pose/3", Some(Value::Null)),
            ("pose-degrees", "pose/55", Some(json!(90.0))),
            ("pose-1e30", "pose/4", Some(json!(1e30))),
            ("betas-1e4", "betas/0", Some(json!(1e4))),
            ("betas-1e30", "betas/0", Some(json!(1e30))),
            ("betas-string", "betas", Some(json!("tall"))),
            ("trans-1e9", "trans", Some(json!([1e9, 0, 0]))),
            ("trans-2", "trans", Some(json!([0, 0]))),
            ("pose-nested-wrong", "pose", Some(json!([[1, 2], [3]]))),
        ];
        for (n, path, value) in pose_edits {
            pose_files.push((n.into(), serde_json::to_vec(&set(&pose, path, value)).unwrap()));
        }
        for (n, b) in pose_files {
            let p = self.file(&format!("pose-{n}.json"), &b);
            let args = os(&[
                &"body",
                &"--pose",
                &p,
                &"--lowpoly",
                &"--out",
                &self.out(&format!("pose-{n}.obj")),
            ]);
            self.push(format!("pose {n}"), args, Some(p));
        }

        let clip: Value = serde_json::from_slice(&std::fs::read(&self.f.clip).unwrap()).unwrap();
        let mut clip_files: Vec<(String, Vec<u8>)> = vec![
            ("empty".into(), Vec::new()),
            ("truncated".into(), std::fs::read(&self.f.clip).unwrap()[..100].to_vec()),
        ];
        let clip_edits: Vec<(&str, &str, Option<Value>)> = vec![
            ("fps-1e-30", "fps", Some(json!(1e-30))),
            ("fps-0", "fps", Some(json!(0))),
            ("fps-1e9", "fps", Some(json!(1e9))),
            ("no-frames", "frames", Some(json!([]))),
            ("pose-71", "frames/1/pose", Some(json!(vec![0.0; 71]))),
            ("pose-null", "frames/1/pose/7", Some(Value::Null)),
            ("pose-degrees", "frames/2/pose/55", Some(json!(90.0))),
            ("trans-2", "frames/0/trans", Some(json!([0, 0]))),
            ("betas-1e30", "frames/0/betas", Some(json!([1e30]))),
            ("format", "format", Some(json!("bvh"))),
            ("version-2", "version", Some(json!(2))),
        ];
        for (n, path, value) in clip_edits {
            clip_files.push((n.into(), serde_json::to_vec(&set(&clip, path, value)).unwrap()));
        }
        for (n, b) in clip_files {
            let p = self.file(&format!("clip-{n}.json"), &b);
            let args =
                os(&[&"export", &"--motion", &p, &"--out", &self.out(&format!("clip-{n}.glb"))]);
            self.push(format!("motion clip {n}"), args, Some(p));
        }

        let base = amass_entries();
        let with = |key: &str, entry: Option<Vec<u8>>| -> Vec<(&'static str, Vec<u8>)> {
            let mut e: Vec<(&'static str, Vec<u8>)> =
                base.iter().filter(|(k, _)| *k != key).cloned().collect();
            if let Some(b) = entry {
                let k = base.iter().find(|(k, _)| *k == key).map(|(k, _)| *k).unwrap();
                e.push((k, b));
            }
            e
        };
        let mut degrees = vec![0f32; 3 * 72];
        degrees[60] = 90.0;
        let mut nan = vec![0f32; 3 * 72];
        nan[10] = f32::NAN;
        let amass: Vec<(&str, NpzEntries)> = vec![
            ("width-71", with("poses", Some(npy("<f4", &[3, 71], &f32s(&[0.0; 213]))))),
            ("width-100", with("poses", Some(npy("<f4", &[2, 100], &f32s(&[0.0; 200]))))),
            ("no-frames", with("poses", Some(npy("<f4", &[0, 72], &[])))),
            ("rank-3", with("poses", Some(npy("<f4", &[1, 3, 72], &f32s(&[0.0; 216]))))),
            ("fps-1e-30", with("mocap_framerate", Some(npy("<f8", &[], &f64s(&[1e-30]))))),
            ("fps-1e9", with("mocap_framerate", Some(npy("<f8", &[], &f64s(&[1e9]))))),
            ("fps-nan", with("mocap_framerate", Some(npy("<f8", &[], &f64s(&[f64::NAN]))))),
            ("pose-nan", with("poses", Some(npy("<f4", &[3, 72], &f32s(&nan))))),
            ("pose-degrees", with("poses", Some(npy("<f4", &[3, 72], &f32s(&degrees))))),
            ("trans-shape", with("trans", Some(npy("<f4", &[2, 3], &f32s(&[0.0; 6]))))),
            ("betas-1e4", with("betas", Some(npy("<f4", &[10], &f32s(&[1e4; 10]))))),
            ("no-poses", with("poses", None)),
            ("poses-float16", with("poses", Some(npy("<f2", &[3, 72], &[0u8; 3 * 72 * 2])))),
            ("poses-strings", with("poses", Some(npy("<U4", &[2], &[0u8; 32])))),
            ("poses-claim-huge", with("poses", Some(npy("<f4", &[100_000_000, 72], &[0u8; 64])))),
            ("poses-truncated-data", with("poses", Some(npy("<f4", &[3, 72], &[0u8; 100])))),
        ];
        for (n, entries) in amass {
            let p = self.bad.join(format!("amass-{n}.npz"));
            write_npz(&p, &entries, false);
            let args =
                os(&[&"export", &"--motion", &p, &"--out", &self.out(&format!("amass-{n}.glb"))]);
            self.push(format!("AMASS {n}"), args, Some(p));
        }
        let whole = std::fs::read(&self.f.amass).unwrap();
        for (n, b) in [
            ("empty", Vec::new()),
            ("truncated", whole[..whole.len() / 2].to_vec()),
            ("text", b"poses".to_vec()),
        ] {
            let p = self.file(&format!("amass-{n}.npz"), &b);
            let args =
                os(&[&"export", &"--motion", &p, &"--out", &self.out(&format!("amass-{n}.glb"))]);
            self.push(format!("AMASS {n}"), args, Some(p));
        }
    }

    pub(super) fn body_models(&mut self) {
        let base = smpl_entries();
        let nv = open_body_lowpoly_vertices();
        let replace = |key: &str, entry: Option<Vec<u8>>| -> Vec<(&'static str, Vec<u8>)> {
            base.iter()
                .filter_map(|(k, b)| {
                    if *k == key { entry.clone().map(|e| (*k, e)) } else { Some((*k, b.clone())) }
                })
                .collect()
        };
        let template: Vec<f64> = open_body_lowpoly_template();
        let scaled = |s: f64, at: Option<(usize, f64)>| {
            let mut t: Vec<f64> = template.iter().map(|v| v * s).collect();
            if let Some((i, v)) = at {
                t[i] = v;
            }
            npy("<f8", &[nv, 3], &f64s(&t))
        };
        let models: Vec<(&str, NpzEntries, bool)> = vec![
            ("template-1e300", replace("v_template", Some(scaled(1.0, Some((4, 1e300))))), false),
            ("template-mm", replace("v_template", Some(scaled(1000.0, None))), false),
            ("template-nan", replace("v_template", Some(scaled(1.0, Some((4, f64::NAN))))), false),
            (
                "template-wrong-shape",
                replace("v_template", Some(npy("<f4", &[nv, 2], &f32s(&vec![0.0; nv * 2])))),
                false,
            ),
            ("no-template", replace("v_template", None), false),
            (
                "shapedirs-wrong-shape",
                replace("shapedirs", Some(npy("<f4", &[nv, 3], &f32s(&vec![0.0; nv * 3])))),
                false,
            ),
            (
                "kintree-smplh",
                replace("kintree_table", Some(npy("<f4", &[2, 52], &f32s(&[0.0; 104])))),
                false,
            ),
            (
                "regressor-1e30",
                replace("J_regressor", Some(npy("<f4", &[24, nv], &f32s(&vec![1e30; 24 * nv])))),
                false,
            ),
            (
                "weights-sum-2",
                replace("weights", Some(npy("<f4", &[nv, 24], &f32s(&vec![2.0 / 24.0; nv * 24])))),
                false,
            ),
            (
                "faces-out-of-range",
                replace("f", Some(npy("<f4", &[1, 3], &f32s(&[0.0, 1.0, 1e7])))),
                false,
            ),
            (
                "faces-fractional",
                replace("f", Some(npy("<f4", &[1, 3], &f32s(&[0.0, 0.5, 2.0])))),
                false,
            ),
            (
                "template-float16",
                replace("v_template", Some(npy("<f2", &[nv, 3], &vec![0u8; nv * 6]))),
                false,
            ),
            (
                "template-object",
                replace("v_template", Some(npy("|O", &[nv, 3], &[0u8; 16]))),
                false,
            ),
            (
                "shapedirs-claim-1.5gb",
                replace("shapedirs", Some(npy("<f8", &[6890, 3, 10000], &[0u8; 64]))),
                false,
            ),
        ];
        for (n, entries, deflate) in models {
            let p = self.bad.join(format!("smpl-{n}.npz"));
            write_npz(&p, &entries, deflate);
            let args =
                os(&[&"body", &"--model", &p, &"--out", &self.out(&format!("smpl-{n}.obj"))]);
            self.push(format!("SMPL npz {n}"), args, Some(p));
        }
        // Zip bombs: 1.5 GB of zero float64s deflated to 1.5 MB, refused from the npy header
        // before inflating; and 16 M values (under the size cap) of the wrong shape for this body,
        // inflated (128 MB at most), then refused.
        for (n, shape) in [
            ("zip-bomb-1.5gb", vec![6890usize, 3, 9070]),
            ("zip-bomb-under-cap", vec![(1 << 24) / 3, 3]),
        ] {
            let p = self.bad.join(format!("smpl-{n}.npz"));
            let bytes = 8 * shape.iter().product::<usize>();
            write_npz_with_zeros(
                &p,
                &replace("shapedirs", None),
                false,
                Some(("shapedirs", npy("<f8", &shape, &[]), bytes)),
            );
            let args =
                os(&[&"body", &"--model", &p, &"--out", &self.out(&format!("smpl-{n}.obj"))]);
            self.push(format!("SMPL npz {n}"), args, Some(p));
        }
        let whole = std::fs::read(&self.f.smpl).unwrap();
        for (n, b) in [
            ("empty", Vec::new()),
            ("truncated", whole[..whole.len() / 2].to_vec()),
            ("passwd-like", b"root:x:0:0:root:/root:/bin/bash\n".to_vec()),
        ] {
            let p = self.file(&format!("smpl-{n}.npz"), &b);
            let args =
                os(&[&"body", &"--model", &p, &"--out", &self.out(&format!("smpl-{n}.obj"))]);
            self.push(format!("SMPL npz {n}"), args, Some(p));
        }
    }
}

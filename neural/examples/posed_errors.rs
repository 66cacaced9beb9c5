//! A fitted avatar against the generator's truth at the poses of library clips: the
//! evaluation's metrics per clip (Chamfer-L2, NC, spurious and missing shares), at training
//! clips and held-out ones, so a change to how an avatar is posed (its skinning, its loose
//! pieces) is measured on one fitted avatar in seconds instead of a refit.
//!   cargo run -p avatar-neural --example posed_errors -- AVATAR CAPTURE SUBJECT OUTFIT [EVERY] [CLIP,...]
//! The clip `capture` is the capture's own frames at their given fittings (the training poses),
//! `zero` the zero pose. PIECES=1: each frame's connected pieces, their area and the share of
//! it farther than 2 cm from the truth.
//! CAPTURE gives the body and the subject's shape (the capture the avatar was fitted from).
//! An evaluation's avatars and captures: `avatar-studio eval ... --save-avatars DIR
//! --keep-captures CAPS` writes DIR/NAME.avatar beside CAPS/NAME. AT_REST=1 poses
//! the rest pose's canonical surface at every pose (what the pose-conditioned SDF adds).
//! RESOLUTION=N meshes the avatar on N cells. TEMPLATE=1 poses as the exporter does (the rest
//! surface moved to each pose: `PoseTemplate`, what `posed_mesh` does for loose cloth),
//! TEMPLATE_POSE=K the same from capture frame K's surface. PER_POSE=1 skins each pose's own
//! canonical surface.
//! AS_EXTRACTED=1 keeps the loose pieces as extracted; SHEET_THIN, SHEET_SEARCH, SHEET_BORDER_REACH (metres),
//! SHEET_BORDER_ITERATIONS, SHEET_HEM_WINDOW, SHEET_GAP_ROWS, SHEET_GAP_COLUMNS set the garment
//! sheet's options.
//! A simulated outfit's truth at a library clip is its garment simulated through the clip, as
//! the evaluation's; RIGID_TRUTH=1 scores the generator's rule-posed garment against it
//! instead of the avatar (how far the cloth's own motion lies from any rule of the pose).
//! LOOPS=1 prints each frame's border loops; LOOSE_SHEET=PREFIX draws every piece but the
//! largest close up.
use avatar_core::canonical::FieldCache;
use avatar_core::capture::Capture;
use avatar_core::eval::metrics::{MetricOptions, Regions, evaluate_frame};
use avatar_core::eval::runner::{ground_truth_mesh, query};
use avatar_core::mesh::TriMesh;
use avatar_core::mesh::bvh::Bvh;
use avatar_core::motion::library_clip;
use avatar_core::synth::contact_sheet::write_view_sheet;
use avatar_core::synth::{ClothedTemplate, Outfit};
use glam::Vec3;

/// Body parts by the ground truth's dominant joint (`JOINT_NAMES`), for `REGIONS` and `OFFSETS`.
const PARTS: [(&str, &[usize]); 5] = [
    ("torso", &[0, 3, 6, 9, 13, 14]),
    ("upper arm", &[16, 17]),
    ("forearm", &[18, 19]),
    ("thigh", &[1, 2]),
    ("shin", &[4, 5]),
];

/// Where these runs cache skinning fields (a fixed folder under the temporary directory).
fn field_cache() -> FieldCache {
    FieldCache::in_dir(std::env::temp_dir().join("avatar-studio-fields"))
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    if args.len() < 5 {
        return Err("usage: posed_errors AVATAR CAPTURE SUBJECT OUTFIT [EVERY] [CLIP,...]".into());
    }
    let mut avatar = avatar_neural::MetaAvatar::load(&args[1], &field_cache())?;
    // RESOLUTION=N: mesh on N cells instead of the output resolution (loose pieces at most
    // `MeshResolution::LOOSE_MAX`).
    if let Ok(r) = std::env::var("RESOLUTION") {
        avatar.set_mesh_resolution(avatar_neural::avatar::MeshResolution::new(r.parse()?)?);
    }
    // AS_EXTRACTED=1: loose pieces as extracted; SHEET_THIN=m, SHEET_SEARCH=m: the
    // garment sheet's options (`canonical::garment_sheet`).
    if let Some(wrap) = avatar.wrap_mut() {
        let number = |name: &str| std::env::var(name).ok().and_then(|v| v.parse::<f32>().ok());
        if std::env::var("AS_EXTRACTED").is_ok() {
            wrap.options.remesh_loose = false;
        }
        let sheet = &mut wrap.sheet.options;
        sheet.thin = number("SHEET_THIN").unwrap_or(sheet.thin);
        sheet.search = number("SHEET_SEARCH").unwrap_or(sheet.search);
        sheet.border_reach = number("SHEET_BORDER_REACH").unwrap_or(sheet.border_reach);
        sheet.border_smoothing =
            number("SHEET_BORDER_ITERATIONS").map_or(sheet.border_smoothing, |n| n as usize);
        sheet.hem_window = number("SHEET_HEM_WINDOW").map_or(sheet.hem_window, |n| n as usize);
        sheet.gap_rows = number("SHEET_GAP_ROWS").map_or(sheet.gap_rows, |n| n as usize);
        sheet.gap_columns = number("SHEET_GAP_COLUMNS").map_or(sheet.gap_columns, |n| n as usize);
    }
    // SKIN_LOOSE=a,b: where loose cloth's weights start to be inpainted, and are wholly.
    if let Ok(v) = std::env::var("SKIN_LOOSE") {
        let (a, b) = v.split_once(',').ok_or("SKIN_LOOSE=a,b")?;
        avatar.garment_skinning_mut().loose = (a.parse()?, b.parse()?);
    }
    // AT_REST=1: the rest pose's canonical surface at every pose.
    let at_rest = std::env::var("AT_REST").is_ok();
    let capture = Capture::open(&args[2])?;
    let subject: u64 = args[3].parse()?;
    let every: usize = args.get(5).map(|s| s.parse()).transpose()?.unwrap_or(10);
    let clips: Vec<String> = match args.get(6) {
        Some(list) => list.split(',').map(str::to_string).collect(),
        None => ["kick", "lunge", "twist", "walk", "march", "squat"].map(String::from).to_vec(),
    };
    let betas = capture.frames[0].params.betas.clone();
    let template = ClothedTemplate::build(&capture.body, &betas, Outfit::from_name(&args[4])?);
    let regions = Regions::of_template(&template)?;
    let options = MetricOptions { iou_resolution: 32, ..MetricOptions::default() };
    if std::env::var("WEIGHTS").is_ok() {
        use avatar_core::avatar::AvatarSource;
        let rest = query(&Default::default(), &betas);
        let mesh = avatar.canonical_mesh(&rest)?;
        let weights = avatar.mesh_skinning_weights(&mesh);
        let body = avatar_core::mesh::signed_distance::SignedDistance::new(
            &capture.body.mesh(capture.body.shaped_vertices(&betas)),
        );
        let crotch = capture.body.pose(&rest).bones.rest_joints[1].y;
        for (lo, hi) in [(0.0, 0.1), (0.1, 0.2), (0.2, 0.3), (0.3, 0.6)] {
            let picked: Vec<usize> = (0..mesh.positions.len())
                .filter(|&v| {
                    let p = mesh.positions[v];
                    let below = crotch - p.y;
                    below >= lo && below < hi && body.at(p).is_some_and(|d| d > 0.05)
                })
                .collect();
            let mean = |j: usize| {
                picked.iter().map(|&v| weights[v][j]).sum::<f32>() / picked.len().max(1) as f32
            };
            println!(
                "{lo:.1}-{hi:.1} m below the hips, {} loose vertices: pelvis {:.2} hips {:.2} {:.2} knees {:.2} {:.2} spine {:.2}",
                picked.len(),
                mean(0),
                mean(1),
                mean(2),
                mean(4),
                mean(5),
                mean(3)
            );
        }
    }
    if std::env::var("OFFSETS").is_ok() {
        use avatar_core::avatar::AvatarSource;
        let mesh = avatar.canonical_mesh(&query(&Default::default(), &betas))?;
        let body = avatar_core::mesh::signed_distance::SignedDistance::new(
            &capture.body.mesh(capture.body.shaped_vertices(&betas)),
        );
        for (label, joints) in PARTS {
            let mut d: Vec<f32> = (0..template.body_vertices.min(mesh.positions.len()))
                .filter(|&v| joints.contains(&(template.vertex_joint[v] as usize)))
                .filter_map(|v| body.smooth_offset(mesh.positions[v]).map(|o| o.0 * 1000.0))
                .collect();
            d.sort_by(f32::total_cmp);
            let q = |f: f32| d[((d.len() - 1) as f32 * f) as usize];
            println!(
                "{label}: offsets (mm) p5 {:.1} p25 {:.1} median {:.1} p75 {:.1} p95 {:.1}",
                q(0.05),
                q(0.25),
                q(0.5),
                q(0.75),
                q(0.95)
            );
        }
    }
    // TEMPLATE_POSE=K: the template is the canonical surface at capture frame K's pose.
    let seen_template = match std::env::var("TEMPLATE_POSE") {
        Ok(k) => {
            use avatar_core::avatar::AvatarSource;
            let p = capture.frames[k.parse::<usize>()?].params.clone();
            let rest = avatar.canonical_mesh_at(&p, avatar.mesh_resolution())?;
            let weights = avatar.mesh_skinning_weights(&rest);
            let smoother = avatar.surface_smoother(&rest);
            Some(avatar_core::avatar::PoseTemplate { rest, weights, smoother })
        }
        Err(_) => None,
    };
    let exporter = avatar_core::avatar::PoseTemplate::new(&avatar)?;
    let mut all = Vec::new();
    let mut integ = Vec::new();
    // SHEET=OUT.png: the frame with the most spurious surface, truth beside the avatar and its
    // faces farther than 2 cm from the truth (front, side, back, below).
    let mut worst: Option<(f32, Vec<avatar_core::mesh::TriMesh>, String)> = None;
    for name in &clips {
        // "capture": the capture's own frames at their given fittings (the training poses).
        let poses: Vec<(usize, _)> = if name == "capture" {
            capture.frames.iter().map(|f| f.params.clone()).enumerate().collect()
        } else if name == "zero" {
            vec![(0, avatar_core::body::BodyParams { betas: betas.clone(), ..Default::default() })]
        } else {
            library_clip(name)?
                .frames
                .iter()
                .enumerate()
                .step_by(every.max(1))
                .map(|(i, frame)| (i, query(frame, &betas)))
                .collect()
        };
        // Simulated outfits: the truth is the garment simulated through the clip, as the
        // evaluation scores it.
        let clip = library_clip(name).ok();
        let outfit_truth = clip.as_ref().map(|c| {
            avatar_core::eval::truth::OutfitTruth::new(
                &capture.body,
                &template,
                subject,
                &betas,
                &[c],
            )
        });
        let mut rows = Vec::new();
        for (i, pose) in poses {
            let truth = match &outfit_truth {
                Some(t) => t.mesh(name, i, &pose)?,
                None => ground_truth_mesh(&capture.body, &template, &pose, subject),
            };
            // RIGID_TRUTH=1: score the generator's rule-posed garment (no simulation) instead
            // of the avatar: how far a simulated garment lies from any rule of the pose.
            let predicted = if std::env::var("RIGID_TRUTH").is_ok() {
                ground_truth_mesh(&capture.body, &template, &pose, subject)
            } else if let Some(t) = &seen_template {
                t.posed_mesh(&avatar, &pose)?
            } else if std::env::var("TEMPLATE").is_ok() {
                exporter.posed_mesh(&avatar, &pose)?
            } else if at_rest {
                avatar.posed_mesh_of_surface_at(&pose, &avatar.rest_params())?
            } else if std::env::var("PER_POSE").is_ok() {
                avatar.posed_mesh_of_surface_at(&pose, &pose)?
            } else {
                avatar.posed_mesh(&pose)?
            };
            if std::env::var("REGIONS").is_ok() {
                use avatar_core::eval::metrics::{Prepared, vertex_scores};
                let gt = Prepared::new(&truth, "truth")?;
                let naked = capture.body.mesh(capture.body.pose(&pose).vertices);
                let scores: Vec<Vec<f32>> = [&predicted, &naked]
                    .iter()
                    .map(|m| {
                        Prepared::new(m, "mesh")
                            .map(|p| vertex_scores(&truth.positions, &gt.normals, &p).normal_error)
                    })
                    .collect::<Result<_, _>>()?;
                let scored: (&str, &[usize]) =
                    ("scored", &avatar_core::body::skeleton::CLOTHED_JOINTS);
                let line: Vec<String> = PARTS
                    .iter()
                    .chain([&scored])
                    .map(|(label, joints)| {
                        let picked: Vec<usize> = (0..truth.positions.len())
                            .filter(|&v| joints.contains(&(template.vertex_joint[v] as usize)))
                            .collect();
                        let nc = |e: &[f32]| {
                            1.0 - picked.iter().map(|&v| e[v]).sum::<f32>()
                                / picked.len().max(1) as f32
                        };
                        format!("{label} {:.3}/{:.3}", nc(&scores[0]), nc(&scores[1]))
                    })
                    .collect();
                println!("{name} {i}: NC avatar/naked: {}", line.join(", "));
            }
            if std::env::var("PIECES").is_ok() {
                println!("{name} {i}: {}", pieces_report(&predicted, &truth));
            }
            integ.push(avatar_core::mesh::integrity::integrity(&predicted));
            if let Ok(out) = std::env::var("LOOSE_SHEET") {
                // Every piece but the largest (the wrapped body), close up.
                let (labels, count) = avatar_core::mesh::topology::face_components(&predicted);
                let mut area = vec![0f32; count];
                for (f, &l) in labels.iter().enumerate() {
                    area[l as usize] += predicted.triangle_area(f);
                }
                let big = (0..count).max_by(|&a, &b| area[a].total_cmp(&area[b])).unwrap_or(0);
                let faces: Vec<[u32; 3]> = predicted
                    .faces
                    .iter()
                    .zip(&labels)
                    .filter(|(_, l)| **l as usize != big)
                    .map(|(f, _)| *f)
                    .collect();
                let loose = avatar_core::mesh::topology::compact(&predicted.positions, &faces);
                let views = [
                    Vec3::Z,
                    Vec3::X,
                    Vec3::NEG_Z,
                    Vec3::new(0.0, -1.0, 0.35),
                    Vec3::new(0.0, 1.0, 0.2),
                ];
                avatar_core::synth::contact_sheet::write_view_sheet_from(
                    format!("{out}-{name}{i}.png").as_ref(),
                    &[loose],
                    &views,
                    1.6,
                )?;
            }
            if std::env::var("LOOPS").is_ok() {
                for (label, mesh) in [("loops", &predicted), ("truth's", &truth)] {
                    let mut loops: Vec<(f32, f32, f32)> =
                        avatar_core::mesh::holes::border_loops(mesh)
                            .iter()
                            .map(|l| {
                                let c = l.iter().map(|&v| mesh.positions[v as usize]).sum::<Vec3>()
                                    / l.len() as f32;
                                (avatar_core::mesh::holes::loop_length(mesh, l), c.y, c.z)
                            })
                            .collect();
                    loops.sort_by(|a, b| b.0.total_cmp(&a.0));
                    let t: Vec<String> = loops
                        .iter()
                        .take(12)
                        .map(|(l, y, z)| format!("{l:.2}m@y{y:.2}z{z:.2}"))
                        .collect();
                    println!("{name} {i}: {label} {}", t.join(" "));
                }
            }
            // OBJ=PREFIX: each frame's predicted and true meshes as OBJ files.
            if let Ok(prefix) = std::env::var("OBJ") {
                avatar_core::mesh::io::write_obj(format!("{prefix}-{name}{i}.obj"), &predicted)?;
                avatar_core::mesh::io::write_obj(format!("{prefix}-{name}{i}-truth.obj"), &truth)?;
            }
            let metrics = evaluate_frame(&predicted, &truth, &regions, &options, i as u64)?;
            if worst.as_ref().is_none_or(|w| metrics.surface.spurious > w.0) {
                let far = far_faces(&predicted, &truth);
                worst = Some((
                    metrics.surface.spurious,
                    vec![truth, predicted, far],
                    format!("{name} frame {i}"),
                ));
            }
            rows.push(metrics);
        }
        let mean = |f: &dyn Fn(&avatar_core::eval::metrics::FrameMetrics) -> f32| {
            rows.iter().map(f).sum::<f32>() / rows.len() as f32
        };
        println!(
            "{name:>14}: {} frames, Chamfer-L2 {:.3} cm, NC {:.3}, spurious {:.1} %, missing {:.1} %",
            rows.len(),
            mean(&|m| m.chamfer_cm),
            mean(&|m| m.nc),
            100.0 * mean(&|m| m.surface.spurious),
            100.0 * mean(&|m| m.surface.missing)
        );
        all.extend(rows);
    }
    let n = all.len() as f32;
    println!(
        "{:>14}: {} frames, Chamfer-L2 {:.3} cm, NC {:.3}, spurious {:.1} %, missing {:.1} %",
        "all",
        all.len(),
        all.iter().map(|m| m.chamfer_cm).sum::<f32>() / n,
        all.iter().map(|m| m.nc).sum::<f32>() / n,
        100.0 * all.iter().map(|m| m.surface.spurious).sum::<f32>() / n,
        100.0 * all.iter().map(|m| m.surface.missing).sum::<f32>() / n
    );
    let m = integ.len() as f32;
    println!(
        "integrity: border {:.2} m, non-manifold {:.1}, pieces {:.1}, small {:.1}, self-intersecting {:.2} %",
        integ.iter().map(|i| i.boundary_length_m).sum::<f32>() / m,
        integ.iter().map(|i| i.non_manifold_edges as f32).sum::<f32>() / m,
        integ.iter().map(|i| i.pieces as f32).sum::<f32>() / m,
        integ.iter().map(|i| i.small_pieces as f32).sum::<f32>() / m,
        100.0 * integ.iter().map(|i| i.self_intersecting).sum::<f32>() / m
    );
    if let (Ok(out), Some((spurious, meshes, which))) = (std::env::var("SHEET"), worst) {
        let views = [Vec3::Z, Vec3::X, Vec3::NEG_Z, Vec3::new(0.0, -1.0, 0.35)];
        write_view_sheet(out.as_ref(), &meshes, &views)?;
        println!("{out}: {which}, spurious {:.1} %", spurious * 100.0);
    }
    Ok(())
}

/// The connected pieces of `mesh`, largest first (at most 8): each one's area, its share of
/// the mesh's area, and the share of the mesh's area that is in it and farther than 2 cm from
/// `truth`; then the far share outside the largest piece.
fn pieces_report(mesh: &TriMesh, truth: &TriMesh) -> String {
    let (labels, count) = avatar_core::mesh::topology::face_components(mesh);
    let bvh = Bvh::build(truth);
    let (mut area, mut far) = (vec![0f32; count], vec![0f32; count]);
    for (f, &l) in labels.iter().enumerate() {
        let [a, b, c] = mesh.triangle(f);
        area[l as usize] += mesh.triangle_area(f);
        if is_far(&bvh, (a + b + c) / 3.0) {
            far[l as usize] += mesh.triangle_area(f);
        }
    }
    let total: f32 = area.iter().sum();
    let mut order: Vec<usize> = (0..count).collect();
    order.sort_by(|&a, &b| area[b].total_cmp(&area[a]));
    let pieces: Vec<String> = order
        .iter()
        .take(8)
        .map(|&c| {
            format!(
                "{:.0} cm2 {:.1} % (far {:.1} %)",
                area[c] * 1e4,
                100.0 * area[c] / total,
                100.0 * far[c] / total
            )
        })
        .collect();
    let far_outside: f32 = order.iter().skip(1).map(|&c| far[c]).sum::<f32>() / total;
    format!(
        "{count} pieces: {}; far outside the largest {:.1} %",
        pieces.join(", "),
        100.0 * far_outside
    )
}

/// The faces of `mesh` whose centre lies farther than 2 cm from `truth`.
fn far_faces(mesh: &TriMesh, truth: &TriMesh) -> TriMesh {
    let bvh = Bvh::build(truth);
    let faces = mesh
        .faces
        .iter()
        .copied()
        .filter(|f| {
            let centre = f.iter().map(|&i| mesh.positions[i as usize]).sum::<Vec3>() / 3.0;
            is_far(&bvh, centre)
        })
        .collect();
    TriMesh::new(mesh.positions.clone(), faces)
}

/// Farther than 2 cm from the truth (`bvh`): the evaluation's spurious distance.
fn is_far(truth: &Bvh, x: Vec3) -> bool {
    truth.closest_point(x).is_some_and(|h| h.distance > 0.02)
}

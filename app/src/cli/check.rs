//! `avatar-studio check`: whether an avatar's surface is whole, at the rest pose: its open
//! border, non-manifold edges, pieces, faces that cut through others, and the share of its
//! surface that faces against the naked body beneath it (inside-out patches, crumpled sheets),
//! over the whole body and per part (head, hands, feet); the crossing faces per part beside the
//! naked body's own.

use avatar_core::body::BodyParams;
use avatar_core::eval::integrity::inside_out_shares;
use avatar_core::eval::metrics::Prepared;
use avatar_core::io::Inputs;
use avatar_core::mesh::TriMesh;
use avatar_core::mesh::holes::{border_loops, loop_length};
use avatar_core::mesh::integrity::{integrity, self_intersecting_faces};
use avatar_core::mesh::topology::compact;
use avatar_core::synth::contact_sheet::write_view_sheet_from;
use avatar_core::synth::outfit::{dominant, joint};
use avatar_neural::AnyAvatar;
use glam::Vec3;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// The avatar (NAME.avatar).
    avatar: PathBuf,
    /// Also write a close-up of the head (PNG): the naked body and the avatar, front and side,
    /// faces seen from behind in orange, open borders in blue.
    #[arg(long)]
    head_sheet: Option<PathBuf>,
    /// Also write the whole avatar beside the naked body (PNG), from the front, the side and
    /// the back, coloured as the head's close-up.
    #[arg(long)]
    sheet: Option<PathBuf>,
}

/// SMPL joints of the parts reported on their own.
const HEAD: [usize; 2] = [joint::NECK, 15];
const HANDS: [usize; 4] = [joint::L_WRIST, joint::R_WRIST, 22, 23];
const FEET: [usize; 4] = [joint::L_ANKLE, joint::R_ANKLE, 10, 11];

pub fn run(args: Args) -> anyhow::Result<()> {
    let avatar = AnyAvatar::load(&args.avatar, avatar_studio::cache::field_cache())?;
    let source = avatar.source();
    let body = source.body();
    let rest = BodyParams { betas: source.betas().to_vec(), ..BodyParams::default() };
    let mesh = source.canonical_mesh(&rest)?;
    let naked = body.mesh(body.pose(&rest).vertices);
    let beneath = Prepared::new(&naked, "body")?;
    let part_of = |p: glam::Vec3| dominant(&body.weights[beneath.vertices.nearest(p).0]);
    let i = integrity(&mesh);
    println!(
        "{} at the rest pose: {} vertices, {} faces",
        args.avatar.display(),
        mesh.positions.len(),
        mesh.faces.len()
    );
    let prior = match &avatar {
        avatar_neural::avatar::AnyAvatar::Meta(a) => a.header.prior.as_ref(),
        avatar_neural::avatar::AnyAvatar::Static(a) => a.header.prior.as_ref(),
    };
    if let Some(prior) = prior {
        println!("  fine-tuned from the prior {}: {}", prior.label(), prior.provenance);
    }
    println!(
        "  open border {:.2} m ({} edges), non-manifold edges {}, pieces {} ({} under 1 % of the \
         area), self-intersecting faces {:.2} %",
        i.boundary_length_m,
        i.boundary_edges,
        i.non_manifold_edges,
        i.pieces,
        i.small_pieces,
        100.0 * i.self_intersecting
    );
    let share =
        |joints: &[usize]| inside_out_shares(&mesh, &beneath, |p| joints.contains(&part_of(p)));
    let mut loops: Vec<f32> = border_loops(&mesh).iter().map(|l| loop_length(&mesh, l)).collect();
    if !loops.is_empty() {
        loops.sort_by(|a, b| b.total_cmp(a));
        let longest: Vec<String> = loops.iter().take(5).map(|l| format!("{l:.2}")).collect();
        println!(
            "  open border: {} loops, the longest {} m; {} under 30 cm",
            loops.len(),
            longest.join(", "),
            loops.iter().filter(|&&l| l < 0.3).count()
        );
    }
    // Where the crossing faces lie, beside the naked body's own (the open body's toes cross
    // themselves): each face's crossing and part found once per mesh.
    let crossing_by_part = |m: &TriMesh| -> Vec<(bool, usize)> {
        let flags = self_intersecting_faces(&m.positions, &m.faces);
        m.faces
            .iter()
            .zip(flags)
            .map(|(f, x)| {
                (x, part_of(f.iter().map(|&v| m.positions[v as usize]).sum::<Vec3>() / 3.0))
            })
            .collect()
    };
    let (ours, bare) = (crossing_by_part(&mesh), crossing_by_part(&naked));
    // (crossing, all) faces of the part (`joints` empty: the whole surface).
    let count = |faces: &[(bool, usize)], joints: &[usize]| {
        faces
            .iter()
            .filter(|(_, part)| joints.is_empty() || joints.contains(part))
            .fold((0, 0), |(crossed, all), &(x, _)| (crossed + usize::from(x), all + 1))
    };
    let parts: [(&str, &[usize]); 4] =
        [("whole", &[]), ("head", &HEAD), ("hands", &HANDS), ("feet", &FEET)];
    let mut line = Vec::new();
    for (name, joints) in parts {
        let ((a, an), (b, _)) = (count(&ours, joints), count(&bare, joints));
        line.push(format!("{name} {a} of {an} (naked body {b})"));
    }
    println!("  self-intersecting faces: {}", line.join(", "));
    let (whole, head) = share(&HEAD);
    println!(
        "  facing against the body beneath it: {:.2} % of the surface; head {:.2} %, hands {:.2} %, \
         feet {:.2} %",
        100.0 * whole,
        100.0 * head,
        100.0 * share(&HANDS).1,
        100.0 * share(&FEET).1
    );
    if let Some(path) = &args.sheet {
        Inputs::new().file(&args.avatar).check_file(path, &["png"])?;
        let views = [Vec3::new(0.0, 0.1, 1.0), Vec3::new(1.0, 0.1, 0.3), Vec3::new(0.0, 0.1, -1.0)];
        write_view_sheet_from(path, &[naked.clone(), mesh.clone()], &views, 3.2)?;
        println!("  wrote {}", path.display());
    }
    if let Some(path) = &args.head_sheet {
        Inputs::new().file(&args.avatar).check_file(path, &["png"])?;
        let neck = body.pose(&rest).bones.posed_joints()[joint::NECK].y - 0.02;
        let head = |m: &TriMesh| {
            let faces: Vec<[u32; 3]> = m
                .faces
                .iter()
                .copied()
                .filter(|f| f.iter().all(|&v| m.positions[v as usize].y > neck))
                .collect();
            compact(&m.positions, &faces)
        };
        let views = [Vec3::new(0.0, 0.1, 1.0), Vec3::new(1.0, 0.1, 0.3)];
        write_view_sheet_from(path, &[head(&naked), head(&mesh)], &views, 0.45)?;
        println!("  wrote {}", path.display());
    }
    Ok(())
}

//! How much the synthetic clothing depends on the pose: for every outfit and two poses, the
//! distance between the true posed clothed surface and plain linear blend skinning of the
//! outfit's rest shape (what a pose-independent avatar would show), over clothed vertices.
//!
//! cargo run -p avatar-core --example pose_dependence

use avatar_core::body::{BodyParams, open_body_ref};
use avatar_core::motion::{PoseBuilder, Side};
use avatar_core::synth::*;

fn main() {
    let body = open_body_ref();
    let mut stride = PoseBuilder::relaxed();
    stride
        .hip(Side::Left, 35.0, 0.0, 0.0)
        .hip(Side::Right, -20.0, 0.0, 0.0)
        .knee(Side::Right, 40.0)
        .elbow(Side::Left, 90.0)
        .elbow(Side::Right, 70.0);
    let mut raised = PoseBuilder::tpose();
    raised
        .shoulder(Side::Left, 70.0, 0.0, 0.0)
        .shoulder(Side::Right, 70.0, 0.0, 0.0)
        .hip(Side::Left, 60.0, 10.0, 0.0)
        .hip(Side::Right, 60.0, 10.0, 0.0)
        .knee(Side::Left, 90.0)
        .knee(Side::Right, 90.0);
    let poses: [(&str, BodyParams); 2] =
        [("stride, elbows bent", stride.build()), ("arms raised, squat", raised.build())];
    println!("| outfit | pose | mean (cm) | 95th pct (cm) | max (cm) |");
    println!("|---|---|---|---|---|");
    for outfit in ALL_OUTFITS {
        let t = ClothedTemplate::build(body, &[], outfit);
        for (name, p) in &poses {
            let bones = body.pose(p).bones;
            let truth =
                pose_surface(&t, &canonical_surface(&t, &PoseFeatures::of(&bones), 0), &bones);
            let plain = pose_surface(&t, &t.vertices, &bones);
            let mut d: Vec<f32> = truth
                .iter()
                .zip(&plain)
                .zip(&t.cloth)
                .filter(|(_, c)| **c > 0.5)
                .map(|((a, b), _)| (*a - *b).length() * 100.0)
                .collect();
            d.sort_by(f32::total_cmp);
            let mean = d.iter().sum::<f32>() / d.len() as f32;
            println!(
                "| {} | {name} | {mean:.2} | {:.2} | {:.2} |",
                outfit.name(),
                d[d.len() * 95 / 100],
                d[d.len() - 1]
            );
        }
    }
}

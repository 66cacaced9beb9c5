//! The animated glTF export: a fixed-topology canonical mesh extracted once at the reference
//! (rest) pose, skinned to the 24-joint skeleton, the pose-dependent clothing as PCA morph
//! targets, and per-joint rotation, root translation and morph-weight animation (LINEAR at the
//! clip's frame rate).

use super::glb::{ARRAY_BUFFER, GlbBuilder};
use super::morph::MorphTargets;
pub use super::options::{DEFAULT_COLOR, ExportOptions, top4};
use super::stream::{Control, FrameMaker, stream_frames};
use crate::avatar::AvatarSource;
use crate::body::{JOINT_NAMES, NUM_JOINTS, SMPL_PARENTS};
use crate::error::{Error, Result};
use crate::mesh::TriMesh;
use crate::motion::MotionClip;
use glam::{Quat, Vec3};
use serde_json::json;

/// The exported data (kept for round-trip checks and reports) and the GLB bytes.
pub struct Exported {
    pub glb: Vec<u8>,
    pub rest: TriMesh,
    pub joints: Vec<[u8; 4]>,
    pub weights: Vec<[f32; 4]>,
    pub morphs: MorphTargets,
    /// The posed mesh of every exported frame (forward skinning of the projected surface with
    /// the avatar's full skinning weights; between keyframes the interpolated projection,
    /// `export::keyframes`, within `ExportOptions::interpolation_tolerance` of the studio's):
    /// what the morph targets compress. Kept by [`export_glb`] only; empty from
    /// [`export_glb_streaming`].
    pub posed: Vec<Vec<Vec3>>,
    pub frames: usize,
    pub fps: f32,
    /// Largest PCA reconstruction error of a vertex delta over all frames (metres).
    pub max_compression_error: f32,
    /// Mean vertex error over all frames (metres).
    pub mean_compression_error: f32,
    /// Frames the morph targets' basis was fitted on, and how many of them the refinement
    /// added (`export::stream`).
    pub basis_frames: usize,
    pub refined_frames: usize,
    /// The most frame meshes held at once while exporting (bounded, whatever the clip's length).
    pub peak_frames_held: usize,
    /// Projections made and interpolation checked (`export::keyframes`).
    pub keyframes: super::keyframes::KeyStats,
}

/// Keep quaternions on one hemisphere from key to key so LINEAR slerp takes the short path.
fn continuous(qs: &mut [Quat]) {
    for i in 1..qs.len() {
        if qs[i].dot(qs[i - 1]) < 0.0 {
            qs[i] = -qs[i];
        }
    }
}

/// The animated glTF of `source` playing `clip`, keeping every frame's posed mesh in
/// [`Exported::posed`] (for checks and short clips; memory grows with the clip).
pub fn export_glb(
    source: &dyn AvatarSource,
    clip: &MotionClip,
    options: &ExportOptions,
) -> Result<Exported> {
    export_with(source, clip, options, Control::default(), true)
}

/// [`export_glb`] with progress and cancellation through `control` (the studio's export).
pub fn export_glb_with(
    source: &dyn AvatarSource,
    clip: &MotionClip,
    options: &ExportOptions,
    control: Control,
) -> Result<Exported> {
    export_with(source, clip, options, control, true)
}

/// The animated glTF, frames streamed (`export::stream`): memory bounded whatever the clip's
/// length; progress and cancellation through `control`.
pub fn export_glb_streaming(
    source: &dyn AvatarSource,
    clip: &MotionClip,
    options: &ExportOptions,
    control: Control,
) -> Result<Exported> {
    export_with(source, clip, options, control, false)
}

/// Refuse what the exporter cannot play: an empty clip, a bad frame rate, bad frames.
pub fn check_clip(clip: &MotionClip) -> Result<()> {
    if clip.is_empty() {
        return Err(Error::invalid(format!("motion clip {:?} has no frames", clip.name)));
    }
    if !(clip.fps.is_finite() && clip.fps > 0.0) {
        return Err(Error::invalid(format!(
            "motion clip {:?} has frame rate {}",
            clip.name, clip.fps
        )));
    }
    clip.validate()
}

fn export_with(
    source: &dyn AvatarSource,
    clip: &MotionClip,
    options: &ExportOptions,
    control: Control,
    keep_posed: bool,
) -> Result<Exported> {
    check_clip(clip)?;
    let maker = FrameMaker::new(source, options.newton_steps)?;
    let streamed = stream_frames(&maker, clip, options, control, keep_posed)?;
    let morphs = streamed.basis.targets(&streamed.coefficients);
    let body = source.body();
    let betas = source.betas().to_vec();
    let FrameMaker { rest, joints, weights, .. } = maker;
    let params = &clip.frames;
    let rest_joints = body.rest_joints(&betas);
    let mut b = GlbBuilder::default();
    let flat = |v: &[Vec3]| v.iter().flat_map(|p| p.to_array()).collect::<Vec<f32>>();
    let position = b.floats(&flat(&rest.positions), "VEC3", 3, Some(ARRAY_BUFFER), true);
    let normal = b.floats(&flat(&rest.vertex_normals()), "VEC3", 3, Some(ARRAY_BUFFER), false);
    let joints_acc = b.joints_u8(&joints);
    let weights_acc = b.floats(
        &weights.iter().flatten().copied().collect::<Vec<_>>(),
        "VEC4",
        4,
        Some(ARRAY_BUFFER),
        false,
    );
    let indices = b.indices_u32(&rest.faces.iter().flatten().copied().collect::<Vec<_>>());
    let targets: Vec<serde_json::Value> = morphs
        .all_targets()
        .iter()
        .map(|t| json!({"POSITION": b.floats(&flat(t), "VEC3", 3, Some(ARRAY_BUFFER), true)}))
        .collect();
    let target_names: Vec<String> = std::iter::once("compensation".to_string())
        .chain((0..morphs.targets.len()).map(|k| format!("pca_{k:02}")))
        .collect();
    // Inverse bind matrices: a translation by -J, written as exact constants.
    let ibm: Vec<f32> = rest_joints
        .iter()
        .flat_map(|j| {
            [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, -j.x, -j.y, -j.z, 1.0]
        })
        .collect();
    let ibm_acc = b.floats(&ibm, "MAT4", 16, None, false);

    let n = params.len();
    let times: Vec<f32> = (0..n).map(|f| f as f32 / clip.fps).collect();
    let input = b.floats(&times, "SCALAR", 1, None, true);
    let mut samplers = Vec::new();
    let mut channels = Vec::new();
    for j in 0..NUM_JOINTS {
        let mut qs: Vec<Quat> =
            params.iter().map(|p| Quat::from_scaled_axis(p.pose[j]).normalize()).collect();
        continuous(&mut qs);
        let out = b.floats(
            &qs.iter().flat_map(|q| q.to_array()).collect::<Vec<_>>(),
            "VEC4",
            4,
            None,
            false,
        );
        samplers.push(json!({"input": input, "output": out, "interpolation": "LINEAR"}));
        channels.push(
            json!({"sampler": samplers.len() - 1, "target": {"node": j, "path": "rotation"}}),
        );
    }
    let root_t: Vec<f32> =
        params.iter().flat_map(|p| (rest_joints[0] + p.trans).to_array()).collect();
    let out = b.floats(&root_t, "VEC3", 3, None, false);
    samplers.push(json!({"input": input, "output": out, "interpolation": "LINEAR"}));
    channels
        .push(json!({"sampler": samplers.len() - 1, "target": {"node": 0, "path": "translation"}}));
    let morph_w: Vec<f32> = (0..n).flat_map(|f| morphs.all_weights(f)).collect();
    let out = b.floats(&morph_w, "SCALAR", 1, None, false);
    samplers.push(json!({"input": input, "output": out, "interpolation": "LINEAR"}));
    channels.push(
        json!({"sampler": samplers.len() - 1, "target": {"node": NUM_JOINTS, "path": "weights"}}),
    );

    let nodes: Vec<serde_json::Value> = (0..NUM_JOINTS)
        .map(|j| {
            let parent = SMPL_PARENTS[j];
            let t = if parent < 0 { rest_joints[0] + params[0].trans } else { rest_joints[j] - rest_joints[parent as usize] };
            let children: Vec<usize> = (0..NUM_JOINTS).filter(|&c| SMPL_PARENTS[c] == j as i32).collect();
            let q = Quat::from_scaled_axis(params[0].pose[j]).normalize();
            let mut node = json!({"name": JOINT_NAMES[j], "translation": t.to_array(), "rotation": q.to_array()});
            if !children.is_empty() {
                node["children"] = json!(children);
            }
            node
        })
        .chain(std::iter::once(json!({"name": "avatar", "mesh": 0, "skin": 0})))
        .collect();
    let c = options.color.map(|v| if v.is_finite() { v.clamp(0.0, 1.0) } else { 0.5 });
    let doc = json!({
        "asset": {"version": "2.0", "generator": "Avatar Studio"},
        "scene": 0,
        "scenes": [{"name": "avatar", "nodes": [0, NUM_JOINTS]}],
        "nodes": nodes,
        "skins": [{"joints": (0..NUM_JOINTS).collect::<Vec<_>>(), "inverseBindMatrices": ibm_acc, "skeleton": 0}],
        "meshes": [{
            "name": "avatar",
            "primitives": [{
                "attributes": {"POSITION": position, "NORMAL": normal, "JOINTS_0": joints_acc, "WEIGHTS_0": weights_acc},
                "indices": indices,
                "material": 0,
                "targets": targets,
            }],
            "weights": morphs.all_weights(0),
            "extras": {"targetNames": target_names},
        }],
        "materials": [{
            "name": "avatar",
            "pbrMetallicRoughness": {"baseColorFactor": [c[0], c[1], c[2], 1.0], "metallicFactor": 0.0, "roughnessFactor": 0.7},
        }],
        "animations": [{"name": clip.name, "samplers": samplers, "channels": channels}],
    });
    Ok(Exported {
        glb: b.finish(doc),
        rest,
        joints,
        weights,
        morphs,
        posed: streamed.posed,
        frames: n,
        fps: clip.fps,
        max_compression_error: streamed.max_error,
        mean_compression_error: streamed.mean_error,
        basis_frames: streamed.basis_frames,
        refined_frames: streamed.refined_frames,
        peak_frames_held: streamed.peak_frames_held,
        keyframes: streamed.keys,
    })
}

/// The plain alternative: the studio's posed mesh of every frame as OBJ or PLY files
/// (`frame_000000.obj`, ...), written atomically.
pub fn write_mesh_sequence(
    exported: &Exported,
    dir: &std::path::Path,
    extension: &str,
) -> Result<usize> {
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    for (f, v) in exported.posed.iter().enumerate() {
        let mesh = TriMesh::new(v.clone(), exported.rest.faces.clone());
        crate::mesh::io::write_mesh(dir.join(format!("frame_{f:06}.{extension}")), &mesh)?;
    }
    Ok(exported.posed.len())
}

//! Outfits: clothing as a real surface offset from the body (body topology, per-vertex offset
//! along the normal blended by skinning weights, so edges of garments are smooth), plus free
//! panels that do not follow the legs (a dress skirt, blazer tails) as tubes hanging from the
//! waist, skinned to the pelvis and both hips so they swing as a whole.

use crate::body::{BodyModel, NUM_JOINTS, Weights};
use crate::error::{Error, Result};
use crate::mesh::TriMesh;
use glam::Vec3;

mod cape;

/// SMPL joint indices used by the outfits.
pub mod joint {
    pub const PELVIS: usize = 0;
    pub const L_HIP: usize = 1;
    pub const R_HIP: usize = 2;
    pub const SPINE1: usize = 3;
    pub const L_KNEE: usize = 4;
    pub const R_KNEE: usize = 5;
    pub const SPINE2: usize = 6;
    pub const L_ANKLE: usize = 7;
    pub const R_ANKLE: usize = 8;
    pub const SPINE3: usize = 9;
    pub const NECK: usize = 12;
    pub const L_COLLAR: usize = 13;
    pub const R_COLLAR: usize = 14;
    pub const L_SHOULDER: usize = 16;
    pub const R_SHOULDER: usize = 17;
    pub const L_ELBOW: usize = 18;
    pub const R_ELBOW: usize = 19;
    pub const L_WRIST: usize = 20;
    pub const R_WRIST: usize = 21;
}
use joint::*;

#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Outfit {
    TshirtShorts,
    LongsleeveTrousers,
    PoloLoose,
    Dress,
    BlazerTails,
    /// A fitted top and a long skirt simulated as cloth (`synth::cloth`).
    SimSkirt,
    /// Long sleeves and trousers under a cape from the shoulders to the knees, simulated.
    SimCape,
}

pub const ALL_OUTFITS: [Outfit; 5] = [
    Outfit::TshirtShorts,
    Outfit::LongsleeveTrousers,
    Outfit::PoloLoose,
    Outfit::Dress,
    Outfit::BlazerTails,
];

/// The outfits whose loose garment is simulated as cloth through each motion.
pub const SIM_OUTFITS: [Outfit; 2] = [Outfit::SimSkirt, Outfit::SimCape];

/// A free panel hanging from the waist: a (partial) elliptic tube.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Panel {
    /// Length below the waist (metres).
    pub length: f32,
    /// Extra radius at the hem relative to the waist (metres).
    pub flare: f32,
    /// Angular extent around the body, radians (2 pi = a full skirt; about pi = tails at the back).
    pub extent: f32,
}

/// Offsets (metres along the normal) of one outfit per body region, and its panels.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OutfitSpec {
    /// Shirt over the torso (spine, collars, pelvis above the hem).
    pub shirt: f32,
    /// Extra looseness at the shirt's hem (a polo's loose hem).
    pub hem_flare: f32,
    pub upper_sleeve: f32,
    pub lower_sleeve: f32,
    /// Shorts/trousers over the pelvis and thighs ...
    pub pants: f32,
    /// ... and the shins (0 = shorts).
    pub lower_legs: f32,
    /// How far the shirt's hem rises when both arms are raised overhead (metres).
    pub hem_lift: f32,
    pub panel: Option<Panel>,
}

impl Outfit {
    pub fn name(self) -> &'static str {
        match self {
            Outfit::TshirtShorts => "tshirt_shorts",
            Outfit::LongsleeveTrousers => "longsleeve_trousers",
            Outfit::PoloLoose => "polo_loose",
            Outfit::Dress => "dress",
            Outfit::BlazerTails => "blazer_tails",
            Outfit::SimSkirt => "sim_skirt",
            Outfit::SimCape => "sim_cape",
        }
    }

    pub fn from_name(name: &str) -> Result<Outfit> {
        ALL_OUTFITS.into_iter().chain(SIM_OUTFITS).find(|o| o.name() == name).ok_or_else(|| {
            Error::invalid(format!(
                "unknown outfit {name:?}; valid outfits: {}, {}",
                ALL_OUTFITS.map(|o| o.name()).join(", "),
                SIM_OUTFITS.map(|o| o.name()).join(", ")
            ))
        })
    }

    /// Loose outfits have parts far from the body (the canonicalization targets differ).
    pub fn is_loose(self) -> bool {
        matches!(
            self,
            Outfit::PoloLoose
                | Outfit::Dress
                | Outfit::BlazerTails
                | Outfit::SimSkirt
                | Outfit::SimCape
        )
    }

    /// Whether its loose garment moves as simulated cloth (`synth::cloth`), so that its
    /// surface at a frame depends on the motion before it.
    pub fn is_simulated(self) -> bool {
        SIM_OUTFITS.contains(&self)
    }

    pub fn spec(self) -> OutfitSpec {
        let none = OutfitSpec {
            shirt: 0.0,
            hem_flare: 0.0,
            upper_sleeve: 0.0,
            lower_sleeve: 0.0,
            pants: 0.0,
            lower_legs: 0.0,
            hem_lift: 0.0,
            panel: None,
        };
        match self {
            Outfit::TshirtShorts => OutfitSpec {
                shirt: 0.008,
                upper_sleeve: 0.008,
                pants: 0.010,
                hem_lift: 0.05,
                ..none
            },
            Outfit::LongsleeveTrousers => OutfitSpec {
                shirt: 0.012,
                upper_sleeve: 0.012,
                lower_sleeve: 0.012,
                pants: 0.015,
                lower_legs: 0.015,
                hem_lift: 0.05,
                ..none
            },
            Outfit::PoloLoose => OutfitSpec {
                shirt: 0.022,
                hem_flare: 0.045,
                upper_sleeve: 0.016,
                pants: 0.012,
                hem_lift: 0.07,
                ..none
            },
            Outfit::Dress => OutfitSpec {
                shirt: 0.010,
                upper_sleeve: 0.008,
                hem_lift: 0.0,
                panel: Some(Panel { length: 0.55, flare: 0.12, extent: std::f32::consts::TAU }),
                ..none
            },
            Outfit::BlazerTails => OutfitSpec {
                shirt: 0.030,
                upper_sleeve: 0.022,
                lower_sleeve: 0.020,
                pants: 0.016,
                lower_legs: 0.016,
                hem_lift: 0.04,
                panel: Some(Panel { length: 0.38, flare: 0.05, extent: 3.4 }),
                ..none
            },
            Outfit::SimSkirt => OutfitSpec {
                shirt: 0.008,
                upper_sleeve: 0.008,
                panel: Some(Panel { length: 0.78, flare: 0.2, extent: std::f32::consts::TAU }),
                ..none
            },
            Outfit::SimCape => OutfitSpec {
                shirt: 0.012,
                upper_sleeve: 0.012,
                lower_sleeve: 0.012,
                pants: 0.015,
                lower_legs: 0.015,
                hem_lift: 0.05,
                ..none
            },
        }
    }
}

/// The rest (T-pose, pose-independent) clothed surface of one subject in one outfit, with
/// everything the pose-dependent deformation and the ground truth need per vertex.
#[derive(Debug, Clone)]
pub struct ClothedTemplate {
    pub outfit: Outfit,
    pub vertices: Vec<Vec3>,
    pub normals: Vec<Vec3>,
    /// The naked shaped body in the rest pose (the garments are offsets from it).
    pub body_rest: Vec<Vec3>,
    pub faces: Vec<[u32; 3]>,
    pub weights: Vec<Weights>,
    /// The body joint each vertex belongs to (dominant skinning weight; the pelvis for panels).
    pub vertex_joint: Vec<u8>,
    /// Per vertex: how much it is covered by a garment (0 = skin, 1 = cloth).
    pub cloth: Vec<f32>,
    /// Per body vertex: the shirt's offset before the hem cut (so the pose can move the hem),
    /// and the offset of what is under the shirt (pants).
    pub shirt_offset: Vec<f32>,
    pub base_offset: Vec<f32>,
    /// Naked body vertices under the garments (the first `body_vertices` entries).
    pub body_vertices: usize,
    /// Panel vertices: (height fraction 0 waist .. 1 hem, angle around the body).
    pub panel: Vec<(f32, f32)>,
    /// Rest height of the shirt's hem (metres, canonical Y).
    pub hem_y: f32,
    pub waist_y: f32,
    /// The shaped body's rest joints.
    pub rest_joints: [Vec3; NUM_JOINTS],
}

fn smoothstep(e0: f32, e1: f32, x: f32) -> f32 {
    let t = ((x - e0) / (e1 - e0)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// Sum of the weights of the listed joints.
fn weight_of(w: &Weights, joints: &[usize]) -> f32 {
    joints.iter().map(|&j| w[j]).sum()
}

pub fn dominant(w: &Weights) -> usize {
    (0..NUM_JOINTS).max_by(|&a, &b| w[a].total_cmp(&w[b])).unwrap_or(0)
}

impl ClothedTemplate {
    /// Dress the shaped body (`betas`) in `outfit`.
    pub fn build(body: &BodyModel, betas: &[f32], outfit: Outfit) -> ClothedTemplate {
        let spec = outfit.spec();
        let rest = body.shaped_vertices(betas);
        let joints = body.regress_joints(&rest);
        let normals = body.mesh(rest.clone()).vertex_normals();
        let waist_y = joints[PELVIS].y + 0.6 * (joints[SPINE1].y - joints[PELVIS].y);
        // The shirt ends a little below the hip joints.
        let hem_y = joints[L_HIP].y - 0.03;
        let n = rest.len();
        let mut shirt_offset = vec![0f32; n];
        let mut base_offset = vec![0f32; n];
        for v in 0..n {
            let w = &body.weights[v];
            let torso = weight_of(w, &[PELVIS, SPINE1, SPINE2, SPINE3, L_COLLAR, R_COLLAR]);
            let upper = weight_of(w, &[L_SHOULDER, R_SHOULDER]);
            let lower = weight_of(w, &[L_ELBOW, R_ELBOW]);
            let thigh = weight_of(w, &[L_HIP, R_HIP]);
            let shin = weight_of(w, &[L_KNEE, R_KNEE]);
            // The neck and head stay bare: fade the shirt out towards the neck joint.
            let neck_fade =
                1.0 - smoothstep(joints[NECK].y - 0.08, joints[NECK].y - 0.02, rest[v].y);
            shirt_offset[v] =
                (torso * spec.shirt + upper * spec.upper_sleeve + lower * spec.lower_sleeve)
                    * neck_fade;
            // Pants cover the pelvis below the waist and the legs.
            let below_waist = 1.0 - smoothstep(waist_y - 0.02, waist_y + 0.02, rest[v].y);
            base_offset[v] = (torso * below_waist + thigh) * spec.pants + shin * spec.lower_legs;
        }
        let mut t = ClothedTemplate {
            outfit,
            vertices: Vec::new(),
            normals: normals.clone(),
            body_rest: rest.clone(),
            faces: body.faces.clone(),
            weights: body.weights.clone(),
            vertex_joint: body.weights.iter().map(|w| dominant(w) as u8).collect(),
            cloth: vec![0.0; n],
            shirt_offset,
            base_offset,
            body_vertices: n,
            panel: Vec::new(),
            hem_y,
            waist_y,
            rest_joints: joints,
        };
        t.vertices = rest.clone();
        // Offsets at the rest pose (hem not lifted), so `vertices` is the rest clothed surface.
        let offsets = t.offsets(0.0);
        for v in 0..n {
            t.vertices[v] = rest[v] + normals[v] * offsets[v];
            t.cloth[v] = (offsets[v] / 0.004).min(1.0);
        }
        if let Some(panel) = spec.panel {
            t.add_panel(&rest, &joints, panel);
        }
        if outfit == Outfit::SimCape {
            cape::add_cape(&mut t);
        }
        t
    }

    /// Per-body-vertex offset with the shirt's hem raised by `lift` metres.
    pub fn offsets(&self, lift: f32) -> Vec<f32> {
        let spec = self.outfit.spec();
        let hem = self.hem_y + lift;
        (0..self.body_vertices)
            .map(|v| {
                let y = self.body_rest[v].y;
                let on_torso = self.shirt_offset[v] > 0.0;
                let below = smoothstep(hem - 0.015, hem + 0.015, y);
                // A loose hem: extra room in the 12 cm above the hem.
                let flare = spec.hem_flare * (1.0 - smoothstep(hem, hem + 0.12, y)) * below;
                let shirt = if on_torso {
                    (self.shirt_offset[v] + flare) * below + self.sleeve_part(v) * (1.0 - below)
                } else {
                    0.0
                };
                shirt.max(self.base_offset[v])
            })
            .collect()
    }

    /// Sleeves are never cut by the torso hem (they are above it anyway).
    fn sleeve_part(&self, v: usize) -> f32 {
        let spec = self.outfit.spec();
        let w = &self.weights[v];
        weight_of(w, &[L_SHOULDER, R_SHOULDER]) * spec.upper_sleeve
            + weight_of(w, &[L_ELBOW, R_ELBOW]) * spec.lower_sleeve
    }

    fn add_panel(&mut self, rest: &[Vec3], joints: &[Vec3; NUM_JOINTS], panel: Panel) {
        const RINGS: usize = 24;
        const SEGMENTS: usize = 72;
        // The waist ring: the body's extent at waist height, plus the shirt's offset and a gap.
        let near_waist: Vec<Vec3> = rest
            .iter()
            .copied()
            .filter(|p| (p.y - self.waist_y).abs() < 0.02 && p.x.abs() < 0.25)
            .collect();
        let cx = joints[PELVIS].x;
        let cz = near_waist.iter().map(|p| p.z).sum::<f32>() / near_waist.len().max(1) as f32;
        let rx = near_waist.iter().map(|p| (p.x - cx).abs()).fold(0.1f32, f32::max) + 0.025;
        let rz = near_waist.iter().map(|p| (p.z - cz).abs()).fold(0.08f32, f32::max) + 0.025;
        // Hips are wider than the waist: the skirt must clear them.
        let hips: Vec<Vec3> = rest
            .iter()
            .copied()
            .filter(|p| (p.y - joints[L_HIP].y).abs() < 0.05 && p.x.abs() < 0.3)
            .collect();
        let hip_rx = hips.iter().map(|p| (p.x - cx).abs()).fold(rx, f32::max) + 0.03;
        let hip_rz = hips.iter().map(|p| (p.z - cz).abs()).fold(rz, f32::max) + 0.03;
        let full = panel.extent >= std::f32::consts::TAU - 1e-3;
        let cols = if full { SEGMENTS } else { SEGMENTS / 2 + 1 };
        let base = self.vertices.len() as u32;
        for r in 0..=RINGS {
            let t = r as f32 / RINGS as f32;
            let y = self.waist_y - t * panel.length;
            // Radius grows quickly to clear the hips, then flares to the hem.
            let hip_t = smoothstep(0.0, 0.35, t);
            let ex = rx + (hip_rx - rx) * hip_t + panel.flare * t * t;
            let ez = rz + (hip_rz - rz) * hip_t + panel.flare * t * t;
            for c in 0..cols {
                // Angle 0 = front (+Z); tails are centred at the back (pi).
                let a = if full {
                    c as f32 / cols as f32 * std::f32::consts::TAU
                } else {
                    std::f32::consts::PI - panel.extent / 2.0
                        + panel.extent * c as f32 / (cols - 1) as f32
                };
                let dir = Vec3::new(a.sin(), 0.0, a.cos());
                self.vertices.push(Vec3::new(cx + ex * dir.x, y, cz + ez * dir.z));
                self.normals.push(Vec3::new(dir.x / ex, 0.0, dir.z / ez).normalize());
                // Pelvis at the waist, both hips lower down, the near leg's side more.
                let side = dir.x.clamp(-1.0, 1.0);
                let mut w: Weights = [0.0; NUM_JOINTS];
                w[PELVIS] = 1.0 - 0.6 * t;
                w[L_HIP] = 0.6 * t * (0.5 + 0.5 * side);
                w[R_HIP] = 0.6 * t * (0.5 - 0.5 * side);
                self.weights.push(w);
                self.vertex_joint.push(PELVIS as u8);
                self.cloth.push(1.0);
                self.panel.push((t, a));
            }
        }
        let idx = |r: usize, c: usize| base + (r * cols + c % cols) as u32;
        let last_col = if full { cols } else { cols - 1 };
        for r in 0..RINGS {
            for c in 0..last_col {
                // Outward-facing triangles (counter-clockwise seen from outside).
                self.faces.push([idx(r, c), idx(r + 1, c), idx(r + 1, c + 1)]);
                self.faces.push([idx(r, c), idx(r + 1, c + 1), idx(r, c + 1)]);
            }
        }
    }

    pub fn mesh(&self) -> TriMesh {
        TriMesh::new(self.vertices.clone(), self.faces.clone())
    }
}

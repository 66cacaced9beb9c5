//! A long take exports in bounded memory: a generated 3,000-frame 120 fps clip
//! (`motion::bvh_write::long_take`, written as BVH and read back) exported frame by frame
//! (`export_glb_streaming`). The allocation high-water mark of this test binary (a counting
//! global allocator) while exporting 3,000 frames is compared with 750 frames of the same take:
//! holding every frame's delta, as the exporter did before, would add 2,250 deltas; the
//! streamed export must add under a tenth of that. Its compression error stays within the
//! file's bound on every frame, sampled or not.

use avatar_core::avatar::AvatarSource;
use avatar_core::body::{BodyModel, BodyParams, Weights, open_body_ref};
use avatar_core::export::{Control, ExportOptions, export_glb_streaming};
use avatar_core::mesh::TriMesh;
use avatar_core::motion::MotionClip;
use glam::Vec3;
use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

struct Counting;
static LIVE: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let p = unsafe { System.alloc(layout) };
        if !p.is_null() {
            let now = LIVE.fetch_add(layout.size(), Ordering::Relaxed) + layout.size();
            PEAK.fetch_max(now, Ordering::Relaxed);
        }
        p
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) };
        LIVE.fetch_sub(layout.size(), Ordering::Relaxed);
    }
}

#[global_allocator]
static ALLOCATOR: Counting = Counting;

/// The open body (13,380 vertices) with a pose-dependent "garment": its surface moves out with the knees'
/// and the shoulders' angles (a smooth, low-rank change, as clothing's is).
struct BodyAvatar {
    body: &'static BodyModel,
}

impl AvatarSource for BodyAvatar {
    fn body(&self) -> &BodyModel {
        self.body
    }
    fn betas(&self) -> &[f32] {
        &[]
    }
    fn canonical_mesh(&self, _params: &BodyParams) -> avatar_core::Result<TriMesh> {
        Ok(TriMesh::new(self.body.v_template.clone(), self.body.faces.clone()))
    }
    fn sdf(&self, _params: &BodyParams, points: &[Vec3]) -> avatar_core::Result<Vec<f32>> {
        Ok(vec![0.0; points.len()])
    }
    fn skinning_weights(&self, points: &[Vec3]) -> Vec<Weights> {
        vec![self.body.weights[0]; points.len()]
    }
    fn mesh_skinning_weights(&self, _mesh: &TriMesh) -> Vec<Weights> {
        self.body.weights.clone()
    }
    fn project(
        &self,
        params: &BodyParams,
        points: &[Vec3],
        _steps: usize,
    ) -> avatar_core::Result<Vec<Vec3>> {
        let knees = params.pose[4].length() + params.pose[5].length();
        let arms = params.pose[16].z - params.pose[17].z;
        Ok(points
            .iter()
            .map(|p| {
                let low = (-p.y * 2.0).exp(); // more at the legs
                *p + Vec3::new(p.x, 0.0, p.z) * (0.02 * knees * low)
                    + Vec3::new(0.0, 0.01 * arms * p.x, 0.0)
            })
            .collect())
    }
}

fn export_peak(avatar: &BodyAvatar, clip: &MotionClip, options: &ExportOptions) -> (usize, usize) {
    let before = LIVE.load(Ordering::Relaxed);
    PEAK.store(before, Ordering::Relaxed);
    let e = export_glb_streaming(avatar, clip, options, Control::default()).unwrap();
    assert_eq!(e.frames, clip.len());
    assert!(e.posed.is_empty(), "a streamed export keeps no posed meshes");
    assert!(e.max_compression_error <= options.error_bound, "{}", e.max_compression_error);
    let bound = options.sample_frames + options.refine_frames + avatar_core::export::stream::CHUNK;
    assert!(e.peak_frames_held <= bound, "{} frames held", e.peak_frames_held);
    (PEAK.load(Ordering::Relaxed) - before, e.peak_frames_held)
}

#[test]
fn a_3000_frame_take_at_120_fps_exports_in_bounded_memory() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("take.bvh");
    let take = avatar_core::motion::bvh_write::long_take("take", 3000, 120.0).unwrap();
    avatar_core::motion::bvh_write::save_bvh(&take, &path).unwrap();
    let clip = MotionClip::load(&path).unwrap();
    assert_eq!((clip.len(), clip.fps.round()), (3000, 120.0));
    let avatar = BodyAvatar { body: open_body_ref() };
    let options = ExportOptions { max_targets: 16, sample_frames: 64, ..Default::default() };
    let short = MotionClip { frames: clip.frames[..750].to_vec(), ..clip.clone() };
    let (peak_short, _) = export_peak(&avatar, &short, &options);
    let (peak_long, held) = export_peak(&avatar, &clip, &options);
    let delta_bytes = avatar.body.v_template.len() * std::mem::size_of::<Vec3>();
    let all_frames = 2250 * delta_bytes;
    let growth = peak_long.saturating_sub(peak_short);
    eprintln!(
        "peak {:.1} MB (750 frames) -> {:.1} MB (3,000 frames): +{:.2} MB; holding every delta would add {:.1} MB; {held} frames held at most",
        peak_short as f64 / 1e6,
        peak_long as f64 / 1e6,
        growth as f64 / 1e6,
        all_frames as f64 / 1e6
    );
    assert!(growth < all_frames / 10, "memory grew by {growth} bytes with the clip");
    // The same take resampled to 30 fps: a quarter of the frames, each a source frame.
    let at30 = clip.resample(30.0).unwrap();
    assert_eq!((at30.len(), at30.source_fps.round()), (750, 120.0));
}

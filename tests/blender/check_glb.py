"""Headless Blender check of an animated GLB from `avatar-studio export`.

Run:
    blender -b --factory-startup --python-exit-code 2 --python tests/blender/check_glb.py -- \
        anim.glb --expect-joints 24 --expect-shape-keys 41 --expect-frames 96

Imports the file with Blender's own glTF importer (bpy.ops.import_scene.gltf), finds the
armature and the mesh it skins, counts bones, shape keys (without the Basis key) and animation
keyframes, then plays the animation: every frame is set on the scene and the skinned, morphed
mesh is evaluated through the depsgraph. Prints one line `BLENDER_CHECK {json}` and exits 0
when everything matches, 1 with `BLENDER_CHECK_FAILED: ...` lines otherwise. Argument errors
exit 2. See docs/export.md ("Blender").

How the importer (io_scene_gltf2 3.4) maps the file, checked on the walk clip:
  * skin joints -> bones of one armature object named after the skin ("Armature" when the skin
    has no name); bone names are the joint nodes' names.
  * the skinned mesh is re-created as a child of the armature with an Armature modifier; because
    the mesh node carries the morph-weights animation, the original node stays behind as an
    empty of the same name and the mesh object gets a suffix ("avatar.001").
  * every morph target that moves POSITION -> one shape key, named from mesh.extras.targetNames
    (so the constant `compensation` target is a shape key like the PCA ones), after a "Basis"
    key the importer adds itself.
  * animation times are converted with the scene's frame rate (frame = t * fps), so a 30 fps clip
    imported into the default 24 fps scene lands on fractional frames. The script therefore
    imports once to read the key spacing, sets the scene rate to the clip's and imports again.
  * each glTF animation becomes an action per object (NAME_Armature for the bones, NAME_<mesh>
    for the shape keys), active and also pushed to an NLA track named after the animation.
"""

import json
import logging
import math
import os
import sys
import time

import bpy

try:
    import numpy as np
except ImportError:  # the glTF importer itself needs numpy; say so instead of a traceback
    print("BLENDER_CHECK_FAILED: Python numpy is missing (Debian: apt-get install python3-numpy); "
          "Blender's glTF importer needs it", flush=True)
    sys.exit(1)


def parse_args():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    import argparse

    p = argparse.ArgumentParser(prog="check_glb.py", description="Headless Blender check of an animated GLB.")
    p.add_argument("file")
    p.add_argument("--expect-joints", type=int, required=True)
    p.add_argument("--expect-shape-keys", type=int, required=True, help="shape keys without Basis")
    p.add_argument("--expect-frames", type=int, required=True, help="animation keyframes (glTF samples)")
    p.add_argument("--fps", type=float, default=0.0, help="the clip's frame rate; 0 (default) infers it from the keys")
    p.add_argument("--compare-obj", metavar="DIR",
                   help="folder of `avatar-studio export --format obj` of the same clip: every frame_NNNNNN.obj "
                        "there is compared vertex by vertex with Blender's evaluated mesh of that frame")
    p.add_argument("--max-error", type=float, default=0.002,
                   help="largest vertex distance (metres) allowed by --compare-obj (default 2 mm)")
    p.add_argument("--min-motion", type=float, default=1e-3,
                   help="the evaluated mesh must move at least this far (metres) between some frames")
    try:
        args = p.parse_args(argv)
    except SystemExit as e:
        sys.exit(2 if e.code else 0)
    for path in [args.file] + ([args.compare_obj] if args.compare_obj else []):
        if not os.path.exists(path):
            print(f"BLENDER_CHECK_FAILED: {path} does not exist", flush=True)
            sys.exit(2)
    return args


class WarningCollector(logging.Handler):
    """Keeps the importer's log records at WARNING and above (its logger is 'glTFImporter')."""

    def __init__(self):
        super().__init__(level=logging.WARNING)
        self.messages = []

    def emit(self, record):
        self.messages.append(f"{record.levelname}: {record.getMessage()}")


IMPORT_LOG = WarningCollector()
logging.getLogger("glTFImporter").addHandler(IMPORT_LOG)


def import_file(path, fps):
    """Empties the scene, sets its frame rate, imports the GLB. Returns the import's seconds."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    # The importer logs at CRITICAL only unless Blender's debug value asks for more; 2 = WARNING.
    bpy.app.debug_value = 2
    IMPORT_LOG.messages.clear()
    scene = bpy.context.scene
    if fps:
        scene.render.fps = int(round(fps))
        scene.render.fps_base = 1.0
    t = time.time()
    # import_shading="SMOOTH": Debian bookworm's Blender 3.4.1 with numpy 1.24 fails in the
    # default "NORMALS" mode (np.bool was removed from numpy; the importer fixed it in 3.5).
    # The avatar is one smooth surface, so this loses nothing.
    result = bpy.ops.import_scene.gltf(filepath=path, import_shading="SMOOTH")
    if result != {"FINISHED"}:
        raise RuntimeError(f"the glTF importer returned {result}")
    return time.time() - t


def read_obj_positions(path):
    """The `v` lines of an OBJ file, converted from glTF's Y-up to Blender's Z-up as the importer does."""
    rows = []
    with open(path) as f:
        for line in f:
            if line.startswith("v "):
                rows.append([float(x) for x in line.split()[1:4]])
    v = np.array(rows, dtype=np.float64).reshape(-1, 3)
    return np.stack([v[:, 0], -v[:, 2], v[:, 1]], axis=1)


def key_times(action):
    times = set()
    for fc in action.fcurves:
        for kp in fc.keyframe_points:
            times.add(round(kp.co[0], 4))
    return sorted(times)


def main():
    args = parse_args()
    errors = []

    def check(ok, message):
        if not ok:
            errors.append(message)
        return ok

    try:
        import_s = import_file(args.file, args.fps)
    except Exception as e:  # the importer raises RuntimeError with its Python traceback inside
        print(f"BLENDER_CHECK_FAILED: importing {args.file}: {e}", flush=True)
        sys.exit(1)

    def find_objects():
        armatures = [o for o in bpy.context.scene.objects if o.type == "ARMATURE"]
        skinned = [o for o in bpy.context.scene.objects if o.type == "MESH"
                   and any(m.type == "ARMATURE" and m.object is not None for m in o.modifiers)]
        return armatures, skinned

    armatures, skinned = find_objects()
    if not (check(len(armatures) == 1, f"expected one armature, found {len(armatures)}")
            and check(len(skinned) == 1, f"expected one skinned mesh, found {len(skinned)}")):
        finish(args, errors, {})
    arm = armatures[0]
    if not arm.animation_data or not arm.animation_data.action:
        check(False, "the armature has no active action (no joint animation imported)")
        finish(args, errors, {})

    # The importer converts seconds to frames with the scene's rate: read the clip's rate from
    # the key spacing and import again at that rate so that one clip frame = one scene frame.
    fps = args.fps
    if not fps:
        times = key_times(arm.animation_data.action)
        if len(times) >= 2:
            spacing = (times[-1] - times[0]) / (len(times) - 1)
            fps = bpy.context.scene.render.fps / spacing
            if abs(spacing - 1.0) > 1e-4:
                import_s = import_file(args.file, fps)
                armatures, skinned = find_objects()
                arm = armatures[0]
        else:
            fps = float(bpy.context.scene.render.fps)

    scene = bpy.context.scene
    mesh_obj = skinned[0]
    check(mesh_obj.find_armature() == arm, f"the mesh {mesh_obj.name!r} is not deformed by {arm.name!r}")

    joints = len(arm.data.bones)
    key = mesh_obj.data.shape_keys
    blocks = list(key.key_blocks) if key else []
    basis = key.reference_key if key else None
    shape_keys = [kb for kb in blocks if kb != basis]
    arm_action = arm.animation_data.action
    sk_action = key.animation_data.action if key and key.animation_data else None

    bone_curves = [fc for fc in arm_action.fcurves if fc.data_path.startswith("pose.bones[")]
    animated_bones = sorted({fc.data_path.split('"')[1] for fc in bone_curves})
    sk_curves = list(sk_action.fcurves) if sk_action else []
    curves = bone_curves + sk_curves
    key_counts = sorted({len(fc.keyframe_points) for fc in curves})
    frames = key_counts[-1] if key_counts else 0
    f0, f1 = arm_action.frame_range
    if sk_action:
        f0, f1 = min(f0, sk_action.frame_range[0]), max(f1, sk_action.frame_range[1])

    check(joints == args.expect_joints, f"joints: Blender has {joints} bones, expected {args.expect_joints}")
    check(len(shape_keys) == args.expect_shape_keys,
          f"shape keys: Blender has {len(shape_keys)} (without Basis), expected {args.expect_shape_keys}")
    check(frames == args.expect_frames, f"frames: the animation has {frames} keyframes, expected {args.expect_frames}")
    check(len(key_counts) <= 1, f"animation curves disagree on the number of keyframes: {key_counts}")
    check(abs((f1 - f0) - (frames - 1)) < 1e-3,
          f"frame range {f0:g}..{f1:g} at {scene.render.fps} fps does not hold {frames} frames one apart")
    check(len(animated_bones) == joints,
          f"{len(animated_bones)} of {joints} bones are animated")
    if shape_keys:
        check(sk_action is not None, "the shape keys have no action (morph weights not imported)")
        check(len(sk_curves) == len(shape_keys),
              f"{len(sk_curves)} shape-key curves for {len(shape_keys)} shape keys")

    # Play: set every frame, evaluate the skinned, morphed mesh, watch it and the key values move.
    t = time.time()
    n = len(mesh_obj.data.vertices)
    first = prev = None
    max_step = max_from_first = 0.0
    centroids = []
    compared = []
    values = np.zeros((0, len(shape_keys)))
    frame_list = list(range(int(math.floor(f0 + 1e-6)), int(math.floor(f1 + 1e-6)) + 1))
    co = np.empty(n * 3, dtype=np.float32)
    for frame in frame_list:
        scene.frame_set(frame)
        depsgraph = bpy.context.evaluated_depsgraph_get()
        ev = mesh_obj.evaluated_get(depsgraph)
        me = ev.to_mesh()
        if not check(len(me.vertices) == n, f"frame {frame}: evaluated mesh has {len(me.vertices)} vertices, not {n}"):
            ev.to_mesh_clear()
            break
        me.vertices.foreach_get("co", co)
        m = np.array(ev.matrix_world, dtype=np.float64)
        ev.to_mesh_clear()
        p = co.reshape(n, 3).astype(np.float64) @ m[:3, :3].T + m[:3, 3]
        if not check(bool(np.isfinite(p).all()), f"frame {frame}: non-finite vertex positions"):
            break
        if first is None:
            first = p
        else:
            max_step = max(max_step, float(np.linalg.norm(p - prev, axis=1).max()))
            max_from_first = max(max_from_first, float(np.linalg.norm(p - first, axis=1).max()))
        prev = p
        centroids.append(p.mean(axis=0))
        if args.compare_obj:
            obj_path = os.path.join(args.compare_obj, f"frame_{frame - frame_list[0]:06d}.obj")
            if os.path.exists(obj_path):
                ref = read_obj_positions(obj_path)
                if check(ref.shape == p.shape, f"{obj_path}: {len(ref)} vertices, Blender has {n}"):
                    err = float(np.linalg.norm(p - ref, axis=1).max())
                    compared.append(err)
                    check(err <= args.max_error,
                          f"frame {frame}: Blender's vertices are up to {err * 1000:.2f} mm from {obj_path}")
        values = np.vstack([values, [kb.value for kb in shape_keys]]) if shape_keys else values
    eval_s = time.time() - t

    check(len(frame_list) == frames, f"played {len(frame_list)} scene frames for {frames} keyframes")
    check(max_from_first >= args.min_motion,
          f"the evaluated mesh does not move: largest vertex motion from the first frame {max_from_first:.2e} m")
    varying = []
    if args.compare_obj:
        check(len(compared) > 0, f"no frame_NNNNNN.obj compared from {args.compare_obj}")
    if shape_keys and len(values) > 1:
        spread = values.max(axis=0) - values.min(axis=0)
        varying = [kb.name for kb, s in zip(shape_keys, spread) if s > 1e-6]
        if len(shape_keys) > 1:
            check(len(varying) > 0, "no shape-key value changes while the animation plays")

    # The exported PBR material: Blender's importer makes it a Principled BSDF whose Base Color
    # is the file's baseColorFactor (linear RGB).
    material = mesh_obj.active_material
    base_color = None
    if material is not None and material.use_nodes:
        bsdf = next((nd for nd in material.node_tree.nodes if nd.type == "BSDF_PRINCIPLED"), None)
        if bsdf is not None:
            base_color = [round(float(v), 4) for v in bsdf.inputs["Base Color"].default_value[:3]]
    check(base_color is not None, "the mesh has no material with a Principled BSDF")

    summary = {
        "file": args.file,
        "material": material.name if material is not None else None,
        "base_color": base_color,
        "blender": bpy.app.version_string,
        "armature": arm.name,
        "mesh": mesh_obj.name,
        "vertices": n,
        "joints": joints,
        "root_bones": [b.name for b in arm.data.bones if b.parent is None],
        "shape_keys": len(shape_keys),
        "shape_key_names": [kb.name for kb in shape_keys[:3]] + (["..."] if len(shape_keys) > 3 else []),
        "animated_shape_keys": len(varying),
        "frames": frames,
        "fps": round(fps, 4),
        "frame_range": [round(f0, 4), round(f1, 4)],
        "played_frames": len(frame_list),
        "actions": sorted(a.name for a in bpy.data.actions),
        "max_vertex_step_m": round(max_step, 5),
        "max_vertex_motion_m": round(max_from_first, 5),
        "centroid_travel_m": round(float(np.linalg.norm(centroids[-1] - centroids[0])), 4) if centroids else 0.0,
        "import_warnings": list(IMPORT_LOG.messages),
        "obj_frames_compared": len(compared),
        "obj_max_error_mm": round(max(compared) * 1000, 4) if compared else None,
        "import_s": round(import_s, 3),
        "play_s": round(eval_s, 3),
    }
    finish(args, errors, summary)


def finish(args, errors, summary):
    summary = dict(summary, ok=not errors, errors=errors)
    print("BLENDER_CHECK " + json.dumps(summary), flush=True)
    for e in errors:
        print(f"BLENDER_CHECK_FAILED: {e}", flush=True)
    sys.exit(1 if errors else 0)


if __name__ == "__main__":
    main()

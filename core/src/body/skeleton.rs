//! SMPL's 24-joint skeleton: names, parents, left/right pairs and body-part groups.

pub const NUM_JOINTS: usize = 24;

/// Parent of each joint (root = -1). Parents always precede children.
pub const SMPL_PARENTS: [i32; NUM_JOINTS] =
    [-1, 0, 0, 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 9, 9, 12, 13, 14, 16, 17, 18, 19, 20, 21];

pub const JOINT_NAMES: [&str; NUM_JOINTS] = [
    "pelvis",
    "left_hip",
    "right_hip",
    "spine1",
    "left_knee",
    "right_knee",
    "spine2",
    "left_ankle",
    "right_ankle",
    "spine3",
    "left_foot",
    "right_foot",
    "neck",
    "left_collar",
    "right_collar",
    "head",
    "left_shoulder",
    "right_shoulder",
    "left_elbow",
    "right_elbow",
    "left_wrist",
    "right_wrist",
    "left_hand",
    "right_hand",
];

/// (left, right) joint pairs.
pub const LEFT_RIGHT_PAIRS: [(usize, usize); 9] =
    [(1, 2), (4, 5), (7, 8), (10, 11), (13, 14), (16, 17), (18, 19), (20, 21), (22, 23)];

/// Joints whose regions MetaAvatar's metrics keep (clothed regions). Hands, wrists, feet,
/// ankles, neck and head are excluded.
pub const CLOTHED_JOINTS: [usize; 14] = [0, 1, 2, 3, 4, 5, 6, 9, 13, 14, 16, 17, 18, 19];

/// Coarse body part of a joint's region, used for labels and metric masks.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub enum BodyPart {
    Torso,
    Arm,
    Leg,
    Hand,
    Foot,
    Head,
}

impl BodyPart {
    pub fn of_joint(j: usize) -> BodyPart {
        match j {
            0 | 3 | 6 | 9 | 13 | 14 => BodyPart::Torso,
            1 | 2 | 4 | 5 => BodyPart::Leg,
            7 | 8 | 10 | 11 => BodyPart::Foot,
            12 | 15 => BodyPart::Head,
            16..=19 => BodyPart::Arm,
            _ => BodyPart::Hand,
        }
    }

    /// Whether the evaluation protocol scores this joint's region.
    pub fn is_clothed_joint(j: usize) -> bool {
        CLOTHED_JOINTS.contains(&j)
    }
}

/// Parent index or `None` for the root.
pub fn parent(j: usize) -> Option<usize> {
    let p = SMPL_PARENTS[j];
    (p >= 0).then_some(p as usize)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parents_precede_children_and_pairs_mirror_names() {
        for j in 1..NUM_JOINTS {
            assert!((SMPL_PARENTS[j] as usize) < j);
        }
        for (l, r) in LEFT_RIGHT_PAIRS {
            assert_eq!(JOINT_NAMES[l].replace("left", "right"), JOINT_NAMES[r]);
        }
    }
}

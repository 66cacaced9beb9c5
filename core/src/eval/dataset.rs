//! The evaluation set: synthetic subjects and outfits that meta-training never sees, and the
//! clips used to fine-tune and to evaluate. One place defines the split.

use crate::synth::Outfit;

/// Shape seeds of the subjects meta-training may use.
pub const TRAIN_SUBJECT_SEEDS: std::ops::Range<u64> = 1..41;
/// Shape seeds of the held-out evaluation subjects (disjoint from training).
pub const EVAL_SUBJECT_SEEDS: [u64; 4] = [1001, 1002, 1003, 1004];
/// Outfits meta-training may use.
pub const TRAIN_OUTFITS: [Outfit; 4] =
    [Outfit::TshirtShorts, Outfit::LongsleeveTrousers, Outfit::PoloLoose, Outfit::Dress];
/// Outfits whose garment is simulated as cloth (`synth::cloth`), which meta-training may also
/// use when asked (`MetaDataConfig::outfits`). The shipped prior holds them out, so the
/// evaluation's simulated rows measure a garment kind the prior never saw; a prior trained with
/// them (on training subjects and clips only) is the other variant.
pub const SIMULATED_TRAIN_OUTFITS: [Outfit; 2] = crate::synth::SIM_OUTFITS;
/// The outfit no meta-training ever sees (like the paper's blazer).
pub const UNSEEN_OUTFIT: Outfit = Outfit::BlazerTails;
/// Evaluation outfits: a seen one and the unseen one.
pub const EVAL_OUTFITS: [Outfit; 2] = [Outfit::LongsleeveTrousers, Outfit::BlazerTails];
/// Clips the avatar is fine-tuned on (from the library's training clips).
pub const FINETUNE_CLIPS: [&str; 8] =
    ["walk", "raise_arms", "squat", "turn", "bend", "arm_swing", "jumping_jacks", "march"];
/// Held-out clips (never in meta-training or fine-tuning): the library's held-out set.
pub const EVAL_CLIPS: [&str; 3] = crate::motion::HELDOUT_CLIPS;
/// The held-out pose of the evaluation's contact sheets: a clip and where in it (0-1). The
/// kick's raised leg is where loose garments go wrong (a skirt or tails around the leg).
pub const SHEET_POSE: (&str, f32) = ("kick", 0.45);

/// The contact sheets' pose (`SHEET_POSE`).
pub fn sheet_pose() -> crate::error::Result<crate::body::BodyParams> {
    let (clip, frame) = sheet_frame()?;
    Ok(clip.frames[frame].clone())
}

/// The contact sheets' clip and frame (`SHEET_POSE`).
pub fn sheet_frame() -> crate::error::Result<(crate::motion::MotionClip, usize)> {
    let (name, at) = SHEET_POSE;
    let clip = crate::motion::library_clip(name)?;
    let frame = ((clip.len().max(1) - 1) as f32 * at) as usize;
    Ok((clip, frame))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_split_is_disjoint() {
        assert!(EVAL_SUBJECT_SEEDS.iter().all(|s| !TRAIN_SUBJECT_SEEDS.contains(s)));
        assert!(!TRAIN_OUTFITS.contains(&UNSEEN_OUTFIT));
        assert!(!SIMULATED_TRAIN_OUTFITS.contains(&UNSEEN_OUTFIT));
        assert!(SIMULATED_TRAIN_OUTFITS.iter().all(|o| o.is_simulated()));
        assert!(EVAL_OUTFITS.contains(&UNSEEN_OUTFIT));
        let (train, held) = crate::motion::library_split();
        for c in FINETUNE_CLIPS {
            assert!(train.iter().any(|t| t.name == c) && !held.iter().any(|h| h.name == c), "{c}");
        }
        for c in EVAL_CLIPS {
            assert!(held.iter().any(|h| h.name == c));
        }
    }
}

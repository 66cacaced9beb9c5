//! The evaluation protocols (MetaAvatar Sec. 5, Tables 1 and 3) as frame selections:
//! - interpolation: fine-tune on every 10th frame of the fine-tuning clips, evaluate every 5th
//!   frame in between (frames 5, 15, 25, ...);
//! - extrapolation: the same fine-tuning frames, evaluate on the held-out clips (every 5th frame);
//! - few-shot: a fraction (100%, 50%, 20%, 10%, 5%) of those fine-tuning frames, or one frame
//!   per clip (about 8 frames), evaluated like extrapolation.

use serde::{Deserialize, Serialize};

#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum Shots {
    /// Keep this fraction of the fine-tuning frames, evenly spread.
    Fraction(f32),
    /// One frame per fine-tuning clip (its middle frame).
    OnePerClip,
}

#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum Protocol {
    Interpolation,
    Extrapolation,
    FewShot(Shots),
}

pub const FEW_SHOT: [Shots; 6] = [
    Shots::Fraction(1.0),
    Shots::Fraction(0.5),
    Shots::Fraction(0.2),
    Shots::Fraction(0.1),
    Shots::Fraction(0.05),
    Shots::OnePerClip,
];

impl Protocol {
    pub fn label(&self) -> String {
        match self {
            Protocol::Interpolation => "interpolation".into(),
            Protocol::Extrapolation => "extrapolation".into(),
            Protocol::FewShot(Shots::Fraction(f)) => format!("few-shot {}%", (f * 100.0).round()),
            Protocol::FewShot(Shots::OnePerClip) => "few-shot 1/clip".into(),
        }
    }

    /// The protocols selected by a command-line name, or a comma-separated list of names
    /// (`few-shot:100`, `few-shot:1/clip` pick one few-shot setting).
    pub fn parse_list(name: &str) -> Option<Vec<Protocol>> {
        if name.contains(',') {
            let mut all = Vec::new();
            for part in name.split(',') {
                all.extend(Self::parse_list(part.trim())?);
            }
            return Some(all);
        }
        if let Some(shots) = name.strip_prefix("few-shot:") {
            return Some(vec![Protocol::FewShot(match shots {
                "1/clip" => Shots::OnePerClip,
                percent => Shots::Fraction(
                    percent.parse::<f32>().ok().filter(|p| *p > 0.0 && *p <= 100.0)? / 100.0,
                ),
            })]);
        }
        Some(match name {
            "interpolation" => vec![Protocol::Interpolation],
            "extrapolation" => vec![Protocol::Extrapolation],
            "few-shot" => FEW_SHOT.iter().map(|&s| Protocol::FewShot(s)).collect(),
            "all" => {
                let mut v = vec![Protocol::Interpolation, Protocol::Extrapolation];
                v.extend(FEW_SHOT.iter().map(|&s| Protocol::FewShot(s)));
                v
            }
            _ => return None,
        })
    }

    /// Whether evaluation uses the held-out clips (else the fine-tuning clips' in-between frames).
    pub fn evaluates_heldout(&self) -> bool {
        !matches!(self, Protocol::Interpolation)
    }
}

/// Fine-tuning frames of one clip of `len` frames: every 10th.
pub fn finetune_frames(len: usize) -> Vec<usize> {
    (0..len).step_by(10).collect()
}

/// Interpolation evaluation frames of a fine-tuning clip: every 5th frame between the
/// fine-tuning frames (5, 15, 25, ...).
pub fn interpolation_frames(len: usize) -> Vec<usize> {
    (5..len).step_by(10).collect()
}

/// Evaluation frames of a held-out clip: every `stride`-th.
pub fn heldout_frames(len: usize, stride: usize) -> Vec<usize> {
    (0..len).step_by(stride.max(1)).collect()
}

/// The fine-tuning frames (clip index, frame) of a protocol, over clips of the given lengths.
pub fn training_selection(protocol: &Protocol, clip_lengths: &[usize]) -> Vec<(usize, usize)> {
    let all: Vec<(usize, usize)> = clip_lengths
        .iter()
        .enumerate()
        .flat_map(|(c, &n)| finetune_frames(n).into_iter().map(move |f| (c, f)))
        .collect();
    match protocol {
        Protocol::Interpolation
        | Protocol::Extrapolation
        | Protocol::FewShot(Shots::Fraction(1.0)) => all,
        Protocol::FewShot(Shots::Fraction(f)) => {
            let keep = ((all.len() as f32 * f).round() as usize).max(1);
            (0..keep).map(|i| all[i * all.len() / keep]).collect()
        }
        Protocol::FewShot(Shots::OnePerClip) => clip_lengths
            .iter()
            .copied()
            .enumerate()
            .filter(|&(_, n)| n > 0)
            .map(|(c, n)| (c, n / 2))
            .collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn protocol_lists_parse() {
        assert_eq!(
            Protocol::parse_list("few-shot:100,few-shot:1/clip"),
            Some(vec![
                Protocol::FewShot(Shots::Fraction(1.0)),
                Protocol::FewShot(Shots::OnePerClip)
            ])
        );
        assert_eq!(Protocol::parse_list("interpolation,extrapolation").map(|v| v.len()), Some(2));
        assert_eq!(Protocol::parse_list("all").map(|v| v.len()), Some(8));
        for bad in ["few-shot:0", "few-shot:250", "few-shot:x", "interp", "few-shot:100,nope"] {
            assert_eq!(Protocol::parse_list(bad), None, "{bad}");
        }
    }

    #[test]
    fn interpolation_frames_lie_between_training_frames() {
        let t = finetune_frames(95);
        let e = interpolation_frames(95);
        assert_eq!(t, vec![0, 10, 20, 30, 40, 50, 60, 70, 80, 90]);
        assert_eq!(e, vec![5, 15, 25, 35, 45, 55, 65, 75, 85]);
        assert!(e.iter().all(|f| !t.contains(f)));
    }

    #[test]
    fn few_shot_fractions_shrink_the_training_set() {
        let lens = [96, 90, 90, 75];
        let full = training_selection(&Protocol::Interpolation, &lens).len();
        assert_eq!(full, 10 + 9 + 9 + 8);
        let counts: Vec<usize> = FEW_SHOT
            .iter()
            .map(|&s| training_selection(&Protocol::FewShot(s), &lens).len())
            .collect();
        assert_eq!(counts, vec![36, 18, 7, 4, 2, 4]);
        // Subsets of the full selection, spread over the clips.
        let half = training_selection(&Protocol::FewShot(Shots::Fraction(0.5)), &lens);
        let all = training_selection(&Protocol::Interpolation, &lens);
        assert!(half.iter().all(|x| all.contains(x)));
        assert_eq!(half.iter().map(|x| x.0).collect::<std::collections::BTreeSet<_>>().len(), 4);
        assert_eq!(Protocol::parse_list("all").unwrap().len(), 8);
        assert!(Protocol::parse_list("nope").is_none());
    }
}

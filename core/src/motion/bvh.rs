//! BVH motion capture files (Biovision Hierarchy): the HIERARCHY (joints, offsets, channels in
//! any order, any joint order) and the MOTION block (frame count, frame time, one line of
//! channel values per frame). Errors name the file and the line. Retargeting to the SMPL
//! skeleton is in [`super::retarget`]; see docs/motion-import.md.
//!
//! Conventions (those of Biovision and of the common exporters): angles in degrees; a joint's
//! rotation is the product of its rotation channels in the order listed (`Zrotation Xrotation
//! Yrotation` = Rz * Rx * Ry); position channels, where present, replace the OFFSET's
//! components (the root's give its position in the file's world).

use crate::error::{Error, Result};
use glam::{Mat3, Vec3};
use std::path::Path;

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Channel {
    Xposition,
    Yposition,
    Zposition,
    Xrotation,
    Yrotation,
    Zrotation,
}

impl Channel {
    fn parse(s: &str) -> Option<Channel> {
        Some(match s.to_ascii_lowercase().as_str() {
            "xposition" => Channel::Xposition,
            "yposition" => Channel::Yposition,
            "zposition" => Channel::Zposition,
            "xrotation" => Channel::Xrotation,
            "yrotation" => Channel::Yrotation,
            "zrotation" => Channel::Zrotation,
            _ => return None,
        })
    }
}

#[derive(Debug, Clone, PartialEq)]
pub struct BvhJoint {
    pub name: String,
    pub parent: Option<usize>,
    /// Offset from the parent joint, in file units.
    pub offset: Vec3,
    pub channels: Vec<Channel>,
    /// Index of this joint's first value in a frame.
    pub first_value: usize,
    /// The End Site offset, if the joint has one (the tip of a chain).
    pub end_site: Option<Vec3>,
    /// Line of the joint's name in the file.
    pub line: usize,
}

/// A parsed BVH file.
#[derive(Debug, Clone, PartialEq)]
pub struct BvhFile {
    /// Parents precede children (file order).
    pub joints: Vec<BvhJoint>,
    /// Seconds per frame.
    pub frame_time: f32,
    /// Channel values per frame (`values_per_frame` each).
    pub frames: Vec<Vec<f32>>,
    pub values_per_frame: usize,
}

/// One frame's pose of the BVH skeleton: local rotations and translations.
#[derive(Debug, Clone, PartialEq)]
pub struct BvhPose {
    pub rotations: Vec<Mat3>,
    pub translations: Vec<Vec3>,
}

impl BvhFile {
    /// Read and parse a BVH file; errors name the file and the line.
    pub fn load(path: impl AsRef<Path>) -> Result<BvhFile> {
        let path = path.as_ref();
        let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
        let text = String::from_utf8_lossy(&bytes);
        Self::parse(&text).map_err(|e| e.in_file(path))
    }

    /// Parse BVH text (errors are `Error::Invalid` with the line; `load` adds the file).
    pub fn parse(text: &str) -> Result<BvhFile> {
        let mut p =
            Parser { tokens: tokenize(text), pos: 0, last_line: text.lines().count().max(1) };
        p.expect_keyword("HIERARCHY")?;
        let mut joints = Vec::new();
        let (kw, line) = p.next_token("ROOT")?;
        if !kw.eq_ignore_ascii_case("ROOT") {
            return Err(at(line, format!("expected ROOT, found '{kw}'")));
        }
        p.joint(&mut joints, None, line)?;
        let values_per_frame: usize = joints.iter().map(|j| j.channels.len()).sum();
        let (kw, line) = p.next_token("MOTION")?;
        if kw.eq_ignore_ascii_case("ROOT") {
            return Err(at(line, "several ROOT skeletons in one file are not supported"));
        }
        if !kw.eq_ignore_ascii_case("MOTION") {
            return Err(at(line, format!("expected MOTION after the hierarchy, found '{kw}'")));
        }
        p.expect_keyword("Frames:")?;
        let (n, line) = p.next_token("the frame count")?;
        let count: usize =
            n.parse().map_err(|_| at(line, format!("'Frames: {n}' is not a frame count")))?;
        if count == 0 {
            return Err(at(line, "the MOTION block has 0 frames"));
        }
        if count > super::clip::MAX_CLIP_FRAMES {
            return Err(at(
                line,
                format!(
                    "'Frames: {count}' is over the supported {} frames (about 14 min at 120 fps); cut the take into parts",
                    super::clip::MAX_CLIP_FRAMES
                ),
            ));
        }
        p.expect_keyword("Frame")?;
        p.expect_keyword("Time:")?;
        let (t, line) = p.next_token("the frame time")?;
        let frame_time: f32 =
            t.parse().map_err(|_| at(line, format!("'Frame Time: {t}' is not a number")))?;
        if !(frame_time.is_finite() && frame_time > 0.0 && frame_time <= 10.0) {
            return Err(at(line, format!("frame time {t} s is not in (0, 10]")));
        }
        // One frame per line: a line with too few or too many values is named.
        let mut frames = Vec::with_capacity(count);
        while frames.len() < count {
            let Some(line) = p.peek_line() else {
                return Err(at(
                    p.last_line,
                    format!(
                        "the MOTION block is truncated: 'Frames: {count}' but the file ends after {} frames",
                        frames.len()
                    ),
                ));
            };
            let values = p.take_line(line);
            if values.len() != values_per_frame {
                return Err(at(
                    line,
                    format!(
                        "frame {} has {} values, the hierarchy's channels need {values_per_frame}",
                        frames.len(),
                        values.len()
                    ),
                ));
            }
            let mut row = Vec::with_capacity(values_per_frame);
            for (k, s) in values.iter().enumerate() {
                let v: f32 = s.parse().ok().filter(|v: &f32| v.is_finite()).ok_or_else(|| {
                    let joint = joints
                        .iter()
                        .rev()
                        .find(|j| j.first_value <= k)
                        .expect("the root starts at 0");
                    at(
                        line,
                        format!(
                            "value {} ('{s}', {:?} of joint '{}') is not a finite number",
                            k + 1,
                            joint.channels[k - joint.first_value],
                            joint.name
                        ),
                    )
                })?;
                row.push(v);
            }
            frames.push(row);
        }
        if let Some(line) = p.peek_line() {
            return Err(at(line, format!("more frame lines than 'Frames: {count}' announces")));
        }
        Ok(BvhFile { joints, frame_time, frames, values_per_frame })
    }

    pub fn fps(&self) -> f32 {
        1.0 / self.frame_time
    }

    pub fn joint_index(&self, name: &str) -> Option<usize> {
        self.joints.iter().position(|j| j.name == name)
    }

    /// Joint positions in the rest pose (all channels zero), in file units.
    pub fn rest_positions(&self) -> Vec<Vec3> {
        let mut out: Vec<Vec3> = Vec::with_capacity(self.joints.len());
        for j in &self.joints {
            let base = j.parent.map_or(Vec3::ZERO, |p| out[p]);
            out.push(base + j.offset);
        }
        out
    }

    /// End Site positions in the rest pose (file units).
    pub fn rest_end_sites(&self) -> Vec<Vec3> {
        let rest = self.rest_positions();
        self.joints.iter().zip(&rest).filter_map(|(j, p)| j.end_site.map(|e| *p + e)).collect()
    }

    /// Local rotations and translations of frame `f`.
    pub fn pose(&self, f: usize) -> BvhPose {
        let row = &self.frames[f];
        let mut rotations = Vec::with_capacity(self.joints.len());
        let mut translations = Vec::with_capacity(self.joints.len());
        for j in &self.joints {
            let mut r = Mat3::IDENTITY;
            let mut t = j.offset;
            for (k, c) in j.channels.iter().enumerate() {
                let v = row[j.first_value + k];
                match c {
                    Channel::Xposition => t.x = v,
                    Channel::Yposition => t.y = v,
                    Channel::Zposition => t.z = v,
                    Channel::Xrotation => r *= Mat3::from_rotation_x(v.to_radians()),
                    Channel::Yrotation => r *= Mat3::from_rotation_y(v.to_radians()),
                    Channel::Zrotation => r *= Mat3::from_rotation_z(v.to_radians()),
                }
            }
            rotations.push(r);
            translations.push(t);
        }
        BvhPose { rotations, translations }
    }
}

impl BvhPose {
    /// Global rotations and positions (file units) by forward kinematics.
    pub fn global(&self, joints: &[BvhJoint]) -> (Vec<Mat3>, Vec<Vec3>) {
        let mut rot: Vec<Mat3> = Vec::with_capacity(joints.len());
        let mut pos: Vec<Vec3> = Vec::with_capacity(joints.len());
        for (i, j) in joints.iter().enumerate() {
            match j.parent {
                None => {
                    rot.push(self.rotations[i]);
                    pos.push(self.translations[i]);
                }
                Some(p) => {
                    pos.push(pos[p] + rot[p] * self.translations[i]);
                    rot.push(rot[p] * self.rotations[i]);
                }
            }
        }
        (rot, pos)
    }
}

fn at(line: usize, message: impl std::fmt::Display) -> Error {
    Error::invalid(format!("line {line}: {message}"))
}

/// Whitespace-separated tokens with their 1-based line numbers; `{` and `}` are tokens of
/// their own even when glued to a name.
fn tokenize(text: &str) -> Vec<(String, usize)> {
    let mut out = Vec::new();
    for (i, line) in text.lines().enumerate() {
        for word in line.split_whitespace() {
            let mut rest = word;
            while !rest.is_empty() {
                match rest.find(['{', '}']) {
                    Some(0) => {
                        out.push((rest[..1].to_string(), i + 1));
                        rest = &rest[1..];
                    }
                    Some(k) => {
                        out.push((rest[..k].to_string(), i + 1));
                        rest = &rest[k..];
                    }
                    None => {
                        out.push((rest.to_string(), i + 1));
                        rest = "";
                    }
                }
            }
        }
    }
    out
}

struct Parser {
    tokens: Vec<(String, usize)>,
    pos: usize,
    last_line: usize,
}

impl Parser {
    fn next_token(&mut self, what: &str) -> Result<(String, usize)> {
        let t = self.tokens.get(self.pos).cloned().ok_or_else(|| {
            at(self.last_line, format!("the file ends where {what} was expected"))
        })?;
        self.pos += 1;
        Ok(t)
    }

    fn peek(&self) -> Option<&(String, usize)> {
        self.tokens.get(self.pos)
    }

    fn expect_keyword(&mut self, kw: &str) -> Result<usize> {
        let (t, line) = self.next_token(kw)?;
        if !t.eq_ignore_ascii_case(kw) {
            return Err(at(line, format!("expected '{kw}', found '{t}'")));
        }
        Ok(line)
    }

    fn number(&mut self, what: &str) -> Result<f32> {
        let (t, line) = self.next_token(what)?;
        t.parse::<f32>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| at(line, format!("{what}: '{t}' is not a finite number")))
    }

    fn offset(&mut self) -> Result<Vec3> {
        self.expect_keyword("OFFSET")?;
        Ok(Vec3::new(self.number("OFFSET x")?, self.number("OFFSET y")?, self.number("OFFSET z")?))
    }

    /// The line of the next token, if any.
    fn peek_line(&self) -> Option<usize> {
        self.peek().map(|t| t.1)
    }

    /// Every token on `line`, consumed.
    fn take_line(&mut self, line: usize) -> Vec<String> {
        let mut out = Vec::new();
        while let Some((t, l)) = self.peek() {
            if *l != line {
                break;
            }
            out.push(t.clone());
            self.pos += 1;
        }
        out
    }

    /// `name { OFFSET .. CHANNELS n .. (JOINT ..)* (End Site { OFFSET .. })? }` after ROOT/JOINT.
    fn joint(
        &mut self,
        joints: &mut Vec<BvhJoint>,
        parent: Option<usize>,
        kw_line: usize,
    ) -> Result<()> {
        // The name: the rest of the keyword's line, up to a `{`.
        let mut name_parts = Vec::new();
        while let Some((t, l)) = self.peek() {
            if *l != kw_line || t == "{" {
                break;
            }
            name_parts.push(t.clone());
            self.pos += 1;
        }
        if name_parts.is_empty() {
            return Err(at(kw_line, "a joint without a name"));
        }
        let name = name_parts.join(" ");
        if joints.iter().any(|j: &BvhJoint| j.name == name) {
            return Err(at(kw_line, format!("joint name '{name}' appears twice")));
        }
        self.expect_keyword("{")?;
        let offset = self.offset()?;
        let (t, line) = self.next_token("CHANNELS")?;
        if !t.eq_ignore_ascii_case("CHANNELS") {
            return Err(at(line, format!("joint '{name}' has no CHANNELS line (found '{t}')")));
        }
        let (n, nline) = self.next_token("the channel count")?;
        let n: usize = n.parse().ok().filter(|&n| n <= 6).ok_or_else(|| {
            at(nline, format!("joint '{name}': channel count '{n}' is not 0 to 6"))
        })?;
        let mut channels = Vec::with_capacity(n);
        for _ in 0..n {
            let (c, cline) = self.next_token("a channel name")?;
            let ch = Channel::parse(&c).ok_or_else(|| {
                at(cline, format!("joint '{name}': '{c}' is not a channel (CHANNELS {n} needs {n} of Xposition .. Zrotation)"))
            })?;
            if channels.contains(&ch) {
                return Err(at(cline, format!("joint '{name}': channel {c} appears twice")));
            }
            channels.push(ch);
        }
        let first_value = joints.iter().map(|j| j.channels.len()).sum();
        let index = joints.len();
        joints.push(BvhJoint {
            name,
            parent,
            offset,
            channels,
            first_value,
            end_site: None,
            line: kw_line,
        });
        loop {
            let (t, line) = self.next_token("'}'")?;
            if t == "}" {
                return Ok(());
            } else if t.eq_ignore_ascii_case("JOINT") {
                self.joint(joints, Some(index), line)?;
            } else if t.eq_ignore_ascii_case("End") {
                self.expect_keyword("Site")?;
                self.expect_keyword("{")?;
                joints[index].end_site = Some(self.offset()?);
                self.expect_keyword("}")?;
            } else {
                return Err(at(
                    line,
                    format!(
                        "expected JOINT, End Site or '}}' in joint '{}', found '{t}'",
                        joints[index].name
                    ),
                ));
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const TWO_JOINTS: &str = "HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0 0\n  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation\n  JOINT Chest{\n    OFFSET 0 10 0\n    CHANNELS 3 Xrotation Yrotation Zrotation\n    End Site\n    {\n      OFFSET 0 5 0\n    }\n  }\n}\nMOTION\nFrames: 2\nFrame Time: 0.0333333\n1 90 2 0 0 0 90 0 0\n1 90 2 0 0 0 0 0 90\n";

    #[test]
    fn parses_hierarchy_channels_and_frames() {
        let b = BvhFile::parse(TWO_JOINTS).unwrap();
        assert_eq!(b.joints.len(), 2);
        assert_eq!(b.joints[1].parent, Some(0));
        assert_eq!(b.joints[1].first_value, 6);
        assert_eq!(b.values_per_frame, 9);
        assert!((b.fps() - 30.0).abs() < 1e-3);
        assert_eq!(b.rest_end_sites(), vec![Vec3::new(0.0, 15.0, 0.0)]);
        // Frame 0: the chest rotated 90 degrees about X: its end site (0, 5, 0) goes to (0, 0, 5).
        let (rot, pos) = b.pose(0).global(&b.joints);
        assert!(pos[0].abs_diff_eq(Vec3::new(1.0, 90.0, 2.0), 1e-5));
        assert!((rot[1] * Vec3::Y).abs_diff_eq(Vec3::Z, 1e-5));
        let (rot, _) = b.pose(1).global(&b.joints);
        assert!((rot[1] * Vec3::Y).abs_diff_eq(-Vec3::X, 1e-5));
    }

    #[test]
    fn channel_order_is_the_listed_order() {
        // Zrotation Xrotation Yrotation = Rz * Rx * Ry.
        let text = TWO_JOINTS.replace(
            "1 90 2 0 0 0 90 0 0\n1 90 2 0 0 0 0 0 90\n",
            "0 0 0 30 40 50 0 0 0\n0 0 0 0 0 0 0 0 0\n",
        );
        let b = BvhFile::parse(&text).unwrap();
        let r = b.pose(0).rotations[0];
        let expect = Mat3::from_rotation_z(30f32.to_radians())
            * Mat3::from_rotation_x(40f32.to_radians())
            * Mat3::from_rotation_y(50f32.to_radians());
        assert!(r.abs_diff_eq(expect, 1e-6));
    }

    #[test]
    fn errors_name_the_line() {
        let e = BvhFile::parse(&TWO_JOINTS.replace("1 90 2 0 0 0 0 0 90\n", ""))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("truncated") && e.contains("line 18") && e.contains("after 1 frames"),
            "{e}"
        );
        let e =
            BvhFile::parse(&TWO_JOINTS.replace("0 0 90\n", "0 nan 90\n")).unwrap_err().to_string();
        assert!(e.contains("line 19") && e.contains("Yrotation of joint 'Chest'"), "{e}");
        let e = BvhFile::parse(
            &TWO_JOINTS.replace("    CHANNELS 3 Xrotation Yrotation Zrotation\n", ""),
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("line 8") && e.contains("no CHANNELS"), "{e}");
    }
}

//! The evaluation report: one row per method, setting (capture conditions x protocol) and
//! outfit, with mean, median, min and max of every metric over the evaluated frames; JSON and
//! a Markdown table per setting.

use super::integrity::IntegrityRow;
use super::metrics::{FrameMetrics, Summary};
use crate::error::{Error, Result};
use serde::{Deserialize, Serialize};

/// One cell of the table: a method under a setting on one outfit (or `all` outfits), over the
/// subjects and evaluated frames.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RowResult {
    pub method: String,
    pub protocol: String,
    /// The capture conditions' name (`user`, `clean`).
    #[serde(default)]
    pub capture: String,
    /// The outfit's name, or `all` (every outfit's frames together).
    #[serde(default)]
    pub outfit: String,
    pub training_frames: usize,
    pub evaluated_frames: usize,
    pub dp_cm: Summary,
    pub df_cm: Summary,
    pub nc: Summary,
    pub iou: Summary,
    pub chamfer_cm: Summary,
    /// Shares (0-1) and p99 (cm), whole surface.
    pub spurious: Summary,
    pub missing: Summary,
    pub p99_cm: Summary,
    /// The same on the clothed region.
    pub cloth_spurious: Summary,
    pub cloth_missing: Summary,
    pub cloth_p99_cm: Summary,
    /// Whether the surfaces are whole (absent in reports written before the column existed).
    #[serde(default)]
    pub integrity: Option<IntegrityRow>,
    /// Fine-tuning and scoring time of this row (seconds, summed over subjects; f32 so that
    /// the JSON round trip is exact).
    pub seconds: f32,
}

/// What a row is summarised from.
pub struct RowInput<'a> {
    pub method: String,
    pub protocol: String,
    pub capture: String,
    pub outfit: String,
    pub training_frames: usize,
    pub metrics: &'a [FrameMetrics],
    pub seconds: f64,
}

impl RowResult {
    pub fn summarise(input: RowInput) -> Result<RowResult> {
        let m = input.metrics;
        let s = |f: fn(&FrameMetrics) -> f32| {
            Summary::of(&m.iter().map(f).collect::<Vec<_>>())
                .ok_or_else(|| Error::invalid("no frames evaluated"))
        };
        Ok(RowResult {
            method: input.method,
            protocol: input.protocol,
            capture: input.capture,
            outfit: input.outfit,
            training_frames: input.training_frames,
            evaluated_frames: m.len(),
            dp_cm: s(|m| m.dp_cm)?,
            df_cm: s(|m| m.df_cm)?,
            nc: s(|m| m.nc)?,
            iou: s(|m| m.iou)?,
            chamfer_cm: s(|m| m.chamfer_cm)?,
            spurious: s(|m| m.surface.spurious)?,
            missing: s(|m| m.surface.missing)?,
            p99_cm: s(|m| m.surface.p99_cm)?,
            cloth_spurious: s(|m| m.cloth.spurious)?,
            cloth_missing: s(|m| m.cloth.missing)?,
            cloth_p99_cm: s(|m| m.cloth.p99_cm)?,
            integrity: IntegrityRow::of(&m.iter().map(|m| m.integrity).collect::<Vec<_>>()),
            seconds: input.seconds as f32,
        })
    }
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Report {
    pub subjects: Vec<u64>,
    pub outfits: Vec<String>,
    pub finetune_clips: Vec<String>,
    pub eval_clips: Vec<String>,
    /// One line per capture conditions (`CaptureConditions::describe`).
    #[serde(default)]
    pub captures: Vec<String>,
    pub seed: u64,
    pub rows: Vec<RowResult>,
}

impl Report {
    /// Markdown: one table per setting (capture conditions, protocol), rows by outfit then
    /// method; means over frames. Shares in percent.
    pub fn markdown(&self) -> String {
        let mut s = format!(
            "Subjects {:?}, outfits {}, fine-tuning clips {}, evaluation clips {}, seed {}.\n",
            self.subjects,
            self.outfits.join(", "),
            self.finetune_clips.join(", "),
            self.eval_clips.join(", "),
            self.seed
        );
        for c in &self.captures {
            s += &format!("- capture {c}\n");
        }
        let mut settings: Vec<(&str, &str)> = Vec::new();
        for r in &self.rows {
            if !settings.contains(&(r.capture.as_str(), r.protocol.as_str())) {
                settings.push((&r.capture, &r.protocol));
            }
        }
        let mut outfits: Vec<&str> = self.outfits.iter().map(|o| o.as_str()).collect();
        outfits.push("all");
        for (capture, protocol) in settings {
            s += &format!("\n**{capture} capture, {protocol}**\n\n");
            s += "| method | outfit | training frames | evaluated frames | Chamfer-L2 (cm) | NC | Dp (cm) | Df (cm) | IoU | spurious | missing | p99 (cm) | clothed spurious | clothed missing | clothed p99 (cm) |\n";
            s += "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
            for outfit in &outfits {
                for r in self.rows.iter().filter(|r| {
                    r.capture == capture && r.protocol == protocol && r.outfit == *outfit
                }) {
                    s += &format!(
                        "| {} | {} | {} | {} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} | {:.1}% | {:.1}% | {:.2} | {:.1}% | {:.1}% | {:.2} |\n",
                        r.method,
                        r.outfit,
                        r.training_frames,
                        r.evaluated_frames,
                        r.chamfer_cm.mean,
                        r.nc.mean,
                        r.dp_cm.mean,
                        r.df_cm.mean,
                        r.iou.mean,
                        100.0 * r.spurious.mean,
                        100.0 * r.missing.mean,
                        r.p99_cm.mean,
                        100.0 * r.cloth_spurious.mean,
                        100.0 * r.cloth_missing.mean,
                        r.cloth_p99_cm.mean
                    );
                }
            }
            s += &self.integrity_table(capture, protocol, &outfits);
        }
        s
    }

    /// The integrity table of one setting (rows written before the columns existed are left
    /// out).
    fn integrity_table(&self, capture: &str, protocol: &str, outfits: &[&str]) -> String {
        let mut s = format!(
            "\n*Integrity, {capture} capture, {protocol}*\n\n| method | outfit | {} |\n|---|---|{}\n",
            IntegrityRow::HEADER,
            "---|".repeat(IntegrityRow::HEADER.matches('|').count() + 1)
        );
        let mut any = false;
        for outfit in outfits {
            for r in self
                .rows
                .iter()
                .filter(|r| r.capture == capture && r.protocol == protocol && r.outfit == *outfit)
            {
                if let Some(i) = &r.integrity {
                    s += &format!("| {} | {} | {} |\n", r.method, r.outfit, i.cells());
                    any = true;
                }
            }
        }
        if any { s } else { String::new() }
    }

    pub fn save_json(&self, path: impl AsRef<std::path::Path>) -> Result<()> {
        let text = serde_json::to_string_pretty(self).map_err(|e| Error::invalid(e.to_string()))?;
        crate::io::write_bytes_atomic(path, text.as_bytes())
    }
}

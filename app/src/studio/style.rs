//! The studio's look: egui's dark theme, a little denser and with a blue accent.

use eframe::egui;

pub const ACCENT: egui::Color32 = egui::Color32::from_rgb(88, 150, 235);
pub const WARN: egui::Color32 = egui::Color32::from_rgb(235, 160, 60);
pub const ERROR: egui::Color32 = egui::Color32::from_rgb(235, 85, 80);

/// The panels' colour.
pub const PANEL_FILL: egui::Color32 = egui::Color32::from_rgb(27, 29, 33);

/// `backdrop`: the panels' colour is painted behind them (viewport/flat.rs), so egui leaves
/// them unfilled.
pub fn apply(ctx: &egui::Context, backdrop: bool) {
    ctx.set_theme(egui::Theme::Dark);
    ctx.all_styles_mut(|style| {
        style.spacing.item_spacing = egui::vec2(6.0, 5.0);
        style.spacing.button_padding = egui::vec2(7.0, 3.0);
        let v = &mut style.visuals;
        v.panel_fill = if backdrop { egui::Color32::TRANSPARENT } else { PANEL_FILL };
        v.window_fill = egui::Color32::from_rgb(30, 32, 37);
        v.extreme_bg_color = egui::Color32::from_rgb(17, 18, 21);
        v.faint_bg_color = egui::Color32::from_rgb(34, 36, 41);
        v.selection.bg_fill = egui::Color32::from_rgb(40, 82, 140);
        v.selection.stroke = egui::Stroke::new(1.0, ACCENT);
        v.hyperlink_color = ACCENT;
        v.widgets.noninteractive.bg_stroke =
            egui::Stroke::new(1.0, egui::Color32::from_rgb(45, 48, 54));
    });
}

/// A section heading in a side panel.
pub fn heading(ui: &mut egui::Ui, text: &str) {
    ui.add_space(4.0);
    ui.label(
        egui::RichText::new(text.to_uppercase())
            .small()
            .strong()
            .color(egui::Color32::from_rgb(150, 158, 172)),
    );
    ui.add_space(1.0);
}

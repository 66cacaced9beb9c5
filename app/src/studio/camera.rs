//! An orbit camera: yaw and pitch around a target, a distance; orbit (left drag), pan (right
//! or middle drag, or shift + left drag), zoom to the cursor (wheel), frame a box.

use crate::studio::viewport::CameraMatrices;
use eframe::egui;
use glam::{Mat4, Vec2, Vec3};

#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct OrbitCamera {
    pub target: [f32; 3],
    /// Radians around +Y; 0 looks at the body's front (+Z towards the camera).
    pub yaw: f32,
    /// Radians above the horizon.
    pub pitch: f32,
    pub distance: f32,
    /// Vertical field of view, degrees.
    pub fov_deg: f32,
}

impl Default for OrbitCamera {
    fn default() -> Self {
        OrbitCamera {
            target: [0.0, 0.0, 0.0],
            yaw: 0.35,
            pitch: 0.12,
            distance: 3.0,
            fov_deg: 35.0,
        }
    }
}

/// The camera presets: the subject seen from the front, the side (its left), the back or the
/// top, keeping the target and the distance.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Preset {
    Front,
    Side,
    Back,
    Top,
}

impl Preset {
    pub const ALL: [Preset; 4] = [Preset::Front, Preset::Side, Preset::Back, Preset::Top];

    pub fn label(self) -> &'static str {
        match self {
            Preset::Front => "Front",
            Preset::Side => "Side",
            Preset::Back => "Back",
            Preset::Top => "Top",
        }
    }

    /// (yaw, pitch) in radians.
    pub fn angles(self) -> (f32, f32) {
        match self {
            Preset::Front => (0.0, 0.0),
            Preset::Side => (std::f32::consts::FRAC_PI_2, 0.0),
            Preset::Back => (std::f32::consts::PI, 0.0),
            Preset::Top => (0.0, 1.5),
        }
    }

    pub fn apply(self, camera: &mut OrbitCamera) {
        (camera.yaw, camera.pitch) = self.angles();
    }
}

impl OrbitCamera {
    /// Turn around the target (the turntable): `radians` about +Y.
    pub fn turn(&mut self, radians: f32) {
        self.yaw = (self.yaw + radians).rem_euclid(std::f32::consts::TAU);
    }

    pub fn target(&self) -> Vec3 {
        Vec3::from(self.target)
    }

    pub fn eye(&self) -> Vec3 {
        let dir = Vec3::new(
            self.pitch.cos() * self.yaw.sin(),
            self.pitch.sin(),
            self.pitch.cos() * self.yaw.cos(),
        );
        self.target() + dir * self.distance
    }

    pub fn matrices(&self, aspect: f32) -> CameraMatrices {
        let view = Mat4::look_at_rh(self.eye(), self.target(), Vec3::Y);
        let near = (self.distance * 0.01).max(0.005);
        let proj = Mat4::perspective_rh(
            self.fov_deg.to_radians(),
            aspect.max(0.01),
            near,
            self.distance * 20.0 + 10.0,
        );
        CameraMatrices { view, proj }
    }

    /// Look at the box from the current direction, fitting it in view.
    pub fn frame(&mut self, lo: Vec3, hi: Vec3) {
        if !(lo.is_finite() && hi.is_finite()) || lo.cmpgt(hi).any() {
            return;
        }
        let center = (lo + hi) * 0.5;
        let radius = ((hi - lo).length() * 0.5).max(0.05);
        self.target = center.to_array();
        self.distance = radius / (self.fov_deg.to_radians() * 0.5).sin() * 1.05;
    }

    pub fn orbit(&mut self, delta: Vec2) {
        self.yaw -= delta.x * 0.008;
        self.pitch = (self.pitch + delta.y * 0.008).clamp(-1.5, 1.5);
    }

    /// Pan by a drag of `delta` points in a viewport `height` points tall.
    pub fn pan(&mut self, delta: Vec2, height: f32) {
        let view = Mat4::look_at_rh(self.eye(), self.target(), Vec3::Y).inverse();
        let (right, up) = (view.x_axis.truncate(), view.y_axis.truncate());
        let scale = 2.0 * self.distance * (self.fov_deg.to_radians() * 0.5).tan() / height.max(1.0);
        let t = self.target() + (-right * delta.x + up * delta.y) * scale;
        self.target = t.to_array();
    }

    /// Zoom by `factor` (< 1 closer) towards the point under the cursor (`ndc` in [-1, 1]^2,
    /// y up) on the plane through the target facing the camera.
    pub fn zoom_to(&mut self, factor: f32, ndc: Vec2, aspect: f32) {
        let factor = factor.clamp(0.2, 5.0);
        let view = Mat4::look_at_rh(self.eye(), self.target(), Vec3::Y).inverse();
        let (right, up) = (view.x_axis.truncate(), view.y_axis.truncate());
        let half_h = self.distance * (self.fov_deg.to_radians() * 0.5).tan();
        let under_cursor = self.target() + right * ndc.x * half_h * aspect + up * ndc.y * half_h;
        // Keep the point under the cursor fixed: the target moves towards it by (1 - factor).
        let t = under_cursor + (self.target() - under_cursor) * factor;
        self.target = t.to_array();
        self.distance = (self.distance * factor).clamp(0.05, 200.0);
    }

    /// Apply the mouse input of the viewport's response. Returns true when the camera moved.
    pub fn handle_input(&mut self, ui: &egui::Ui, response: &egui::Response) -> bool {
        let before = *self;
        let rect = response.rect;
        let shift = ui.input(|i| i.modifiers.shift);
        if response.dragged_by(egui::PointerButton::Primary) && !shift {
            let d = response.drag_delta();
            self.orbit(Vec2::new(d.x, d.y));
        } else if response.dragged_by(egui::PointerButton::Secondary)
            || response.dragged_by(egui::PointerButton::Middle)
            || (shift && response.dragged_by(egui::PointerButton::Primary))
        {
            let d = response.drag_delta();
            self.pan(Vec2::new(d.x, d.y), rect.height());
        }
        if response.hovered() {
            let scroll = ui.input(|i| i.smooth_scroll_delta.y + i.zoom_delta().ln() * 200.0);
            if scroll.abs() > 0.0 {
                let factor = (-scroll * 0.002).exp();
                let ndc = response.hover_pos().map_or(Vec2::ZERO, |p| {
                    Vec2::new(
                        (p.x - rect.center().x) / (rect.width() * 0.5),
                        -(p.y - rect.center().y) / (rect.height() * 0.5),
                    )
                });
                self.zoom_to(factor, ndc, rect.width() / rect.height().max(1.0));
            }
        }
        *self != before
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn framing_puts_the_box_in_view() {
        let mut c = OrbitCamera::default();
        c.frame(Vec3::new(-0.5, 0.0, -0.2), Vec3::new(0.5, 1.8, 0.2));
        let m = c.matrices(1.0);
        for corner in [Vec3::new(-0.5, 0.0, -0.2), Vec3::new(0.5, 1.8, 0.2)] {
            let p = (m.proj * m.view).project_point3(corner);
            assert!(p.x.abs() <= 1.0 && p.y.abs() <= 1.0, "{p}");
        }
    }

    #[test]
    fn presets_look_along_the_axes() {
        let mut c = OrbitCamera::default();
        for (p, dir) in
            [(Preset::Front, Vec3::Z), (Preset::Side, Vec3::X), (Preset::Back, -Vec3::Z)]
        {
            p.apply(&mut c);
            assert!(((c.eye() - c.target()).normalize() - dir).length() < 1e-5, "{p:?}");
        }
        Preset::Top.apply(&mut c);
        assert!((c.eye() - c.target()).normalize().y > 0.99);
    }

    #[test]
    fn zoom_keeps_the_point_under_the_cursor() {
        let mut c = OrbitCamera::default();
        let aspect = 1.5;
        let ndc = Vec2::new(0.5, -0.3);
        let m = c.matrices(aspect);
        // The world point under the cursor on the target's plane.
        let inv = (m.proj * m.view).inverse();
        let near = inv.project_point3(ndc.extend(0.0));
        let far = inv.project_point3(ndc.extend(1.0));
        let n = (c.eye() - c.target()).normalize();
        let t = (c.target() - near).dot(n) / (far - near).dot(n);
        let p = near + (far - near) * t;
        c.zoom_to(0.5, ndc, aspect);
        let m2 = c.matrices(aspect);
        let q = (m2.proj * m2.view).project_point3(p);
        assert!((q.truncate() - ndc).length() < 1e-3, "{q} vs {ndc}");
    }
}

//! Pinhole depth camera (OpenCV axes: x right, y down, z forward) and the orbiting camera of
//! the MetaAvatar protocol.
//!
//! Pixel convention: pixel `(u, v)` (integer column, row) samples the ray through image
//! coordinates `(u, v)`, i.e. `x = (u - cx) z / fx`, `y = (v - cy) z / fy` (the convention of
//! Open3D and TUM back-projection).

use crate::capture::manifest::Intrinsics;
use glam::{Mat4, Vec2, Vec3, Vec4};
use serde::{Deserialize, Serialize};

/// The renderer's camera: the capture's [`Intrinsics`] (what capture.json records, checked when
/// read) plus a depth range, with projection and rays. Back-projection is written once, in
/// `Intrinsics::unproject`; a ray is its point at depth 1 (bit for bit `(u - cx) / fx`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PinholeCamera {
    pub fx: f32,
    pub fy: f32,
    pub cx: f32,
    pub cy: f32,
    pub width: u32,
    pub height: u32,
    /// Depth range (metres along the optical axis); geometry outside is not drawn.
    pub near: f32,
    pub far: f32,
}

impl PinholeCamera {
    /// MetaAvatar's protocol camera: 250 x 250, f = 250 px, principal point at the centre,
    /// near 1 m, far 10 m.
    pub fn metaavatar() -> Self {
        PinholeCamera {
            fx: 250.0,
            fy: 250.0,
            cx: 125.0,
            cy: 125.0,
            width: 250,
            height: 250,
            near: 1.0,
            far: 10.0,
        }
    }

    /// What a capture written with this camera records as its intrinsics.
    pub fn intrinsics(&self) -> Intrinsics {
        Intrinsics {
            fx: self.fx,
            fy: self.fy,
            cx: self.cx,
            cy: self.cy,
            width: self.width,
            height: self.height,
        }
    }

    /// Camera-space point -> pixel coordinates.
    pub fn project(&self, p: Vec3) -> Vec2 {
        Vec2::new(self.fx * p.x / p.z + self.cx, self.fy * p.y / p.z + self.cy)
    }

    /// Ray direction (camera space, z = 1) through pixel coordinates `(u, v)`.
    pub fn ray(&self, u: f32, v: f32) -> Vec3 {
        self.intrinsics().unproject(u, v, 1.0)
    }

    /// Back-project a pixel with depth z (metres) to camera space.
    pub fn unproject(&self, u: f32, v: f32, z: f32) -> Vec3 {
        self.intrinsics().unproject(u, v, z)
    }
}

/// Camera-to-world transform (OpenCV camera axes) of a camera at `eye` looking at `target`,
/// with the image's "down" along the world's -Y.
pub fn look_at(eye: Vec3, target: Vec3) -> Mat4 {
    let z = (target - eye).normalize();
    let down = Vec3::NEG_Y;
    let x = down.cross(z).normalize();
    let y = z.cross(x);
    Mat4::from_cols(
        x.extend(0.0),
        y.extend(0.0),
        z.extend(0.0),
        Vec4::new(eye.x, eye.y, eye.z, 1.0),
    )
}

/// A camera on a horizontal circle of radius `distance` around `target`, at `azimuth`
/// radians: 0 = in front of the body (+Z), increasing counter-clockwise seen from above
/// (towards the body's left, +X). Looking at the person from azimuth a is the same image as
/// the person turned by -a in front of a fixed camera.
pub fn orbit(target: Vec3, distance: f32, azimuth: f32) -> Mat4 {
    let eye = target + Vec3::new(azimuth.sin(), 0.0, azimuth.cos()) * distance;
    look_at(eye, target)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn front_camera_sees_the_body_left_on_the_image_right() {
        let c2w = orbit(Vec3::ZERO, 3.0, 0.0);
        let w2c = c2w.inverse();
        let cam = PinholeCamera::metaavatar();
        let left_hand = w2c.transform_point3(Vec3::new(0.5, 0.0, 0.0));
        let head = w2c.transform_point3(Vec3::new(0.0, 0.5, 0.0));
        assert!((left_hand.z - 3.0).abs() < 1e-6);
        assert!(cam.project(left_hand).x > 125.0, "body's left appears right");
        assert!(cam.project(head).y < 125.0, "head appears up");
        // A rotation matrix with det +1 (right-handed OpenCV axes).
        assert!((glam::Mat3::from_mat4(c2w).determinant() - 1.0).abs() < 1e-6);
        // Orbiting 90 degrees puts the camera on the body's left.
        let eye = orbit(Vec3::ZERO, 3.0, std::f32::consts::FRAC_PI_2).w_axis.truncate();
        assert!(eye.abs_diff_eq(Vec3::new(3.0, 0.0, 0.0), 1e-5));
        let p = Vec3::new(0.2, -0.3, 2.5);
        let (u, v) = (cam.project(p).x, cam.project(p).y);
        assert!(cam.unproject(u, v, p.z).abs_diff_eq(p, 1e-5));
    }
}

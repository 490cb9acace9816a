//! The ego camera: a level pinhole camera (AnoVox: FOV 90°, 1.8 m above the road) that
//! looks along the ego's heading. Rays are expressed relative to the camera's ground
//! position so that the ray caster works with small coordinates.

use super::math::V3;
use crate::sequence::CameraIntrinsics;

/// Camera pose and intrinsics of one frame.
#[derive(Debug, Clone, Copy)]
pub struct Camera {
    /// World x of the camera.
    pub x: f32,
    /// World y of the camera.
    pub y: f32,
    /// Height above the road.
    pub height: f32,
    /// cos(yaw).
    pub c: f32,
    /// sin(yaw).
    pub s: f32,
    /// Focal lengths and principal point (pixels, continuous coordinates in which pixel
    /// `i` spans `[i, i + 1)`).
    pub fx: f32,
    /// Vertical focal length.
    pub fy: f32,
    /// Principal point x.
    pub cx: f32,
    /// Principal point y.
    pub cy: f32,
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height_px: u32,
}

/// A point projected into the image.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Projected {
    /// Continuous x (pixel `i` centre at `i + 0.5`).
    pub u: f32,
    /// Continuous y.
    pub v: f32,
    /// Depth along the optical axis (m).
    pub z: f32,
}

impl Camera {
    /// A camera at world (x, y) with heading `yaw`.
    pub fn new(intrinsics: &CameraIntrinsics, x: f32, y: f32, yaw: f32) -> Self {
        Self {
            x,
            y,
            height: intrinsics.mount_height_m,
            c: yaw.cos(),
            s: yaw.sin(),
            fx: intrinsics.fx,
            fy: intrinsics.fy,
            cx: intrinsics.cx,
            cy: intrinsics.cy,
            width: intrinsics.width,
            height_px: intrinsics.height,
        }
    }

    /// Ray origin in camera-relative world coordinates.
    #[inline]
    pub fn origin(&self) -> V3 {
        V3::new(0.0, 0.0, self.height)
    }

    /// Unnormalised ray direction through continuous image point (u, v), scaled so that its
    /// component along the optical axis is 1: the ray parameter is the depth.
    #[inline]
    pub fn ray(&self, u: f32, v: f32) -> V3 {
        let (x, y) = self.ray_xy(u);
        V3::new(x, y, self.ray_z(v))
    }

    /// The horizontal components of [`Camera::ray`], which depend on `u` alone (an image
    /// column shares them).
    #[inline]
    pub fn ray_xy(&self, u: f32) -> (f32, f32) {
        let a = (u - self.cx) / self.fx;
        // forward (c, s, 0), right (s, -c, 0), up (0, 0, 1)
        (self.c + a * self.s, self.s - a * self.c)
    }

    /// The vertical component of [`Camera::ray`], which depends on `v` alone (an image row
    /// shares it).
    #[inline]
    pub fn ray_z(&self, v: f32) -> f32 {
        -((v - self.cy) / self.fy)
    }

    /// Converts a world point to camera-relative coordinates.
    #[inline]
    pub fn relative(&self, p: V3) -> V3 {
        V3::new(p.x - self.x, p.y - self.y, p.z)
    }

    /// Projects a camera-relative point; `None` behind the near plane.
    #[inline]
    pub fn project_relative(&self, p: V3) -> Option<Projected> {
        let z = p.x * self.c + p.y * self.s;
        if z < 0.05 {
            return None;
        }
        let right = p.x * self.s - p.y * self.c;
        let up = p.z - self.height;
        Some(Projected {
            u: self.cx + self.fx * right / z,
            v: self.cy - self.fy * up / z,
            z,
        })
    }

    /// Projects a world point; `None` behind the near plane.
    #[inline]
    pub fn project(&self, p: V3) -> Option<Projected> {
        self.project_relative(self.relative(p))
    }

    /// Projects a direction (a point at infinity); `None` if it points backwards.
    pub fn project_direction(&self, d: V3) -> Option<Projected> {
        let z = d.x * self.c + d.y * self.s;
        if z < 1e-4 {
            return None;
        }
        let right = d.x * self.s - d.y * self.c;
        Some(Projected {
            u: self.cx + self.fx * right / z,
            v: self.cy - self.fy * d.z / z,
            z: f32::INFINITY,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ray_and_projection_are_inverse() {
        let cam = Camera::new(&CameraIntrinsics::anovox(128, 96), 10.0, -3.0, 0.7);
        for &(u, v) in &[
            (0.5f32, 0.5f32),
            (64.0, 48.0),
            (127.5, 95.5),
            (20.25, 70.75),
        ] {
            let d = cam.ray(u, v);
            let p = cam.origin() + d * 17.0;
            let q = cam.project_relative(p).expect("in front");
            assert!((q.u - u).abs() < 1e-3 && (q.v - v).abs() < 1e-3 && (q.z - 17.0).abs() < 1e-3);
        }
    }
}

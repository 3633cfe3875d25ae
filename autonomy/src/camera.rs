//! The pinhole camera of DESIGN.md: OpenCV optical frame (x right, y down, z forward), pixel
//! centres at integer coordinates, planar depth.

use crate::math::{Isometry3, Matrix3, Point3, Vector3};
use serde::{Deserialize, Serialize};

/// Pinhole intrinsics of a W x H image; pixel (u, v) has its centre at (u, v).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Intrinsics {
    /// Focal length along x, pixels.
    pub fx: f64,
    /// Focal length along y, pixels.
    pub fy: f64,
    /// Principal point x, pixels.
    pub cx: f64,
    /// Principal point y, pixels.
    pub cy: f64,
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
}

impl Intrinsics {
    /// The intrinsics of an OpenGL-style symmetric frustum with vertical field of view `fovy`
    /// (radians) and square pixels, as MuJoCo renders a camera.
    pub fn from_fovy(fovy: f64, width: u32, height: u32) -> Self {
        let fy = 0.5 * f64::from(height) / (0.5 * fovy).tan();
        Intrinsics {
            fx: fy,
            fy,
            cx: 0.5 * (f64::from(width) - 1.0),
            cy: 0.5 * (f64::from(height) - 1.0),
            width,
            height,
        }
    }

    /// The 3x3 matrix K.
    pub fn matrix(&self) -> Matrix3 {
        Matrix3::new(self.fx, 0.0, self.cx, 0.0, self.fy, self.cy, 0.0, 0.0, 1.0)
    }

    /// The point in the camera frame seen at pixel (u, v) with planar depth `depth`.
    pub fn back_project(&self, u: f64, v: f64, depth: f64) -> Point3 {
        Point3::new(
            (u - self.cx) / self.fx * depth,
            (v - self.cy) / self.fy * depth,
            depth,
        )
    }

    /// The direction through pixel (u, v) in the camera frame, with unit z (so a distance
    /// along it is planar depth).
    pub fn ray(&self, u: f64, v: f64) -> Vector3 {
        Vector3::new((u - self.cx) / self.fx, (v - self.cy) / self.fy, 1.0)
    }

    /// The pixel where a camera-frame point lands and its depth; `None` behind the camera.
    pub fn project(&self, point_in_camera: &Point3) -> Option<(f64, f64, f64)> {
        let z = point_in_camera.z;
        (z > 0.0).then(|| {
            (
                self.fx * point_in_camera.x / z + self.cx,
                self.fy * point_in_camera.y / z + self.cy,
                z,
            )
        })
    }

    /// Number of pixels.
    pub fn pixel_count(&self) -> usize {
        self.width as usize * self.height as usize
    }
}

/// A camera with a pose: intrinsics plus `world_from_camera` of the optical frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PinholeCamera {
    /// Intrinsics.
    pub intrinsics: Intrinsics,
    /// Pose of the optical frame in the world.
    pub world_from_camera: Isometry3,
}

impl PinholeCamera {
    /// World point seen at pixel (u, v) with planar depth `depth`.
    pub fn back_project_to_world(&self, u: f64, v: f64, depth: f64) -> Point3 {
        self.world_from_camera * self.intrinsics.back_project(u, v, depth)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn project_inverts_back_project() {
        let k = Intrinsics::from_fovy(60f64.to_radians(), 320, 240);
        let p = k.back_project(17.0, 201.5, 2.75);
        let (u, v, d) = k.project(&p).expect("in front");
        assert!((u - 17.0).abs() < 1e-12 && (v - 201.5).abs() < 1e-12 && (d - 2.75).abs() < 1e-12);
    }

    #[test]
    fn fovy_gives_half_height_over_tangent() {
        let k = Intrinsics::from_fovy(90f64.to_radians(), 640, 480);
        assert!((k.fy - 240.0).abs() < 1e-9);
        assert_eq!((k.cx, k.cy), (319.5, 239.5));
        assert!(k.project(&Point3::new(0.0, 0.0, -1.0)).is_none());
    }
}

//! Names for the geometry types, so the rest of the code reads as geometry.

/// Scalar type of poses and geometry.
pub type Real = f64;
/// A point in 3D.
pub type Point3 = nalgebra::Point3<Real>;
/// A vector in 3D.
pub type Vector3 = nalgebra::Vector3<Real>;
/// A rigid transform; name values by their spaces, e.g. `world_from_camera`.
pub type Isometry3 = nalgebra::Isometry3<Real>;
/// A rotation in 3D.
pub type Rotation3 = nalgebra::Rotation3<Real>;
/// A unit quaternion.
pub type UnitQuaternion = nalgebra::UnitQuaternion<Real>;
/// A 3x3 matrix.
pub type Matrix3 = nalgebra::Matrix3<Real>;
/// A homogeneous transform as a matrix (poses from files and other programs).
pub type Matrix4 = nalgebra::Matrix4<Real>;
/// A translation in 3D.
pub type Translation3 = nalgebra::Translation3<Real>;

/// An f64 ordered by `total_cmp`, for priority queues (A*, Dijkstra): costs are never NaN,
/// and a total order keeps equal inputs giving equal outputs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TotalF64(pub f64);

impl Eq for TotalF64 {}

impl PartialOrd for TotalF64 {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}

impl Ord for TotalF64 {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        self.0.total_cmp(&other.0)
    }
}

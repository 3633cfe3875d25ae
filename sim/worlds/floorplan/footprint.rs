//! Where a geom stands: the convex polygon its shape covers on the floor and the heights it
//! spans. Exact for boxes and meshes (MuJoCo collides a mesh as its convex hull), and
//! conservative for curved shapes, whose circles become circumscribed polygons.

use crate::mujoco::{Data, Model, Shape};
use nalgebra::{Point3, Vector3};

/// Sides of the polygons that stand in for circles.
const CIRCLE_SIDES: usize = 24;

/// A geom's footprint: its projection onto the floor and its vertical extent.
#[derive(Debug, Clone, PartialEq)]
pub struct Footprint {
    /// The geom.
    pub geom: usize,
    /// Convex polygon, counter-clockwise, world x-y, metres.
    pub polygon: Vec<[f64; 2]>,
    /// Lowest and highest z, metres.
    pub z: [f64; 2],
}

impl Footprint {
    /// The footprint of `geom` at the state in `data`; `None` for ground (planes, height
    /// fields) and shapes this host does not model.
    pub fn of(model: &Model, data: &Data, geom: usize) -> Option<Footprint> {
        let size = model.geom_size(geom);
        let position = data.geom_position(geom);
        let rotation = data.geom_rotation(geom);
        let world = |p: Vector3<f64>| position + rotation * p;
        // Points whose hull is the shape's projection, and the heights each adds (a sphere's
        // centre adds its radius above and below).
        let mut points: Vec<Point3<f64>> = Vec::new();
        let mut z = [f64::INFINITY, f64::NEG_INFINITY];
        let mut add = |p: Point3<f64>, reach: f64, points: &mut Vec<Point3<f64>>| {
            z[0] = z[0].min(p.z - reach);
            z[1] = z[1].max(p.z + reach);
            points.push(p);
        };
        match model.geom_shape(geom) {
            Shape::Plane | Shape::HeightField | Shape::Other => return None,
            Shape::Box | Shape::Ellipsoid => {
                for corner in 0..8 {
                    let sign = |bit: usize| if corner >> bit & 1 == 1 { 1.0 } else { -1.0 };
                    let local =
                        Vector3::new(sign(0) * size[0], sign(1) * size[1], sign(2) * size[2]);
                    add(world(local), 0.0, &mut points);
                }
            }
            Shape::Mesh(mesh) => {
                for v in model.mesh_vertices(mesh) {
                    let local = Vector3::new(f64::from(v[0]), f64::from(v[1]), f64::from(v[2]));
                    add(world(local), 0.0, &mut points);
                }
            }
            Shape::Sphere => {
                for p in horizontal_circle(position, size[0]) {
                    add(p, size[0], &mut points);
                }
            }
            Shape::Capsule => {
                for end in [-1.0, 1.0] {
                    let centre = world(Vector3::new(0.0, 0.0, end * size[1]));
                    for p in horizontal_circle(centre, size[0]) {
                        add(p, size[0], &mut points);
                    }
                }
            }
            Shape::Cylinder => {
                let r = size[0] / (std::f64::consts::PI / CIRCLE_SIDES as f64).cos();
                for end in [-1.0, 1.0] {
                    for k in 0..CIRCLE_SIDES {
                        let a = std::f64::consts::TAU * k as f64 / CIRCLE_SIDES as f64;
                        let local = Vector3::new(r * a.cos(), r * a.sin(), end * size[1]);
                        add(world(local), 0.0, &mut points);
                    }
                }
            }
        }
        if points.is_empty() {
            return None;
        }
        let flat: Vec<[f64; 2]> = points.iter().map(|p| [p.x, p.y]).collect();
        Some(Footprint {
            geom,
            polygon: convex_hull(flat),
            z,
        })
    }

    /// The polygon's bounding box: (min x, min y), (max x, max y).
    pub fn bounds(&self) -> ([f64; 2], [f64; 2]) {
        let mut lo = [f64::INFINITY; 2];
        let mut hi = [f64::NEG_INFINITY; 2];
        for p in &self.polygon {
            for a in 0..2 {
                lo[a] = lo[a].min(p[a]);
                hi[a] = hi[a].max(p[a]);
            }
        }
        (lo, hi)
    }

    /// How deep two footprints' solids overlap (in the plane and in height), metres; zero or
    /// less when they are apart or only touch.
    pub fn penetration(&self, other: &Footprint) -> f64 {
        let dz = self.z[1].min(other.z[1]) - self.z[0].max(other.z[0]);
        dz.min(polygon_penetration(&self.polygon, &other.polygon))
    }
}

/// A circle of `radius` around `centre` in the horizontal plane, as the vertices of a
/// circumscribed polygon (so it covers the circle).
fn horizontal_circle(centre: Point3<f64>, radius: f64) -> impl Iterator<Item = Point3<f64>> {
    let r = radius / (std::f64::consts::PI / CIRCLE_SIDES as f64).cos();
    (0..CIRCLE_SIDES).map(move |k| {
        let a = std::f64::consts::TAU * k as f64 / CIRCLE_SIDES as f64;
        centre + Vector3::new(r * a.cos(), r * a.sin(), 0.0)
    })
}

/// Convex hull, counter-clockwise (Andrew's monotone chain); collinear points dropped.
pub fn convex_hull(mut points: Vec<[f64; 2]>) -> Vec<[f64; 2]> {
    points.sort_by(|a, b| a[0].total_cmp(&b[0]).then(a[1].total_cmp(&b[1])));
    points.dedup();
    if points.len() < 3 {
        return points;
    }
    let cross = |o: [f64; 2], a: [f64; 2], b: [f64; 2]| {
        (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])
    };
    let mut hull: Vec<[f64; 2]> = Vec::with_capacity(2 * points.len());
    for pass in 0..2 {
        let start = hull.len();
        let ordered: Box<dyn Iterator<Item = &[f64; 2]>> = if pass == 0 {
            Box::new(points.iter())
        } else {
            Box::new(points.iter().rev())
        };
        for &p in ordered {
            while hull.len() >= start + 2
                && cross(hull[hull.len() - 2], hull[hull.len() - 1], p) <= 1e-12
            {
                hull.pop();
            }
            hull.push(p);
        }
        hull.pop();
    }
    hull
}

/// The separating-axis overlap of two convex polygons: the smallest overlap of their
/// projections over every edge normal of both (negative: the gap between them).
pub fn polygon_penetration(a: &[[f64; 2]], b: &[[f64; 2]]) -> f64 {
    let mut least = f64::INFINITY;
    for polygon in [a, b] {
        let n = polygon.len();
        for i in 0..n {
            let (p, q) = (polygon[i], polygon[(i + 1) % n]);
            let (nx, ny) = (q[1] - p[1], p[0] - q[0]);
            let length = nx.hypot(ny);
            if length < 1e-12 {
                continue;
            }
            let axis = [nx / length, ny / length];
            let project = |poly: &[[f64; 2]]| {
                poly.iter()
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
                        let d = v[0] * axis[0] + v[1] * axis[1];
                        (lo.min(d), hi.max(d))
                    })
            };
            let (alo, ahi) = project(a);
            let (blo, bhi) = project(b);
            least = least.min(ahi.min(bhi) - alo.max(blo));
        }
    }
    least
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hull_of_a_square_with_inner_points_is_its_corners_counter_clockwise() {
        let hull = convex_hull(vec![
            [0.0, 0.0],
            [1.0, 1.0],
            [0.5, 0.5],
            [1.0, 0.0],
            [0.0, 1.0],
            [0.5, 0.0],
        ]);
        assert_eq!(hull, vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]);
    }

    #[test]
    fn penetration_of_squares_is_their_overlap_and_their_gap_is_negative() {
        let square = |x: f64| vec![[x, 0.0], [x + 1.0, 0.0], [x + 1.0, 1.0], [x, 1.0]];
        assert!((polygon_penetration(&square(0.0), &square(0.75)) - 0.25).abs() < 1e-12);
        assert!((polygon_penetration(&square(0.0), &square(1.5)) + 0.5).abs() < 1e-12);
        assert!(polygon_penetration(&square(0.0), &square(1.0)).abs() < 1e-12);
    }
}

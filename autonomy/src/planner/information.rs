//! Information of a viewpoint (DESIGN.md): xi = #high-uncertainty Gaussians in view -
//! lambda_xi #low-uncertainty ones, "in view" meaning inside the camera frustum and within
//! the sensor range (planar depth), no occlusion test. A dense 3-D grid of per-cell counts
//! answers it exactly: cells wholly inside the view add their counts, cells on the boundary
//! test their members one by one.

use super::unicycle::State;
use crate::camera::Intrinsics;
use crate::map::UncertaintyClass;

/// Where the camera sits on the robot.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CameraMount {
    /// Intrinsics of the sensor.
    pub intrinsics: Intrinsics,
    /// Forward offset from the robot's centre, metres.
    pub forward: f64,
    /// Height above the floor, metres.
    pub height: f64,
    /// Sensor range (planar depth), metres.
    pub range: f64,
}

impl Default for CameraMount {
    fn default() -> Self {
        // models/unicycle.xml: camera 0.2 m ahead, 0.4 m up, fovy 60, 320x240; 5 m range.
        CameraMount {
            intrinsics: Intrinsics::from_fovy(60f64.to_radians(), 320, 240),
            forward: 0.2,
            height: 0.4,
            range: 5.0,
        }
    }
}

/// A camera pose reduced to what the frustum test needs.
#[derive(Debug, Clone, Copy)]
struct View {
    centre: [f32; 3],
    forward: [f32; 2],
    range: f32,
    // |x / z| and |y / z| limits of the image.
    half_x: f32,
    half_y_up: f32,
    half_y_down: f32,
}

impl View {
    fn new(mount: &CameraMount, s: &State) -> Self {
        let k = &mount.intrinsics;
        let (c, sn) = (s.theta.cos(), s.theta.sin());
        View {
            centre: [
                (s.x + mount.forward * c) as f32,
                (s.y + mount.forward * sn) as f32,
                mount.height as f32,
            ],
            forward: [c as f32, sn as f32],
            range: mount.range as f32,
            half_x: ((k.cx + 0.5) / k.fx) as f32,
            // Image rows grow downward: the top edge is cy + 0.5 pixels above the centre.
            half_y_up: ((k.cy + 0.5) / k.fy) as f32,
            half_y_down: ((f64::from(k.height) - 0.5 - k.cy) / k.fy) as f32,
        }
    }

    #[inline]
    fn sees(&self, p: [f32; 3]) -> bool {
        let d = [
            p[0] - self.centre[0],
            p[1] - self.centre[1],
            p[2] - self.centre[2],
        ];
        let z = d[0] * self.forward[0] + d[1] * self.forward[1];
        if z <= 0.0 || z > self.range {
            return false;
        }
        // Optical x points right: (sin, -cos); optical y points down: -world z.
        let x = d[0] * self.forward[1] - d[1] * self.forward[0];
        let up = d[2];
        x.abs() <= self.half_x * z && up <= self.half_y_up * z && -up <= self.half_y_down * z
    }
}

/// Per-cell counts of high and low Gaussians, and their members for boundary cells.
#[derive(Debug, Clone)]
pub struct ViewCounter {
    origin: [f32; 3],
    cell: f32,
    dims: [usize; 3],
    high: Vec<u32>,
    low: Vec<u32>,
    starts: Vec<u32>,
    members: Vec<([f32; 3], bool)>,
    mount: CameraMount,
    /// lambda_xi.
    pub low_weight: f64,
}

impl ViewCounter {
    /// Files every high and low Gaussian (others do not count) in cells of side `cell`.
    pub fn new(
        means: &[[f32; 3]],
        classes: &[UncertaintyClass],
        mount: CameraMount,
        cell: f32,
    ) -> Self {
        let mut counter = ViewCounter {
            origin: [0.0; 3],
            cell,
            dims: [1; 3],
            high: Vec::new(),
            low: Vec::new(),
            starts: Vec::new(),
            members: Vec::new(),
            mount,
            low_weight: 1.0,
        };
        counter.rebuild(means, classes);
        counter
    }

    /// Refiles for a new map, reusing the buffers (a plan over 3e6 Gaussians would otherwise
    /// spend most of its time on the kernel zeroing fresh pages).
    pub fn rebuild(&mut self, means: &[[f32; 3]], classes: &[UncertaintyClass]) {
        let counted =
            |c: &UncertaintyClass| matches!(c, UncertaintyClass::High | UncertaintyClass::Low);
        let mut lo = [f32::MAX; 3];
        let mut hi = [f32::MIN; 3];
        let mut any = false;
        for (m, c) in means.iter().zip(classes) {
            if counted(c) {
                any = true;
                for a in 0..3 {
                    lo[a] = lo[a].min(m[a]);
                    hi[a] = hi[a].max(m[a]);
                }
            }
        }
        if !any {
            lo = [0.0; 3];
            hi = [0.0; 3];
        }
        let cell = self.cell;
        let dims = [0, 1, 2].map(|a| ((hi[a] - lo[a]) / cell).floor() as usize + 1);
        let n = dims[0] * dims[1] * dims[2];
        let index = |m: &[f32; 3]| {
            let c = [0, 1, 2].map(|a| (((m[a] - lo[a]) / cell) as usize).min(dims[a] - 1));
            (c[2] * dims[1] + c[1]) * dims[0] + c[0]
        };
        self.high.clear();
        self.high.resize(n, 0);
        self.low.clear();
        self.low.resize(n, 0);
        self.starts.clear();
        self.starts.resize(n + 1, 0);
        for (m, c) in means.iter().zip(classes) {
            match c {
                UncertaintyClass::High => self.high[index(m)] += 1,
                UncertaintyClass::Low => self.low[index(m)] += 1,
                _ => {}
            }
        }
        for i in 0..n {
            self.starts[i + 1] = self.starts[i] + self.high[i] + self.low[i];
        }
        let mut cursor = self.starts.clone();
        self.members.clear();
        self.members
            .resize(self.starts[n] as usize, ([0.0; 3], false));
        for (m, c) in means.iter().zip(classes) {
            if counted(c) {
                let i = index(m);
                self.members[cursor[i] as usize] = (*m, *c == UncertaintyClass::High);
                cursor[i] += 1;
            }
        }
        self.origin = lo;
        self.dims = dims;
    }

    /// (#high, #low) in view from robot state `s`.
    pub fn count(&self, s: &State) -> (u32, u32) {
        if self.members.is_empty() {
            return (0, 0);
        }
        let view = View::new(&self.mount, s);
        let (f, c) = (view.forward, view.centre);
        let right = [f[1], -f[0]];
        // The view's six half-spaces as (normal, offset): inside when n . (p - c) + o > 0.
        let planes: [([f32; 3], f32); 6] = [
            ([f[0], f[1], 0.0], 0.0),
            ([-f[0], -f[1], 0.0], view.range),
            (
                [
                    view.half_x * f[0] - right[0],
                    view.half_x * f[1] - right[1],
                    0.0,
                ],
                0.0,
            ),
            (
                [
                    view.half_x * f[0] + right[0],
                    view.half_x * f[1] + right[1],
                    0.0,
                ],
                0.0,
            ),
            ([view.half_y_up * f[0], view.half_y_up * f[1], -1.0], 0.0),
            ([view.half_y_down * f[0], view.half_y_down * f[1], 1.0], 0.0),
        ];
        // Cells under the view: its footprint (a triangle) in x, y; its height span in z.
        let far = [
            [c[0], c[1]],
            [
                c[0] + view.range * (f[0] + view.half_x * right[0]),
                c[1] + view.range * (f[1] + view.half_x * right[1]),
            ],
            [
                c[0] + view.range * (f[0] - view.half_x * right[0]),
                c[1] + view.range * (f[1] - view.half_x * right[1]),
            ],
        ];
        let span = |a: usize, lo: f32, hi: f32| -> Option<(usize, usize)> {
            let l = ((lo - self.origin[a]) / self.cell).floor();
            let h = ((hi - self.origin[a]) / self.cell).floor();
            if h < 0.0 || l > (self.dims[a] - 1) as f32 {
                return None;
            }
            Some((l.max(0.0) as usize, (h as usize).min(self.dims[a] - 1)))
        };
        let fold = |a: usize| {
            far.iter().fold((f32::MAX, f32::MIN), |(lo, hi), p| {
                (lo.min(p[a]), hi.max(p[a]))
            })
        };
        let ((xl, xh), (yl, yh)) = (fold(0), fold(1));
        let (Some((x0, x1)), Some((y0, y1)), Some((z0, z1))) = (
            span(0, xl, xh),
            span(1, yl, yh),
            span(
                2,
                c[2] - view.half_y_down * view.range,
                c[2] + view.half_y_up * view.range,
            ),
        ) else {
            return (0, 0);
        };
        let half = 0.5 * self.cell;
        let (mut high, mut low) = (0u32, 0u32);
        for cz in z0..=z1 {
            for cy in y0..=y1 {
                for cx in x0..=x1 {
                    let i = (cz * self.dims[1] + cy) * self.dims[0] + cx;
                    if self.high[i] + self.low[i] == 0 {
                        continue;
                    }
                    let centre = [
                        self.origin[0] + (cx as f32 + 0.5) * self.cell - c[0],
                        self.origin[1] + (cy as f32 + 0.5) * self.cell - c[1],
                        self.origin[2] + (cz as f32 + 0.5) * self.cell - c[2],
                    ];
                    let mut outside = false;
                    let mut inside = true;
                    for (n, o) in &planes {
                        let v = n[0] * centre[0] + n[1] * centre[1] + n[2] * centre[2] + o;
                        let reach = half * (n[0].abs() + n[1].abs() + n[2].abs());
                        if v + reach < 0.0 {
                            outside = true;
                            break;
                        }
                        inside &= v - reach > 0.0;
                    }
                    if outside {
                        continue;
                    }
                    if inside {
                        high += self.high[i];
                        low += self.low[i];
                        continue;
                    }
                    let range = self.starts[i] as usize..self.starts[i + 1] as usize;
                    for (m, h) in &self.members[range] {
                        if view.sees(*m) {
                            if *h {
                                high += 1;
                            } else {
                                low += 1;
                            }
                        }
                    }
                }
            }
        }
        (high, low)
    }

    /// xi of state `s`.
    pub fn information(&self, s: &State) -> f64 {
        let (h, l) = self.count(s);
        f64::from(h) - self.low_weight * f64::from(l)
    }

    /// (#high, #low) in view by checking every counted Gaussian: the reference.
    pub fn count_brute_force(&self, s: &State) -> (u32, u32) {
        let view = View::new(&self.mount, s);
        self.members.iter().fold((0, 0), |(h, l), (m, is_high)| {
            if view.sees(*m) {
                if *is_high {
                    (h + 1, l)
                } else {
                    (h, l + 1)
                }
            } else {
                (h, l)
            }
        })
    }
}

//! The 2D evidence grid of frontier exploration (AG-SLAM's FBE baseline): depth rays add free
//! evidence and occupied evidence at their ends when the end lies in the height band; the map's
//! Gaussian means add obstacle evidence. A cell's class is the argmax of its evidence over
//! {unknown, occupied, free}, where (as their code weighs end points 100 to a crossing's 1 and
//! normalises each frame) a frame votes once per cell: occupied if any of its rays ended there.
//! Which cells a ray frees is [`FreeCells`]: the papers' grid frees what their code draws (an
//! 8-connected line from the camera's cell to each end cell in the band, and points sampled
//! along every ray), RT-GuIDE's every cell a ray crosses. The grid grows as the robot sees
//! further, so no world size is assumed.

use crate::camera::PinholeCamera;
use crate::math::Point3;

/// Settings of the grid (AG-SLAM's code's values).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct EvidenceConfig {
    /// Cell side, metres.
    pub cell: f64,
    /// Lowest height of an obstacle, metres (below it is floor).
    pub min_height: f64,
    /// Highest height that matters to the robot, metres.
    pub max_height: f64,
    /// The robot's top, metres (`max_height` in AG-SLAM's code): rays add free evidence only
    /// where they pass below it, and Gaussians above it are no obstacle. A ray over a table
    /// top proves nothing at the robot's height (with 1.3 m, RT-GuIDE's grid took a solid
    /// table's unseen side for floor: apartment, 57 s), and a table top's Gaussians are no
    /// wall to a robot that fits under it (apartment_01: stuck under a table for 46 s).
    pub free_height: f64,
    /// Rays add free evidence only above this height, metres (no limit by default). A ray
    /// that slides under an overhang near the floor (a ball's lower half) proves nothing at
    /// the body's height: office_03's RT-GuIDE took the unseen side of a ball, crossed by
    /// rays at 2-10 cm, for floor and touched it with a wheel.
    pub free_from_height: f64,
    /// Free space by height (0 = off): the band from `free_from_height` (at least
    /// `min_height`) to `slices_top` is cut into this many slices, and a cell is free only
    /// once rays have crossed it within every slice. A ray over an object's top proves nothing
    /// below it: with one count per cell, rays over a 0.55 m cylinder made its unseen far side
    /// free (office_02, a wheel touched it for 6 s).
    pub height_slices: u32,
    /// The top of the sliced band, metres: the camera's height for a robot no taller than
    /// its camera (rays to the floor cross every height below it; rays up may find nothing
    /// within range in an open hall and return no depth).
    pub slices_top: f64,
    /// Rays count up to this range, metres.
    pub max_range: f64,
    /// Free evidence only this near the camera, metres (up to `max_range`): space seen from
    /// further is not yet seen well enough to map, so its edge stays a frontier.
    pub free_range: f64,
    /// One ray per `pixel_stride` pixels in each direction.
    pub pixel_stride: usize,
    /// More Gaussian means in a cell than this remove it from free space...
    pub gaussians_unfree: u32,
    /// ... and more than this mark it occupied.
    pub gaussians_occupied: u32,
    /// The class of a cell that rays crossed (free evidence wins) but more than
    /// `gaussians_unfree` Gaussian means fill. The papers' grid takes it for `Occupied`:
    /// AG-SLAM's code drops such a cell from free space, yet its frontier asks for cells with no
    /// evidence at all, so it is no frontier. `Unknown` made it one, and a densely mapped wall
    /// seen from a metre away was a frontier no view could clear (AG-SLAM's flat warehouse
    /// curves, issue 40). RT-GuIDE's grid keeps `Unknown` (its frontier regions were tuned so).
    pub filled_class: CellClass,
    /// A frame votes once per cell: occupied if any of its rays ended there, else free (as
    /// AG-SLAM's code weighs a frame's end points 100 to a crossing's 1 and normalises each
    /// frame). Counting every ray instead let the rays grazing a wall's face outvote the few
    /// ending in it: the face turned free, the wall's unseen inside became a frontier along
    /// every thin wall, and AG-SLAM shuttled before one for hundreds of seconds (issue 40).
    /// RT-GuIDE's grid counts rays (off; its frontier regions were tuned so).
    pub frame_votes: bool,
    /// Which cells a ray adds free evidence to.
    pub free_cells: FreeCells,
}

/// Which cells a depth ray adds free evidence to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub enum FreeCells {
    /// Every cell the ray crosses while within the free band and range (an exact traversal;
    /// RT-GuIDE's grid and the executor's guard, whose free bands and height slices need it).
    Crossed,
    /// What AG-SLAM's code draws (`update_occ_map`): an 8-connected (Bresenham) line from the
    /// camera's cell to the cell of every end in the band and range, and the cells of points
    /// at `SAMPLED_FRACTIONS` of every ray that lie in the band and range. A line has one cell
    /// per step of its major axis, so a ray grazing a wall's face crosses fewer of the face's
    /// cells than the exact traversal marks: with every crossed cell, thin walls' faces kept
    /// turning free in frames where only grazing rays crossed them, and AG-SLAM chose
    /// frontiers behind them (issue 40). `free_range`, `free_from_height` and `free_height`
    /// bound the sampled points; lines follow the ends alone; height slices are not used.
    PapersLines,
}

/// Where along a ray (as fractions of its length) AG-SLAM's code samples its free points: ten of
/// `linspace(1e-3, 0.95, 11)`, whose last entry is replaced by the end itself.
pub const SAMPLED_FRACTIONS: [f64; 10] = {
    let mut f = [0.0; 10];
    let mut k = 0;
    while k < 10 {
        f[k] = 1e-3 + (0.95 - 1e-3) * k as f64 / 10.0;
        k += 1;
    }
    f
};

impl Default for EvidenceConfig {
    fn default() -> Self {
        EvidenceConfig {
            cell: 0.05,
            min_height: 0.1,
            max_height: 1.3,
            free_height: 1.3,
            free_from_height: f64::NEG_INFINITY,
            height_slices: 0,
            slices_top: 1.3,
            max_range: 7.0,
            free_range: 7.0,
            pixel_stride: 4,
            gaussians_unfree: 25,
            gaussians_occupied: 50,
            filled_class: CellClass::Occupied,
            frame_votes: true,
            free_cells: FreeCells::PapersLines,
        }
    }
}

/// What a cell is believed to be.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub enum CellClass {
    /// No evidence yet.
    Unknown,
    /// More free than occupied evidence.
    Free,
    /// Occupied evidence wins (ties count as occupied: a wall is safer than a hole).
    Occupied,
}

/// A grid of cell classes, as frontier detection and path search read it.
#[derive(Debug, Clone, PartialEq)]
pub struct ClassGrid {
    /// Cells along x and y.
    pub size: [usize; 2],
    /// World position of cell (0, 0)'s lower corner, metres.
    pub origin: [f64; 2],
    /// Cell side, metres.
    pub cell: f64,
    /// Row-major classes (index = y * size[0] + x).
    pub classes: Vec<CellClass>,
}

impl ClassGrid {
    /// A grid of one class.
    pub fn filled(size: [usize; 2], origin: [f64; 2], cell: f64, class: CellClass) -> Self {
        ClassGrid {
            size,
            origin,
            cell,
            classes: vec![class; size[0] * size[1]],
        }
    }

    /// The cell holding a world point, if inside.
    pub fn cell_of(&self, p: [f64; 2]) -> Option<usize> {
        let x = ((p[0] - self.origin[0]) / self.cell).floor();
        let y = ((p[1] - self.origin[1]) / self.cell).floor();
        (x >= 0.0 && y >= 0.0 && (x as usize) < self.size[0] && (y as usize) < self.size[1])
            .then(|| y as usize * self.size[0] + x as usize)
    }

    /// A cell's centre in the world.
    pub fn centre(&self, c: usize) -> [f64; 2] {
        let (x, y) = (c % self.size[0], c / self.size[0]);
        [
            self.origin[0] + (x as f64 + 0.5) * self.cell,
            self.origin[1] + (y as f64 + 0.5) * self.cell,
        ]
    }

    /// The up-to-8 neighbours of a cell.
    pub fn neighbours8(&self, c: usize) -> impl Iterator<Item = usize> + '_ {
        let [w, h] = self.size;
        let (x, y) = ((c % w) as i64, (c / w) as i64);
        (-1i64..=1)
            .flat_map(move |dy| (-1i64..=1).map(move |dx| (dx, dy)))
            .filter(|&(dx, dy)| dx != 0 || dy != 0)
            .filter_map(move |(dx, dy)| {
                let (nx, ny) = (x + dx, y + dy);
                (nx >= 0 && ny >= 0 && nx < w as i64 && ny < h as i64)
                    .then(|| ny as usize * w + nx as usize)
            })
    }

    /// Whether the straight segment between two points crosses free cells only (sampled every
    /// quarter cell, so a corner clipped by less than that may pass): an unseen cell may hide
    /// a wall, so it blocks the view like an occupied one; off the grid blocks too.
    pub fn line_of_sight(&self, from: [f64; 2], to: [f64; 2]) -> bool {
        let n = ((to[0] - from[0]).hypot(to[1] - from[1]) / (0.25 * self.cell)).ceil() as usize;
        (0..=n).all(|k| {
            let t = if n == 0 { 0.0 } else { k as f64 / n as f64 };
            let p = [
                from[0] + t * (to[0] - from[0]),
                from[1] + t * (to[1] - from[1]),
            ];
            self.cell_of(p)
                .is_some_and(|c| self.classes[c] == CellClass::Free)
        })
    }

    /// Cells in total.
    pub fn len(&self) -> usize {
        self.classes.len()
    }

    /// Whether the grid has no cells.
    pub fn is_empty(&self) -> bool {
        self.classes.is_empty()
    }
}

/// The accumulated evidence.
#[derive(Debug, Clone)]
pub struct EvidenceGrid {
    config: EvidenceConfig,
    /// Cell index of the grid's (0, 0) cell in the world lattice.
    origin: [i64; 2],
    size: [usize; 2],
    free: Vec<u32>,
    /// Per cell, a bit per height slice a free ray has crossed it in (with `height_slices`).
    slices: Vec<u32>,
    /// The height slices, derived once from the config (`None` without `height_slices`).
    slicing: Option<Slicing>,
    occupied: Vec<u32>,
    gaussians: Vec<u32>,
}

/// Cells added on each side whenever the grid grows.
const GROW_MARGIN: i64 = 80;

impl EvidenceGrid {
    /// An empty grid.
    pub fn new(config: EvidenceConfig) -> Self {
        let slicing = match config.free_cells {
            FreeCells::Crossed => Slicing::of(&config),
            FreeCells::PapersLines => None,
        };
        EvidenceGrid {
            config,
            slicing,
            origin: [0, 0],
            size: [0, 0],
            free: Vec::new(),
            slices: Vec::new(),
            occupied: Vec::new(),
            gaussians: Vec::new(),
        }
    }

    /// The settings.
    pub fn config(&self) -> &EvidenceConfig {
        &self.config
    }

    fn lattice(&self, p: [f64; 2]) -> [i64; 2] {
        [
            (p[0] / self.config.cell).floor() as i64,
            (p[1] / self.config.cell).floor() as i64,
        ]
    }

    /// Grows the grid to hold lattice cells `lo..=hi`.
    fn reserve(&mut self, lo: [i64; 2], hi: [i64; 2]) {
        let [w, h] = [self.size[0] as i64, self.size[1] as i64];
        let inside = w > 0
            && lo[0] >= self.origin[0]
            && lo[1] >= self.origin[1]
            && hi[0] < self.origin[0] + w
            && hi[1] < self.origin[1] + h;
        if inside {
            return;
        }
        let (new_lo, new_hi) = if w == 0 {
            (
                [lo[0] - GROW_MARGIN, lo[1] - GROW_MARGIN],
                [hi[0] + GROW_MARGIN, hi[1] + GROW_MARGIN],
            )
        } else {
            (
                [
                    self.origin[0].min(lo[0] - GROW_MARGIN),
                    self.origin[1].min(lo[1] - GROW_MARGIN),
                ],
                [
                    (self.origin[0] + w - 1).max(hi[0] + GROW_MARGIN),
                    (self.origin[1] + h - 1).max(hi[1] + GROW_MARGIN),
                ],
            )
        };
        let size = [
            (new_hi[0] - new_lo[0] + 1) as usize,
            (new_hi[1] - new_lo[1] + 1) as usize,
        ];
        let grown = |old: &[u32]| {
            let mut v = vec![0u32; size[0] * size[1]];
            for y in 0..self.size[1] {
                let ny = (self.origin[1] + y as i64 - new_lo[1]) as usize;
                let nx = (self.origin[0] - new_lo[0]) as usize;
                v[ny * size[0] + nx..ny * size[0] + nx + self.size[0]]
                    .copy_from_slice(&old[y * self.size[0]..(y + 1) * self.size[0]]);
            }
            v
        };
        self.free = grown(&self.free);
        self.slices = grown(&self.slices);
        self.occupied = grown(&self.occupied);
        self.gaussians = grown(&self.gaussians);
        self.origin = new_lo;
        self.size = size;
    }

    fn index(&self, l: [i64; 2]) -> usize {
        (l[1] - self.origin[1]) as usize * self.size[0] + (l[0] - self.origin[0]) as usize
    }

    /// Adds one depth frame: a ray per `pixel_stride` pixels.
    pub fn integrate(&mut self, depth: &[f32], camera: &PinholeCamera) {
        let k = &camera.intrinsics;
        let (w, h) = (k.width as usize, k.height as usize);
        if depth.len() != w * h {
            return;
        }
        let origin = Point3::from(camera.world_from_camera.translation.vector);
        let stride = self.config.pixel_stride.max(1);
        let mut ends = Vec::new();
        for v in (stride / 2..h).step_by(stride) {
            for u in (stride / 2..w).step_by(stride) {
                let d = f64::from(depth[v * w + u]);
                if d.is_finite() && d > 0.0 {
                    ends.push(camera.back_project_to_world(u as f64, v as f64, d));
                }
            }
        }
        self.integrate_frame(origin, &ends);
    }

    /// One frame's rays from `origin` to the surface points `ends`.
    pub fn integrate_frame(&mut self, origin: Point3, ends: &[Point3]) {
        let mut cells = Vec::new();
        if self.config.frame_votes {
            for end in ends {
                self.ray_cells(origin, *end, &mut cells);
            }
            self.vote(&mut cells);
        } else {
            for end in ends {
                cells.clear();
                self.ray_cells(origin, *end, &mut cells);
                self.vote(&mut cells);
            }
        }
    }

    /// One ray from `origin` to the surface point `end` (a frame of one ray).
    pub fn integrate_ray(&mut self, origin: Point3, end: Point3) {
        self.integrate_frame(origin, std::slice::from_ref(&end));
    }

    /// One vote per cell of `cells`: occupied if any of its entries is an end, else free.
    fn vote(&mut self, cells: &mut [([i64; 2], bool)]) {
        cells.sort_unstable();
        for group in cells.chunk_by(|a, b| a.0 == b.0) {
            let i = self.index(group[0].0);
            if group.iter().any(|(_, hit)| *hit) {
                self.occupied[i] += 1;
            } else {
                self.free[i] += 1;
            }
        }
    }

    /// The cells a ray adds evidence to, `true` for its end's occupied evidence (the grid
    /// grown to hold them, their height slices marked).
    fn ray_cells(&mut self, origin: Point3, end: Point3, out: &mut Vec<([i64; 2], bool)>) {
        match self.config.free_cells {
            FreeCells::Crossed => self.crossed_cells(origin, end, out),
            FreeCells::PapersLines => self.papers_cells(origin, end, out),
        }
    }

    /// [`FreeCells::PapersLines`]: the line to an end in the band and range, then the sampled
    /// points in the band and range, then the end.
    fn papers_cells(&mut self, origin: Point3, end: Point3, out: &mut Vec<([i64; 2], bool)>) {
        let c = self.config;
        let length = (end - origin).norm();
        if !(length.is_finite() && length > 0.0) {
            return;
        }
        let in_band = |z: f64| z >= c.min_height && z <= c.max_height;
        let hit = length <= c.max_range && in_band(end.z);
        let (la, lb) = (
            self.lattice([origin.x, origin.y]),
            self.lattice([end.x, end.y]),
        );
        let start = out.len();
        if hit {
            // The end's own cell holds its occupied evidence, pushed last.
            bresenham(la, lb, |l| {
                if l != lb {
                    out.push((l, false));
                }
            });
        }
        let (low, high) = (
            c.min_height.max(c.free_from_height),
            c.max_height.min(c.free_height),
        );
        let reach = c.max_range.min(c.free_range);
        for f in SAMPLED_FRACTIONS {
            let p = origin + f * (end - origin);
            if f * length <= reach && p.z >= low && p.z <= high {
                out.push((self.lattice([p.x, p.y]), false));
            }
        }
        if hit {
            out.push((lb, true));
        }
        let Some(&(first, _)) = out.get(start) else {
            return;
        };
        let (lo, hi) = out[start..]
            .iter()
            .fold((first, first), |(lo, hi), (l, _)| {
                (
                    [lo[0].min(l[0]), lo[1].min(l[1])],
                    [hi[0].max(l[0]), hi[1].max(l[1])],
                )
            });
        self.reserve(lo, hi);
    }

    /// [`FreeCells::Crossed`]: every cell crossed within the free band and range.
    fn crossed_cells(&mut self, origin: Point3, end: Point3, out: &mut Vec<([i64; 2], bool)>) {
        let c = &self.config;
        let length = (end - origin).norm();
        if !(length.is_finite() && length > 0.0) {
            return;
        }
        let mut t_end = (c.max_range / length).min(1.0);
        let dz = end.z - origin.z;
        if origin.z > c.max_height {
            return;
        }
        if end.z > c.max_height && dz > 0.0 {
            t_end = t_end.min((c.max_height - origin.z) / dz);
        }
        let hit = t_end >= 1.0 && end.z >= c.min_height && end.z <= c.max_height;
        // Free evidence only where the ray is between `free_from_height` and `free_height`
        // (the hit counts anyway).
        let (t_from, t_free) =
            band_interval(origin.z, dz, c.free_from_height, c.free_height, t_end);
        let t_free = t_free.min(c.free_range / length);
        let a = [origin.x, origin.y];
        let b = [
            origin.x + t_end * (end.x - origin.x),
            origin.y + t_end * (end.y - origin.y),
        ];
        let (la, lb) = (self.lattice(a), self.lattice(b));
        self.reserve(
            [la[0].min(lb[0]), la[1].min(lb[1])],
            [la[0].max(lb[0]), la[1].max(lb[1])],
        );
        let mut cells = Vec::new();
        let along = |t: f64| {
            [
                origin.x + t * (end.x - origin.x),
                origin.y + t * (end.y - origin.y),
            ]
        };
        if t_free > t_from {
            traverse(along(t_from), along(t_free), self.config.cell, &mut cells);
        }
        for l in cells {
            if !(hit && l == lb) {
                out.push((l, false));
                if let Some(slicing) = &self.slicing {
                    let i = self.index(l);
                    let (t0, t1) = cell_interval(l, self.config.cell, origin, end);
                    let (t0, t1) = (t0.max(t_from), t1.min(t_free));
                    if t1 >= t0 {
                        self.slices[i] |= slicing.mask(origin.z + t0 * dz, origin.z + t1 * dz);
                    }
                }
            }
        }
        if hit {
            out.push((lb, true));
        }
    }

    /// Takes in one camera frame of a robot whose footprint has radius `footprint`: its rays,
    /// and the footprint marked free.
    pub fn observe(&mut self, observation: &super::Observation<'_>, footprint: f64) {
        self.integrate(observation.depth, observation.camera);
        self.mark_free_disc([observation.robot.x, observation.robot.y], footprint);
    }

    /// Marks the robot's footprint free: the camera never sees the floor under the robot, yet
    /// the robot stands there.
    pub fn mark_free_disc(&mut self, centre: [f64; 2], radius: f64) {
        let lo = self.lattice([centre[0] - radius, centre[1] - radius]);
        let hi = self.lattice([centre[0] + radius, centre[1] + radius]);
        self.reserve(lo, hi);
        let cell = self.config.cell;
        for y in lo[1]..=hi[1] {
            for x in lo[0]..=hi[0] {
                let p = [(x as f64 + 0.5) * cell, (y as f64 + 0.5) * cell];
                if (p[0] - centre[0]).hypot(p[1] - centre[1]) <= radius {
                    let i = self.index([x, y]);
                    self.free[i] = self.free[i].max(self.occupied[i] + 1);
                    self.slices[i] = u32::MAX;
                }
            }
        }
    }

    /// Recounts the Gaussian means per cell (those within the height band).
    pub fn set_gaussians(&mut self, means: &[[f32; 3]]) {
        self.gaussians.fill(0);
        if self.size[0] == 0 {
            return;
        }
        let (lo, hi) = (
            self.config.min_height,
            self.config.max_height.min(self.config.free_height),
        );
        for m in means {
            let z = f64::from(m[2]);
            if z < lo || z > hi {
                continue;
            }
            let l = self.lattice([f64::from(m[0]), f64::from(m[1])]);
            let (x, y) = (l[0] - self.origin[0], l[1] - self.origin[1]);
            if x >= 0 && y >= 0 && (x as usize) < self.size[0] && (y as usize) < self.size[1] {
                let i = self.index(l);
                self.gaussians[i] += 1;
            }
        }
    }

    fn all_slices_seen(&self, i: usize) -> bool {
        self.slicing
            .as_ref()
            .is_none_or(|s| self.slices[i] & s.full() == s.full())
    }

    fn class_at(&self, i: usize) -> CellClass {
        let (f, o, g) = (self.free[i], self.occupied[i], self.gaussians[i]);
        if g > self.config.gaussians_occupied {
            return CellClass::Occupied;
        }
        if f == 0 && o == 0 {
            return CellClass::Unknown;
        }
        if o >= f {
            CellClass::Occupied
        } else if g > self.config.gaussians_unfree {
            self.config.filled_class
        } else if !self.all_slices_seen(i) {
            CellClass::Unknown
        } else {
            CellClass::Free
        }
    }

    /// The class of the cell holding a world point (unknown outside the grid).
    pub fn class(&self, p: [f64; 2]) -> CellClass {
        let l = self.lattice(p);
        let (x, y) = (l[0] - self.origin[0], l[1] - self.origin[1]);
        if x < 0 || y < 0 || x as usize >= self.size[0] || y as usize >= self.size[1] {
            return CellClass::Unknown;
        }
        self.class_at(self.index(l))
    }

    /// Every cell's class.
    pub fn classes(&self) -> ClassGrid {
        let cell = self.config.cell;
        ClassGrid {
            size: self.size,
            origin: [self.origin[0] as f64 * cell, self.origin[1] as f64 * cell],
            cell,
            classes: (0..self.free.len()).map(|i| self.class_at(i)).collect(),
        }
    }
}

/// Equal height slices of the free band.
#[derive(Debug, Clone)]
struct Slicing {
    low: f64,
    height: f64,
    count: u32,
}

impl Slicing {
    /// The slices a config asks for, when it asks for any.
    fn of(c: &EvidenceConfig) -> Option<Self> {
        (c.height_slices > 0).then(|| {
            let low = c.free_from_height.max(c.min_height);
            Slicing {
                low,
                height: (c.slices_top - low) / f64::from(c.height_slices),
                count: c.height_slices.min(32),
            }
        })
    }

    /// Every slice's bit.
    fn full(&self) -> u32 {
        if self.count >= 32 {
            u32::MAX
        } else {
            (1u32 << self.count) - 1
        }
    }

    /// The bits of the slices the heights between `a` and `b` overlap.
    fn mask(&self, a: f64, b: f64) -> u32 {
        let (lo, hi) = (a.min(b), a.max(b));
        let top = self.low + self.height * f64::from(self.count);
        if hi < self.low || lo > top || self.height <= 0.0 {
            return 0;
        }
        let slice =
            |z: f64| (((z - self.low) / self.height).floor().max(0.0) as u32).min(self.count - 1);
        let (first, last) = (slice(lo), slice(hi));
        (first..=last).fold(0, |m, k| m | (1 << k))
    }
}

/// The part of the segment `origin + t (end - origin)`, t in [0, 1], whose plan position
/// lies in lattice cell `l` (cells of side `cell`); empty when `to < from`.
fn cell_interval(l: [i64; 2], cell: f64, origin: Point3, end: Point3) -> (f64, f64) {
    let (o, d) = ([origin.x, origin.y], [end.x - origin.x, end.y - origin.y]);
    let (mut from, mut to) = (0.0f64, 1.0f64);
    for k in 0..2 {
        let (lo, hi) = (l[k] as f64 * cell, (l[k] + 1) as f64 * cell);
        if d[k] == 0.0 {
            if o[k] < lo || o[k] > hi {
                return (1.0, 0.0);
            }
        } else {
            let (a, b) = ((lo - o[k]) / d[k], (hi - o[k]) / d[k]);
            from = from.max(a.min(b));
            to = to.min(a.max(b));
        }
    }
    (from, to)
}

/// The part `[from, to]` of `[0, t_end]` where the height `z0 + t dz` lies within `[low, high]`
/// (an empty interval has `to <= from`).
fn band_interval(z0: f64, dz: f64, low: f64, high: f64, t_end: f64) -> (f64, f64) {
    if dz == 0.0 {
        return if (low..=high).contains(&z0) {
            (0.0, t_end)
        } else {
            (t_end, t_end)
        };
    }
    let (a, b) = ((low - z0) / dz, (high - z0) / dz);
    let (lo, hi) = if a < b { (a, b) } else { (b, a) };
    (lo.max(0.0), hi.min(t_end))
}

/// The 8-connected line of lattice cells from `a` to `b`, both included (Bresenham's: one cell
/// per step along the major axis, the minor axis stepping where the line's error passes half a
/// cell), as OpenCV's `cv2.line` draws it with thickness 1.
fn bresenham(a: [i64; 2], b: [i64; 2], mut visit: impl FnMut([i64; 2])) {
    let (dx, dy) = ((b[0] - a[0]).abs(), -(b[1] - a[1]).abs());
    let (sx, sy) = ((b[0] - a[0]).signum(), (b[1] - a[1]).signum());
    let mut error = dx + dy;
    let mut l = a;
    loop {
        visit(l);
        if l == b {
            break;
        }
        let twice = 2 * error;
        if twice >= dy {
            error += dy;
            l[0] += sx;
        }
        if twice <= dx {
            error += dx;
            l[1] += sy;
        }
    }
}

/// The lattice cells a 2D segment crosses, in order (Amanatides and Woo's traversal).
fn traverse(a: [f64; 2], b: [f64; 2], cell: f64, out: &mut Vec<[i64; 2]>) {
    let mut l = [(a[0] / cell).floor() as i64, (a[1] / cell).floor() as i64];
    let last = [(b[0] / cell).floor() as i64, (b[1] / cell).floor() as i64];
    let d = [b[0] - a[0], b[1] - a[1]];
    let mut step = [0i64; 2];
    let mut t_max = [f64::INFINITY; 2];
    let mut t_delta = [f64::INFINITY; 2];
    for k in 0..2 {
        if d[k] > 0.0 {
            step[k] = 1;
            t_max[k] = ((l[k] + 1) as f64 * cell - a[k]) / d[k];
            t_delta[k] = cell / d[k];
        } else if d[k] < 0.0 {
            step[k] = -1;
            t_max[k] = (l[k] as f64 * cell - a[k]) / d[k];
            t_delta[k] = -cell / d[k];
        }
    }
    out.push(l);
    let limit = (last[0] - l[0]).abs() + (last[1] - l[1]).abs();
    for _ in 0..limit {
        if l == last {
            break;
        }
        let k = usize::from(t_max[1] < t_max[0]);
        l[k] += step[k];
        t_max[k] += t_delta[k];
        out.push(l);
    }
}

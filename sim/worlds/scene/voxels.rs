//! Colliders for an imported scene: its triangles voxelised into cubes (a voxel is solid when
//! a triangle crosses it: the separating-axis test of Akenine-Möller), then merged greedily
//! into as few boxes as cover exactly the solid voxels. MuJoCo collides a mesh as its convex
//! hull, which for a room is the whole room; boxes follow walls, doors and furniture.

/// A solid voxel grid over a box of the world.
#[derive(Debug, Clone)]
pub struct Voxels {
    /// World position of voxel (0, 0, 0)'s lower corner.
    pub origin: [f64; 3],
    /// Voxel side, metres.
    pub size: f64,
    /// Voxels along x, y and z.
    pub dims: [usize; 3],
    solid: Vec<bool>,
}

/// An axis-aligned box: centre and half sizes, metres.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cuboid {
    /// Centre.
    pub centre: [f64; 3],
    /// Half sizes.
    pub half: [f64; 3],
}

impl Voxels {
    /// An empty grid of `dims` voxels of side `size` from `origin`.
    pub fn new(origin: [f64; 3], size: f64, dims: [usize; 3]) -> Self {
        Voxels {
            origin,
            size,
            dims,
            solid: vec![false; dims[0] * dims[1] * dims[2]],
        }
    }

    fn index(&self, i: usize, j: usize, k: usize) -> usize {
        (k * self.dims[1] + j) * self.dims[0] + i
    }

    /// Whether voxel (i, j, k) is solid.
    pub fn is_solid(&self, i: usize, j: usize, k: usize) -> bool {
        self.solid[self.index(i, j, k)]
    }

    /// Solid voxels.
    pub fn count(&self) -> usize {
        self.solid.iter().filter(|s| **s).count()
    }

    /// Marks every voxel the triangle crosses.
    pub fn add_triangle(&mut self, t: [[f64; 3]; 3]) {
        let mut range = [(0usize, 0usize); 3];
        for a in 0..3 {
            let lo = t.iter().map(|p| p[a]).fold(f64::INFINITY, f64::min);
            let hi = t.iter().map(|p| p[a]).fold(f64::NEG_INFINITY, f64::max);
            let first = ((lo - self.origin[a]) / self.size).floor();
            let last = ((hi - self.origin[a]) / self.size).floor();
            if last < 0.0 || first >= self.dims[a] as f64 {
                return;
            }
            range[a] = (
                first.max(0.0) as usize,
                (last as usize).min(self.dims[a] - 1),
            );
        }
        let h = 0.5 * self.size;
        for k in range[2].0..=range[2].1 {
            for j in range[1].0..=range[1].1 {
                for i in range[0].0..=range[0].1 {
                    let centre = [
                        self.origin[0] + (i as f64 + 0.5) * self.size,
                        self.origin[1] + (j as f64 + 0.5) * self.size,
                        self.origin[2] + (k as f64 + 0.5) * self.size,
                    ];
                    if triangle_crosses_box(&t, centre, h) {
                        let at = self.index(i, j, k);
                        self.solid[at] = true;
                    }
                }
            }
        }
    }

    /// Fills, layer by layer, the empty space that solid voxels enclose (4-connected) when it
    /// is smaller than `max_area` m2: the hollow insides of closed objects, which a surface
    /// voxelisation leaves empty. A room with a door is never enclosed; a sealed room larger
    /// than `max_area` stays empty, so `world check` still reports it.
    pub fn fill_enclosed(&mut self, max_area: f64) {
        let [nx, ny, nz] = self.dims;
        let max_cells = (max_area / (self.size * self.size)).floor() as usize;
        let mut label = vec![0u32; nx * ny];
        for k in 0..nz {
            label.fill(0);
            let mut next = 1u32;
            let mut fills: Vec<Vec<usize>> = Vec::new();
            for start in 0..nx * ny {
                if label[start] != 0 || self.solid[self.index(start % nx, start / nx, k)] {
                    continue;
                }
                // One empty region of the layer, and whether it reaches the grid's edge.
                let mut cells = vec![start];
                label[start] = next;
                let mut open = false;
                let mut at = 0;
                while at < cells.len() {
                    let c = cells[at];
                    at += 1;
                    let (i, j) = (c % nx, c / nx);
                    open |= i == 0 || j == 0 || i + 1 == nx || j + 1 == ny;
                    let mut visit = |n: usize| {
                        if label[n] == 0 && !self.solid[self.index(n % nx, n / nx, k)] {
                            label[n] = next;
                            cells.push(n);
                        }
                    };
                    if i > 0 {
                        visit(c - 1);
                    }
                    if i + 1 < nx {
                        visit(c + 1);
                    }
                    if j > 0 {
                        visit(c - nx);
                    }
                    if j + 1 < ny {
                        visit(c + nx);
                    }
                }
                next += 1;
                if !open && cells.len() <= max_cells {
                    fills.push(cells);
                }
            }
            for c in fills.into_iter().flatten() {
                let at = self.index(c % nx, c / nx, k);
                self.solid[at] = true;
            }
        }
    }

    /// Boxes that cover exactly the solid voxels: runs along x, grown along y, then along z.
    pub fn merge(&self) -> Vec<Cuboid> {
        let [nx, ny, nz] = self.dims;
        let mut used = vec![false; self.solid.len()];
        let free = |used: &[bool], i: usize, j: usize, k: usize| {
            let at = self.index(i, j, k);
            self.solid[at] && !used[at]
        };
        let mut boxes = Vec::new();
        for k in 0..nz {
            for j in 0..ny {
                for i in 0..nx {
                    if !free(&used, i, j, k) {
                        continue;
                    }
                    let mut i1 = i + 1;
                    while i1 < nx && free(&used, i1, j, k) {
                        i1 += 1;
                    }
                    let mut j1 = j + 1;
                    while j1 < ny && (i..i1).all(|x| free(&used, x, j1, k)) {
                        j1 += 1;
                    }
                    let mut k1 = k + 1;
                    while k1 < nz && (j..j1).all(|y| (i..i1).all(|x| free(&used, x, y, k1))) {
                        k1 += 1;
                    }
                    for z in k..k1 {
                        for y in j..j1 {
                            for x in i..i1 {
                                let at = self.index(x, y, z);
                                used[at] = true;
                            }
                        }
                    }
                    let s = self.size;
                    let lo = [i, j, k].map(|v| v as f64 * s);
                    let hi = [i1, j1, k1].map(|v| v as f64 * s);
                    boxes.push(Cuboid {
                        centre: [0, 1, 2].map(|a| self.origin[a] + 0.5 * (lo[a] + hi[a])),
                        half: [0, 1, 2].map(|a| 0.5 * (hi[a] - lo[a])),
                    });
                }
            }
        }
        boxes
    }
}

/// Whether a triangle crosses the cube of half side `h` at `centre` (13 separating axes).
pub fn triangle_crosses_box(t: &[[f64; 3]; 3], centre: [f64; 3], h: f64) -> bool {
    let v: [[f64; 3]; 3] = t.map(|p| [p[0] - centre[0], p[1] - centre[1], p[2] - centre[2]]);
    let sub = |a: [f64; 3], b: [f64; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    let cross = |a: [f64; 3], b: [f64; 3]| {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    };
    let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let separated = |axis: [f64; 3]| {
        let p = v.map(|q| dot(q, axis));
        let r = h * (axis[0].abs() + axis[1].abs() + axis[2].abs());
        let lo = p[0].min(p[1]).min(p[2]);
        let hi = p[0].max(p[1]).max(p[2]);
        lo > r || hi < -r
    };
    let edges = [sub(v[1], v[0]), sub(v[2], v[1]), sub(v[0], v[2])];
    for e in edges {
        for a in 0..3 {
            let mut unit = [0.0; 3];
            unit[a] = 1.0;
            let axis = cross(unit, e);
            if axis.iter().any(|c| c.abs() > 1e-15) && separated(axis) {
                return false;
            }
        }
    }
    for a in 0..3 {
        let lo = v[0][a].min(v[1][a]).min(v[2][a]);
        let hi = v[0][a].max(v[1][a]).max(v[2][a]);
        if lo > h || hi < -h {
            return false;
        }
    }
    let normal = cross(edges[0], edges[1]);
    !(normal.iter().any(|c| c.abs() > 1e-15) && separated(normal))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn triangle_box_test_agrees_with_dense_sampling() {
        // Triangles near a unit cube: the exact test against points sampled on the triangle.
        let mut seed = 12345u64;
        let mut next = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((seed >> 11) as f64 / (1u64 << 53) as f64) * 3.0 - 1.5
        };
        let mut sampled_hits = 0;
        for _ in 0..400 {
            let t = [
                [next(), next(), next()],
                [next(), next(), next()],
                [next(), next(), next()],
            ];
            let mut sampled = false;
            let n = 120;
            for a in 0..=n {
                for b in 0..=(n - a) {
                    let (u, w) = (a as f64 / n as f64, b as f64 / n as f64);
                    let p: Vec<f64> = (0..3)
                        .map(|k| t[0][k] + u * (t[1][k] - t[0][k]) + w * (t[2][k] - t[0][k]))
                        .collect();
                    if p.iter().all(|c| c.abs() <= 0.5) {
                        sampled = true;
                    }
                }
            }
            let exact = triangle_crosses_box(&t, [0.0; 3], 0.5);
            // Sampling can only miss a crossing, never invent one.
            assert!(exact || !sampled, "{t:?}");
            sampled_hits += usize::from(sampled);
        }
        assert!(sampled_hits > 50);
    }

    #[test]
    fn merged_boxes_cover_exactly_the_solid_voxels() {
        let mut grid = Voxels::new([0.0; 3], 1.0, [6, 5, 4]);
        for (i, j, k) in [
            (0, 0, 0),
            (1, 0, 0),
            (2, 0, 0),
            (0, 1, 0),
            (1, 1, 0),
            (2, 1, 0),
            (4, 4, 3),
            (5, 2, 1),
            (5, 2, 2),
        ] {
            let at = grid.index(i, j, k);
            grid.solid[at] = true;
        }
        let boxes = grid.merge();
        let covered = |i: usize, j: usize, k: usize| {
            let c = [i as f64 + 0.5, j as f64 + 0.5, k as f64 + 0.5];
            boxes
                .iter()
                .filter(|b| (0..3).all(|a| (c[a] - b.centre[a]).abs() < b.half[a]))
                .count()
        };
        for k in 0..4 {
            for j in 0..5 {
                for i in 0..6 {
                    assert_eq!(
                        covered(i, j, k),
                        usize::from(grid.is_solid(i, j, k)),
                        "({i}, {j}, {k})"
                    );
                }
            }
        }
        assert_eq!(boxes.len(), 3);
    }

    #[test]
    fn enclosed_insides_are_filled_and_open_rooms_are_not() {
        // One layer: a closed 3x3 ring (inside 1 cell) and an open ring (a gap in its wall).
        let mut grid = Voxels::new([0.0; 3], 1.0, [12, 6, 1]);
        let ring = |grid: &mut Voxels, x0: usize, gap: bool| {
            for i in x0..x0 + 3 {
                for j in 1..4 {
                    let wall = i == x0 || i == x0 + 2 || j == 1 || j == 3;
                    let door = gap && i == x0 + 1 && j == 1;
                    if wall && !door {
                        let at = grid.index(i, j, 0);
                        grid.solid[at] = true;
                    }
                }
            }
        };
        ring(&mut grid, 1, false);
        ring(&mut grid, 6, true);
        let before = grid.count();
        grid.fill_enclosed(4.0);
        assert!(grid.is_solid(2, 2, 0), "the closed ring's inside is filled");
        assert!(
            !grid.is_solid(7, 2, 0),
            "the open ring's inside stays empty"
        );
        assert_eq!(grid.count(), before + 1);
        // Above the area limit an enclosed space stays empty.
        let mut big = Voxels::new([0.0; 3], 1.0, [12, 6, 1]);
        ring(&mut big, 1, false);
        big.fill_enclosed(0.5);
        assert!(!big.is_solid(2, 2, 0));
    }
}

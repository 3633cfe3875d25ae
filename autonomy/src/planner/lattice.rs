//! A dense index over a cubic lattice anchored at the world origin, for the planner's
//! per-cell stores (the collision grid, the counting grid). It grows as the map grows, with
//! room to spare so growth is rare; cell keys never change, so growing only re-lays the
//! index. Cells beyond a size limit (far outliers) share one overflow cell that callers
//! always visit.

/// Index entries the dense index may hold (64 MiB of u32).
const MAX_DENSE_CELLS: usize = 1 << 24;
/// An index entry with no cell.
const NO_CELL: u32 = u32::MAX;
/// The id of the overflow cell.
pub const OVERFLOW: u32 = u32::MAX - 1;

/// Cells of type `T` on a lattice of side `cell` metres.
#[derive(Debug, Clone)]
pub struct Lattice<T> {
    cell: f32,
    /// Lattice key of the index's first entry, and the index's extent in cells.
    lo: [i32; 3],
    dims: [usize; 3],
    index: Vec<u32>,
    cells: Vec<T>,
    overflow: T,
}

impl<T: Default> Lattice<T> {
    /// An empty lattice of cells of side `cell` metres.
    pub fn new(cell: f32) -> Self {
        Lattice {
            cell,
            lo: [0; 3],
            dims: [0; 3],
            index: Vec::new(),
            cells: Vec::new(),
            overflow: T::default(),
        }
    }

    /// Side of a cell, metres.
    pub fn cell_size(&self) -> f32 {
        self.cell
    }

    /// The key of the cell holding `p`.
    pub fn key(&self, p: [f32; 3]) -> [i32; 3] {
        p.map(|v| (v / self.cell).floor() as i32)
    }

    fn dense(&self, key: [i32; 3]) -> Option<usize> {
        let mut i = 0;
        for a in (0..3).rev() {
            let k = i64::from(key[a]) - i64::from(self.lo[a]);
            if k < 0 || k >= self.dims[a] as i64 {
                return None;
            }
            i = i * self.dims[a] + k as usize;
        }
        Some(i)
    }

    /// The id of the cell with `key`, if it exists.
    #[inline]
    pub fn find(&self, key: [i32; 3]) -> Option<u32> {
        self.dense(key)
            .map(|i| self.index[i])
            .filter(|c| *c != NO_CELL)
    }

    /// Widens the index to hold keys [lo, hi] (with room to grow); false when that would
    /// pass the size limit.
    pub fn cover(&mut self, lo: [i32; 3], hi: [i32; 3]) -> bool {
        let empty = self.dims.contains(&0);
        let end = |a: usize| i64::from(self.lo[a]) + self.dims[a] as i64;
        if !empty && (0..3).all(|a| lo[a] >= self.lo[a] && i64::from(hi[a]) < end(a)) {
            return true;
        }
        let (mut new_lo, mut new_hi) = (lo.map(i64::from), hi.map(i64::from));
        if !empty {
            for a in 0..3 {
                let margin = (self.dims[a] as i64 / 4).max(4);
                let old_hi = end(a) - 1;
                new_lo[a] = if new_lo[a] < i64::from(self.lo[a]) {
                    new_lo[a] - margin
                } else {
                    i64::from(self.lo[a])
                };
                new_hi[a] = if new_hi[a] > old_hi {
                    new_hi[a] + margin
                } else {
                    old_hi
                };
            }
        }
        let dims = [0, 1, 2].map(|a| (new_hi[a] - new_lo[a] + 1) as usize);
        let total = dims.iter().try_fold(1usize, |p, d| p.checked_mul(*d));
        if total.is_none_or(|n| n > MAX_DENSE_CELLS)
            || new_lo.iter().any(|v| *v < i64::from(i32::MIN))
        {
            return false;
        }
        let new_lo = new_lo.map(|v| v as i32);
        let mut index = vec![NO_CELL; dims[0] * dims[1] * dims[2]];
        for z in 0..self.dims[2] {
            for y in 0..self.dims[1] {
                for x in 0..self.dims[0] {
                    let c = self.index[(z * self.dims[1] + y) * self.dims[0] + x];
                    if c != NO_CELL {
                        let n = [x, y, z].map(|v| v as i64);
                        let n = [0, 1, 2].map(|a| {
                            (n[a] + i64::from(self.lo[a]) - i64::from(new_lo[a])) as usize
                        });
                        index[(n[2] * dims[1] + n[1]) * dims[0] + n[0]] = c;
                    }
                }
            }
        }
        self.index = index;
        self.lo = new_lo;
        self.dims = dims;
        true
    }

    /// Widens the index once for all of `points` (cheaper than cell by cell).
    pub fn cover_points<'a>(&mut self, points: impl Iterator<Item = &'a [f32; 3]>) {
        let (mut lo, mut hi) = ([i32::MAX; 3], [i32::MIN; 3]);
        for p in points {
            let k = self.key(*p);
            for a in 0..3 {
                lo[a] = lo[a].min(k[a]);
                hi[a] = hi[a].max(k[a]);
            }
        }
        if lo[0] <= hi[0] {
            self.cover(lo, hi);
        }
    }

    /// The id of the cell holding `p`, created if need be; [`OVERFLOW`] beyond the limit.
    pub fn cell_for(&mut self, p: [f32; 3]) -> u32 {
        let key = self.key(p);
        if self.dense(key).is_none() && !self.cover(key, key) {
            return OVERFLOW;
        }
        let Some(d) = self.dense(key) else {
            return OVERFLOW;
        };
        if self.index[d] == NO_CELL {
            self.index[d] = self.cells.len() as u32;
            self.cells.push(T::default());
        }
        self.index[d]
    }

    /// The cell with id `c` ([`OVERFLOW`] included).
    #[inline]
    pub fn get(&self, c: u32) -> &T {
        if c == OVERFLOW {
            &self.overflow
        } else {
            &self.cells[c as usize]
        }
    }

    /// The cell with id `c` ([`OVERFLOW`] included), to change.
    pub fn get_mut(&mut self, c: u32) -> &mut T {
        if c == OVERFLOW {
            &mut self.overflow
        } else {
            &mut self.cells[c as usize]
        }
    }

    /// The cells, by id (the overflow cell not among them).
    pub fn cells(&self) -> &[T] {
        &self.cells
    }

    /// The overflow cell, which every query visits.
    pub fn overflow(&self) -> &T {
        &self.overflow
    }

    /// Every cell, the overflow cell last.
    pub fn iter(&self) -> impl Iterator<Item = &T> {
        self.cells.iter().chain(std::iter::once(&self.overflow))
    }

    /// Every cell, the overflow cell last, to change.
    pub fn iter_mut(&mut self) -> impl Iterator<Item = &mut T> {
        self.cells
            .iter_mut()
            .chain(std::iter::once(&mut self.overflow))
    }

    /// The range of keys along axis `a` that the index holds and that [lo, hi] (metres)
    /// overlaps, or None.
    pub fn span(&self, a: usize, lo: f32, hi: f32) -> Option<(i32, i32)> {
        if self.dims[a] == 0 {
            return None;
        }
        let l = (lo / self.cell).floor().max(self.lo[a] as f32);
        let h = (hi / self.cell)
            .floor()
            .min((i64::from(self.lo[a]) + self.dims[a] as i64 - 1) as f32);
        (l <= h).then_some((l as i32, h as i32))
    }
}

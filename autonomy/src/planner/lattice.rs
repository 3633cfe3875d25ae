//! Points filed by slot in the cells of a cubic lattice anchored at the world origin: the
//! store under the planner's collision grid (points are obstacle means, values radii) and
//! counting grid (values are uncertainties). A dense index finds a cell; it grows as the map
//! grows, with room to spare so growth is rare, and since cell keys never change, growing
//! only re-lays the index. Cells beyond a size limit (far outliers) share one overflow cell
//! that callers always visit. Each slot knows its cell and position, so a point leaves in
//! O(1) (swap-remove).

/// Index entries the dense index may hold (64 MiB of u32).
const MAX_DENSE_CELLS: usize = 1 << 24;
/// An index entry with no cell.
const NO_CELL: u32 = u32::MAX;
/// The id of the overflow cell.
pub const OVERFLOW: u32 = u32::MAX - 1;

/// The points of one cell, structure of arrays (so tests over them vectorise), unordered.
#[derive(Debug, Clone, Default)]
pub struct CellPoints {
    /// x of each point, metres.
    pub x: Vec<f32>,
    /// y of each point, metres.
    pub y: Vec<f32>,
    /// z of each point, metres.
    pub z: Vec<f32>,
    /// The value each point carries.
    pub value: Vec<f32>,
    /// The slot of each point.
    pub slots: Vec<u32>,
}

impl CellPoints {
    /// Points in the cell.
    pub fn len(&self) -> usize {
        self.slots.len()
    }

    /// Whether the cell has none.
    pub fn is_empty(&self) -> bool {
        self.slots.is_empty()
    }

    /// Point `k`.
    pub fn point(&self, k: usize) -> [f32; 3] {
        [self.x[k], self.y[k], self.z[k]]
    }

    fn push(&mut self, slot: u32, p: [f32; 3], value: f32) -> u32 {
        self.x.push(p[0]);
        self.y.push(p[1]);
        self.z.push(p[2]);
        self.value.push(value);
        self.slots.push(slot);
        (self.slots.len() - 1) as u32
    }

    /// Removes point `k`; returns the slot moved into its place, if any.
    fn swap_remove(&mut self, k: usize) -> Option<u32> {
        self.x.swap_remove(k);
        self.y.swap_remove(k);
        self.z.swap_remove(k);
        self.value.swap_remove(k);
        self.slots.swap_remove(k);
        self.slots.get(k).copied()
    }
}

/// `located` of a slot with no point.
const NOWHERE: (u32, u32) = (u32::MAX, 0);

/// Points by slot in cells of side `cell` metres.
#[derive(Debug, Clone)]
pub struct PointLattice {
    cell: f32,
    /// Lattice key of the index's first entry, and the index's extent in cells.
    lo: [i32; 3],
    dims: [usize; 3],
    index: Vec<u32>,
    cells: Vec<CellPoints>,
    overflow: CellPoints,
    /// Per slot: the cell and the position in it ([`NOWHERE`] when not filed).
    located: Vec<(u32, u32)>,
    count: usize,
}

impl PointLattice {
    /// An empty lattice of cells of side `cell` metres.
    pub fn new(cell: f32) -> Self {
        PointLattice {
            cell,
            lo: [0; 3],
            dims: [0; 3],
            index: Vec::new(),
            cells: Vec::new(),
            overflow: CellPoints::default(),
            located: Vec::new(),
            count: 0,
        }
    }

    /// Points filed.
    pub fn len(&self) -> usize {
        self.count
    }

    /// Whether none are filed.
    pub fn is_empty(&self) -> bool {
        self.count == 0
    }

    /// One past the largest slot ever filed.
    pub fn slot_end(&self) -> usize {
        self.located.len()
    }

    /// Files `slot` at `p` with `value`, in the overflow cell when `overflow` says so or `p`
    /// is beyond the index's limit; returns the cell's id. The slot must not be filed.
    pub fn insert(&mut self, slot: u32, p: [f32; 3], value: f32, overflow: bool) -> u32 {
        let c = if overflow { OVERFLOW } else { self.cell_for(p) };
        let k = self.get_mut(c).push(slot, p, value);
        let s = slot as usize;
        if s >= self.located.len() {
            self.located.resize(s + 1, NOWHERE);
        }
        self.located[s] = (c, k);
        self.count += 1;
        c
    }

    /// Takes `slot` out; returns its cell's id and its value, or None when it was not filed.
    pub fn remove(&mut self, slot: u32) -> Option<(u32, f32)> {
        let s = slot as usize;
        let &(c, k) = self.located.get(s).filter(|l| **l != NOWHERE)?;
        self.located[s] = NOWHERE;
        let cell = self.get_mut(c);
        let value = cell.value[k as usize];
        if let Some(moved) = cell.swap_remove(k as usize) {
            self.located[moved as usize].1 = k;
        }
        self.count -= 1;
        Some((c, value))
    }

    /// Where `slot` is filed: (point, value).
    pub fn filed(&self, slot: u32) -> Option<([f32; 3], f32)> {
        let &(c, k) = self.located.get(slot as usize).filter(|l| **l != NOWHERE)?;
        let (cell, k) = (self.get(c), k as usize);
        Some((cell.point(k), cell.value[k]))
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
    fn cell_for(&mut self, p: [f32; 3]) -> u32 {
        let key = self.key(p);
        if self.dense(key).is_none() && !self.cover(key, key) {
            return OVERFLOW;
        }
        let Some(d) = self.dense(key) else {
            return OVERFLOW;
        };
        if self.index[d] == NO_CELL {
            self.index[d] = self.cells.len() as u32;
            self.cells.push(CellPoints::default());
        }
        self.index[d]
    }

    /// The cell with id `c` ([`OVERFLOW`] included).
    #[inline]
    pub fn get(&self, c: u32) -> &CellPoints {
        if c == OVERFLOW {
            &self.overflow
        } else {
            &self.cells[c as usize]
        }
    }

    fn get_mut(&mut self, c: u32) -> &mut CellPoints {
        if c == OVERFLOW {
            &mut self.overflow
        } else {
            &mut self.cells[c as usize]
        }
    }

    /// The cells, by id (the overflow cell not among them).
    pub fn cells(&self) -> &[CellPoints] {
        &self.cells
    }

    /// The overflow cell, which every query visits.
    pub fn overflow(&self) -> &CellPoints {
        &self.overflow
    }

    /// Every cell, the overflow cell last.
    pub fn iter(&self) -> impl Iterator<Item = &CellPoints> {
        self.cells.iter().chain(std::iter::once(&self.overflow))
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

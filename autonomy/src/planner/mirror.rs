//! The planner's copy of the map as it last read it, and the list of what changed since.
//!
//! A plan over millions of Gaussians cannot refile them all (issue 5: 62 ms at 3e6). The
//! mirror compares the map with its copy in one sequential pass (the map's stable ids line
//! the two up after a prune) and hands the collision grid, the tallies and the counting grid
//! only the Gaussians that appeared, moved, resized, changed uncertainty or went. Each keeps
//! a stable slot, so a prune that renumbers the map renumbers nothing downstream. The
//! comparison covers every value the planner reads, so the planner stays exact however the
//! map was changed; the ids only make it cheap.

use crate::map::{ClassifyOptions, GaussianMap};

/// What the planner reads of one Gaussian.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Record {
    /// Mean, metres.
    pub mean: [f32; 3],
    /// Radius, metres.
    pub radius: f32,
    /// Uncertainty, metres.
    pub uncertainty: f32,
}

/// One Gaussian that appeared, changed or went since the last sync. A record is `None` when
/// the Gaussian did not exist or planning leaves it out (the ground plane).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Change {
    /// The Gaussian's slot: stable for its life, reused after it goes.
    pub slot: u32,
    /// What the consumers filed for it.
    pub old: Option<Record>,
    /// What they should file now.
    pub new: Option<Record>,
}

/// The map as last synced, aligned with the map's order, plus each Gaussian's slot.
#[derive(Debug, Clone, Default)]
pub struct MapMirror {
    ids: Vec<u64>,
    slots: Vec<u32>,
    means: Vec<[f32; 3]>,
    log_radii: Vec<f32>,
    uncertainty: Vec<f32>,
    free: Vec<u32>,
    slot_count: u32,
}

fn bits(m: [f32; 3]) -> [u32; 3] {
    m.map(f32::to_bits)
}

fn record(options: &ClassifyOptions, mean: [f32; 3], log_radius: f32, u: f32) -> Option<Record> {
    options.includes(&mean).then(|| Record {
        mean,
        radius: log_radius.exp(),
        uncertainty: u,
    })
}

impl MapMirror {
    /// An empty mirror: the first sync reports every Gaussian as new.
    pub fn new() -> Self {
        MapMirror::default()
    }

    /// Gaussians mirrored.
    pub fn len(&self) -> usize {
        self.ids.len()
    }

    /// Whether nothing is mirrored.
    pub fn is_empty(&self) -> bool {
        self.ids.is_empty()
    }

    /// One past the largest slot handed out: consumers size per-slot arrays by it.
    pub fn slot_count(&self) -> u32 {
        self.slot_count
    }

    fn take_slot(&mut self) -> u32 {
        self.free.pop().unwrap_or_else(|| {
            self.slot_count += 1;
            self.slot_count - 1
        })
    }

    /// Brings the mirror up to `map` and writes into `changes` (cleared first) every
    /// Gaussian whose planning record changed, with `options` deciding which are left out.
    pub fn sync(
        &mut self,
        map: &GaussianMap,
        options: &ClassifyOptions,
        changes: &mut Vec<Change>,
    ) {
        changes.clear();
        let g = &map.gaussians;
        let n = g.len().min(map.uncertainty.len());
        // Ids line the copy up with the map; a map whose ids lag its Gaussians (pushed, not
        // adopted) is lined up by position instead, which is as exact and only slower.
        let positional: Vec<u64>;
        let ids: &[u64] = if map.ids().len() >= n {
            &map.ids()[..n]
        } else {
            positional = (0..n as u64).collect();
            &positional
        };
        let old_n = self.ids.len();
        let prefix = n >= old_n && (old_n == 0 || ids[old_n - 1] == self.ids[old_n - 1]);
        if !prefix {
            self.realign(ids, options, changes);
        }
        // Compare what is lined up.
        let common = self.ids.len();
        for i in 0..common {
            let (m, r, u) = (g.means[i], g.log_radii[i], map.uncertainty[i]);
            if bits(m) == bits(self.means[i])
                && r.to_bits() == self.log_radii[i].to_bits()
                && u.to_bits() == self.uncertainty[i].to_bits()
            {
                continue;
            }
            let old = record(
                options,
                self.means[i],
                self.log_radii[i],
                self.uncertainty[i],
            );
            let new = record(options, m, r, u);
            self.means[i] = m;
            self.log_radii[i] = r;
            self.uncertainty[i] = u;
            if old != new {
                changes.push(Change {
                    slot: self.slots[i],
                    old,
                    new,
                });
            }
        }
        // Append the rest.
        for i in common..n {
            let slot = self.take_slot();
            let (m, r, u) = (g.means[i], g.log_radii[i], map.uncertainty[i]);
            self.ids.push(ids[i]);
            self.slots.push(slot);
            self.means.push(m);
            self.log_radii.push(r);
            self.uncertainty.push(u);
            if let Some(new) = record(options, m, r, u) {
                changes.push(Change {
                    slot,
                    old: None,
                    new: Some(new),
                });
            }
        }
    }

    /// Lines the copy up with `ids` (both strictly increasing): Gaussians whose id went are
    /// reported gone and free their slots; survivors keep theirs. Ids past the survivors are
    /// left for `sync` to append.
    fn realign(&mut self, ids: &[u64], options: &ClassifyOptions, changes: &mut Vec<Change>) {
        let old_ids = std::mem::take(&mut self.ids);
        let old_slots = std::mem::take(&mut self.slots);
        let old_means = std::mem::take(&mut self.means);
        let old_log_radii = std::mem::take(&mut self.log_radii);
        let old_uncertainty = std::mem::take(&mut self.uncertainty);
        let mut i = 0;
        let gone = |i: usize, this: &mut Self, changes: &mut Vec<Change>| {
            this.free.push(old_slots[i]);
            if let Some(old) = record(options, old_means[i], old_log_radii[i], old_uncertainty[i]) {
                changes.push(Change {
                    slot: old_slots[i],
                    old: Some(old),
                    new: None,
                });
            }
        };
        for &id in ids {
            while i < old_ids.len() && old_ids[i] < id {
                gone(i, self, changes);
                i += 1;
            }
            if i < old_ids.len() && old_ids[i] == id {
                self.ids.push(id);
                self.slots.push(old_slots[i]);
                self.means.push(old_means[i]);
                self.log_radii.push(old_log_radii[i]);
                self.uncertainty.push(old_uncertainty[i]);
                i += 1;
            } else {
                // An id the copy never had. Ids are handed out in increasing order, so every
                // later one is new too: `sync` appends them.
                break;
            }
        }
        while i < old_ids.len() {
            gone(i, self, changes);
            i += 1;
        }
        // Hand slots out lowest first again, so equal histories give equal slots.
        self.free.sort_unstable_by(|a, b| b.cmp(a));
    }
}

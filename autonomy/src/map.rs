//! The Gaussian map the planner reads: the Gaussians and each one's uncertainty, with the
//! high / low / other split of RT-GuIDE (half a standard deviation either side of the mean).

use crate::gaussians::Gaussians;

/// Gaussians and their per-Gaussian uncertainty |mu_k - mu_(k-1)|, metres.
///
/// Every Gaussian also carries a stable id, strictly increasing along the arrays: pruning
/// renumbers the Gaussians but keeps their ids, so the planner can follow a map that lost
/// some Gaussians without refiling the rest.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct GaussianMap {
    /// The Gaussians.
    pub gaussians: Gaussians,
    /// One value per Gaussian.
    pub uncertainty: Vec<f32>,
    ids: Vec<u64>,
    next_id: u64,
}

/// Where a Gaussian's uncertainty falls.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum UncertaintyClass {
    /// More than half a standard deviation above the mean: worth looking at again.
    High,
    /// More than half a standard deviation below the mean: settled.
    Low,
    /// In between.
    Other,
    /// Left out of planning (on the ground plane).
    Excluded,
}

/// Which Gaussians the statistics (and the planner) consider.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ClassifyOptions {
    /// Leave out Gaussians whose centre is below this height (metres): the floor is noisy.
    /// `None` keeps all.
    pub ground_below: Option<f32>,
}

impl ClassifyOptions {
    /// Whether a Gaussian centred at `mean` is considered (not on the ground plane).
    pub fn includes(&self, mean: &[f32; 3]) -> bool {
        self.ground_below.is_none_or(|z| mean[2] >= z)
    }
}

impl Default for ClassifyOptions {
    fn default() -> Self {
        ClassifyOptions {
            ground_below: Some(0.05),
        }
    }
}

/// Mean and standard deviation of the included uncertainties.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct UncertaintyStats {
    /// Mean.
    pub mean: f32,
    /// Standard deviation.
    pub std: f32,
    /// Gaussians included.
    pub count: usize,
}

/// Gaussians per parallel work item of the map's passes.
pub const CHUNK: usize = 1 << 15;

/// What one parallel pass over the map tells the planner: the uncertainty statistics and the
/// bounding box of the included Gaussians (regions and the counting grid are laid over it).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MapSummary {
    /// Statistics of the included uncertainties.
    pub stats: UncertaintyStats,
    /// Smallest corner of the included means (f32::MAX when none).
    pub lo: [f32; 3],
    /// Largest corner of the included means (f32::MIN when none).
    pub hi: [f32; 3],
}

impl MapSummary {
    /// The class of an included Gaussian of uncertainty `u` (mean +- half a standard deviation).
    pub fn class_of(&self, u: f32) -> UncertaintyClass {
        let (mean, half) = (self.stats.mean, 0.5 * self.stats.std);
        if u > mean + half {
            UncertaintyClass::High
        } else if u < mean - half {
            UncertaintyClass::Low
        } else {
            UncertaintyClass::Other
        }
    }
}

impl GaussianMap {
    /// A map of `gaussians` with one uncertainty each (missing ones are 0), ids from 0.
    pub fn new(gaussians: Gaussians, uncertainty: Vec<f32>) -> Self {
        let mut map = GaussianMap {
            gaussians,
            uncertainty,
            ids: Vec::new(),
            next_id: 0,
        };
        map.adopt_new_gaussians();
        map
    }

    /// Gives Gaussians pushed onto `gaussians` since the last call an uncertainty of 0 and a
    /// fresh id (callers that grow the map in place call it once they are done).
    pub fn adopt_new_gaussians(&mut self) {
        let n = self.gaussians.len();
        self.uncertainty.resize(n, 0.0);
        self.ids.truncate(n);
        while self.ids.len() < n {
            self.ids.push(self.next_id);
            self.next_id += 1;
        }
    }

    /// The stable ids, strictly increasing; shorter than the map when Gaussians were pushed
    /// and not yet adopted.
    pub fn ids(&self) -> &[u64] {
        &self.ids
    }

    /// Number of Gaussians.
    pub fn len(&self) -> usize {
        self.gaussians.len()
    }

    /// Whether the map is empty.
    pub fn is_empty(&self) -> bool {
        self.gaussians.is_empty()
    }

    fn included(&self, i: usize, options: &ClassifyOptions) -> bool {
        options.includes(&self.gaussians.means[i])
    }

    /// Statistics and bounds of the included Gaussians, in one pass split across threads
    /// (the planner reads them every plan, over millions of Gaussians).
    pub fn summary(&self, options: &ClassifyOptions) -> MapSummary {
        use rayon::prelude::*;
        type Acc = (f64, f64, usize, [f32; 3], [f32; 3]);
        let empty: Acc = (0.0, 0.0, 0, [f32::MAX; 3], [f32::MIN; 3]);
        // Fixed chunks summed in a fixed order: the same sums whatever the thread count and
        // scheduling, so episodes repeat exactly.
        let partial: Vec<Acc> = self
            .gaussians
            .means
            .par_chunks(CHUNK)
            .zip(self.uncertainty.par_chunks(CHUNK))
            .map(|(means, uncertainty)| {
                let mut a = empty;
                for (m, u) in means.iter().zip(uncertainty) {
                    if options.includes(m) {
                        let u = f64::from(*u);
                        a.0 += u;
                        a.1 += u * u;
                        a.2 += 1;
                        for k in 0..3 {
                            a.3[k] = a.3[k].min(m[k]);
                            a.4[k] = a.4[k].max(m[k]);
                        }
                    }
                }
                a
            })
            .collect();
        let (sum, sum2, count, lo, hi) = partial.into_iter().fold(empty, |a, b| {
            (
                a.0 + b.0,
                a.1 + b.1,
                a.2 + b.2,
                std::array::from_fn(|k| a.3[k].min(b.3[k])),
                std::array::from_fn(|k| a.4[k].max(b.4[k])),
            )
        });
        let stats = if count == 0 {
            UncertaintyStats::default()
        } else {
            let mean = sum / count as f64;
            let var = (sum2 / count as f64 - mean * mean).max(0.0);
            UncertaintyStats {
                mean: mean as f32,
                std: var.sqrt() as f32,
                count,
            }
        };
        MapSummary { stats, lo, hi }
    }

    /// Statistics of the uncertainty over the included Gaussians.
    pub fn stats(&self, options: &ClassifyOptions) -> UncertaintyStats {
        self.summary(options).stats
    }

    /// The class of every Gaussian.
    pub fn classify(&self, options: &ClassifyOptions) -> Vec<UncertaintyClass> {
        self.classify_with(options, &self.summary(options))
    }

    /// [`GaussianMap::classify`] with the thresholds of a summary already computed (the
    /// planner takes one per plan and shares it with the regions).
    pub fn classify_with(
        &self,
        options: &ClassifyOptions,
        summary: &MapSummary,
    ) -> Vec<UncertaintyClass> {
        self.uncertainty
            .iter()
            .enumerate()
            .map(|(i, u)| {
                if self.included(i, options) {
                    summary.class_of(*u)
                } else {
                    UncertaintyClass::Excluded
                }
            })
            .collect()
    }

    /// Keeps the Gaussians whose flag is set, in order, with their ids.
    pub fn retain(&mut self, keep: &[bool]) {
        self.adopt_new_gaussians();
        let g = &mut self.gaussians;
        let mut out = Gaussians::default();
        let mut uncertainty = Vec::new();
        let mut ids = Vec::new();
        for (i, k) in keep.iter().enumerate() {
            if *k {
                out.means.push(g.means[i]);
                out.log_radii.push(g.log_radii[i]);
                out.logit_opacities.push(g.logit_opacities[i]);
                out.colours.push(g.colours[i]);
                uncertainty.push(self.uncertainty[i]);
                ids.push(self.ids[i]);
            }
        }
        *g = out;
        self.uncertainty = uncertainty;
        self.ids = ids;
    }
}

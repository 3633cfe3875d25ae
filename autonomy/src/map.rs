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

impl UncertaintyStats {
    /// The class of an included Gaussian of uncertainty `u` (mean +- half a standard deviation).
    pub fn class_of(&self, u: f32) -> UncertaintyClass {
        let (mean, half) = (self.mean, 0.5 * self.std);
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

    /// Statistics of the uncertainty over the included Gaussians, in one pass split across
    /// threads.
    pub fn stats(&self, options: &ClassifyOptions) -> UncertaintyStats {
        use rayon::prelude::*;
        type Acc = (f64, f64, usize);
        // Fixed chunks summed in a fixed order: the same sums whatever the thread count and
        // scheduling, so results repeat exactly.
        let partial: Vec<Acc> = self
            .gaussians
            .means
            .par_chunks(CHUNK)
            .zip(self.uncertainty.par_chunks(CHUNK))
            .map(|(means, uncertainty)| {
                let mut a: Acc = (0.0, 0.0, 0);
                for (m, u) in means.iter().zip(uncertainty) {
                    if options.includes(m) {
                        let u = f64::from(*u);
                        a.0 += u;
                        a.1 += u * u;
                        a.2 += 1;
                    }
                }
                a
            })
            .collect();
        let (sum, sum2, count) = partial
            .into_iter()
            .fold((0.0, 0.0, 0), |a, b| (a.0 + b.0, a.1 + b.1, a.2 + b.2));
        if count == 0 {
            return UncertaintyStats::default();
        }
        let mean = sum / count as f64;
        let var = (sum2 / count as f64 - mean * mean).max(0.0);
        UncertaintyStats {
            mean: mean as f32,
            std: var.sqrt() as f32,
            count,
        }
    }

    /// The class of every Gaussian.
    pub fn classify(&self, options: &ClassifyOptions) -> Vec<UncertaintyClass> {
        let stats = self.stats(options);
        self.uncertainty
            .iter()
            .enumerate()
            .map(|(i, u)| {
                if self.included(i, options) {
                    stats.class_of(*u)
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

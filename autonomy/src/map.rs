//! The Gaussian map the planner reads: the Gaussians and each one's uncertainty, with the
//! high / low / other split of RT-GuIDE (half a standard deviation either side of the mean).

use crate::gaussians::Gaussians;

/// Gaussians and their per-Gaussian uncertainty |mu_k - mu_(k-1)|, metres.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct GaussianMap {
    /// The Gaussians.
    pub gaussians: Gaussians,
    /// One value per Gaussian.
    pub uncertainty: Vec<f32>,
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

impl GaussianMap {
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

    /// Statistics of the uncertainty over the included Gaussians.
    pub fn stats(&self, options: &ClassifyOptions) -> UncertaintyStats {
        let (mut sum, mut sum2, mut count) = (0.0f64, 0.0f64, 0usize);
        for (i, u) in self.uncertainty.iter().enumerate() {
            if self.included(i, options) {
                sum += f64::from(*u);
                sum2 += f64::from(*u) * f64::from(*u);
                count += 1;
            }
        }
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
        let s = self.stats(options);
        let (high, low) = (s.mean + 0.5 * s.std, s.mean - 0.5 * s.std);
        self.uncertainty
            .iter()
            .enumerate()
            .map(|(i, u)| {
                if !self.included(i, options) {
                    UncertaintyClass::Excluded
                } else if *u > high {
                    UncertaintyClass::High
                } else if *u < low {
                    UncertaintyClass::Low
                } else {
                    UncertaintyClass::Other
                }
            })
            .collect()
    }

    /// Keeps the Gaussians whose flag is set.
    pub fn retain(&mut self, keep: &[bool]) {
        let g = &mut self.gaussians;
        let mut out = Gaussians::default();
        let mut uncertainty = Vec::new();
        for (i, k) in keep.iter().enumerate() {
            if *k {
                out.means.push(g.means[i]);
                out.log_radii.push(g.log_radii[i]);
                out.logit_opacities.push(g.logit_opacities[i]);
                out.colours.push(g.colours[i]);
                uncertainty.push(self.uncertainty[i]);
            }
        }
        *g = out;
        self.uncertainty = uncertainty;
    }
}

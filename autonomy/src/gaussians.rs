//! The Gaussian map's parameters: isotropic Gaussians in structure-of-arrays form
//! (DESIGN.md "Gaussian map"), radius and opacity stored as log and logit so the optimiser
//! works unconstrained.

use thiserror::Error;

/// Isotropic 3D Gaussians, 8 parameters each.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Gaussians {
    /// Centres in the world frame, metres.
    pub means: Vec<[f32; 3]>,
    /// Natural log of the radius (standard deviation), log-metres.
    pub log_radii: Vec<f32>,
    /// Logit of the opacity.
    pub logit_opacities: Vec<f32>,
    /// RGB in [0, 1] (not clamped; the optimiser may leave the range slightly).
    pub colours: Vec<[f32; 3]>,
}

/// Problems with Gaussian parameters that must stop a render instead of producing NaN images.
#[derive(Debug, Error, PartialEq)]
pub enum GaussianError {
    /// The arrays disagree in length.
    #[error("Gaussian arrays have different lengths (means {means}, radii {radii}, opacities {opacities}, colours {colours})")]
    LengthMismatch {
        /// means.len()
        means: usize,
        /// log_radii.len()
        radii: usize,
        /// logit_opacities.len()
        opacities: usize,
        /// colours.len()
        colours: usize,
    },
    /// A parameter is NaN or infinite.
    #[error("Gaussian {index} has a non-finite {parameter}; refusing to render NaN")]
    NotFinite {
        /// Which Gaussian.
        index: usize,
        /// Which parameter.
        parameter: &'static str,
    },
}

impl Gaussians {
    /// Number of Gaussians.
    pub fn len(&self) -> usize {
        self.means.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.means.is_empty()
    }

    /// Appends one Gaussian from natural parameters (radius in metres, opacity in (0, 1)).
    pub fn push(&mut self, mean: [f32; 3], radius: f32, opacity: f32, colour: [f32; 3]) {
        self.means.push(mean);
        self.log_radii.push(radius.ln());
        self.logit_opacities.push(logit(opacity));
        self.colours.push(colour);
    }

    /// Radius of Gaussian `i`, metres.
    pub fn radius(&self, i: usize) -> f32 {
        self.log_radii[i].exp()
    }

    /// Opacity of Gaussian `i`, in (0, 1).
    pub fn opacity(&self, i: usize) -> f32 {
        sigmoid(self.logit_opacities[i])
    }

    /// Checks lengths and finiteness; every renderer calls this first.
    pub fn validate(&self) -> Result<(), GaussianError> {
        let n = self.means.len();
        if self.log_radii.len() != n || self.logit_opacities.len() != n || self.colours.len() != n {
            return Err(GaussianError::LengthMismatch {
                means: n,
                radii: self.log_radii.len(),
                opacities: self.logit_opacities.len(),
                colours: self.colours.len(),
            });
        }
        for i in 0..n {
            let bad = |parameter| {
                Err(GaussianError::NotFinite {
                    index: i,
                    parameter,
                })
            };
            if !self.means[i].iter().all(|v| v.is_finite()) {
                return bad("mean");
            }
            if !self.log_radii[i].is_finite() {
                return bad("log-radius");
            }
            if !self.logit_opacities[i].is_finite() {
                return bad("logit-opacity");
            }
            if !self.colours[i].iter().all(|v| v.is_finite()) {
                return bad("colour");
            }
        }
        Ok(())
    }
}

/// Gradients of a scalar loss with respect to every parameter of [`Gaussians`], same layout.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Gradients {
    /// d loss / d mean.
    pub means: Vec<[f32; 3]>,
    /// d loss / d log-radius.
    pub log_radii: Vec<f32>,
    /// d loss / d logit-opacity.
    pub logit_opacities: Vec<f32>,
    /// d loss / d colour.
    pub colours: Vec<[f32; 3]>,
    /// Gaussians that contributed to at least one pixel: the ones Adam updates.
    pub touched: Vec<u32>,
}

impl Gradients {
    /// All-zero gradients for `n` Gaussians.
    pub fn zeros(n: usize) -> Self {
        Gradients {
            means: vec![[0.0; 3]; n],
            log_radii: vec![0.0; n],
            logit_opacities: vec![0.0; n],
            colours: vec![[0.0; 3]; n],
            touched: Vec::new(),
        }
    }
}

impl Gradients {
    /// Adds `other` (gradients of another view of the same Gaussians) into `self`.
    pub fn accumulate(&mut self, other: &Gradients) {
        for &i in &other.touched {
            let i = i as usize;
            for a in 0..3 {
                self.means[i][a] += other.means[i][a];
                self.colours[i][a] += other.colours[i][a];
            }
            self.log_radii[i] += other.log_radii[i];
            self.logit_opacities[i] += other.logit_opacities[i];
        }
        self.touched.extend_from_slice(&other.touched);
        self.touched.sort_unstable();
        self.touched.dedup();
    }
}

/// The logistic function.
pub fn sigmoid(x: f32) -> f32 {
    1.0 / (1.0 + (-x).exp())
}

/// The inverse of [`sigmoid`].
pub fn logit(p: f32) -> f32 {
    (p / (1.0 - p)).ln()
}

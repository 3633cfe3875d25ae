//! Adam with per-parameter learning rates (SplaTAM's TUM rates) that updates only the
//! Gaussians an iteration touched; each Gaussian keeps its own step count, so Gaussians added
//! later get Adam's bias correction from their own first step.

use crate::gaussians::{Gaussians, Gradients};

/// Learning rate of each parameter kind.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LearningRates {
    /// Means, metres per step.
    pub means: f32,
    /// Colours.
    pub colours: f32,
    /// Logit-opacities.
    pub logit_opacities: f32,
    /// Log-radii.
    pub log_radii: f32,
}

impl Default for LearningRates {
    /// SplaTAM's TUM rates (DESIGN.md).
    fn default() -> Self {
        LearningRates {
            means: 1e-4,
            colours: 2.5e-3,
            logit_opacities: 0.05,
            log_radii: 1e-3,
        }
    }
}

impl LearningRates {
    /// Every rate times `factor`.
    pub fn scaled(self, factor: f32) -> Self {
        LearningRates {
            means: self.means * factor,
            colours: self.colours * factor,
            logit_opacities: self.logit_opacities * factor,
            log_radii: self.log_radii * factor,
        }
    }
}

/// Adam's state, borrowed: for an engine that runs the optimiser where the map is (the GPU's
/// resident map loads it before a mapping step).
#[derive(Debug, Clone, Copy)]
pub struct AdamState<'a> {
    /// First moments, one record per Gaussian.
    pub first: &'a Gaussians,
    /// Second moments.
    pub second: &'a Gaussians,
    /// Steps taken per Gaussian (its bias correction).
    pub steps: &'a [u32],
}

/// Adam's state, borrowed mutably: what the GPU's resident map stores back after a step.
#[derive(Debug)]
pub struct AdamStateMut<'a> {
    /// First moments.
    pub first: &'a mut Gaussians,
    /// Second moments.
    pub second: &'a mut Gaussians,
    /// Steps taken per Gaussian.
    pub steps: &'a mut [u32],
}

const BETA1: f32 = 0.9;
const BETA2: f32 = 0.999;
const EPSILON: f32 = 1e-15;

/// Optimiser state for a growing and shrinking set of Gaussians.
#[derive(Debug, Clone, Default)]
pub struct Adam {
    /// Learning rates.
    pub rates: LearningRates,
    first: Gaussians,
    second: Gaussians,
    steps: Vec<u32>,
}

fn update(param: &mut f32, grad: f32, m: &mut f32, v: &mut f32, lr: f32, c1: f32, c2: f32) {
    *m = BETA1 * *m + (1.0 - BETA1) * grad;
    *v = BETA2 * *v + (1.0 - BETA2) * grad * grad;
    *param -= lr * (*m / c1) / ((*v / c2).sqrt() + EPSILON);
}

impl Adam {
    /// An optimiser with `rates` and no state yet.
    pub fn new(rates: LearningRates) -> Self {
        Adam {
            rates,
            ..Adam::default()
        }
    }

    /// Grows the state to `n` Gaussians (new ones start with zero moments).
    pub fn resize(&mut self, n: usize) {
        for state in [&mut self.first, &mut self.second] {
            state.means.resize(n, [0.0; 3]);
            state.log_radii.resize(n, 0.0);
            state.logit_opacities.resize(n, 0.0);
            state.colours.resize(n, [0.0; 3]);
        }
        self.steps.resize(n, 0);
    }

    /// The state, to load elsewhere.
    pub fn state(&self) -> AdamState<'_> {
        AdamState {
            first: &self.first,
            second: &self.second,
            steps: &self.steps,
        }
    }

    /// The state, to store back into.
    pub fn state_mut(&mut self) -> AdamStateMut<'_> {
        AdamStateMut {
            first: &mut self.first,
            second: &mut self.second,
            steps: &mut self.steps,
        }
    }

    /// Keeps the state of the Gaussians whose `keep` flag is set (after pruning).
    pub fn retain(&mut self, keep: &[bool]) {
        fn filter<T: Copy>(v: &mut Vec<T>, keep: &[bool]) {
            let mut i = 0;
            v.retain(|_| {
                i += 1;
                keep[i - 1]
            });
        }
        for state in [&mut self.first, &mut self.second] {
            filter(&mut state.means, keep);
            filter(&mut state.log_radii, keep);
            filter(&mut state.logit_opacities, keep);
            filter(&mut state.colours, keep);
        }
        filter(&mut self.steps, keep);
    }

    /// One step on the touched Gaussians.
    pub fn step(&mut self, gaussians: &mut Gaussians, grads: &Gradients) {
        if self.steps.len() < gaussians.len() {
            self.resize(gaussians.len());
        }
        let r = self.rates;
        for &i in &grads.touched {
            let i = i as usize;
            self.steps[i] += 1;
            let t = self.steps[i] as i32;
            let (c1, c2) = (1.0 - BETA1.powi(t), 1.0 - BETA2.powi(t));
            let (m, v) = (&mut self.first, &mut self.second);
            for a in 0..3 {
                update(
                    &mut gaussians.means[i][a],
                    grads.means[i][a],
                    &mut m.means[i][a],
                    &mut v.means[i][a],
                    r.means,
                    c1,
                    c2,
                );
                update(
                    &mut gaussians.colours[i][a],
                    grads.colours[i][a],
                    &mut m.colours[i][a],
                    &mut v.colours[i][a],
                    r.colours,
                    c1,
                    c2,
                );
            }
            update(
                &mut gaussians.log_radii[i],
                grads.log_radii[i],
                &mut m.log_radii[i],
                &mut v.log_radii[i],
                r.log_radii,
                c1,
                c2,
            );
            update(
                &mut gaussians.logit_opacities[i],
                grads.logit_opacities[i],
                &mut m.logit_opacities[i],
                &mut v.logit_opacities[i],
                r.logit_opacities,
                c1,
                c2,
            );
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Adam as written in the paper, bias corrections by `powi` at every step: the reference.
    fn reference_step(x: &mut f32, m: &mut f32, v: &mut f32, grad: f32, lr: f32, t: i32) {
        *m = BETA1 * *m + (1.0 - BETA1) * grad;
        *v = BETA2 * *v + (1.0 - BETA2) * grad * grad;
        let (c1, c2) = (1.0 - BETA1.powi(t), 1.0 - BETA2.powi(t));
        *x -= lr * (*m / c1) / ((*v / c2).sqrt() + EPSILON);
    }

    #[test]
    fn steps_match_the_reference_bit_for_bit_with_gaussians_added_and_skipped() {
        let rates = LearningRates::default();
        let mut adam = Adam::new(rates);
        let mut gaussians = Gaussians::default();
        // Per Gaussian: (opacity, m, v, steps) of the reference.
        let mut reference: Vec<(f32, f32, f32, i32)> = Vec::new();
        for iteration in 0..300usize {
            // One Gaussian joins every 7 iterations; every third one sits out odd iterations.
            if iteration % 7 == 0 {
                gaussians.means.push([0.0; 3]);
                gaussians.log_radii.push(0.0);
                gaussians.logit_opacities.push(0.5);
                gaussians.colours.push([0.0; 3]);
                reference.push((0.5, 0.0, 0.0, 0));
            }
            let n = gaussians.len();
            let mut grads = Gradients::zeros(n);
            for i in 0..n {
                if i % 3 == 0 && iteration % 2 == 1 {
                    continue;
                }
                let g = ((iteration * 31 + i * 17) % 23) as f32 / 23.0 - 0.4;
                grads.logit_opacities[i] = g;
                grads.touched.push(i as u32);
                let r = &mut reference[i];
                r.3 += 1;
                reference_step(&mut r.0, &mut r.1, &mut r.2, g, rates.logit_opacities, r.3);
            }
            adam.step(&mut gaussians, &grads);
            for (i, r) in reference.iter().enumerate() {
                assert_eq!(
                    gaussians.logit_opacities[i].to_bits(),
                    r.0.to_bits(),
                    "iteration {iteration}, gaussian {i}"
                );
            }
        }
    }
}

//! Whether the robot is closing on the target it keeps. A kept target is given up when its
//! route has not come shorter for a number of plans, not after a fixed number of plans: a
//! frontier 20 m off takes some 35 plans at 0.6 m/s, and a fixed count gave it up half way
//! (office_02: two frontiers 20 m apart taken in turn, neither reached), while a target the
//! robot cannot close on (a jiggle at a door) is still given up as soon as before.

/// The route to a kept target must come this much shorter than it has ever been for the robot
/// to count as closing on it, metres: more than the jitter of a route whose first leg starts at
/// a moving robot and whose nodes are a metre apart, less than a second's drive.
pub const PROGRESS_STEP: f64 = 0.5;

/// The shortest route to the current target seen so far, and the plans since it last shrank.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TargetProgress {
    shortest: f64,
    stalled: usize,
}

impl TargetProgress {
    /// A plan toward a new target, `remaining` metres of route away: its first plan.
    pub fn start(&mut self, remaining: f64) {
        self.shortest = remaining;
        self.stalled = 1;
    }

    /// Another plan toward the same target, now `remaining` metres of route away.
    pub fn observe(&mut self, remaining: f64) {
        if remaining <= self.shortest - PROGRESS_STEP {
            self.shortest = remaining;
            self.stalled = 1;
        } else {
            self.stalled += 1;
        }
    }

    /// Plans toward the target since its route last came `PROGRESS_STEP` shorter than ever
    /// (counting that plan): the old count of plans kept, for a robot that never closes in.
    pub fn stalled_plans(&self) -> usize {
        self.stalled
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Brute force over the whole history: the last plan whose route beat every earlier record
    /// by `PROGRESS_STEP` (a record being such a plan, the first plan always one).
    fn stalled_by_brute_force(history: &[f64]) -> usize {
        let mut records = vec![0];
        for (i, r) in history.iter().enumerate().skip(1) {
            let record = history[*records.last().expect("the first plan is a record")];
            if *r <= record - PROGRESS_STEP {
                records.push(i);
            }
        }
        history.len() - records.last().expect("the first plan is a record")
    }

    #[test]
    fn stalled_plans_match_a_brute_force_count_over_random_routes() {
        // A fixed linear congruential sequence: routes that shrink, stall and grow again.
        let mut state: u64 = 0x2545_f491_4f6c_dd1d;
        let mut next = || {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        for _ in 0..200 {
            let mut history = vec![5.0 + 20.0 * next()];
            let mut progress = TargetProgress::default();
            progress.start(history[0]);
            assert_eq!(progress.stalled_plans(), 1);
            for _ in 0..60 {
                let last = *history.last().expect("started");
                let r = (last + 1.2 * next() - 0.8).max(0.0);
                history.push(r);
                progress.observe(r);
                assert_eq!(progress.stalled_plans(), stalled_by_brute_force(&history));
            }
        }
    }

    #[test]
    fn a_robot_that_never_closes_in_counts_every_plan_and_one_that_does_counts_none() {
        let mut stuck = TargetProgress::default();
        stuck.start(10.0);
        for _ in 0..14 {
            stuck.observe(10.2);
        }
        assert_eq!(stuck.stalled_plans(), 15);

        let mut driving = TargetProgress::default();
        driving.start(20.0);
        for k in 1..40 {
            driving.observe(20.0 - 0.6 * k as f64);
            assert_eq!(driving.stalled_plans(), 1);
        }
        // A new target starts the count again.
        driving.start(3.0);
        assert_eq!(driving.stalled_plans(), 1);
    }
}

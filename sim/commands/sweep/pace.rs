//! How long a running sweep has left, from the episodes it has seen start and finish.
//!
//! Wall time per finished episode (the obvious estimate) is wrong exactly when a person looks
//! first: with N episodes running side by side, the first to finish took a whole episode's
//! time, so the estimate starts N times too long (a 2-job sweep of 300 s episodes once said
//! "61 h" for 17). Here the time left is the episodes' own mean duration shared among the
//! episodes that run at once, less what the running ones have already done.

use std::collections::HashMap;

/// Start times of the running episodes and durations of the finished ones, in seconds from
/// any fixed instant (the caller's clock, so tests need no sleeping).
#[derive(Debug, Default)]
pub struct Pace {
    running: HashMap<usize, f64>,
    finished_seconds: f64,
    finished: usize,
    side_by_side: usize,
}

impl Pace {
    /// Episode `index` started at `at`.
    pub fn started(&mut self, index: usize, at: f64) {
        self.running.insert(index, at);
        self.side_by_side = self.side_by_side.max(self.running.len());
    }

    /// Episode `index` ended at `at`, complete or not (a failed episode took its time too).
    pub fn finished(&mut self, index: usize, at: f64) {
        if let Some(start) = self.running.remove(&index) {
            self.finished_seconds += (at - start).max(0.0);
            self.finished += 1;
        }
    }

    /// Seconds from `at` until the running episodes and `queued` more have finished; none
    /// before an episode has finished, since nothing says yet how long one takes.
    pub fn seconds_left(&self, at: f64, queued: usize) -> Option<f64> {
        if self.finished == 0 {
            return None;
        }
        let mean = self.finished_seconds / self.finished as f64;
        // A running episode older than the mean is taken to be about to end, not overdue.
        let running_left: f64 = self
            .running
            .values()
            .map(|&start| (mean - (at - start)).max(0.0))
            .sum();
        let work = running_left + mean * queued as f64;
        Some(work / self.side_by_side.max(1) as f64)
    }
}

/// A duration as a person reads it in a log line: "40 s", "25 min", "3.4 h".
pub fn human_duration(seconds: f64) -> String {
    if seconds < 90.0 {
        format!("{:.0} s", seconds.max(0.0))
    } else if seconds < 90.0 * 60.0 {
        format!("{:.0} min", seconds / 60.0)
    } else {
        format!("{:.1} h", seconds / 3600.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn no_estimate_before_an_episode_has_finished() {
        let mut pace = Pace::default();
        pace.started(0, 0.0);
        assert_eq!(pace.seconds_left(50.0, 3), None);
    }

    /// Two jobs, 100 s episodes, the second started just after the first: when the first
    /// ends, 9 are left and the truth is 400 s (the second ends now; 8 more take 4 rounds of
    /// 100 s on two jobs). Wall time per finished episode would say 900 s.
    #[test]
    fn the_first_finish_of_a_parallel_sweep_is_not_taken_for_its_pace() {
        let mut pace = Pace::default();
        pace.started(0, 0.0);
        pace.started(1, 0.0);
        pace.finished(0, 100.0);
        pace.started(2, 100.0);
        let left = pace
            .seconds_left(100.0, 7)
            .expect("an episode has finished");
        assert!((left - 400.0).abs() < 1e-9, "{left}");
    }

    #[test]
    fn in_a_steady_state_the_estimate_is_the_rounds_left() {
        let mut pace = Pace::default();
        for i in 0..4 {
            pace.started(i, 0.0);
        }
        for i in 0..4 {
            pace.finished(i, 60.0);
            pace.started(i + 4, 60.0);
        }
        // Four running, 30 s into their 60 s; 8 queued: 30 s, then two rounds of 60 s.
        let left = pace.seconds_left(90.0, 8).expect("episodes have finished");
        assert!((left - 150.0).abs() < 1e-9, "{left}");
    }

    #[test]
    fn durations_read_as_a_person_would_say_them() {
        assert_eq!(human_duration(40.2), "40 s");
        assert_eq!(human_duration(25.0 * 60.0), "25 min");
        assert_eq!(human_duration(3.44 * 3600.0), "3.4 h");
    }
}

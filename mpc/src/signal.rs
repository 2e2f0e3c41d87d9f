//! Measurement helpers of the controllers. The thesis' signal chain (2nd-order 500 Hz filter, nested
//! peak-and-hold, first-order 0.0005/0.9995 filter) lives in `millcomp_sim::filters` and is used from there;
//! this module only adds the one-revolution sliding peak used by the MPC's force measurement.

use std::collections::VecDeque;

/// Maximum over a sliding window of the last `window` samples (monotone deque, O(1) amortised).
#[derive(Debug, Clone, PartialEq)]
pub struct SlidingMax {
    window: usize,
    k: usize,
    q: VecDeque<(usize, f64)>,
}

impl SlidingMax {
    /// Window length in samples (≥ 1).
    pub fn new(window: usize) -> Self {
        Self {
            window: window.max(1),
            k: 0,
            q: VecDeque::new(),
        }
    }

    /// Feed one sample (non-finite samples are ignored), get the window maximum (0 before any sample).
    pub fn step(&mut self, x: f64) -> f64 {
        if x.is_finite() {
            while self.q.back().is_some_and(|&(_, v)| v <= x) {
                self.q.pop_back();
            }
            self.q.push_back((self.k, x));
        }
        while self
            .q
            .front()
            .is_some_and(|&(i, _)| i + self.window <= self.k)
        {
            self.q.pop_front();
        }
        self.k += 1;
        self.q.front().map(|&(_, v)| v).unwrap_or(0.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sliding_max_follows_the_window() {
        let mut m = SlidingMax::new(3);
        let v: Vec<f64> = [1.0, 5.0, 2.0, 1.0, 1.0, 0.5]
            .iter()
            .map(|&x| m.step(x))
            .collect();
        assert_eq!(v, vec![1.0, 5.0, 5.0, 5.0, 2.0, 1.0]);
        // NaN samples are ignored
        assert_eq!(m.step(f64::NAN), 1.0);
    }
}

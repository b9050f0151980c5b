//! Enumerating the admissible outcomes of an ambiguous ray.
//!
//! Where the oracle finds a decision that rounding may take either way (a ray within rounding
//! of an edge, a t tie, a t at tmin or tmax), it asks a [`Chooser`] which way to go. The
//! launch index is then run again for every sequence of answers (depth first), and every
//! outcome is admissible. A run that asks nothing is unambiguous.

/// Hands out answers to the decisions of one run and steps through all sequences.
#[derive(Debug, Default)]
pub struct Chooser {
    /// The answers of the current run (a prefix fixed by earlier runs, then zeros).
    answers: Vec<usize>,
    /// How many alternatives each decision of the current run had.
    counts: Vec<usize>,
    /// Where the next decision of this run is.
    position: usize,
    /// Why each decision was ambiguous, for reports (deduplicated).
    reasons: Vec<&'static str>,
}

impl Chooser {
    /// A chooser at the first sequence.
    pub fn new() -> Self {
        Self::default()
    }

    /// Picks one of `n` alternatives (n ≥ 1) for a decision that is ambiguous because of
    /// `reason` ("edge", "t tie", ...). Alternative 0 is the oracle's canonical answer.
    pub fn choose(&mut self, n: usize, reason: &'static str) -> usize {
        if n <= 1 {
            return 0;
        }
        if !self.reasons.contains(&reason) {
            self.reasons.push(reason);
        }
        let k = self.position;
        self.position += 1;
        if k < self.answers.len() {
            self.counts.truncate(k);
            self.counts.push(n);
            return self.answers[k].min(n - 1);
        }
        self.answers.push(0);
        self.counts.push(n);
        0
    }

    /// Moves to the next sequence of answers; `false` when every sequence has run.
    pub fn next_run(&mut self) -> bool {
        let used = self.position;
        self.answers.truncate(used);
        self.counts.truncate(used);
        self.position = 0;
        while let Some(last) = self.answers.pop() {
            let n = self.counts.pop().unwrap_or(1);
            if last + 1 < n {
                self.answers.push(last + 1);
                self.counts.push(n);
                return true;
            }
        }
        false
    }

    /// Why this ray was ambiguous (empty when it was not).
    pub fn reasons(&self) -> &[&'static str] {
        &self.reasons
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn enumerates_every_sequence_of_a_tree() {
        // A decision of 2, then (only on branch 1) a decision of 3: 1 + 3 leaves.
        let mut c = Chooser::new();
        let mut leaves = Vec::new();
        loop {
            let a = c.choose(2, "x");
            let b = if a == 1 { c.choose(3, "y") } else { 9 };
            leaves.push((a, b));
            if !c.next_run() {
                break;
            }
        }
        assert_eq!(leaves, vec![(0, 9), (1, 0), (1, 1), (1, 2)]);
        assert_eq!(c.reasons(), &["x", "y"]);
    }

    #[test]
    fn unambiguous_runs_once() {
        let mut c = Chooser::new();
        assert_eq!(c.choose(1, "never"), 0);
        assert!(!c.next_run());
        assert!(c.reasons().is_empty());
    }
}

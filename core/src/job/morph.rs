//! Morph targets: `output[v] = base[v] + Σ_t weights[t] · targets[t][v]`.

use super::{check_eq, check_len};
use crate::error::JobError;

/// Applies weighted morph deltas of one attribute (positions or normals) to a base.
#[derive(Debug)]
pub struct MorphJob<'a> {
    /// Base attribute values.
    pub base: &'a [[f32; 3]],
    /// Deltas per target: each `base.len()` long, or empty when that target does not
    /// move this attribute.
    pub targets: &'a [&'a [[f32; 3]]],
    /// One weight per target.
    pub weights: &'a [f32],
    /// Output, at least `base.len()`.
    pub output: &'a mut [[f32; 3]],
}

impl MorphJob<'_> {
    /// Checks lengths.
    pub fn validate(&self) -> Result<(), JobError> {
        check_eq("weights", self.targets.len(), self.weights.len())?;
        check_len("output", self.base.len(), self.output.len())?;
        for target in self.targets.iter().filter(|t| !t.is_empty()) {
            check_eq("targets", self.base.len(), target.len())?;
        }
        Ok(())
    }

    /// Validates, then writes `output`.
    pub fn run(&mut self) -> Result<(), JobError> {
        self.validate()?;
        let out = &mut self.output[..self.base.len()];
        out.copy_from_slice(self.base);
        for (target, &w) in self.targets.iter().zip(self.weights) {
            if w == 0.0 || target.is_empty() {
                continue;
            }
            for (o, d) in out.iter_mut().zip(target.iter()) {
                o[0] += w * d[0];
                o[1] += w * d[1];
                o[2] += w * d[2];
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn weighted_sum_of_deltas() {
        let base = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        let t0 = [[1.0, 1.0, 1.0], [0.0, 0.0, 2.0]];
        let t1: [[f32; 3]; 0] = [];
        let t2 = [[0.0, 4.0, 0.0], [4.0, 0.0, 0.0]];
        let mut out = [[0.0; 3]; 2];
        MorphJob { base: &base, targets: &[&t0, &t1, &t2], weights: &[0.5, 3.0, 0.25], output: &mut out }
            .run()
            .expect("valid");
        assert_eq!(out, [[1.5, 1.5, 0.5], [1.0, 1.0, 1.0]]);
    }

    #[test]
    fn mismatched_lengths_are_refused() {
        let base = [[0.0; 3]; 2];
        let short = [[0.0; 3]; 1];
        let mut out = [[0.0; 3]; 2];
        let mut job = MorphJob { base: &base, targets: &[&short], weights: &[1.0], output: &mut out };
        assert!(job.run().is_err());
        let mut job = MorphJob { base: &base, targets: &[], weights: &[1.0], output: &mut out };
        assert!(job.run().is_err());
    }
}

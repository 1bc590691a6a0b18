//! The per-ray checks (the contract's own rules, [`check_ray`](obscura_sdk::contract::check_ray))
//! and the clipping check that compares each valid ray's distances with the environment's clipping
//! range.

use obscura_sdk::DeepMetric;
use obscura_sdk::contract::{Violation, clipping_distances};

use super::{Checker, relative_error};
use crate::report::count;
use crate::run::{Input, Run};
use crate::{Case, CheckKind};

/// The per-ray checks: the check of each rule of [`check_ray`](obscura_sdk::contract::check_ray)
/// ([`Violation::is_per_ray`]), in [`Violation::ALL`] order, each once (radius and spread share one).
fn per_ray_checks() -> Vec<CheckKind> {
    let mut kinds = Vec::new();
    for k in Violation::ALL
        .into_iter()
        .filter(|v| v.is_per_ray())
        .map(CheckKind::of)
    {
        if !kinds.contains(&k) {
            kinds.push(k);
        }
    }
    kinds
}

impl Checker<'_> {
    /// The per-ray checks on the first run; returns which samples are valid and not culled.
    pub(super) fn per_ray(&mut self, inputs: &[Input], run: &Run) -> Vec<bool> {
        let unit = self.opts.unit_tolerance;
        let per_ray = per_ray_checks();
        let mut valid = vec![false; inputs.len()];
        for (i, o) in run.outputs.iter().enumerate() {
            let Some(o) = o else { continue };
            for &k in &per_ray {
                self.report.at(k).examined += 1;
            }
            match o.breach(unit) {
                Some(b) => {
                    let sample = inputs[i].sample();
                    self.report
                        .at(CheckKind::of(b.violation))
                        .fail(b.severity, || Case {
                            sample: Some(sample),
                            what: b.what.into(),
                            expected: b.expected,
                            got: b.got,
                            severity: b.severity,
                        });
                }
                None if o.ray.is_culled() => self.report.culled += 1,
                None => valid[i] = true,
            }
        }
        valid
    }

    /// Every valid ray's `min_dist`/`max_dist` against the environment's clipping planes (CameraZ) or
    /// spheres (RayLength): [`clipping_distances`], the host's own rule for its default rays.
    pub(super) fn clipping(&mut self, inputs: &[Input], run: &Run, valid: &[bool]) {
        let metric = self.report.deep_metric;
        let (near, far) = (self.env.clipping_near(), self.env.clipping_far());
        let tolerance = self.opts.clipping_tolerance;
        let surface = match metric {
            DeepMetric::CameraZ => "plane",
            DeepMetric::RayLength => "sphere",
        };
        let r = self.report.at(CheckKind::Clipping);
        let mut backward = 0u64;
        for (i, o) in run.outputs.iter().enumerate() {
            let Some(o) = o.filter(|_| valid[i]) else {
                continue;
            };
            let Some(want) = clipping_distances(o.ray.origin, o.ray.direction, metric, near, far) else {
                backward += 1;
                continue;
            };
            r.examined += 1;
            let worst = [
                ("min_dist", o.ray.min_dist, want.0, "near"),
                ("max_dist", o.ray.max_dist, want.1, "far"),
            ]
            .into_iter()
            .map(|(what, got, want, which)| (relative_error(got, want), what, got, want, which))
            .max_by(|a, b| a.0.total_cmp(&b.0));
            if let Some((error, what, got, want, which)) = worst.filter(|w| w.0 > tolerance) {
                r.fail(error, || Case {
                    sample: Some(inputs[i].sample()),
                    what: format!("{what} with {metric:?}"),
                    expected: format!("{want} (the {which} clipping {surface})"),
                    got: format!("{got}"),
                    severity: error,
                });
            }
        }
        if backward > 0 {
            r.skipped += backward;
            r.notes.push(format!(
                "{} toward -Z with CameraZ left to the deep_metric check",
                count(backward, "rays")
            ));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::per_ray_checks;
    use crate::CheckKind;

    #[test]
    fn the_per_ray_checks_are_the_reports_third_to_ninth() {
        assert_eq!(per_ray_checks(), CheckKind::ALL[2..9]);
    }
}

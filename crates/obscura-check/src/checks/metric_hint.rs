//! The DeepMetric and DicingHint properties against the rays: CameraZ depth needs rays toward +Z, a
//! Perspective hint one centre of projection, an Orthographic hint parallel rays.

use obscura_sdk::{DeepMetric, DicingHint, Point2, ProjectionProperty, RayGeometry};

use super::{Checker, Grid, angle, dist, norm, v3};
use crate::run::{Input, Run};
use crate::{Case, CheckKind};

impl Checker<'_> {
    /// With CameraZ depth (the property, else the environment's), every valid ray must have `D.z ≥ 0`.
    pub(super) fn deep_metric(&mut self, inputs: &[Input], run: &Run, valid: &[bool]) {
        let answered = self
            .report
            .properties
            .iter()
            .any(|(p, v)| *p == ProjectionProperty::DeepMetric && v.is_some_and(|v| p.accepts(v)));
        let source = if answered {
            "the DeepMetric property"
        } else {
            "the environment's deep metric (DeepMetric not answered)"
        };
        let metric = self.report.deep_metric;
        let r = self.report.at(CheckKind::DeepMetric);
        if metric == DeepMetric::RayLength {
            r.notes
                .push(format!("RayLength ({source}): rays may point anywhere"));
            return;
        }
        for (i, o) in run.outputs.iter().enumerate() {
            let Some(o) = o.filter(|_| valid[i]) else {
                continue;
            };
            r.examined += 1;
            let dz = o.ray.direction.z;
            if dz < 0.0 {
                r.fail(-f64::from(dz), || Case {
                    sample: Some(inputs[i].sample()),
                    what: format!("direction.z with CameraZ from {source}"),
                    expected: "direction.z >= 0 (or report DeepMetric RayLength)".into(),
                    got: format!("{dz} (direction {})", v3(o.ray.direction)),
                    severity: 0.0,
                });
            }
        }
    }

    /// Every valid chief ray against the one nearest the window's centre: the same origin
    /// (Perspective) or the same direction (Orthographic); Spherical asks neither.
    pub(super) fn dicing_hint(&mut self, inputs: &[Input], g: &Grid, run: &Run, valid: &[bool]) {
        let hint = self.report.dicing_hint;
        let r = &mut self.report.checks[CheckKind::DicingHint.index()];
        if hint == DicingHint::Spherical {
            r.notes
                .push("Spherical: neither one origin nor parallel rays required".into());
            return;
        }
        let chief: Vec<(usize, RayGeometry)> = (0..g.gw * g.gh)
            .filter(|&i| valid[i])
            .filter_map(|i| run.outputs[i].map(|o| (i, o.ray)))
            .collect();
        let (cx, cy) = (
            0.5 * (self.window.left + self.window.right),
            0.5 * (self.window.bottom + self.window.top),
        );
        let Some(&(ref_i, reference)) = chief.iter().min_by(|a, b| {
            let d = |s: Point2| (s.x - cx).powi(2) + (s.y - cy).powi(2);
            d(inputs[a.0].screen).total_cmp(&d(inputs[b.0].screen))
        }) else {
            r.notes.push("no valid chief ray".into());
            return;
        };
        let at = inputs[ref_i].screen;
        for (i, ray) in &chief {
            r.examined += 1;
            if hint == DicingHint::Perspective {
                let d = dist(ray.origin, reference.origin);
                let tol = self.opts.origin_tolerance * norm(reference.origin).max(1.0);
                if d > tol {
                    r.fail(d, || Case {
                        sample: Some(inputs[*i].sample()),
                        what: "origin of the lens-centre ray (DicingHint Perspective)".into(),
                        expected: format!(
                            "{} ± {tol}, the origin of the ray at screen ({}, {}): one centre of projection",
                            v3(reference.origin),
                            at.x,
                            at.y
                        ),
                        got: v3(ray.origin),
                        severity: 0.0,
                    });
                }
            } else {
                let a = angle(ray.direction, reference.direction);
                if a > self.opts.direction_tolerance {
                    r.fail(a, || Case {
                        sample: Some(inputs[*i].sample()),
                        what: "direction of the lens-centre ray (DicingHint Orthographic)".into(),
                        expected: format!(
                            "{}, the direction at screen ({}, {}), within {} rad: parallel rays",
                            v3(reference.direction),
                            at.x,
                            at.y,
                            self.opts.direction_tolerance
                        ),
                        got: format!("{} ({a:.3e} rad off)", v3(ray.direction)),
                        severity: 0.0,
                    });
                }
            }
        }
    }
}

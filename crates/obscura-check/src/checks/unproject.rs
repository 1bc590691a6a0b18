//! `unproject` against `project`: points along each valid lens-centre ray must unproject to the ray's
//! own screen sample. A projection that answers `None` everywhere does not offer the inverse.

use std::panic::{AssertUnwindSafe, catch_unwind};

use obscura_host::contract::panic_message;

use super::{Checker, v3};
use crate::run::{Input, Output, Run, record_panic};
use crate::{Case, CheckKind, Sample};

/// What one `unproject` call gave.
enum Answer {
    /// A screen point (checked and recorded).
    Point,
    /// `None`.
    Nothing,
    /// A panic (recorded).
    Panicked,
}

impl Checker<'_> {
    /// Unprojects two points on every valid lens-centre ray in the window and measures how far, in
    /// pixels, they land from the ray's screen sample.
    pub(super) fn unproject(&mut self, inputs: &[Input], lens_centre: &[usize], run: &Run, valid: &[bool]) {
        let mut answered = 0u64;
        let mut nones: Vec<(Sample, f32)> = Vec::new();
        for &i in lens_centre {
            let Some(o) = run.outputs[i].filter(|_| valid[i]) else {
                continue;
            };
            let base = if o.ray.min_dist.is_finite() && o.ray.min_dist > 0.5 {
                2.0 * o.ray.min_dist
            } else {
                1.0
            };
            for depth in [base, 10.0 * base] {
                match self.unproject_at(&inputs[i], &o, depth) {
                    Answer::Point => answered += 1,
                    Answer::Nothing => nones.push((inputs[i].sample(), depth)),
                    Answer::Panicked => {}
                }
            }
        }
        self.unproject_verdict(answered, nones);
    }

    /// Unprojects `O + D·depth` of the output `o` of `input` at its output time, and records a panic
    /// or a miss by more than the tolerance.
    fn unproject_at(&mut self, input: &Input, o: &Output, depth: f32) -> Answer {
        let (px, py) = self.pixel;
        let tol = self.opts.unproject_tolerance;
        let s = input.screen;
        let point = o.ray.origin + o.ray.direction * depth;
        self.report.at(CheckKind::Panic).examined += 1;
        let back = match catch_unwind(AssertUnwindSafe(|| self.p.unproject(point, o.time))) {
            Ok(b) => b,
            Err(payload) => {
                let msg = panic_message(payload.as_ref());
                record_panic(
                    self.report.at(CheckKind::Panic),
                    Some(input.sample()),
                    "unproject",
                    &msg,
                );
                return Answer::Panicked;
            }
        };
        let Some(u) = back else {
            return Answer::Nothing;
        };
        let r = self.report.at(CheckKind::Unproject);
        r.examined += 1;
        let err = (f64::from(u.x) - f64::from(s.x)).hypot(f64::from(u.y) - f64::from(s.y));
        let err_px = ((f64::from(u.x) - f64::from(s.x)) / px).hypot((f64::from(u.y) - f64::from(s.y)) / py);
        if err_px.is_nan() || err_px > tol {
            r.fail(err_px, || Case {
                sample: Some(input.sample()),
                what: format!(
                    "unproject(O + D·{depth}) = unproject({}) at time {}",
                    v3(point),
                    o.time
                ),
                expected: format!("the screen sample ({}, {}) within {tol} pixel", s.x, s.y),
                got: format!(
                    "({}, {}): {err_px:.4e} pixels ({err:.3e} screen units) off",
                    u.x, u.y
                ),
                severity: 0.0,
            });
        }
        Answer::Point
    }

    /// Not offered when no point was answered; else every `None` (at `(sample, depth)`) is a failure.
    fn unproject_verdict(&mut self, answered: u64, nones: Vec<(Sample, f32)>) {
        let r = self.report.at(CheckKind::Unproject);
        if answered == 0 {
            r.notes.push(if nones.is_empty() {
                "no valid lens-centre ray to unproject".into()
            } else {
                "not offered (unproject answered None everywhere)".into()
            });
            return;
        }
        for (sample, depth) in nones {
            r.examined += 1;
            r.fail(f64::INFINITY, || Case {
                sample: Some(sample),
                what: format!("unproject(O + D·{depth}) of the sample's own ray"),
                expected: format!("the screen sample ({}, {})", sample.screen.x, sample.screen.y),
                got: "None".into(),
                severity: 0.0,
            });
        }
        r.notes.push(
            "points at t and 10t along each valid lens-centre ray in the window (t = 1, or 2·min_dist when min_dist > 0.5)"
                .into(),
        );
    }
}

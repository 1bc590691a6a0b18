//! Determinism and thread safety: the same batches must give bit-identical outputs when run again in
//! order, and when run on several threads at once.

use super::Checker;
use crate::run::{FIELDS, Input, Run};
use crate::{Case, CheckKind};

impl Checker<'_> {
    /// Determinism (first vs second sequential run) and thread safety (each concurrent run vs the first).
    pub(super) fn repeatability(&mut self, inputs: &[Input], first: &Run, second: &Run, concurrent: &[Run]) {
        let mut stable = vec![false; inputs.len()];
        let det = self.report.at(CheckKind::Determinism);
        for (i, (a, b)) in first.outputs.iter().zip(&second.outputs).enumerate() {
            let (Some(a), Some(b)) = (a, b) else { continue };
            det.examined += 1;
            match a.differs(b) {
                None => stable[i] = true,
                Some((field, severity)) => det.fail(severity, || Case {
                    sample: Some(inputs[i].sample()),
                    what: format!("{} on the second run", FIELDS[field]),
                    expected: format!("{} (the first run)", a.values()[field]),
                    got: format!("{}", b.values()[field]),
                    severity,
                }),
            }
        }
        let unstable = det.failures;
        let thr = self.report.at(CheckKind::Threads);
        if unstable > 0 {
            thr.notes.push(format!(
                "{unstable} samples left out: they already differ between two sequential runs"
            ));
        }
        for (t, run) in concurrent.iter().enumerate() {
            for (i, (a, b)) in first.outputs.iter().zip(&run.outputs).enumerate() {
                let (Some(a), Some(b)) = (a, b) else { continue };
                if !stable[i] {
                    continue;
                }
                thr.examined += 1;
                if let Some((field, severity)) = a.differs(b) {
                    thr.fail(severity, || Case {
                        sample: Some(inputs[i].sample()),
                        what: format!("{} on thread {t} of {}", FIELDS[field], concurrent.len()),
                        expected: format!("{} (the sequential run)", a.values()[field]),
                        got: format!("{}", b.values()[field]),
                        severity,
                    });
                }
            }
        }
    }
}

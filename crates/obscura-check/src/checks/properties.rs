//! The properties, asked once as a host asks them ([`Properties::read`]): a panic is a
//! [`CheckKind::Panic`] failure, an answer of the wrong type or out of its domain a
//! [`CheckKind::PropertyType`] failure. What is usable sets the default rays of every batch.

use obscura_host::contract::{DefaultRays, Properties, PropertyProblem};
use obscura_sdk::PropertyValue;

use super::Checker;
use crate::run::record_panic;
use crate::{Case, CheckKind};

impl Checker<'_> {
    /// Asks every property (as the host does: [`Properties::read`]), records panics and answers of the
    /// wrong type or domain, and returns the host's default rays.
    pub(super) fn properties(&mut self) -> DefaultRays {
        let (props, answers) = Properties::read(self.p, self.env);
        for (prop, answer) in answers {
            self.report.at(CheckKind::Panic).examined += 1;
            let problem = match answer {
                Ok(a) => {
                    self.report.properties.push((prop, a));
                    self.report.at(CheckKind::PropertyType).examined += 1;
                    continue;
                }
                Err(problem) => problem,
            };
            let got = problem.got();
            match &problem {
                PropertyProblem::Panicked(msg) => {
                    self.report.properties.push((prop, None));
                    record_panic(
                        self.report.at(CheckKind::Panic),
                        None,
                        &format!("property({})", prop.renderman_name()),
                        msg,
                    );
                    continue;
                }
                // A value sent through the ABI that is no property value at all: the wrong type.
                PropertyProblem::Undecodable(_) => self.report.properties.push((prop, None)),
                PropertyProblem::WrongType(v) => self.report.properties.push((prop, Some(*v))),
                PropertyProblem::OutOfDomain(x) => {
                    self.report
                        .properties
                        .push((prop, Some(PropertyValue::Float(*x))));
                }
            }
            let types = self.report.at(CheckKind::PropertyType);
            types.examined += 1;
            types.fail(1.0, || Case {
                sample: None,
                what: prop.renderman_name().into(),
                expected: problem.expected(prop),
                got,
                severity: 0.0,
            });
        }
        self.report.dicing_hint = props.dicing_hint;
        self.report.deep_metric = props.deep_metric;
        DefaultRays::new(&props, self.env)
    }
}

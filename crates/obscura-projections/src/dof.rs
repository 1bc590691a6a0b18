//! The thin-lens depth-of-field parameters shared by the perspective-like and orthographic projections:
//! `fStop`, `focalLength`, `focalDistance` (RenderMan's names and meanings), and the three properties
//! that report them.
//!
//! Depth of field is on when `fStop` is finite and positive and `focalLength` positive; the lens radius
//! is then `R = ½·focalLength/fStop` (the RenderMan Interface's lens diameter `focalLength/fStop`).
//! An f-stop of ∞ or 0 is a pinhole.

use obscura_sdk::optics::PerspectiveRays;
use obscura_sdk::{ParamDecl, Params, PluginError, ProjectionProperty, PropertyValue, ValueRange};

/// The three parameter declarations, to append to a projection's table.
#[must_use]
pub fn params() -> [ParamDecl; 3] {
    [
        ParamDecl::float("fStop", f32::INFINITY)
            .range(ValueRange::at_least(0.0))
            .doc("aperture f-number; inf (or 0) = pinhole, no depth of field"),
        ParamDecl::float("focalLength", 0.0)
            .range(ValueRange {
                min: 0.0,
                max: f64::INFINITY,
                min_inclusive: true,
                max_inclusive: false,
            })
            .doc("focal length in scene units; the lens radius is focalLength/(2 fStop)"),
        ParamDecl::float("focalDistance", 1.0)
            .range(ValueRange::greater_than(0.0))
            .doc("distance to the plane in focus, scene units"),
    ]
}

/// A projection's depth-of-field settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DepthOfField {
    /// `fStop`.
    pub f_stop: f32,
    /// `focalLength`, scene units.
    pub focal_length: f32,
    /// `focalDistance`, scene units.
    pub focal_distance: f32,
}

impl DepthOfField {
    /// Reads the three parameters declared by [`params`].
    ///
    /// # Errors
    /// A parameter lookup error when the table lacks them (a projection that did not append [`params`]).
    pub fn from_params(p: &Params) -> Result<Self, PluginError> {
        Ok(DepthOfField {
            f_stop: p.float("fStop")?,
            focal_length: p.float("focalLength")?,
            focal_distance: p.float("focalDistance")?,
        })
    }

    /// `½·focalLength/fStop`, or 0 for a pinhole.
    #[must_use]
    pub fn lens_radius(&self) -> f32 {
        PerspectiveRays::lens_radius_for(self.f_stop, self.focal_length)
    }

    /// True when the lens radius is positive.
    #[must_use]
    pub fn is_on(&self) -> bool {
        self.lens_radius() > 0.0
    }

    /// The answer to FStop, FocalLength or FocalDistance when depth of field is on; `None` otherwise
    /// and for every other property.
    #[must_use]
    pub fn property(&self, property: ProjectionProperty) -> Option<PropertyValue> {
        if !self.is_on() {
            return None;
        }
        match property {
            ProjectionProperty::FStop => Some(PropertyValue::Float(self.f_stop)),
            ProjectionProperty::FocalLength => Some(PropertyValue::Float(self.focal_length)),
            ProjectionProperty::FocalDistance => Some(PropertyValue::Float(self.focal_distance)),
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pinhole_unless_fstop_and_focal_length_are_both_usable() {
        let dof = |f_stop, focal_length| DepthOfField {
            f_stop,
            focal_length,
            focal_distance: 2.0,
        };
        assert!(!dof(f32::INFINITY, 0.05).is_on());
        assert!(!dof(0.0, 0.05).is_on());
        assert!(!dof(2.8, 0.0).is_on());
        assert_eq!(dof(2.0, 0.1).lens_radius(), 0.025);
        assert_eq!(
            dof(2.0, 0.1).property(ProjectionProperty::FocalDistance),
            Some(PropertyValue::Float(2.0))
        );
        assert_eq!(dof(2.0, 0.1).property(ProjectionProperty::FieldOfView), None);
        assert_eq!(dof(f32::INFINITY, 0.1).property(ProjectionProperty::FStop), None);
    }
}

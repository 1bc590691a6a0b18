//! The questions a host asks a projection at render start (`RixProjection::GetProperty`).

/// Which property the host asks about (`RixProjection::ProjectionProperty`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(C)]
pub enum ProjectionProperty {
    /// How to dice geometry: answered with [`PropertyValue::DicingHint`].
    DicingHint = 0,
    /// How to measure depth: answered with [`PropertyValue::DeepMetric`].
    DeepMetric = 1,
    /// Field of view in degrees (with a Perspective or Spherical dicing hint): [`PropertyValue::Float`].
    FieldOfView = 2,
    /// The f-stop of the depth-of-field model: [`PropertyValue::Float`].
    FStop = 3,
    /// The focal length, scene units: [`PropertyValue::Float`].
    FocalLength = 4,
    /// The focal distance, scene units: [`PropertyValue::Float`].
    FocalDistance = 5,
}

impl ProjectionProperty {
    /// Every property, in RenderMan's order.
    pub const ALL: [ProjectionProperty; 6] = [
        ProjectionProperty::DicingHint,
        ProjectionProperty::DeepMetric,
        ProjectionProperty::FieldOfView,
        ProjectionProperty::FStop,
        ProjectionProperty::FocalLength,
        ProjectionProperty::FocalDistance,
    ];

    /// RenderMan's name, e.g. `k_FieldOfView`.
    #[must_use]
    pub fn renderman_name(self) -> &'static str {
        match self {
            ProjectionProperty::DicingHint => "k_DicingHint",
            ProjectionProperty::DeepMetric => "k_DeepMetric",
            ProjectionProperty::FieldOfView => "k_FieldOfView",
            ProjectionProperty::FStop => "k_FStop",
            ProjectionProperty::FocalLength => "k_FocalLength",
            ProjectionProperty::FocalDistance => "k_FocalDistance",
        }
    }

    /// True when a well-formed answer to this property has the shape of `value`.
    #[must_use]
    pub fn accepts(self, value: PropertyValue) -> bool {
        matches!(
            (self, value),
            (ProjectionProperty::DicingHint, PropertyValue::DicingHint(_))
                | (ProjectionProperty::DeepMetric, PropertyValue::DeepMetric(_))
                | (
                    ProjectionProperty::FieldOfView
                        | ProjectionProperty::FStop
                        | ProjectionProperty::FocalLength
                        | ProjectionProperty::FocalDistance,
                    PropertyValue::Float(_)
                )
        )
    }
}

/// The general strategy the host should dice geometry with (`DicingHint`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(C)]
pub enum DicingHint {
    /// Size in screen units, no perspective divide.
    Orthographic = 0,
    /// Projected size at the primitive's distance.
    Perspective = 1,
    /// Angular size.
    Spherical = 2,
}

/// How the host measures depth for deep output and the `z` AOV (`DeepMetric`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
#[repr(C)]
pub enum DeepMetric {
    /// The camera-space z of the hit; all rays are assumed to travel toward +Z (`k_cameraZ`).
    #[default]
    CameraZ = 0,
    /// The distance along the ray; rays may go toward −Z as well (`k_rayLength`).
    RayLength = 1,
}

/// A property's value. The answer to a query is `Option<PropertyValue>`: `Some` is RenderMan's
/// `k_RixSCUniform` (a value, invariant for the frame), `None` is `k_RixSCInvalidDetail` (not supported).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PropertyValue {
    /// Answer to [`ProjectionProperty::DicingHint`].
    DicingHint(DicingHint),
    /// Answer to [`ProjectionProperty::DeepMetric`].
    DeepMetric(DeepMetric),
    /// Answer to the four float properties.
    Float(f32),
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_property_accepts_only_its_own_type() {
        use ProjectionProperty as P;
        let hint = PropertyValue::DicingHint(DicingHint::Perspective);
        let metric = PropertyValue::DeepMetric(DeepMetric::CameraZ);
        let float = PropertyValue::Float(1.0);
        assert!(P::DicingHint.accepts(hint) && !P::DicingHint.accepts(float));
        assert!(P::DeepMetric.accepts(metric) && !P::DeepMetric.accepts(hint));
        for p in [P::FieldOfView, P::FStop, P::FocalLength, P::FocalDistance] {
            assert!(p.accepts(float) && !p.accepts(metric) && !p.accepts(hint));
        }
    }
}

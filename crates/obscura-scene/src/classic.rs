//! The classic RenderMan Interface primitives that are neither quadrics nor polygon meshes, as the
//! readers hand them to the renderer: bicubic patches (every basis and bilinear patches converted to
//! Bézier form), NURBS patches, curves and points. The renderer dices them by the projection's
//! dicing hint like the quadrics.

use glam::{Vec2, Vec3};

/// One bicubic Bézier patch: `P(u, v) = Σᵢ Σⱼ Bᵢ(u) Bⱼ(v) points[4j + i]`, `Bᵢ` the cubic Bernstein
/// polynomials; `u` runs fastest through `points`, as in RIB.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BezierPatch {
    /// The 16 control points, object space, `u` fastest.
    pub points: [Vec3; 16],
    /// The texture coordinates `(s, t)` at the corners `(u, v)` = (0, 0), (1, 0), (0, 1), (1, 1), in
    /// the RenderMan Interface's convention (`t = 0` is a texture's top row); inside the patch they
    /// are interpolated bilinearly, as the RI interpolates `varying` values. A lone patch has
    /// `s = u`, `t = v` ([`BezierPatch::UNIT_ST`]); a patch of a `PatchMesh` the part of `[0, 1]²`
    /// it covers in the whole mesh, or the mesh's own `"st"`.
    pub st: [Vec2; 4],
}

impl BezierPatch {
    /// `s = u`, `t = v`: the RI's default texture coordinates.
    pub const UNIT_ST: [Vec2; 4] = [
        Vec2::new(0.0, 0.0),
        Vec2::new(1.0, 0.0),
        Vec2::new(0.0, 1.0),
        Vec2::new(1.0, 1.0),
    ];

    /// A patch with the default texture coordinates.
    #[must_use]
    pub fn new(points: [Vec3; 16]) -> Self {
        BezierPatch {
            points,
            st: Self::UNIT_ST,
        }
    }

    /// The texture coordinates at `(u, v)`: the corners' interpolated bilinearly.
    #[must_use]
    pub fn st_at(&self, u: f32, v: f32) -> Vec2 {
        let [a, b, c, d] = self.st;
        a.lerp(b, u).lerp(c.lerp(d, u), v)
    }
}

/// One parametric direction of a [`NuPatch`].
#[derive(Debug, Clone, PartialEq)]
pub struct NurbsAxis {
    /// Control points along this direction.
    pub count: u32,
    /// Order (degree + 1).
    pub order: u32,
    /// `count + order` non-decreasing knots.
    pub knots: Vec<f32>,
    /// The parameter range drawn, `knots[order − 1] ≤ min < max ≤ knots[count]`.
    pub min: f32,
    /// See `min`.
    pub max: f32,
}

/// `NuPatch`: a rational B-spline surface
/// `S(u, v) = Σ Nᵢ(u) Nⱼ(v) (X, Y, Z)ᵢⱼ / Σ Nᵢ(u) Nⱼ(v) Wᵢⱼ`, with `Nᵢ` the B-spline basis of each
/// axis' knots and `(X, Y, Z, W)` the homogeneous control points (`Pw`, the point being `XYZ/W`; `P`
/// has `W = 1`).
#[derive(Debug, Clone, PartialEq)]
pub struct NuPatch {
    /// The `u` direction (fastest in `points`).
    pub u: NurbsAxis,
    /// The `v` direction.
    pub v: NurbsAxis,
    /// `u.count · v.count` homogeneous control points, `u` fastest.
    pub points: Vec<[f32; 4]>,
}

/// One curve segment as a cubic Bézier (linear segments are degree-elevated: their control points
/// lie a third and two thirds along the line), with its width at each end.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CurveSegment {
    /// Bézier control points, object space.
    pub points: [Vec3; 4],
    /// Object-space width at the start and the end of the segment.
    pub widths: [f32; 2],
    /// The ribbon's normal at each end (`"N"`), or `None` for a ribbon that faces the camera.
    pub normals: Option<[Vec3; 2]>,
}

/// `Curves`: flat ribbons of varying width along their segments.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Curves {
    /// Every segment of every curve.
    pub segments: Vec<CurveSegment>,
}

/// `Points`: discs facing the camera, one per point.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Points {
    /// Centres, object space.
    pub positions: Vec<Vec3>,
    /// Diameters, object space, one per point.
    pub widths: Vec<f32>,
}

/// One operation of a [`Blobby`]'s program, as the RenderMan Interface encodes it.
#[derive(Debug, Clone, PartialEq)]
pub enum BlobOp {
    /// `1000`: a constant field value.
    Constant(f32),
    /// `1001`: an ellipsoid, the unit sphere under `matrix` (column vectors); its field is
    /// `(1 − r²)³` for `r² < 1`, `r` the distance from the centre in the sphere's own space.
    Ellipsoid(glam::Mat4),
    /// `1002`: a segment blob from `start` to `end` of `radius`, under `matrix`: the same field with
    /// `r` the distance to the segment over the radius.
    Segment {
        /// Start, in the blob's space.
        start: Vec3,
        /// End, in the blob's space.
        end: Vec3,
        /// Radius.
        radius: f32,
        /// Blob space → object space.
        matrix: glam::Mat4,
    },
    /// `0` (add), `1` (multiply), `2` (maximum), `3` (minimum) of the operands (earlier
    /// instruction indices).
    Combine {
        /// 0 add, 1 multiply, 2 maximum, 3 minimum.
        kind: u8,
        /// Operand instruction indices.
        operands: Vec<u32>,
    },
    /// `4` (subtract) or `5` (divide): `a − b` or `a / b`.
    Binary {
        /// 4 subtract, 5 divide.
        kind: u8,
        /// First operand.
        a: u32,
        /// Second operand.
        b: u32,
    },
    /// `6` (negate) or `7` (identity) of one operand.
    Unary {
        /// 6 negate, 7 identity.
        kind: u8,
        /// The operand.
        a: u32,
    },
}

/// `Blobby`: the implicit surface where the program's field equals `0.421875` (`27/64`, at which a
/// lone unit blob's surface has radius ½). The field is the last instruction's value when the
/// program combines its leaves, else the sum of the leaves.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Blobby {
    /// The instructions in order.
    pub ops: Vec<BlobOp>,
}

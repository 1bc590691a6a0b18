//! # obscura-shading
//!
//! What happens at a hit: textures filtered by the ray's footprint, the materials, the lights and the
//! path tracer that joins them.
//!
//! | module | job |
//! |---|---|
//! | [`texture`] | images as mip pyramids, filtered by each ray's footprint (EWA) |
//! | [`material`] | BSDFs (Lambert, PxrConstant, PxrSurface with GGX) and textured surfaces at a hit |
//! | [`light`] | dome, distant, rect, sphere, the classic point/spot/ambient lights, emissive triangles |
//! | [`integrator`] | the path tracer: next-event estimation, MIS, Russian roulette, the classic local illumination |
//!
//! It traces through [`obscura_geometry::ray::Tracer`] and writes no files: the film and the writers
//! are `obscura-image`'s.

pub mod integrator;
pub mod light;
pub mod material;
pub mod texture;

/*
 * RixIntegrator.h — Obscura's RenderMan-compatible plugin headers: the camera ray a projection writes.
 * Written for Obscura from RenderMan's public documentation; see RixInterfaces.h.
 */
#ifndef OBSCURA_RIX_INTEGRATOR_H
#define OBSCURA_RIX_INTEGRATOR_H

#include "RixShading.h"

struct RtRayGeometry;

namespace obscura_rman {
/**
 * RtRayGeometry::time: the ray's entry of the context's time array, without storage of its own (so
 * RtRayGeometry keeps ObscuraRayGeometry's layout and a batch crosses without a copy). Reading gives
 * the sample's time; writing sets it (the same as writing pCtx.time[i]). On a ray that is not one of
 * the current batch's (a local copy) it reads 0 and a write is dropped.
 */
struct RayTime {
    operator float() const;
    RayTime &operator=(float t);
    RayTime &operator=(RayTime const &o) { return *this = static_cast<float>(o); }
    RayTime() = default;
    RayTime(RayTime const &) = default;
};
} // namespace obscura_rman

/**
 * One camera ray, camera space (+Z forward), laid out exactly as Obscura's ObscuraRayGeometry
 * (obscura/projection.h): the batch's rays are handed to Project in place.
 *   originRadius  footprint radius at the origin (0 for a pinhole, about a pixel for orthographic)
 *   raySpread     footprint radius growth per unit distance (1 means 45°)
 *   minDist/maxDist clipping distances along the ray, pre-filled by the host
 *   time          the sample's entry of the context's time array (see obscura_rman::RayTime)
 * A zero direction culls the sample. RenderMan's raytype, lobeSampled and shadingCtxId (renderer
 * bookkeeping no projection writes) are not offered.
 */
struct RtRayGeometry {
    RtPoint3 origin;
    RtFloat originRadius;
    RtVector3 direction;
    RtFloat raySpread;
    RtFloat minDist;
    RtFloat maxDist;
    [[no_unique_address]] obscura_rman::RayTime time;
};

#endif /* OBSCURA_RIX_INTEGRATOR_H */

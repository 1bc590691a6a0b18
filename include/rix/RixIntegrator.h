/*
 * RixIntegrator.h — Obscura's RenderMan-compatible plugin headers: the camera ray a projection writes.
 * Written for Obscura from RenderMan's public documentation; see RixInterfaces.h.
 */
#ifndef OBSCURA_RIX_INTEGRATOR_H
#define OBSCURA_RIX_INTEGRATOR_H

#include "RixShading.h"

/**
 * One camera ray, camera space (+Z forward). The first six members are laid out exactly as Obscura's
 * ObscuraRayGeometry (obscura/projection.h): origin, originRadius, direction, raySpread, minDist, maxDist.
 *   originRadius  footprint radius at the origin (0 for a pinhole, about a pixel for orthographic)
 *   raySpread     footprint radius growth per unit distance (1 means 45°)
 *   minDist/maxDist clipping distances along the ray, pre-filled by the host
 *   time          the shutter-normalised time in [0, 1): pre-filled from the context's time array; a
 *                 value the plugin writes here wins over the array
 *   raytype, lobeSampled, shadingCtxId  renderer bookkeeping, not read by Obscura
 * A zero direction culls the sample.
 */
struct RtRayGeometry {
    RtPoint3 origin;
    RtFloat originRadius;
    RtVector3 direction;
    RtFloat raySpread;
    RtFloat minDist;
    RtFloat maxDist;
    RtFloat time;
    uint16_t raytype;
    uint16_t lobeSampled;
    int shadingCtxId;
};

#endif /* OBSCURA_RIX_INTEGRATOR_H */

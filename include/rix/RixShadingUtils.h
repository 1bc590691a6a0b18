/*
 * RixShadingUtils.h — Obscura's RenderMan-compatible plugin headers: small shading helpers.
 * Written for Obscura from RenderMan's public documentation; see RixInterfaces.h.
 */
#ifndef OBSCURA_RIX_SHADING_UTILS_H
#define OBSCURA_RIX_SHADING_UTILS_H

#include "RixShading.h"

/** a·(1 − t) + b·t. */
template <typename T, typename S> inline T RixMix(T const &a, T const &b, S t) { return a * (1 - t) + b * t; }
inline float RixMix(float a, float b, float t) { return a * (1.0f - t) + b * t; }

/** x limited to [lo, hi]. */
template <typename T> inline T RixClamp(T x, T lo, T hi) { return x < lo ? lo : (x > hi ? hi : x); }
inline float RixClamp(float x, float lo, float hi) { return x < lo ? lo : (x > hi ? hi : x); }

/** 0 below lo, 1 above hi, linear between. */
inline float RixLinearStep(float lo, float hi, float x) {
    if (x <= lo) return 0.0f;
    if (x >= hi) return 1.0f;
    return (x - lo) / (hi - lo);
}

/** 0 below lo, 1 above hi, the cubic 3u² − 2u³ of u = (x − lo)/(hi − lo) between. */
inline float RixSmoothStep(float lo, float hi, float x) {
    if (x <= lo) return 0.0f;
    if (x >= hi) return 1.0f;
    float u = (x - lo) / (hi - lo);
    return u * u * (3.0f - 2.0f * u);
}

/** Degrees to radians and back. */
inline float RixDegreesToRadians(float d) { return d * F_DEGTORAD; }
inline float RixRadiansToDegrees(float r) { return r * F_RADTODEG; }

#endif /* OBSCURA_RIX_SHADING_UTILS_H */

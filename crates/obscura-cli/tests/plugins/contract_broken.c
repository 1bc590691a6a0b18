/*
 * ContractPinhole — a pinhole camera written in C against include/obscura/projection.h, correct as
 * compiled by default, with one compile-time switch per breach of the projection contract for the tests
 * of `obscura check` (crates/obscura-cli/tests/check_plugins.rs). Define at most one DEFECT_* macro:
 *
 *   DEFECT_PROJECT_ERROR      project returns OBSCURA_ERROR on batches reaching the top-right corner
 *                             (sx > 1.2, 0.9 < sy < 0.99)                               -> panic
 *   DEFECT_NAN_DIRECTION      direction.x is NaN right of sx = 1.1                      -> direction_finite
 *   DEFECT_LONG_DIRECTION     |direction| = 1.01 above sy = 0.5                         -> direction_unit
 *   DEFECT_INFINITE_ORIGIN    origin.z is +inf below sy = -0.9                          -> origin_finite
 *   DEFECT_TIME_ONE           time set to 1 left of sx = -1.1                           -> time_range
 *   DEFECT_NEGATIVE_SPREAD    ray_spread negated below sy = -0.5                        -> radius_spread
 *   DEFECT_CLIP_INVERTED      max_dist = min_dist / 2 right of sx = 0.8                 -> distances
 *   DEFECT_NAN_TINT           tint.g is NaN left of sx = -0.8                           -> tint_finite
 *   DEFECT_DOUBLE_SPREAD      ray_spread twice the footprint everywhere                 -> ray_spread
 *   DEFECT_WRONG_FOV          FieldOfView answered 5 degrees too wide                   -> field_of_view
 *   DEFECT_BACKWARD           every ray looks down -Z while DeepMetric says CameraZ     -> deep_metric
 *   DEFECT_MOVING_ORIGINS     origin = 0.1 (sx, sy, 0) while DicingHint says Perspective -> dicing_hint
 *   DEFECT_WRONG_UNPROJECT    unproject's x is 1 % too large                            -> unproject
 *   DEFECT_COUNTER            ray_spread scaled by a process-wide call counter          -> determinism
 *   DEFECT_THREAD_DEPENDENT   ray_spread 0.1 % larger on any thread but the creator's   -> threads
 *   DEFECT_PROPERTY_TYPE      FieldOfView answered with a DicingHint value              -> property_type
 *
 * and two breaches the host's adapter already stops at the ABI boundary (so the checker never sees a
 * value):
 *
 *   DEFECT_UNKNOWN_VALUE_KIND   FieldOfView answered with value kind 7, DicingHint with enum value 9
 *   DEFECT_PROPERTY_FAILS       FieldOfView answered with status OBSCURA_PANIC
 *
 * The camera (writing-projections.md, conventions.md): a screen sample s = (sx, sy) on the plane at
 * d = 1 / tan(fov/2) gives
 *
 *     D = (sx, sy, d) / l,   l = sqrt(sx^2 + sy^2 + d^2),   origin 0,
 *
 * so fov is the angle between the rays at screen (-1, 0) and (1, 0). With pixels of px x py screen
 * units the direction turns by ax = px sqrt(sy^2 + d^2) / l^2 along x and ay = py sqrt(sx^2 + d^2) / l^2
 * along y, and ray_spread = 0.5 sqrt(ax ay) (half the per-pixel angle). Planar clipping:
 * min_dist = near / D.z, max_dist = far / D.z. unproject(P) = d (P.x, P.y) / P.z for P.z > 0.
 * Properties: DicingHint Perspective, DeepMetric CameraZ, FieldOfView fov.
 */
#include <math.h>
#include <stdatomic.h>
#include <stdlib.h>

#include "obscura/projection.h"

#define PI_F 3.14159265358979323846f

/* One camera: per-camera constants only (project runs on many threads at once). */
typedef struct Pinhole {
    float fov_deg;
    float d;          /* distance of the screen plane */
    float half_pixel; /* 0.5 sqrt(px py), screen units */
    float near_dist, far_dist;
#ifdef DEFECT_THREAD_DEPENDENT
    const char *creator; /* the address of thread_marker on the thread that created the camera */
#endif
} Pinhole;

#ifdef DEFECT_COUNTER
/* Shared by every call: the output depends on how many rays came before. */
static atomic_ulong rays_so_far;
#endif

#ifdef DEFECT_THREAD_DEPENDENT
/* One per thread: its address tells the threads apart. */
static _Thread_local char thread_marker;
#endif

static const float FOV_DEFAULT[1] = {90.0f};

static const ObscuraParamDecl PARAMS[] = {
    {
        .name = "fov",
        .doc = "angle in degrees between the rays at screen (-1, 0) and (1, 0)",
        .default_floats = FOV_DEFAULT,
        .default_count = 1,
        .range_min = 0.0,
        .range_max = 180.0,
        .type = OBSCURA_PARAM_FLOAT,
        .array_len = OBSCURA_ARRAY_SINGLE,
        .range_flags = OBSCURA_RANGE_LIMITED,
    },
};

/* The factory keeps no state; init hands the host a non-NULL token. */
static int factory_token;

static ObscuraStatus pinhole_init(const ObscuraProjectionDescriptor *self, const char *plugin_path,
                                  void **factory, const ObscuraErrorSink *error) {
    (void)self;
    (void)plugin_path;
    (void)error;
    *factory = &factory_token;
    return OBSCURA_OK;
}

static ObscuraStatus pinhole_create(void *factory, ObscuraEnvironment *env,
                                    const ObscuraParamList *params, void **projection,
                                    const ObscuraErrorSink *error) {
    (void)factory;
    if (env == NULL || env->struct_size < sizeof(ObscuraEnvironment) || params == NULL ||
        params->struct_size < sizeof(ObscuraParamList) || params->num_params != 1 ||
        params->params[0].count != 1 || params->params[0].floats == NULL) {
        obscura_report(error, "ContractPinhole: the host passed an environment or parameter list this "
                              "plugin cannot read");
        return OBSCURA_ERROR;
    }
    const float fov = params->params[0].floats[0];
    if (!(fov > 0.0f && fov < 180.0f)) {
        obscura_report(error, "ContractPinhole: parameter \"fov\" must be in (0, 180) degrees");
        return OBSCURA_ERROR;
    }
    if (env->width == 0 || env->height == 0) {
        obscura_report(error, "ContractPinhole: the image has no pixels");
        return OBSCURA_ERROR;
    }
    Pinhole *p = malloc(sizeof(Pinhole));
    if (p == NULL) {
        obscura_report(error, "ContractPinhole: out of memory");
        return OBSCURA_ERROR;
    }
    const float px = fabsf(env->screen_right - env->screen_left) / (float)env->width;
    const float py = fabsf(env->screen_top - env->screen_bottom) / (float)env->height;
    p->fov_deg = fov;
    p->d = 1.0f / tanf(0.5f * fov * PI_F / 180.0f);
    p->half_pixel = 0.5f * sqrtf(px * py);
    p->near_dist = env->clipping_near;
    p->far_dist = env->clipping_far;
#ifdef DEFECT_THREAD_DEPENDENT
    p->creator = &thread_marker;
#endif
    env->deep_metric = OBSCURA_DEEP_CAMERA_Z;
    *projection = p;
    return OBSCURA_OK;
}

static void pinhole_destroy(void *factory, void *projection) {
    (void)factory;
    free(projection);
}

static ObscuraStatus pinhole_property(const void *projection, ObscuraProjectionProperty property,
                                      ObscuraPropertyValue *value) {
    const Pinhole *p = projection;
    switch (property) {
    case OBSCURA_PROPERTY_DICING_HINT:
        value->kind = OBSCURA_VALUE_DICING_HINT;
#ifdef DEFECT_UNKNOWN_VALUE_KIND
        value->enum_value = 9;
#else
        value->enum_value = OBSCURA_DICING_PERSPECTIVE;
#endif
        return OBSCURA_OK;
    case OBSCURA_PROPERTY_DEEP_METRIC:
        value->kind = OBSCURA_VALUE_DEEP_METRIC;
        value->enum_value = OBSCURA_DEEP_CAMERA_Z;
        return OBSCURA_OK;
    case OBSCURA_PROPERTY_FIELD_OF_VIEW:
#if defined(DEFECT_PROPERTY_TYPE)
        (void)p;
        value->kind = OBSCURA_VALUE_DICING_HINT;
        value->enum_value = OBSCURA_DICING_PERSPECTIVE;
        return OBSCURA_OK;
#elif defined(DEFECT_UNKNOWN_VALUE_KIND)
        value->kind = 7;
        value->float_value = p->fov_deg;
        return OBSCURA_OK;
#elif defined(DEFECT_PROPERTY_FAILS)
        (void)p;
        return OBSCURA_PANIC;
#elif defined(DEFECT_WRONG_FOV)
        value->kind = OBSCURA_VALUE_FLOAT;
        value->float_value = p->fov_deg + 5.0f;
        return OBSCURA_OK;
#else
        value->kind = OBSCURA_VALUE_FLOAT;
        value->float_value = p->fov_deg;
        return OBSCURA_OK;
#endif
    default:
        return OBSCURA_UNSUPPORTED;
    }
}

static ObscuraStatus pinhole_project(const void *projection, const ObscuraProjectionContext *ctx,
                                     const ObscuraErrorSink *error) {
    const Pinhole *p = projection;
    if (ctx == NULL || ctx->struct_size < sizeof(ObscuraProjectionContext)) {
        obscura_report(error, "ContractPinhole: the host passed a context this plugin cannot read");
        return OBSCURA_ERROR;
    }
#ifdef DEFECT_PROJECT_ERROR
    for (uint32_t i = 0; i < ctx->num_rays; ++i) {
        const ObscuraPoint2 s = ctx->screen[i];
        if (s.x > 1.2f && s.y > 0.9f && s.y < 0.99f) {
            obscura_report(error, "ContractPinhole: deliberate failure in the top-right corner");
            return OBSCURA_ERROR;
        }
    }
#endif
#ifdef DEFECT_PROJECT_PANIC
    /* What a C++ plugin returns when it catches an exception. */
    for (uint32_t i = 0; i < ctx->num_rays; ++i) {
        const ObscuraPoint2 s = ctx->screen[i];
        if (s.x > 1.2f && s.y > 0.9f && s.y < 0.99f) {
            obscura_report(error, "ContractPinhole: deliberate exception in the top-right corner");
            return OBSCURA_PANIC;
        }
    }
#endif
    const float d = p->d, d2 = d * d;
    for (uint32_t i = 0; i < ctx->num_rays; ++i) {
        const float sx = ctx->screen[i].x, sy = ctx->screen[i].y;
        const float sx2 = sx * sx, sy2 = sy * sy;
        const float l2 = sx2 + sy2 + d2;
        const float inv_l = 1.0f / sqrtf(l2);
        ObscuraRayGeometry *ray = &ctx->rays[i];
        ray->origin.x = ray->origin.y = ray->origin.z = 0.0f;
        ray->origin_radius = 0.0f;
        ray->direction.x = sx * inv_l;
        ray->direction.y = sy * inv_l;
        ray->direction.z = d * inv_l;
        ray->ray_spread = p->half_pixel * sqrtf(sqrtf((sx2 + d2) * (sy2 + d2))) / l2;
        ray->min_dist = p->near_dist / ray->direction.z;
        ray->max_dist = p->far_dist / ray->direction.z;
#ifdef DEFECT_NAN_DIRECTION
        if (sx > 1.1f) {
            ray->direction.x = NAN;
        }
#endif
#ifdef DEFECT_LONG_DIRECTION
        if (sy > 0.5f) {
            ray->direction.x *= 1.01f;
            ray->direction.y *= 1.01f;
            ray->direction.z *= 1.01f;
        }
#endif
#ifdef DEFECT_INFINITE_ORIGIN
        if (sy < -0.9f) {
            ray->origin.z = INFINITY;
        }
#endif
#ifdef DEFECT_TIME_ONE
        if (sx < -1.1f) {
            ctx->time[i] = 1.0f;
        }
#endif
#ifdef DEFECT_NEGATIVE_SPREAD
        if (sy < -0.5f) {
            ray->ray_spread = -ray->ray_spread;
        }
#endif
#ifdef DEFECT_CLIP_INVERTED
        if (sx > 0.8f) {
            ray->max_dist = 0.5f * ray->min_dist;
        }
#endif
#ifdef DEFECT_CLIP_SPHERES
        /* Clipping spheres while reporting CameraZ: min_dist/max_dist not at the planes. */
        ray->min_dist = p->near_dist;
#endif
#ifdef DEFECT_NAN_TINT
        if (sx < -0.8f) {
            ctx->tint[i].g = NAN;
        }
#endif
#ifdef DEFECT_DOUBLE_SPREAD
        ray->ray_spread *= 2.0f;
#endif
#ifdef DEFECT_BACKWARD
        /* The mirror image through the camera: every ray toward -Z, clipped by the planes z = -near
         * and z = -far. */
        ray->direction.x = -ray->direction.x;
        ray->direction.y = -ray->direction.y;
        ray->direction.z = -ray->direction.z;
#endif
#ifdef DEFECT_MOVING_ORIGINS
        ray->origin.x = 0.1f * sx;
        ray->origin.y = 0.1f * sy;
#endif
#ifdef DEFECT_COUNTER
        ray->ray_spread *= 1.0f + 1e-6f * (float)atomic_fetch_add(&rays_so_far, 1ul);
#endif
#ifdef DEFECT_THREAD_DEPENDENT
        if (&thread_marker != p->creator) {
            ray->ray_spread *= 1.001f;
        }
#endif
    }
    return OBSCURA_OK;
}

static ObscuraStatus pinhole_unproject(const void *projection, ObscuraVec3 point, float time,
                                       ObscuraPoint2 *screen) {
    (void)time;
    const Pinhole *p = projection;
#if defined(DEFECT_BACKWARD)
    /* The exact inverse of the mirrored camera: points in front of it lie at z < 0. */
    if (!(point.z < 0.0f)) {
        return OBSCURA_UNSUPPORTED;
    }
    screen->x = p->d * point.x / point.z;
    screen->y = p->d * point.y / point.z;
#elif defined(DEFECT_MOVING_ORIGINS)
    /* The exact inverse of rays from 0.1 s: P = 0.1 s + t (s, d)/l gives s = P.xy / (0.1 + P.z/d). */
    if (!(point.z > 0.0f)) {
        return OBSCURA_UNSUPPORTED;
    }
    const float k = 0.1f + point.z / p->d;
    screen->x = point.x / k;
    screen->y = point.y / k;
#else
    if (!(point.z > 0.0f)) {
        return OBSCURA_UNSUPPORTED;
    }
    screen->x = p->d * point.x / point.z;
    screen->y = p->d * point.y / point.z;
#endif
#ifdef DEFECT_WRONG_UNPROJECT
    screen->x *= 1.01f;
#endif
    return OBSCURA_OK;
}

static const ObscuraProjectionDescriptor DESCRIPTOR = {
    .abi_version = OBSCURA_PROJECTION_ABI_VERSION,
    .struct_size = sizeof(ObscuraProjectionDescriptor),
    .name = "ContractPinhole",
    .summary = "pinhole camera in C with switchable contract breaches (obscura check tests)",
    .params = PARAMS,
    .num_params = sizeof(PARAMS) / sizeof(PARAMS[0]),
    .init = pinhole_init,
    .finalize = NULL,
    .synchronize = NULL,
    .create_projection = pinhole_create,
    .destroy_projection = pinhole_destroy,
    .property = pinhole_property,
    .project = pinhole_project,
    .unproject = pinhole_unproject,
};

OBSCURA_EXPORT const ObscuraProjectionDescriptor *obscura_projection_entry(uint32_t host_abi_version) {
    return host_abi_version == OBSCURA_PROJECTION_ABI_VERSION ? &DESCRIPTOR : NULL;
}

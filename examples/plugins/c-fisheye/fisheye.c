/*
 * CFisheye — an equidistant fisheye written in C against include/obscura/projection.h.
 *
 * Build (Linux; -dynamiclib on macOS):
 *
 *     cc -std=c11 -O2 -fPIC -shared -I include -o CFisheye.so examples/plugins/c-fisheye/fisheye.c -lm
 *
 * then `obscura render --plugin-path . -p CFisheye --param 'fov=180'`.
 *
 * Mapping (renderman-projection-api.md §3.3): a screen sample s = (sx, sy) at r = |s| and
 * azimuth psi = atan2(sy, sx) looks at the angle phi = r*fov/2 from +Z:
 *
 *     D = (sin phi cos psi, sin phi sin psi, cos phi),   r > 1 culled (D = 0).
 *
 * Footprint: with A = dphi/dr = fov/2 (radial) and B = sin(phi)/r (tangential), a pixel of dx*dy
 * screen units turns the direction by ax = dx*sqrt(A^2 sx^2 + B^2 sy^2)/r along x and
 * ay = dy*sqrt(A^2 sy^2 + B^2 sx^2)/r along y (ax = dx*A, ay = dy*A at r = 0), and
 * ray_spread = 0.5*sqrt(ax*ay). Origin 0, origin radius 0, spherical clipping (min_dist = near,
 * max_dist = far). Properties: DicingHint Spherical, DeepMetric RayLength, FieldOfView the angle across
 * the screen window's shorter side, capped at fov. A 360-degree fisheye leaves out its rim r = 1,
 * which is the single direction -Z.
 */
#include <math.h>
#include <stdlib.h>

#include "obscura/projection.h"

#define PI_F 3.14159265358979323846f

/* The factory state: how many projections are alive (released by finalize). */
typedef struct Factory {
    int live;
} Factory;

/* One camera. */
typedef struct Fisheye {
    float half_fov; /* radians */
    float fov_deg;
    float field_of_view;
    float pixel_x, pixel_y; /* screen units */
    float near_dist, far_dist;
} Fisheye;

static const float FOV_DEFAULT[1] = {180.0f};

static const ObscuraParamDecl PARAMS[] = {
    {
        .name = "fov",
        .doc = "field of view in degrees across the unit circle of screen space",
        .default_floats = FOV_DEFAULT,
        .default_count = 1,
        .range_min = 0.0,
        .range_max = 360.0,
        .type = OBSCURA_PARAM_FLOAT,
        .array_len = OBSCURA_ARRAY_SINGLE,
        .range_flags = OBSCURA_RANGE_LIMITED | OBSCURA_RANGE_MAX_INCLUSIVE,
    },
};

static ObscuraStatus fisheye_init(const ObscuraProjectionDescriptor *self, const char *plugin_path,
                                  void **factory, const ObscuraErrorSink *error) {
    (void)self;
    (void)plugin_path;
    Factory *f = calloc(1, sizeof(Factory));
    if (f == NULL) {
        obscura_report(error, "CFisheye: out of memory");
        return OBSCURA_ERROR;
    }
    *factory = f;
    return OBSCURA_OK;
}

static void fisheye_finalize(void *factory) { free(factory); }

static ObscuraStatus fisheye_create(void *factory, ObscuraEnvironment *env,
                                    const ObscuraParamList *params, void **projection,
                                    const ObscuraErrorSink *error) {
    if (env == NULL || env->struct_size < sizeof(ObscuraEnvironment) || params == NULL ||
        params->struct_size < sizeof(ObscuraParamList) || params->num_params != 1 ||
        params->params[0].count != 1 || params->params[0].floats == NULL) {
        obscura_report(error, "CFisheye: the host passed an environment or parameter list this plugin cannot read");
        return OBSCURA_ERROR;
    }
    /* The host checked the range already; a plugin still refuses what it cannot draw. */
    float fov = params->params[0].floats[0];
    if (!(fov > 0.0f && fov <= 360.0f)) {
        obscura_report(error, "CFisheye: parameter \"fov\" must be in (0, 360] degrees");
        return OBSCURA_ERROR;
    }
    Fisheye *p = malloc(sizeof(Fisheye));
    if (p == NULL) {
        obscura_report(error, "CFisheye: out of memory");
        return OBSCURA_ERROR;
    }
    float w = fabsf(env->screen_right - env->screen_left);
    float h = fabsf(env->screen_top - env->screen_bottom);
    float shorter = w < h ? w : h;
    p->half_fov = 0.5f * fov * PI_F / 180.0f;
    p->fov_deg = fov;
    p->field_of_view = shorter >= 2.0f ? fov : fov * 0.5f * shorter;
    p->pixel_x = w / (float)env->width;
    p->pixel_y = h / (float)env->height;
    p->near_dist = env->clipping_near;
    p->far_dist = env->clipping_far;
    env->deep_metric = OBSCURA_DEEP_RAY_LENGTH;
    ((Factory *)factory)->live += 1;
    *projection = p;
    return OBSCURA_OK;
}

static void fisheye_destroy(void *factory, void *projection) {
    if (factory != NULL) {
        ((Factory *)factory)->live -= 1;
    }
    free(projection);
}

static ObscuraStatus fisheye_property(const void *projection, ObscuraProjectionProperty property,
                                      ObscuraPropertyValue *value) {
    const Fisheye *p = projection;
    switch (property) {
    case OBSCURA_PROPERTY_DICING_HINT:
        value->kind = OBSCURA_VALUE_DICING_HINT;
        value->enum_value = OBSCURA_DICING_SPHERICAL;
        return OBSCURA_OK;
    case OBSCURA_PROPERTY_DEEP_METRIC:
        value->kind = OBSCURA_VALUE_DEEP_METRIC;
        value->enum_value = OBSCURA_DEEP_RAY_LENGTH;
        return OBSCURA_OK;
    case OBSCURA_PROPERTY_FIELD_OF_VIEW:
        value->kind = OBSCURA_VALUE_FLOAT;
        value->float_value = p->field_of_view;
        return OBSCURA_OK;
    default:
        return OBSCURA_UNSUPPORTED;
    }
}

static ObscuraStatus fisheye_project(const void *projection, const ObscuraProjectionContext *ctx,
                                     const ObscuraErrorSink *error) {
    const Fisheye *p = projection;
    if (ctx == NULL || ctx->struct_size < sizeof(ObscuraProjectionContext)) {
        obscura_report(error, "CFisheye: the host passed a context this plugin cannot read");
        return OBSCURA_ERROR;
    }
    const float a = p->half_fov;
    const float half_pixel = 0.5f * sqrtf(p->pixel_x * p->pixel_y);
    const int full_circle = p->fov_deg >= 360.0f;
    for (uint32_t i = 0; i < ctx->num_rays; ++i) {
        const float sx = ctx->screen[i].x, sy = ctx->screen[i].y;
        const float r = sqrtf(sx * sx + sy * sy);
        ObscuraRayGeometry *ray = &ctx->rays[i];
        ray->origin.x = ray->origin.y = ray->origin.z = 0.0f;
        ray->origin_radius = 0.0f;
        ray->min_dist = p->near_dist;
        ray->max_dist = p->far_dist;
        if (r > 1.0f || (full_circle && r >= 1.0f)) {
            ray->direction.x = ray->direction.y = ray->direction.z = 0.0f;
            ray->ray_spread = 0.0f;
            continue;
        }
        const float phi = r * a;
        const float sin_phi = sinf(phi);
        float ax2, ay2; /* squared per-screen-unit turns along x and y */
        if (r > 0.0f) {
            const float cx = sx / r, cy = sy / r, b = sin_phi / r;
            ray->direction.x = sin_phi * cx;
            ray->direction.y = sin_phi * cy;
            ax2 = a * a * cx * cx + b * b * cy * cy;
            ay2 = a * a * cy * cy + b * b * cx * cx;
        } else {
            ray->direction.x = sin_phi;
            ray->direction.y = 0.0f;
            ax2 = ay2 = a * a;
        }
        ray->direction.z = cosf(phi);
        ray->ray_spread = half_pixel * sqrtf(sqrtf(ax2 * ay2));
    }
    return OBSCURA_OK;
}

static ObscuraStatus fisheye_unproject(const void *projection, ObscuraVec3 point, float time,
                                       ObscuraPoint2 *screen) {
    (void)time;
    const Fisheye *p = projection;
    const float rho = sqrtf(point.x * point.x + point.y * point.y);
    if (rho == 0.0f && point.z == 0.0f) {
        return OBSCURA_UNSUPPORTED;
    }
    const float theta = atan2f(rho, point.z);
    const float r = theta / p->half_fov;
    if (r > 1.0f + 1e-6f || (p->fov_deg >= 360.0f && r >= 1.0f)) {
        return OBSCURA_UNSUPPORTED;
    }
    if (rho == 0.0f) {
        screen->x = screen->y = 0.0f;
    } else {
        screen->x = r * point.x / rho;
        screen->y = r * point.y / rho;
    }
    return OBSCURA_OK;
}

static const ObscuraProjectionDescriptor DESCRIPTOR = {
    .abi_version = OBSCURA_PROJECTION_ABI_VERSION,
    .struct_size = sizeof(ObscuraProjectionDescriptor),
    .name = "CFisheye",
    .summary = "equidistant fisheye written in C: phi = r*fov/2 from +Z, r > 1 culled (plugin example)",
    .params = PARAMS,
    .num_params = sizeof(PARAMS) / sizeof(PARAMS[0]),
    .init = fisheye_init,
    .finalize = fisheye_finalize,
    .synchronize = NULL,
    .create_projection = fisheye_create,
    .destroy_projection = fisheye_destroy,
    .property = fisheye_property,
    .project = fisheye_project,
    .unproject = fisheye_unproject,
};

OBSCURA_EXPORT const ObscuraProjectionDescriptor *obscura_projection_entry(uint32_t host_abi_version) {
    return host_abi_version == OBSCURA_PROJECTION_ABI_VERSION ? &DESCRIPTOR : NULL;
}

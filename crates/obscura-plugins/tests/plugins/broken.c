/*
 * "Broken": a test plugin for crates/obscura-plugins/tests/abi.rs, compiled once per defect with -D.
 *
 * Without a define it is a well-behaved modifier (RenderMan's sense): it reports a 90-degree field of
 * view and leaves the host's default pinhole rays alone. Each define breaks exactly one promise:
 *
 *   BAD_VERSION       the descriptor claims ABI version 99
 *   BAD_SIZE          the descriptor's struct_size is 8 bytes short of the layout
 *   LARGER_SIZE       the descriptor is followed by two fields a newer header added (must still load)
 *   NULL_DESCRIPTOR   the entry point returns NULL
 *   NO_ENTRY          the entry point is exported under another name
 *   NULL_NAME         the name is NULL
 *   NULL_PROJECT      the required `project` is NULL
 *   NULL_PARAMS       one parameter promised, the table pointer NULL
 *   BAD_DEFAULT       the parameter's default lies outside its own range
 *   NULL_FACTORY      init returns OK without setting a factory
 *   FAIL_INIT         init fails with a message
 *   NULL_PROJECTION   create_projection returns OK without a projection
 *   BAD_DEEP_METRIC   create_projection writes deep metric 7 into the environment
 *   NAN_OUTPUT        project writes NaN directions right of the screen centre
 *   PROJECT_ERROR     project returns OBSCURA_ERROR with a message on every batch
 *   SIZEOF_DEFAULT    default_count is sizeof the default array (4) instead of its length (1)
 *   HUGE_CHOICES      num_choices is absurd (and choices NULL): refused before anything is read
 *   UNKNOWN_RANGE_BIT range_flags has a bit the header does not define (8)
 *   INCLUSIVE_WITHOUT_LIMITED  range_flags has both INCLUSIVE bits but not LIMITED: no range (loads)
 */
#include <math.h>
#include <stddef.h>

#include "obscura/projection.h"

static int FACTORY_STATE;

static const float SCALE_DEFAULT[1] = {1.0f};

static const ObscuraParamDecl PARAMS[] = {
    {
        .name = "scale",
        .doc = "unused",
        .default_floats = SCALE_DEFAULT,
#ifdef SIZEOF_DEFAULT
        .default_count = sizeof(SCALE_DEFAULT), /* a C slip: bytes, not values */
#else
        .default_count = 1,
#endif
#ifdef BAD_DEFAULT
        .range_min = 2.0,
#else
        .range_min = 0.0,
#endif
        .range_max = 10.0,
        .type = OBSCURA_PARAM_FLOAT,
        .array_len = OBSCURA_ARRAY_SINGLE,
#if defined(UNKNOWN_RANGE_BIT)
        .range_flags = OBSCURA_RANGE_LIMITED | OBSCURA_RANGE_MIN_INCLUSIVE | OBSCURA_RANGE_MAX_INCLUSIVE | 8u,
#elif defined(INCLUSIVE_WITHOUT_LIMITED)
        .range_flags = OBSCURA_RANGE_MIN_INCLUSIVE | OBSCURA_RANGE_MAX_INCLUSIVE,
#else
        .range_flags = OBSCURA_RANGE_LIMITED | OBSCURA_RANGE_MIN_INCLUSIVE | OBSCURA_RANGE_MAX_INCLUSIVE,
#endif
#ifdef HUGE_CHOICES
        .num_choices = (size_t)-1 / 2, /* never read: refused before the (NULL) array is touched */
#endif
    },
};

static ObscuraStatus broken_init(const ObscuraProjectionDescriptor *self, const char *plugin_path,
                                 void **factory, const ObscuraErrorSink *error) {
    (void)self;
    (void)plugin_path;
    (void)error;
#if defined(FAIL_INIT)
    obscura_report(error, "license server unreachable");
    return OBSCURA_ERROR;
#elif defined(NULL_FACTORY)
    (void)factory;
    return OBSCURA_OK;
#else
    *factory = &FACTORY_STATE;
    return OBSCURA_OK;
#endif
}

static int PROJECTION_STATE;

static ObscuraStatus broken_create(void *factory, ObscuraEnvironment *env,
                                   const ObscuraParamList *params, void **projection,
                                   const ObscuraErrorSink *error) {
    (void)factory;
    (void)params;
    (void)error;
#ifdef BAD_DEEP_METRIC
    env->deep_metric = 7;
#else
    (void)env;
#endif
#ifdef NULL_PROJECTION
    (void)projection;
#else
    *projection = &PROJECTION_STATE;
#endif
    return OBSCURA_OK;
}

static void broken_destroy(void *factory, void *projection) {
    (void)factory;
    (void)projection;
}

static ObscuraStatus broken_property(const void *projection, ObscuraProjectionProperty property,
                                     ObscuraPropertyValue *value) {
    (void)projection;
    if (property == OBSCURA_PROPERTY_FIELD_OF_VIEW) {
        value->kind = OBSCURA_VALUE_FLOAT;
        value->float_value = 90.0f;
        return OBSCURA_OK;
    }
    return OBSCURA_UNSUPPORTED;
}

static ObscuraStatus broken_project(const void *projection, const ObscuraProjectionContext *ctx,
                                    const ObscuraErrorSink *error) {
    (void)projection;
    (void)error;
#if defined(NAN_OUTPUT)
    for (uint32_t i = 0; i < ctx->num_rays; ++i) {
        if (ctx->screen[i].x > 0.0f) {
            ctx->rays[i].direction.x = nanf("");
        }
    }
#elif defined(PROJECT_ERROR)
    (void)ctx;
    obscura_report(error, "lens table missing");
    return OBSCURA_ERROR;
#else
    (void)ctx;
#endif
    return OBSCURA_OK;
}

#ifdef LARGER_SIZE
/* What a plugin built against a newer header (two fields appended) looks like to this host. */
typedef struct NewerDescriptor {
    ObscuraProjectionDescriptor base;
    const void *future_a;
    const void *future_b;
} NewerDescriptor;
static const NewerDescriptor NEWER = {
    .base =
#else
static const ObscuraProjectionDescriptor DESCRIPTOR =
#endif
    {
#ifdef BAD_VERSION
        .abi_version = 99,
#else
        .abi_version = OBSCURA_PROJECTION_ABI_VERSION,
#endif
#if defined(BAD_SIZE)
        .struct_size = sizeof(ObscuraProjectionDescriptor) - 8,
#elif defined(LARGER_SIZE)
        .struct_size = sizeof(NewerDescriptor),
#else
        .struct_size = sizeof(ObscuraProjectionDescriptor),
#endif
#ifdef NULL_NAME
        .name = NULL,
#else
        .name = "Broken",
#endif
        .summary = "test plugin with one defect chosen at compile time",
#ifdef NULL_PARAMS
        .params = NULL,
#else
        .params = PARAMS,
#endif
        .num_params = 1,
        .init = broken_init,
        .finalize = NULL,
        .synchronize = NULL,
        .create_projection = broken_create,
        .destroy_projection = broken_destroy,
        .property = broken_property,
#ifdef NULL_PROJECT
        .project = NULL,
#else
        .project = broken_project,
#endif
        .unproject = NULL,
    }
#ifdef LARGER_SIZE
    ,
    .future_a = NULL,
    .future_b = NULL,
};
#define DESCRIPTOR (NEWER.base)
#else
;
#endif

#ifdef NO_ENTRY
#define ENTRY_NAME obscura_projection_entry_v0
#else
#define ENTRY_NAME obscura_projection_entry
#endif

OBSCURA_EXPORT const ObscuraProjectionDescriptor *ENTRY_NAME(uint32_t host_abi_version) {
    (void)host_abi_version;
#ifdef NULL_DESCRIPTOR
    return NULL;
#else
    return &DESCRIPTOR;
#endif
}

/*
 * obscura/projection.h — Obscura's camera-projection plugin ABI, for plugins written in C or C++.
 *
 * A plugin is a shared library (`<Name>.so`, `<Name>.dylib`, `<Name>.dll`) that exports one function,
 *
 *     OBSCURA_EXPORT const ObscuraProjectionDescriptor *obscura_projection_entry(uint32_t host_abi_version);
 *
 * returning a pointer to a constant descriptor: the plugin's name, summary, parameter table and the
 * function pointers of its factory and its projections (RenderMan's RixProjectionFactory and
 * RixProjection). Rust authors do not use this header: `obscura_sdk::export_projection!(MyFactory);`
 * generates the same entry point from the SDK's traits.
 *
 * VERSIONING. `abi_version` names the layout generation; the host refuses any other value with a
 * message. Within one generation the ABI only grows by appending fields at the end of a struct, and
 * every struct that can grow carries its own size (`struct_size`) as its first member (the descriptor
 * as its second, after `abi_version`):
 *   - the host refuses a descriptor whose `struct_size` is smaller than this generation's first
 *     layout, and reads only the fields a smaller (older) descriptor has;
 *   - fields appended later are always optional (NULL or 0 meaning "absent"), so a newer plugin on an
 *     older host still works;
 *   - structs the host passes in (environment, parameter list, context) carry the size the host
 *     filled: a plugin must check `struct_size >= sizeof(...)` of the fields it reads.
 * Enumerations cross as int32_t, never as C enums, so an unknown value is a checked error, not UB.
 *
 * OWNERSHIP. No allocation ever changes hands.
 *   - The descriptor and everything it points to (strings, parameter table, defaults, choices) belong
 *     to the plugin and must stay valid and unchanged for the life of the process: libraries are
 *     never unloaded. The host copies the table when it loads the library.
 *   - Everything the host passes in (environment, parameter lists, context arrays, error sinks,
 *     strings) belongs to the host and is valid only during the call: copy what you keep.
 *   - Error messages: call `error->report(error->host, text, len)` (or `obscura_report`) during the
 *     failing call; the host copies the bytes at once. Your buffer stays yours.
 *   - The factory state `*factory` set by `init` is the plugin's, released by `finalize`. A
 *     projection `*projection` set by `create_projection` is the plugin's, released by
 *     `destroy_projection`, which the host calls exactly once per projection, before `finalize`.
 *
 * THREADS. `property`, `project` and `unproject` are called concurrently from many threads on the same
 * projection (keep per-camera constants in it, nothing mutable). `init`, `finalize`, `synchronize`,
 * `create_projection` and `destroy_projection` are never called concurrently for one library.
 *
 * Lifecycle: `init` once (before the first `create_projection`), `synchronize` with render begin/end and
 * edits, `create_projection` per camera, `destroy_projection` per projection, `finalize` once.
 *
 * Camera space is RenderMan's: the camera at the origin looking down +Z, +Y up, +X right; screen space
 * is the screen window's, y up. See docs/plugin-abi.md and shared/spec/conventions.md.
 */
#ifndef OBSCURA_PROJECTION_H
#define OBSCURA_PROJECTION_H

#include <stddef.h>
#include <stdint.h>
#include <string.h>

#ifdef __cplusplus
extern "C" {
#endif

/** The layout generation of this header. The host refuses a plugin reporting any other. */
#define OBSCURA_PROJECTION_ABI_VERSION 1u

/** The one symbol a plugin library exports. */
#define OBSCURA_PROJECTION_ENTRY_SYMBOL "obscura_projection_entry"

#if defined(_WIN32)
#define OBSCURA_EXPORT __declspec(dllexport)
#else
#define OBSCURA_EXPORT __attribute__((visibility("default")))
#endif

/* ---------------------------------------------------------------------------------------------- */
/* Status codes returned by the plugin's functions.                                               */

typedef int32_t ObscuraStatus;
/** Success. */
#define OBSCURA_OK 0
/** `property`: not supported (RenderMan's k_RixSCInvalidDetail); `unproject`: outside the view. */
#define OBSCURA_UNSUPPORTED 1
/** Failure; the message went to the error sink. */
#define OBSCURA_ERROR 2
/** A panic or exception was caught at the boundary; the message went to the error sink. */
#define OBSCURA_PANIC 3

/* ---------------------------------------------------------------------------------------------- */
/* Enumerations, as int32_t.                                                                      */

/** A parameter's type (RenderMan's RixSCType subset). */
typedef int32_t ObscuraParamType;
#define OBSCURA_PARAM_FLOAT 0
#define OBSCURA_PARAM_INT 1
#define OBSCURA_PARAM_STRING 2
#define OBSCURA_PARAM_COLOR 3  /* three floats */
#define OBSCURA_PARAM_POINT 4  /* three floats */
#define OBSCURA_PARAM_VECTOR 5 /* three floats */
#define OBSCURA_PARAM_NORMAL 6 /* three floats */
#define OBSCURA_PARAM_MATRIX 7 /* sixteen floats, row-major */

/** `array_len` of a single value (`float fov`). A positive value n is a fixed array (`float[n]`). */
#define OBSCURA_ARRAY_SINGLE 0
/** `array_len` of a variable-length list of one or more floats (`float[] coefficients`). */
#define OBSCURA_ARRAY_VARIABLE (-1)

/** ObscuraParamDecl.range_flags bits. */
#define OBSCURA_RANGE_LIMITED 1u       /* range_min / range_max apply to every numeric scalar */
#define OBSCURA_RANGE_MIN_INCLUSIVE 2u /* range_min itself is allowed */
#define OBSCURA_RANGE_MAX_INCLUSIVE 4u /* range_max itself is allowed */

/** What the host tells a factory (RixSCSyncMsg). */
typedef int32_t ObscuraSyncMessage;
#define OBSCURA_SYNC_RENDER_BEGIN 0
#define OBSCURA_SYNC_RENDER_END 1
#define OBSCURA_SYNC_INSTANCE_EDIT 2

/** What the host asks a projection (RixProjection::ProjectionProperty). */
typedef int32_t ObscuraProjectionProperty;
#define OBSCURA_PROPERTY_DICING_HINT 0    /* answered with OBSCURA_VALUE_DICING_HINT */
#define OBSCURA_PROPERTY_DEEP_METRIC 1    /* answered with OBSCURA_VALUE_DEEP_METRIC */
#define OBSCURA_PROPERTY_FIELD_OF_VIEW 2  /* degrees, OBSCURA_VALUE_FLOAT */
#define OBSCURA_PROPERTY_FSTOP 3          /* OBSCURA_VALUE_FLOAT */
#define OBSCURA_PROPERTY_FOCAL_LENGTH 4   /* scene units, OBSCURA_VALUE_FLOAT */
#define OBSCURA_PROPERTY_FOCAL_DISTANCE 5 /* scene units, OBSCURA_VALUE_FLOAT */

/** DicingHint. */
typedef int32_t ObscuraDicingHint;
#define OBSCURA_DICING_ORTHOGRAPHIC 0
#define OBSCURA_DICING_PERSPECTIVE 1
#define OBSCURA_DICING_SPHERICAL 2

/** DeepMetric. */
typedef int32_t ObscuraDeepMetric;
#define OBSCURA_DEEP_CAMERA_Z 0   /* camera-space z; all rays go toward +Z */
#define OBSCURA_DEEP_RAY_LENGTH 1 /* distance along the ray; rays may go toward -Z */

/** ObscuraPropertyValue.kind. */
typedef int32_t ObscuraValueKind;
#define OBSCURA_VALUE_DICING_HINT 0 /* enum_value holds an ObscuraDicingHint */
#define OBSCURA_VALUE_DEEP_METRIC 1 /* enum_value holds an ObscuraDeepMetric */
#define OBSCURA_VALUE_FLOAT 2       /* float_value holds the value */

/* ---------------------------------------------------------------------------------------------- */
/* Plain values (RtPoint2, RtVector3, RtColorRGB, RtMatrix4x4, RtRayGeometry).                    */

typedef struct ObscuraPoint2 {
    float x, y;
} ObscuraPoint2;

typedef struct ObscuraVec3 {
    float x, y, z;
} ObscuraVec3;

typedef struct ObscuraRgb {
    float r, g, b;
} ObscuraRgb;

/** Row-major, acting on row vectors: a point p maps to [p 1]·M (translation in the last row). */
typedef struct ObscuraMatrix4 {
    float m[4][4];
} ObscuraMatrix4;

/**
 * One camera ray in camera space. `direction` is unit length, or exactly zero to cull the sample.
 * The footprint radius at distance t is origin_radius + ray_spread·t and is half a pixel.
 */
typedef struct ObscuraRayGeometry {
    ObscuraVec3 origin;
    float origin_radius;
    ObscuraVec3 direction;
    float ray_spread;
    float min_dist;
    float max_dist;
} ObscuraRayGeometry;

/* ---------------------------------------------------------------------------------------------- */
/* Errors.                                                                                        */

/**
 * Where a plugin sends the message of a failing call. `report` copies `len` bytes of UTF-8 (no NUL
 * needed) into the host's own storage; call it during the failing call only. Several calls append.
 */
typedef struct ObscuraErrorSink {
    void *host;
    void (*report)(void *host, const char *message, size_t len);
} ObscuraErrorSink;

/** Sends a NUL-terminated message to `sink` (does nothing when sink is NULL). */
static inline void obscura_report(const ObscuraErrorSink *sink, const char *message) {
    if (sink != NULL && sink->report != NULL && message != NULL) {
        sink->report(sink->host, message, strlen(message));
    }
}

/* ---------------------------------------------------------------------------------------------- */
/* Parameters.                                                                                    */

/**
 * One row of the parameter table (RixSCParamInfo plus what RenderMan keeps in the .args file).
 *
 * The default lives in the pointer matching the type's storage: `default_floats` for float, color,
 * point, vector, normal and matrix; `default_ints` for int; `default_strings` for string (the others
 * NULL). `default_count` counts scalars: a color is 3, a float[4] is 4, a matrix is 16; a variable
 * length float[] may have any count, 0 included.
 */
typedef struct ObscuraParamDecl {
    const char *name;                    /* as scenes spell it, e.g. "fov"; required */
    const char *doc;                     /* one line for `obscura plugins`; may be NULL */
    const float *default_floats;
    const int32_t *default_ints;
    const char *const *default_strings;
    size_t default_count;
    const char *const *choices;          /* allowed strings, or NULL for any */
    size_t num_choices;
    double range_min;                    /* used when range_flags has OBSCURA_RANGE_LIMITED */
    double range_max;
    ObscuraParamType type;
    int32_t array_len;                   /* OBSCURA_ARRAY_SINGLE, n > 0, or OBSCURA_ARRAY_VARIABLE */
    uint32_t range_flags;
} ObscuraParamDecl;

/**
 * One resolved parameter handed to `create_projection` or `synchronize`. The host has already checked
 * the scene's values against the table (names, types, lengths, ranges, choices) and filled in the
 * defaults: the list holds one entry per table row, **in table order**, so params->params[i] is row i.
 * Values are in the pointer matching the storage, `count` scalars.
 */
typedef struct ObscuraParam {
    const char *name;
    const char *origin;                  /* where the scene gave it ("scene.rib:12"), or NULL */
    const float *floats;
    const int32_t *ints;
    const char *const *strings;
    size_t count;
    ObscuraParamType type;
    int32_t array_len;                   /* as declared in the table */
    int32_t given;                       /* 1 when the scene gave the value, 0 for the default */
} ObscuraParam;

typedef struct ObscuraParamList {
    uint32_t struct_size;                /* sizeof(ObscuraParamList) as the host filled it */
    uint32_t num_params;
    const ObscuraParam *params;
} ObscuraParamList;

/* ---------------------------------------------------------------------------------------------- */
/* The environment (RixProjectionEnvironment).                                                    */

typedef struct ObscuraMotionSample {
    float time;                          /* scene shutter units */
    ObscuraMatrix4 world_to_camera;
} ObscuraMotionSample;

/**
 * What the host knows about the render. Read-only except `deep_metric`, which `create_projection`
 * may set (RenderMan 22); answering OBSCURA_PROPERTY_DEEP_METRIC (RenderMan 23+) wins over it.
 */
typedef struct ObscuraEnvironment {
    uint32_t struct_size;                /* sizeof(ObscuraEnvironment) as the host filled it */
    uint32_t width;                      /* pixels */
    uint32_t height;
    float pixel_aspect;                  /* width / height of one pixel */
    float screen_left;                   /* screen window, y up */
    float screen_right;
    float screen_bottom;
    float screen_top;
    float shutter_open;                  /* scene units */
    float shutter_close;
    float clipping_near;
    float clipping_far;
    ObscuraDeepMetric deep_metric;       /* in/out */
    uint32_t num_motion_samples;         /* >= 1, sorted by time */
    const ObscuraMotionSample *world_to_camera;
} ObscuraEnvironment;

/* ---------------------------------------------------------------------------------------------- */
/* One batch (RixProjectionContext).                                                              */

/**
 * Every array holds `num_rays` elements. `rays` arrive pre-filled with the host's default camera rays
 * and `tint` with white, so a modifier may rewrite only time or tint. Times must stay in [0, 1).
 */
typedef struct ObscuraProjectionContext {
    uint32_t struct_size;                /* sizeof(ObscuraProjectionContext) as the host filled it */
    uint32_t num_rays;
    const ObscuraPoint2 *screen;         /* in: screen-space samples */
    const ObscuraPoint2 *lens;           /* in: canonical lens samples in [0, 1)^2 */
    const ObscuraPoint2 *aperture;       /* in: lens samples warped by the aperture into [-1, 1]^2 */
    float *time;                         /* in/out: shutter-normalised time in [0, 1) */
    ObscuraRayGeometry *rays;            /* out */
    ObscuraRgb *tint;                    /* in/out: multiplies the beauty before the pixel filter */
} ObscuraProjectionContext;

/** A property's answer. */
typedef struct ObscuraPropertyValue {
    ObscuraValueKind kind;
    int32_t enum_value;
    float float_value;
} ObscuraPropertyValue;

/* ---------------------------------------------------------------------------------------------- */
/* The descriptor.                                                                                */

typedef struct ObscuraProjectionDescriptor ObscuraProjectionDescriptor;

struct ObscuraProjectionDescriptor {
    uint32_t abi_version;                /* OBSCURA_PROJECTION_ABI_VERSION */
    uint32_t struct_size;                /* sizeof(ObscuraProjectionDescriptor) */
    const char *name;                    /* the name scenes use, e.g. "CFisheye"; required, UTF-8 */
    const char *summary;                 /* one line; may be NULL */
    const ObscuraParamDecl *params;      /* num_params rows (NULL when num_params is 0) */
    size_t num_params;

    /* The factory (RixProjectionFactory). */

    /** Required. Once per session before the first create: set *factory to the plugin's (non-NULL)
     *  factory state. `self` is this descriptor; `plugin_path` the file it was loaded from. */
    ObscuraStatus (*init)(const ObscuraProjectionDescriptor *self, const char *plugin_path,
                          void **factory, const ObscuraErrorSink *error);
    /** Optional (NULL: nothing to release). Once at the end of the session. */
    void (*finalize)(void *factory);
    /** Optional. Renderer signals; `params` may be NULL. */
    void (*synchronize)(void *factory, ObscuraSyncMessage message, const ObscuraParamList *params);
    /** Required. One projection per camera: set *projection (non-NULL) on OBSCURA_OK; on failure
     *  report a message naming the parameter and what was expected. */
    ObscuraStatus (*create_projection)(void *factory, ObscuraEnvironment *env,
                                       const ObscuraParamList *params, void **projection,
                                       const ObscuraErrorSink *error);
    /** Required. Releases a projection made by create_projection. */
    void (*destroy_projection)(void *factory, void *projection);

    /* The projection (RixProjection). */

    /** Required. OBSCURA_OK with *value filled, or OBSCURA_UNSUPPORTED. */
    ObscuraStatus (*property)(const void *projection, ObscuraProjectionProperty property,
                              ObscuraPropertyValue *value);
    /** Required. Turns one batch of samples into rays. A status other than OBSCURA_OK loses the batch:
     *  the host culls and counts its samples and reports the message; the render goes on. */
    ObscuraStatus (*project)(const void *projection, const ObscuraProjectionContext *ctx,
                             const ObscuraErrorSink *error);
    /** Optional (NULL: no inverse). The screen point whose lens-centre ray passes through `point` at
     *  `time`: OBSCURA_OK with *screen filled, or OBSCURA_UNSUPPORTED outside the view. */
    ObscuraStatus (*unproject)(const void *projection, ObscuraVec3 point, float time,
                               ObscuraPoint2 *screen);
};

/** The entry point's type. Return NULL to refuse a host whose ABI version you cannot serve. */
typedef const ObscuraProjectionDescriptor *(*ObscuraProjectionEntry)(uint32_t host_abi_version);

#ifdef __cplusplus
} /* extern "C" */
#endif

#endif /* OBSCURA_PROJECTION_H */

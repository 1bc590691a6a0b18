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
 * generates the same entry point from the SDK's traits. examples/plugins/c-fisheye/fisheye.c is a
 * complete C plugin; docs/plugin-abi.md says how to build and load one.
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
 * LIFECYCLE of one plugin library:
 *   1. Load. The host opens the library (to render with it, to check it, or to list the plugin path in
 *      `obscura plugins`), calls `obscura_projection_entry` with OBSCURA_PROJECTION_ABI_VERSION, checks
 *      the descriptor and copies its parameter table. Nothing else of the plugin is called then.
 *   2. `init` once, lazily: just before the first `create_projection` of this plugin, not when the
 *      library is loaded or listed. `plugin_path` is the file the library was loaded from.
 *   3. `synchronize(factory, OBSCURA_SYNC_RENDER_BEGIN, ...)` once, before the first frame.
 *   4. `create_projection` once per camera. The host then asks `property` for each property, and calls
 *      `project` for every batch of samples (and `unproject` for tools such as `obscura stmap` and
 *      `obscura check`), from many threads.
 *   5. `destroy_projection` once per projection.
 *   6. `synchronize(factory, OBSCURA_SYNC_RENDER_END, ...)` once, after the last frame.
 *   7. `finalize` once, when the host drops its registry of projections, after every projection is
 *      destroyed. (Registries in one process that use the same library share one init/finalize: it
 *      runs when the last of them goes. A later use starts over at `init`.)
 *
 * STATUS, call by call. Only `init`, `create_projection` and `project` have an error sink; a message
 * reported during a call that returns OBSCURA_OK is dropped.
 *   init               OBSCURA_OK with a non-NULL *factory. Anything else (or OK with NULL) is an error
 *                      naming the plugin, its file and the sink's message; no projection is made.
 *   create_projection  OBSCURA_OK with a non-NULL *projection. Anything else (or OK with NULL, or a
 *                      `deep_metric` written with a value other than 0 or 1) is an error naming the
 *                      plugin and the sink's message (the host puts "<Name>: " in front: no need to).
 *   property           OBSCURA_OK with *value filled; OBSCURA_UNSUPPORTED: "not answered" (the host's
 *                      default applies, see each property). Any other status is a failed call: the
 *                      renderer warns and goes on without the property; `obscura check` fails `panic`.
 *                      A value of unknown kind, of another property's kind, or an enum value out of
 *                      range is ignored with a warning (`obscura check` fails `property_type`).
 *   project            OBSCURA_OK: every ray is then validated (see ObscuraRayGeometry).
 *                      OBSCURA_ERROR is an error: every sample of the batch is culled and counted as
 *                      "project returned an error" with the sink's message; the render goes on.
 *                      OBSCURA_PANIC is a panic (a caught C++ exception, a Rust panic): the batch is
 *                      culled and counted as "samples lost to a panic in project"; the render goes on.
 *                      Return no other value.
 *   unproject          OBSCURA_OK with *screen filled; OBSCURA_UNSUPPORTED: the point is outside the
 *                      view. Any other status is a failed call: `obscura stmap` leaves that pixel
 *                      unmapped and warns with a count; `obscura check` fails `panic`.
 *
 * Camera space is RenderMan's: the camera at the origin looking down +Z, +Y up, +X right; screen space
 * is the screen window's, y up; raster space has (0, 0) at the image's top-left corner, y down. See
 * docs/plugin-abi.md and the conventions page (shared/spec/conventions.md, outside this repository).
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
/* Status codes returned by the plugin's functions (what the host does with each: STATUS above).  */

typedef int32_t ObscuraStatus;
/** Success. */
#define OBSCURA_OK 0
/** `property`: not answered (RenderMan's k_RixSCInvalidDetail); `unproject`: outside the view. From
 *  any other call it is a failure (`project` must not return it). */
#define OBSCURA_UNSUPPORTED 1
/** Failure. From `init`, `create_projection` and `project` the message goes to the error sink first;
 *  from `project` the batch is lost and counted as "project returned an error", not as a panic. */
#define OBSCURA_ERROR 2
/** A panic or exception was caught at the boundary (message to the error sink, where there is one).
 *  From `project` the batch is lost and counted as a panic. */
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

/**
 * ObscuraParamDecl.range_flags bits.
 *
 * [range_min, range_max] applies only when OBSCURA_RANGE_LIMITED is set. Without it the parameter has
 * no range, and OBSCURA_RANGE_MIN_INCLUSIVE / OBSCURA_RANGE_MAX_INCLUSIVE mean nothing. With it, each
 * end is open unless its INCLUSIVE bit is set (LIMITED alone is the open range (min, max)), and the
 * range applies to every scalar of a float, int, color, point, vector, normal or matrix parameter
 * (strings ignore it). Any other bit set makes the host refuse the plugin when it loads, naming the
 * parameter; so do a NaN bound, range_min > range_max, and a default outside its own range.
 *
 * The host checks the scene's values before `create_projection`: NaN is never accepted, and an
 * infinite float only where the range has an inclusive infinite end (range_max = INFINITY with
 * OBSCURA_RANGE_MAX_INCLUSIVE admits an f-stop of infinity); without a range, floats must be finite.
 */
#define OBSCURA_RANGE_LIMITED 1u       /* range_min / range_max apply to every numeric scalar */
#define OBSCURA_RANGE_MIN_INCLUSIVE 2u /* range_min itself is allowed (only with LIMITED) */
#define OBSCURA_RANGE_MAX_INCLUSIVE 4u /* range_max itself is allowed (only with LIMITED) */

/** What the host tells a factory (RixSCSyncMsg), through `synchronize`. */
typedef int32_t ObscuraSyncMessage;
#define OBSCURA_SYNC_RENDER_BEGIN 0    /* once, before the first frame */
#define OBSCURA_SYNC_RENDER_END 1      /* once, after the last frame */
#define OBSCURA_SYNC_INSTANCE_EDIT 2   /* interactive edits; this host does not send it yet */

/**
 * What the host asks a projection (RixProjection::ProjectionProperty). It asks each property after
 * `create_projection` and before the first `project`; the answers are invariant for the frame.
 * Unanswered (OBSCURA_UNSUPPORTED): DicingHint is Perspective, DeepMetric the environment's
 * `deep_metric` as `create_projection` left it, FieldOfView 90°, and no thin lens. A float that is
 * not finite counts as unanswered.
 *
 * FIELD OF VIEW (degrees), by the projection's DicingHint:
 *   - Perspective: the angle across the [-1, 1] square of screen space (RenderMan's fov: across the
 *     shorter image side with the default screen window); for a zoom, the narrower end. The host's
 *     default pinhole rays and its dicing use d = 1/tan(fov/2), fov capped at 179°.
 *   - Spherical: a dicing input. The host dices at 2s/fov pixels per radian of angle seen from the
 *     camera (fov in radians; s = max(width/(r - l), height/(t - b)) pixels per screen unit, so 2s is
 *     the shorter image side with the default screen window and square pixels), fov capped at 360°.
 *     Report the angle that makes this rate the image's finest angular resolution: fov = 2s·α in
 *     degrees, α the smallest angle (radians) between the rays of neighbouring pixel centres anywhere
 *     in the image (an equidistant fisheye over the unit circle of screen space: its own fov).
 *     `obscura check` accepts, within max(2 %, 0.5°), either this rate or an extent: twice the widest
 *     angle from the ray at the window's centre, over the whole window or along its horizontal or
 *     vertical midline.
 *   - Orthographic: not used.
 *
 * FStop, FocalLength and FocalDistance describe a thin lens: when all three are answered (and
 * FocalDistance > 0) the host's default rays go through it (see ObscuraProjectionContext). A pinhole
 * when FStop is not finite and positive or FocalLength is not positive.
 */
typedef int32_t ObscuraProjectionProperty;
#define OBSCURA_PROPERTY_DICING_HINT 0    /* answered with OBSCURA_VALUE_DICING_HINT */
#define OBSCURA_PROPERTY_DEEP_METRIC 1    /* answered with OBSCURA_VALUE_DEEP_METRIC */
#define OBSCURA_PROPERTY_FIELD_OF_VIEW 2  /* degrees, OBSCURA_VALUE_FLOAT (see above, by dicing hint) */
#define OBSCURA_PROPERTY_FSTOP 3          /* OBSCURA_VALUE_FLOAT */
#define OBSCURA_PROPERTY_FOCAL_LENGTH 4   /* scene units, OBSCURA_VALUE_FLOAT */
#define OBSCURA_PROPERTY_FOCAL_DISTANCE 5 /* scene units, OBSCURA_VALUE_FLOAT */

/** DicingHint: the camera closest to the projection, for dicing and the host's default rays. */
typedef int32_t ObscuraDicingHint;
#define OBSCURA_DICING_ORTHOGRAPHIC 0 /* parallel rays: default rays orthographic, no field of view */
#define OBSCURA_DICING_PERSPECTIVE 1  /* one centre of projection; FieldOfView across [-1, 1] */
#define OBSCURA_DICING_SPHERICAL 2    /* panoramas, fisheyes; FieldOfView sets the dicing rate */

/** DeepMetric: how depth is measured, and with it how rays are clipped (see ObscuraRayGeometry). */
typedef int32_t ObscuraDeepMetric;
#define OBSCURA_DEEP_CAMERA_Z 0   /* camera-space z; all rays go toward +Z; clipping planes */
#define OBSCURA_DEEP_RAY_LENGTH 1 /* distance along the ray; rays may go toward -Z; clipping spheres */

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
 * One camera ray in camera space. After every `project` the host validates each ray: `origin` finite;
 * `direction` finite and unit length (within 10^-3), or exactly zero to cull the sample (the other
 * fields of a culled ray are not looked at); `origin_radius` and `ray_spread` finite and >= 0;
 * 0 <= min_dist <= max_dist. A ray that breaks a rule is culled and counted by kind, never traced.
 *
 * FOOTPRINT. The footprint's radius at distance t along the ray is origin_radius + ray_spread·t, and
 * it is half a pixel (the cone is one pixel across). When a pixel is not square in angle, take the
 * geometric mean: with αx and αy the angles (radians) between the ray and the rays of the
 * neighbouring pixel centres in x and in y,
 *     ray_spread = ½·sqrt(αx·αy).
 * A pinhole with its screen plane at d: αx = Δx·sqrt(sy² + d²)/L², αy = Δy·sqrt(sx² + d²)/L², with
 * L² = sx² + sy² + d² and Δx = (r - l)/width, Δy = (t - b)/height a pixel's size in screen units.
 * Parallel rays (orthographic): origin_radius = ½·sqrt(Δx·Δy), ray_spread = 0. Through a thin lens:
 * origin_radius = 0 and the pinhole's spread times |F|/|F - O| (F the focus point, O the origin), so
 * the cone has the pinhole's radius at F. `obscura check` allows 25 % against measured neighbours.
 *
 * CLIPPING. min_dist and max_dist are distances along the ray from its origin, set by the rule of the
 * projection's deep metric (its DeepMetric answer, else the environment's `deep_metric` as
 * `create_projection` left it), with near and far the environment's clipping_near and clipping_far:
 *   - OBSCURA_DEEP_CAMERA_Z: the clipping planes z = near and z = far:
 *         min_dist = (near - origin.z)/direction.z,  max_dist = (far - origin.z)/direction.z;
 *   - OBSCURA_DEEP_RAY_LENGTH (panoramic cameras): clipping spheres: min_dist = near, max_dist = far.
 * far may be +INFINITY, and so may max_dist. The host's pre-filled rays follow this rule; a projection
 * that writes its own rays must follow it too: `obscura check` checks every ray's distances against
 * the environment's clipping planes or spheres.
 */
typedef struct ObscuraRayGeometry {
    ObscuraVec3 origin;
    float origin_radius;                 /* footprint radius at the origin, camera units */
    ObscuraVec3 direction;               /* unit, or exactly zero to cull */
    float ray_spread;                    /* footprint radius growth per unit distance (1 means 45°) */
    float min_dist;                      /* clipping, along the ray: see CLIPPING above */
    float max_dist;
} ObscuraRayGeometry;

/* ---------------------------------------------------------------------------------------------- */
/* Errors.                                                                                        */

/**
 * Where a plugin sends the message of a failing call (`init`, `create_projection`, `project`).
 * `report` copies `len` bytes of UTF-8 (no NUL needed) into the host's own storage; call it during the
 * failing call only. Several calls append.
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
 * One row of the parameter table (RixSCParamInfo plus what RenderMan keeps in the .args file). The
 * host checks every row when it loads the library and refuses the plugin, naming the parameter, for an
 * unknown type, an inconsistent array length or default, a bad range (see the range_flags bits) or
 * choices on a non-string parameter.
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
    double range_min;                    /* used only when range_flags has OBSCURA_RANGE_LIMITED */
    double range_max;
    ObscuraParamType type;
    int32_t array_len;                   /* OBSCURA_ARRAY_SINGLE, n > 0, or OBSCURA_ARRAY_VARIABLE */
    uint32_t range_flags;                /* OBSCURA_RANGE_* bits; no others (refused at load) */
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
 * What the host knows about the render, handed to `create_projection`. Read-only except `deep_metric`,
 * which `create_projection` may set (RenderMan 22); answering OBSCURA_PROPERTY_DEEP_METRIC (RenderMan
 * 23+) wins over it.
 *
 * `width`, `height` and `pixel_aspect` are the Format: the full image, never the crop window. A crop
 * only chooses which pixels receive samples; it changes neither the camera nor the screen mapping.
 * The screen window is the full image's too: raster (x, y) (pixels, y down, (0, 0) the top-left
 * corner) is screen (l + (x/width)·(r - l), t - (y/height)·(t - b)), and one pixel is
 * Δx = (r - l)/width by Δy = (t - b)/height screen units.
 */
typedef struct ObscuraEnvironment {
    uint32_t struct_size;                /* sizeof(ObscuraEnvironment) as the host filled it */
    uint32_t width;                      /* pixels of the full image (Format), not the crop window */
    uint32_t height;                     /* likewise */
    float pixel_aspect;                  /* width / height of one pixel */
    float screen_left;                   /* screen window, y up */
    float screen_right;
    float screen_bottom;
    float screen_top;
    float shutter_open;                  /* scene units; open <= close */
    float shutter_close;
    float clipping_near;                 /* 0 < near < far; planes or spheres by the deep metric */
    float clipping_far;                  /* may be +INFINITY */
    ObscuraDeepMetric deep_metric;       /* in/out; arrives as OBSCURA_DEEP_CAMERA_Z */
    uint32_t num_motion_samples;         /* >= 1, sorted by time; no camera motion: one identity
                                            sample at shutter_open */
    const ObscuraMotionSample *world_to_camera;
} ObscuraEnvironment;

/* ---------------------------------------------------------------------------------------------- */
/* One batch (RixProjectionContext).                                                              */

/**
 * Every array holds `num_rays` elements. The host splits the samples into batches as it likes and
 * runs them on many threads, so a sample's output must depend on that sample alone (`obscura check`
 * compares batch orders and threads bit for bit).
 *
 * WHAT ARRIVES when `project` is called:
 *   - `rays`: the host's default camera ray for every sample, made from this projection's own answers
 *     (see ObscuraProjectionProperty) with screen point s = (sx, sy) and aperture sample a = (ax, ay):
 *       * DicingHint Orthographic: from (sx, sy, 0) along +Z, origin_radius ½·sqrt(Δx·Δy), spread 0;
 *       * otherwise (Perspective, Spherical, or unanswered): a pinhole at the origin toward
 *         (sx, sy, d), d = 1/tan(fov/2), fov the FieldOfView answer (90° when there is none, capped
 *         at 179°), ray_spread by the pinhole formula of ObscuraRayGeometry, origin_radius 0;
 *       * through a thin lens when FStop, FocalLength and FocalDistance are all answered: lens radius
 *         R = ½·FocalLength/FStop, the origin moved by (R·ax, R·ay, 0), the direction aimed at the
 *         point where the lens-centre ray meets z = FocalDistance, and the footprint of the thin-lens
 *         rule of ObscuraRayGeometry (orthographic: origin_radius ½·sqrt(Δx·Δy), spread 0);
 *       * min_dist and max_dist by the CLIPPING rule of ObscuraRayGeometry for this projection's
 *         deep metric: the planes z = near, z = far for CameraZ, the spheres near, far for RayLength.
 *   - `tint`: white (1, 1, 1).
 *   - `time`: the canonical stratified times already warped by the shutter-opening curve
 *     (shutterOpenTime, shutterCloseTime, shutteropening), in [0, 1): 0 opens the shutter, 1 closes.
 *   - `aperture`: `lens` already warped by the camera's aperture (apertureNSides, apertureAngle,
 *     apertureRoundness, apertureDensity, dofaspect).
 * So a modifier (RenderMan's PxrRollingShutter) may rewrite only time or tint; a projection with a
 * mapping of its own writes every field of every ray it does not cull. Times must stay in [0, 1).
 */
typedef struct ObscuraProjectionContext {
    uint32_t struct_size;                /* sizeof(ObscuraProjectionContext) as the host filled it */
    uint32_t num_rays;
    const ObscuraPoint2 *screen;         /* in: screen-space samples; a filter's reach past the image
                                            edge puts some a little outside the screen window */
    const ObscuraPoint2 *lens;           /* in: canonical lens samples in [0, 1)^2 */
    const ObscuraPoint2 *aperture;       /* in: lens samples warped by the aperture into [-1, 1]^2 */
    float *time;                         /* in/out: shutter-normalised time in [0, 1), already warped */
    ObscuraRayGeometry *rays;            /* in/out: the default camera rays in, the projection's out */
    ObscuraRgb *tint;                    /* in/out: multiplies the beauty before the pixel filter */
} ObscuraProjectionContext;

/** A property's answer: `kind` must be the property's (OBSCURA_VALUE_FLOAT for the four floats). */
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
    const char *name;                    /* the name scenes use, e.g. "CFisheye"; required, UTF-8, no
                                            spaces or slashes; found by search as <name>.so */
    const char *summary;                 /* one line; may be NULL */
    const ObscuraParamDecl *params;      /* num_params rows (NULL when num_params is 0) */
    size_t num_params;

    /* The factory (RixProjectionFactory). See LIFECYCLE and STATUS at the top. */

    /** Required. Once, lazily, just before the first `create_projection` of this plugin (not when the
     *  library is loaded or listed): set *factory to the plugin's (non-NULL) factory state; a
     *  stateless plugin may point at a static. `self` is this descriptor; `plugin_path` the file the
     *  library was loaded from. Any status but OBSCURA_OK fails the create, naming the file. */
    ObscuraStatus (*init)(const ObscuraProjectionDescriptor *self, const char *plugin_path,
                          void **factory, const ObscuraErrorSink *error);
    /** Optional (NULL: nothing to release). Once, when the host drops its registry, after every
     *  projection was destroyed. */
    void (*finalize)(void *factory);
    /** Optional (NULL: no signals). OBSCURA_SYNC_RENDER_BEGIN once before the first frame,
     *  OBSCURA_SYNC_RENDER_END once after the last. `params` may be NULL; when not, it is a resolved
     *  list like the one `create_projection` receives. */
    void (*synchronize)(void *factory, ObscuraSyncMessage message, const ObscuraParamList *params);
    /** Required. One projection per camera: set *projection (non-NULL) on OBSCURA_OK; on failure
     *  report a message naming the parameter and what was expected. `env` may be written only in its
     *  `deep_metric`, during this call. */
    ObscuraStatus (*create_projection)(void *factory, ObscuraEnvironment *env,
                                       const ObscuraParamList *params, void **projection,
                                       const ObscuraErrorSink *error);
    /** Required. Releases a projection made by create_projection; once per projection. */
    void (*destroy_projection)(void *factory, void *projection);

    /* The projection (RixProjection). */

    /** Required. OBSCURA_OK with *value filled (its kind the property's), or OBSCURA_UNSUPPORTED for
     *  "not answered". Any other status is a failed call: warned about, never taken for "not
     *  answered". What each property means and its default: ObscuraProjectionProperty. */
    ObscuraStatus (*property)(const void *projection, ObscuraProjectionProperty property,
                              ObscuraPropertyValue *value);
    /** Required. Turns one batch of samples into rays; the context arrives pre-filled (see
     *  ObscuraProjectionContext). OBSCURA_OK, then every ray is validated. OBSCURA_ERROR (message to
     *  the sink) is reported as an error and OBSCURA_PANIC as a panic; either way the host culls and
     *  counts the batch's samples with the message, and the render goes on. */
    ObscuraStatus (*project)(const void *projection, const ObscuraProjectionContext *ctx,
                             const ObscuraErrorSink *error);
    /** Optional (NULL: no inverse). The screen point whose lens-centre ray passes through `point` at
     *  `time`: OBSCURA_OK with *screen filled, or OBSCURA_UNSUPPORTED outside the view. Any other
     *  status is a failed call (the pixel stays unmapped in `obscura stmap`). */
    ObscuraStatus (*unproject)(const void *projection, ObscuraVec3 point, float time,
                               ObscuraPoint2 *screen);
};

/** The entry point's type. Called once per process when the host opens the library. Return NULL to
 *  refuse a host whose ABI version you cannot serve (the host reports it). */
typedef const ObscuraProjectionDescriptor *(*ObscuraProjectionEntry)(uint32_t host_abi_version);

#ifdef __cplusplus
} /* extern "C" */
#endif

#endif /* OBSCURA_PROJECTION_H */

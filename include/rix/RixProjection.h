/*
 * RixProjection.h — Obscura's RenderMan-compatible projection-plugin header, every generation.
 *
 * Written for Obscura from RenderMan's public documentation ("Writing Projections", the RixProjection,
 * RixProjectionEnvironment and RixProjectionContext reference pages); not Pixar's header.
 *
 * OBSCURA_RMAN_VERSION (see RixInterfaces.h) selects the generation where they truly conflict:
 *
 *   19–21  class X : public RixProjection is the plugin: Init(RixContext&, char const*), GetParamTable,
 *          Finalize, RenderBegin(RixContext&, RixProjectionEnvironment&, RixParameterList const*),
 *          RenderEnd, Synchronize, Project; entry macros RIX_PROJECTIONCREATE / RIX_PROJECTIONDESTROY
 *          (parameter `projection`). The context's time array is also called `shutter`.
 *   22     class XFactory : public RixProjectionFactory with Init(RixContext&, RtUString const),
 *          an overridable CreateInstanceData, and CreateProjection(RixContext&, RixProjectionEnvironment&,
 *          RtUString const, RixParameterList const*); the projection has GetProperty and Project only and
 *          writes env.deepMetric (RixProjectionEnvironment::k_rayLength).
 *   23–27  CreateProjection(RixContext&, RtUString const, RixParameterList const*); the projection's
 *          RenderBegin(RixContext&, RixProjectionEnvironment const&, RixParameterList const*); the deep
 *          metric is GetProperty(k_DeepMetric); CreateInstanceData is final.
 *   RenderMan 22+: entry macros RIX_PROJECTIONFACTORYCREATE (parameter `hint`) and
 *   RIX_PROJECTIONFACTORYDESTROY (parameter `factory`).
 *
 * Using an entry macro of another generation is a compile error that names both generations.
 * How Obscura drives these calls (order, threads, errors) is in docs/renderman-plugins.md.
 */
#ifndef OBSCURA_RIX_PROJECTION_H
#define OBSCURA_RIX_PROJECTION_H

#include "RixIntegrator.h"
#include "RixShading.h"

#define OBSCURA_RMAN_STR2(x) #x
#define OBSCURA_RMAN_STR(x) OBSCURA_RMAN_STR2(x)

/**
 * What the host knows about the render, handed to the projection: the Format (full image, never the
 * crop), the screen window (left, right, top, bottom), clipping, the shutter, and the world-to-camera
 * motion samples. RenderMan 22 (and 19–21) also has the writable `deepMetric`.
 */
class RixProjectionEnvironment {
public:
#if OBSCURA_RMAN_GENERATION <= 2
    enum DeepMetric { k_cameraZ = 0, k_rayLength = 1 };
#endif
    int m_version;
    int width, height;
    RtFloat pixelAspectRatio;
    RtFloat clippingNear, clippingFar;
    RtFloat screenWindowLeft, screenWindowRight, screenWindowTop, screenWindowBottom;
    RtFloat shutterOpen, shutterClose;
    unsigned worldToCameraNumSamples;
    RtMatrix4x4 const *worldToCameraMatrix;
    RtFloat const *worldToCameraTimes;
#if OBSCURA_RMAN_GENERATION <= 2
    /** Written by the projection: k_cameraZ (default) or k_rayLength. */
    DeepMetric deepMetric;
#endif
    char _reserved[32];

    RixProjectionEnvironment()
        : m_version(1), width(0), height(0), pixelAspectRatio(1.0f), clippingNear(0.0f), clippingFar(0.0f),
          screenWindowLeft(0.0f), screenWindowRight(0.0f), screenWindowTop(0.0f), screenWindowBottom(0.0f),
          shutterOpen(0.0f), shutterClose(0.0f), worldToCameraNumSamples(0), worldToCameraMatrix(nullptr),
          worldToCameraTimes(nullptr)
#if OBSCURA_RMAN_GENERATION <= 2
          , deepMetric(k_cameraZ)
#endif
    {
        memset(_reserved, 0, sizeof _reserved);
    }
};

/**
 * One batch of samples in, rays out. Every array has numRays elements. `rays` arrive pre-filled with
 * the host's default camera rays (and, under a built-in projection declared before the plugin, that
 * projection's rays), `tint` white, `time` already warped by the shutter opening.
 */
class RixProjectionContext : public RixContext {
public:
    int numRays;
    /* RenderMan 19-21 declared the sample arrays without const (its plugins bind non-const references
       to them); they are inputs all the same: a plugin must not write them. */
#if OBSCURA_RMAN_GENERATION == 1
    RtPoint2 *screen;         /* screen-space samples */
    RtPoint2 *lens;           /* canonical [0,1)^2 */
    RtPoint2 *aperture;       /* lens samples warped by the aperture into [-1,1]^2 */
#else
    RtPoint2 const *screen;   /* screen-space samples */
    RtPoint2 const *lens;     /* canonical [0,1)^2 */
    RtPoint2 const *aperture; /* lens samples warped by the aperture into [-1,1]^2 */
#endif
    union {
        float *time;          /* in/out, [0,1) */
        float *shutter;       /* RenderMan 21's name for the same array */
    };
    RtRayGeometry *rays;      /* in/out */
    RtColorRGB *tint;         /* in/out, multiplies the beauty before the pixel filter */

protected:
    RixProjectionContext()
        : numRays(0), screen(nullptr), lens(nullptr), aperture(nullptr), time(nullptr), rays(nullptr), tint(nullptr) {}
    ~RixProjectionContext() override {}
};

#if OBSCURA_RMAN_GENERATION == 1
/* ------------------------------------------------------------------------------------------------ */
/* RenderMan 19–21: the projection is its own plugin.                                                */

class RixProjectionFactory; /* RenderMan 22+; declared only so a mismatched source fails clearly */

class RixProjection {
public:
    virtual int GetVersion() const { return m_version; }
    virtual int Init(RixContext &ctx, char const *pluginPath) = 0;
    virtual RixSCParamInfo const *GetParamTable() = 0;
    virtual void Finalize(RixContext &ctx) = 0;
    virtual void Synchronize(RixContext &ctx, RixSCSyncMsg syncMsg, RixParameterList const *parameterList) = 0;
    virtual void RenderBegin(RixContext &ctx, RixProjectionEnvironment &env, RixParameterList const *parms) = 0;
    virtual void RenderEnd(RixContext &ctx) { PIXAR_ARGUSED(ctx); }
    virtual void Project(RixProjectionContext &pCtx) = 0;
    virtual ~RixProjection() {}

protected:
    RixProjection() : m_version(OBSCURA_RMAN_VERSION) {}
    int m_version;
};

#define RIX_PROJECTIONCREATE extern "C" OBSCURA_RMAN_EXPORT RixProjection *CreateRixProjection()
#define RIX_PROJECTIONDESTROY extern "C" OBSCURA_RMAN_EXPORT void DestroyRixProjection(RixProjection *projection)
#define RIX_PROJECTIONFACTORYCREATE                                                                          \
    static_assert(false, "RIX_PROJECTIONFACTORYCREATE is the entry of RenderMan 22-27 projection plugins, "   \
                         "but this build selected RenderMan " OBSCURA_RMAN_STR(OBSCURA_RMAN_VERSION)          \
                         " (a self-contained RixProjection): build with --rman-version 22 (or 23-27)");      \
    inline RixProjectionFactory *obscura_rman_wrong_generation_create(char const *hint)
#define RIX_PROJECTIONFACTORYDESTROY                                                                         \
    static_assert(false, "RIX_PROJECTIONFACTORYDESTROY is RenderMan 22-27's; this build selected RenderMan "   \
                         OBSCURA_RMAN_STR(OBSCURA_RMAN_VERSION));                                             \
    inline void obscura_rman_wrong_generation_destroy(RixProjectionFactory *factory)

#else
/* ------------------------------------------------------------------------------------------------ */
/* RenderMan 22–27: a factory makes projections.                                                    */

class RixProjection {
public:
    enum DicingHint { k_Orthographic = 0, k_Perspective = 1, k_Spherical = 2 };
#if OBSCURA_RMAN_GENERATION == 3
    enum DeepMetric { k_cameraZ = 0, k_rayLength = 1 };
    enum ProjectionProperty { k_DicingHint = 0, k_DeepMetric, k_FieldOfView, k_FStop, k_FocalLength, k_FocalDistance };
#else
    enum ProjectionProperty { k_DicingHint = 0, k_FieldOfView = 2, k_FStop, k_FocalLength, k_FocalDistance };
#endif

    /** Points *result at a value that lives as long as the projection; k_RixSCUniform when answered,
     *  k_RixSCInvalidDetail when not. Asked after RenderBegin (RenderMan 23+) or CreateProjection (22). */
    virtual RixSCDetail GetProperty(ProjectionProperty property, void const **result) const = 0;
#if OBSCURA_RMAN_GENERATION == 3
    virtual void RenderBegin(RixContext &ctx, RixProjectionEnvironment const &env, RixParameterList const *parms) = 0;
    virtual void RenderEnd(RixContext &ctx) { PIXAR_ARGUSED(ctx); }
#endif
    virtual void Project(RixProjectionContext &pCtx) = 0;

protected:
    RixProjection() {}
    virtual ~RixProjection() {}
};

class RixProjectionFactory : public RixShadingPlugin {
public:
    virtual int GetInterface() const { return 0; }
#if OBSCURA_RMAN_GENERATION == 2
    virtual RixProjection *CreateProjection(RixContext &ctx, RixProjectionEnvironment &env, RtUString const handle,
                                            RixParameterList const *pList) = 0;
#else
    /** Projections have no lightweight instances: never overridden (RenderMan 23+ makes it final). */
    int CreateInstanceData(RixContext &ctx, RtUString const handle, RixParameterList const *parameterList,
                           InstanceData *result) final {
        PIXAR_ARGUSED(ctx); PIXAR_ARGUSED(handle); PIXAR_ARGUSED(parameterList); PIXAR_ARGUSED(result);
        return -1;
    }
    virtual RixProjection *CreateProjection(RixContext &ctx, RtUString const handle, RixParameterList const *pList) = 0;
#endif
    virtual void DestroyProjection(RixProjection const *projection) = 0;

protected:
    RixProjectionFactory() : RixShadingPlugin(OBSCURA_RMAN_VERSION) {}
    ~RixProjectionFactory() override {}
};

#define RIX_PROJECTIONFACTORYCREATE                                                                          \
    extern "C" OBSCURA_RMAN_EXPORT RixProjectionFactory *CreateRixProjectionFactory(RtConstString hint)
#define RIX_PROJECTIONFACTORYDESTROY                                                                         \
    extern "C" OBSCURA_RMAN_EXPORT void DestroyRixProjectionFactory(RixProjectionFactory *factory)
#define RIX_PROJECTIONCREATE                                                                                 \
    static_assert(false, "RIX_PROJECTIONCREATE is the entry of RenderMan 19-21 projection plugins (a "        \
                         "self-contained RixProjection), but this build selected RenderMan "                  \
                         OBSCURA_RMAN_STR(OBSCURA_RMAN_VERSION) ": build with --rman-version 21");            \
    inline RixProjection *obscura_rman_wrong_generation_create()
#define RIX_PROJECTIONDESTROY                                                                                \
    static_assert(false, "RIX_PROJECTIONDESTROY is RenderMan 19-21's; this build selected RenderMan "        \
                         OBSCURA_RMAN_STR(OBSCURA_RMAN_VERSION));                                             \
    inline void obscura_rman_wrong_generation_destroy(RixProjection *projection)
#endif

#endif /* OBSCURA_RIX_PROJECTION_H */

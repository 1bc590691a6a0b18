// ThinLens — a thin-lens perspective camera written against RenderMan 22's projection interface, the
// way RenderMan's own perspective example is written: screen ±1 spans the field of view, the aperture
// samples scaled by the lens radius ½·focalLength/fStop, every ray aimed at the point the centre ray
// meets the plane z = focalDistance. Build: obscura build-plugin ThinLens.cpp
#include "RixProjection.h"
#include "RixIntegrator.h"
#include "RixShadingUtils.h"

#include <algorithm>
#include <cmath>

static RtUString const US_FOV("fov");
static RtUString const US_FSTOP("fStop");
static RtUString const US_FOCALLENGTH("focalLength");
static RtUString const US_FOCALDISTANCE("focalDistance");

class ThinLens : public RixProjection
{
public:
    ~ThinLens() override {}

    RixSCDetail GetProperty(ProjectionProperty property, void const** result) const override
    {
        switch (property)
        {
            case k_DicingHint: *result = &m_dicing; return k_RixSCUniform;
            case k_FieldOfView: *result = &m_fov; return k_RixSCUniform;
            case k_FStop: *result = &m_fStop; return k_RixSCUniform;
            case k_FocalLength: *result = &m_focalLength; return k_RixSCUniform;
            case k_FocalDistance: *result = &m_focalDistance; return k_RixSCUniform;
            default: return k_RixSCInvalidDetail;
        }
    }

    ThinLens(RixContext& ctx, RixProjectionEnvironment& env, RtUString const handle, RixParameterList const* parms)
    {
        PIXAR_ARGUSED(handle);
        PIXAR_ARGUSED(ctx);
        RtInt id;
        if (parms->GetParamId(US_FOV, &id) == 0) parms->EvalParam(id, 0, &m_fov);
        if (parms->GetParamId(US_FSTOP, &id) == 0) parms->EvalParam(id, 0, &m_fStop);
        if (parms->GetParamId(US_FOCALLENGTH, &id) == 0) parms->EvalParam(id, 0, &m_focalLength);
        if (parms->GetParamId(US_FOCALDISTANCE, &id) == 0) parms->EvalParam(id, 0, &m_focalDistance);

        float sw = env.screenWindowRight - env.screenWindowLeft;
        float sh = env.screenWindowTop - env.screenWindowBottom;
        if (sw == 0.0f || sh == 0.0f)
        {
            float aspect = env.width * env.pixelAspectRatio / env.height;
            sw = std::max(2.0f, 2.0f * aspect);
            sh = std::max(2.0f, 2.0f / aspect);
        }
        m_dx = sw / env.width;
        m_dy = sh / env.height;
        m_d = 1.0f / tanf(0.5f * m_fov * F_DEGTORAD);
        m_lensRadius = (m_fStop > 0.0f && m_fStop < 1e30f) ? 0.5f * m_focalLength / m_fStop : 0.0f;
    }

    void Project(RixProjectionContext& pCtx) override
    {
        for (int i = 0; i < pCtx.numRays; ++i)
        {
            RtPoint2 const& s = pCtx.screen[i];
            RtRayGeometry& ray = pCtx.rays[i];
            float sx2 = s.x * s.x, sy2 = s.y * s.y, d2 = m_d * m_d;
            float l2 = sx2 + sy2 + d2;
            // half a pixel's angle, geometric mean of x and y (Obscura's footprint convention)
            float spread = 0.5f * sqrtf(m_dx * m_dy * sqrtf((sy2 + d2) * (sx2 + d2))) / l2;
            RtVector3 dir(s.x, s.y, m_d);
            dir.Normalize();
            if (m_lensRadius > 0.0f)
            {
                RtPoint3 focus(s.x * m_focalDistance / m_d, s.y * m_focalDistance / m_d, m_focalDistance);
                ray.origin = RtPoint3(m_lensRadius * pCtx.aperture[i].x, m_lensRadius * pCtx.aperture[i].y, 0.0f);
                RtVector3 toFocus = focus - ray.origin;
                float len = toFocus.Length();
                ray.direction = toFocus / len;
                ray.raySpread = spread * focus.Length() / len;
            }
            else
            {
                ray.origin = RtPoint3(0.0f, 0.0f, 0.0f);
                ray.direction = dir;
                ray.raySpread = spread;
            }
            ray.originRadius = 0.0f;
        }
    }

private:
    DicingHint const m_dicing = k_Perspective;
    RtFloat m_fov = 90.0f;
    RtFloat m_fStop = 1e38f;
    RtFloat m_focalLength = 1.0f;
    RtFloat m_focalDistance = 1.0f;
    float m_dx = 0.0f, m_dy = 0.0f, m_d = 1.0f, m_lensRadius = 0.0f;
};

class ThinLensFactory : public RixProjectionFactory
{
public:
    int Init(RixContext& ctx, RtUString const pluginPath) override
    {
        PIXAR_ARGUSED(ctx);
        PIXAR_ARGUSED(pluginPath);
        return 0;
    }
    void Finalize(RixContext& ctx) override { PIXAR_ARGUSED(ctx); }
    RixSCParamInfo const* GetParamTable() override
    {
        static RixSCParamInfo s_ptable[] = {
            RixSCParamInfo(US_FOV, k_RixSCFloat),
            RixSCParamInfo(US_FSTOP, k_RixSCFloat),
            RixSCParamInfo(US_FOCALLENGTH, k_RixSCFloat),
            RixSCParamInfo(US_FOCALDISTANCE, k_RixSCFloat),
            RixSCParamInfo(),
        };
        return &s_ptable[0];
    }
    void Synchronize(RixContext& ctx, RixSCSyncMsg syncMsg, RixParameterList const* parms) override
    {
        PIXAR_ARGUSED(ctx);
        PIXAR_ARGUSED(syncMsg);
        PIXAR_ARGUSED(parms);
    }
    int CreateInstanceData(RixContext& ctx, RtUString handle, RixParameterList const* plist, InstanceData* result) override
    {
        PIXAR_ARGUSED(ctx);
        PIXAR_ARGUSED(handle);
        PIXAR_ARGUSED(plist);
        PIXAR_ARGUSED(result);
        return -1;
    }
    RixProjection* CreateProjection(RixContext& ctx, RixProjectionEnvironment& env, RtUString const handle,
                                    RixParameterList const* pList) override
    {
        return new ThinLens(ctx, env, handle, pList);
    }
    void DestroyProjection(RixProjection const* projection) override { delete static_cast<ThinLens const*>(projection); }
};

RIX_PROJECTIONFACTORYCREATE
{
    PIXAR_ARGUSED(hint);
    return new ThinLensFactory();
}

RIX_PROJECTIONFACTORYDESTROY
{
    delete reinterpret_cast<ThinLensFactory*>(factory);
}

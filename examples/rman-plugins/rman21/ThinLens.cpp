// ThinLens — a thin-lens perspective camera written against RenderMan 19-21's projection interface (one class is the plugin), the
// way RenderMan's own perspective example is written: screen ±1 spans the field of view, the aperture
// samples scaled by the lens radius ½·focalLength/fStop, every ray aimed at the point the centre ray
// meets the plane z = focalDistance. Build: obscura build-plugin ThinLens.cpp
#include "RixProjection.h"
#include "RixIntegrator.h"
#include "RixShadingUtils.h"

#include <algorithm>
#include <cmath>


class ThinLens : public RixProjection
{
public:
    ThinLens() {}
    virtual ~ThinLens() {}

    virtual int Init(RixContext& ctx, char const* pluginPath)
    {
        PIXAR_ARGUSED(ctx);
        PIXAR_ARGUSED(pluginPath);
        return 0;
    }

    virtual RixSCParamInfo const* GetParamTable()
    {
        static RixSCParamInfo s_ptable[] = {
            RixSCParamInfo("fov", k_RixSCFloat),
            RixSCParamInfo("fStop", k_RixSCFloat),
            RixSCParamInfo("focalLength", k_RixSCFloat),
            RixSCParamInfo("focalDistance", k_RixSCFloat),
            RixSCParamInfo(),
        };
        return &s_ptable[0];
    }

    virtual void Finalize(RixContext& ctx) { PIXAR_ARGUSED(ctx); }

    virtual void Synchronize(RixContext& ctx, RixSCSyncMsg syncMsg, RixParameterList const* parms)
    {
        PIXAR_ARGUSED(ctx);
        if (syncMsg == k_RixSCInstanceEdit)
        {
            RtInt id;
            if (parms->GetParamId("fov", &id) == 0) parms->EvalParam(id, 0, &m_fov);
            if (parms->GetParamId("fStop", &id) == 0) parms->EvalParam(id, 0, &m_fStop);
            if (parms->GetParamId("focalLength", &id) == 0) parms->EvalParam(id, 0, &m_focalLength);
            if (parms->GetParamId("focalDistance", &id) == 0) parms->EvalParam(id, 0, &m_focalDistance);
        }
    }

    virtual void RenderBegin(RixContext& ctx, RixProjectionEnvironment& env, RixParameterList const* parms)
    {
        Synchronize(ctx, k_RixSCInstanceEdit, parms);

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

    virtual void Project(RixProjectionContext& pCtx)
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
    RtFloat m_fov = 90.0f;
    RtFloat m_fStop = 1e38f;
    RtFloat m_focalLength = 1.0f;
    RtFloat m_focalDistance = 1.0f;
    float m_dx = 0.0f, m_dy = 0.0f, m_d = 1.0f, m_lensRadius = 0.0f;
};

RIX_PROJECTIONCREATE
{
    return new ThinLens();
}

RIX_PROJECTIONDESTROY
{
    delete reinterpret_cast<ThinLens*>(projection);
}

// CullingFisheye — an equidistant fisheye (RenderMan 19-21 interface: the projection is the plugin): the unit circle of screen space
// spans the field of view, θ = r·fov/2 off the axis; samples outside the circle get a zero direction
// (culled). Build: obscura build-plugin CullingFisheye.cpp
#include "RixProjection.h"
#include "RixIntegrator.h"

class CullingFisheye : public RixProjection
{
public:
    CullingFisheye() {}
    virtual ~CullingFisheye() {}

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
        }
    }

    virtual void RenderBegin(RixContext& ctx, RixProjectionEnvironment& env, RixParameterList const* parms)
    {
        Synchronize(ctx, k_RixSCInstanceEdit, parms);
        float sw = env.screenWindowRight - env.screenWindowLeft;
        float sh = env.screenWindowTop - env.screenWindowBottom;
        // a pixel's angle: screen units per pixel times radians per screen unit
        m_pixelAngle = sqrtf((sw / env.width) * (sh / env.height)) * 0.5f * m_fov * F_DEGTORAD;
    }

    virtual void Project(RixProjectionContext& pCtx)
    {
        float half = 0.5f * m_fov * F_DEGTORAD;
        for (int i = 0; i < pCtx.numRays; ++i)
        {
            RtPoint2 const& s = pCtx.screen[i];
            RtRayGeometry& ray = pCtx.rays[i];
            float r = sqrtf(s.x * s.x + s.y * s.y);
            if (r > 1.0f)
            {
                ray.direction = RtVector3(0.0f, 0.0f, 0.0f);
                continue;
            }
            float theta = r * half;
            float k = r > 0.0f ? sinf(theta) / r : half;
            ray.origin = RtPoint3(0.0f, 0.0f, 0.0f);
            ray.direction = RtVector3(s.x * k, s.y * k, cosf(theta));
            ray.direction.Normalize();
            ray.originRadius = 0.0f;
            // Half a pixel: radially the angle grows by fov/2 per screen unit, tangentially by
            // sin(θ)/r; the footprint takes the geometric mean of both.
            float across = r > 0.0f ? sinf(theta) / theta : 1.0f;
            ray.raySpread = 0.5f * m_pixelAngle * sqrtf(across);
        }
    }

private:
    RtFloat m_fov = 180.0f;
    float m_pixelAngle = 0.0f;
};

RIX_PROJECTIONCREATE
{
    return new CullingFisheye();
}

RIX_PROJECTIONDESTROY
{
    delete reinterpret_cast<CullingFisheye*>(projection);
}

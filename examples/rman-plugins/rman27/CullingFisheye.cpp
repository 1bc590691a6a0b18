// CullingFisheye — an equidistant fisheye (RenderMan 23-27 interface): the unit circle of screen space
// spans the field of view, θ = r·fov/2 off the axis; samples outside the circle get a zero direction
// (culled). Build: obscura build-plugin CullingFisheye.cpp
#include "RixProjection.h"
#include "RixIntegrator.h"

static RtUString const US_FOV("fov");

class CullingFisheye : public RixProjection
{
public:
    RixSCDetail GetProperty(ProjectionProperty property, void const** result) const override
    {
        switch (property)
        {
            case k_DicingHint: *result = &m_dicing; return k_RixSCUniform;
            case k_FieldOfView: *result = &m_fov; return k_RixSCUniform;
            case k_DeepMetric: *result = &m_deep; return k_RixSCUniform;
            default: return k_RixSCInvalidDetail;
        }
    }

    void RenderBegin(RixContext& ctx, RixProjectionEnvironment const& env, RixParameterList const* parms) override
    {
        PIXAR_ARGUSED(ctx);
        RtInt id;
        if (parms->GetParamId(US_FOV, &id) == 0) parms->EvalParam(id, 0, &m_fov);
        float sw = env.screenWindowRight - env.screenWindowLeft;
        float sh = env.screenWindowTop - env.screenWindowBottom;
        // a pixel's angle: screen units per pixel times radians per screen unit
        m_pixelAngle = sqrtf((sw / env.width) * (sh / env.height)) * 0.5f * m_fov * F_DEGTORAD;
    }

    void Project(RixProjectionContext& pCtx) override
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
    DicingHint const m_dicing = k_Spherical;
    DeepMetric const m_deep = k_rayLength;
    RtFloat m_fov = 180.0f;
    float m_pixelAngle = 0.0f;
};

class CullingFisheyeFactory : public RixProjectionFactory
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
        static RixSCParamInfo s_ptable[] = {RixSCParamInfo(US_FOV, k_RixSCFloat), RixSCParamInfo()};
        return &s_ptable[0];
    }
    void Synchronize(RixContext& ctx, RixSCSyncMsg syncMsg, RixParameterList const* parms) override
    {
        PIXAR_ARGUSED(ctx);
        PIXAR_ARGUSED(syncMsg);
        PIXAR_ARGUSED(parms);
    }
    RixProjection* CreateProjection(RixContext& ctx, RtUString const handle, RixParameterList const* pList) override
    {
        PIXAR_ARGUSED(ctx);
        PIXAR_ARGUSED(handle);
        PIXAR_ARGUSED(pList);
        return new CullingFisheye();
    }
    void DestroyProjection(RixProjection const* projection) override { delete (CullingFisheye*)projection; }
};

RIX_PROJECTIONFACTORYCREATE
{
    PIXAR_ARGUSED(hint);
    return new CullingFisheyeFactory();
}

RIX_PROJECTIONFACTORYDESTROY
{
    delete reinterpret_cast<CullingFisheyeFactory*>(factory);
}

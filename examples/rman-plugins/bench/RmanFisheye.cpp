// RmanFisheye — the equidistant fisheye of examples/plugins/c-fisheye/fisheye.c written as a RenderMan
// 23-27 projection plugin, line for line the same mapping and footprint, for the benchmark of the C++
// path against the C ABI and the built-in (crates/obscura-plugins/benches/rman_overhead.rs).
#include "RixProjection.h"
#include "RixIntegrator.h"

static RtUString const US_FOV("fov");

class RmanFisheye : public RixProjection
{
public:
    RixSCDetail GetProperty(ProjectionProperty property, void const** result) const override
    {
        switch (property)
        {
            case k_DicingHint: *result = &m_dicing; return k_RixSCUniform;
            case k_DeepMetric: *result = &m_deep; return k_RixSCUniform;
            case k_FieldOfView: *result = &m_fieldOfView; return k_RixSCUniform;
            default: return k_RixSCInvalidDetail;
        }
    }

    void RenderBegin(RixContext& ctx, RixProjectionEnvironment const& env, RixParameterList const* parms) override
    {
        PIXAR_ARGUSED(ctx);
        RtInt id;
        if (parms->GetParamId(US_FOV, &id) == 0) parms->EvalParam(id, 0, &m_fov);
        float w = env.screenWindowRight - env.screenWindowLeft;
        float h = env.screenWindowTop - env.screenWindowBottom;
        float shorter = std::min(w, h);
        m_halfFov = 0.5f * m_fov * F_PI / 180.0f;
        m_fieldOfView = shorter >= 2.0f ? m_fov : m_fov * 0.5f * shorter;
        m_halfPixel = 0.5f * sqrtf((w / env.width) * (h / env.height));
        m_fullCircle = m_fov >= 360.0f;
        m_near = env.clippingNear;
        m_far = env.clippingFar;
    }

    void Project(RixProjectionContext& pCtx) override
    {
        float const a = m_halfFov;
        for (int i = 0; i < pCtx.numRays; ++i)
        {
            float const sx = pCtx.screen[i].x, sy = pCtx.screen[i].y;
            float const r = sqrtf(sx * sx + sy * sy);
            RtRayGeometry& ray = pCtx.rays[i];
            ray.origin = RtPoint3(0.0f, 0.0f, 0.0f);
            ray.originRadius = 0.0f;
            ray.minDist = m_near;
            ray.maxDist = m_far;
            if (r > 1.0f || (m_fullCircle && r >= 1.0f))
            {
                ray.direction = RtVector3(0.0f, 0.0f, 0.0f);
                ray.raySpread = 0.0f;
                continue;
            }
            float const phi = r * a;
            float const sinPhi = sinf(phi);
            float ax2, ay2;
            if (r > 0.0f)
            {
                float const cx = sx / r, cy = sy / r, b = sinPhi / r;
                ray.direction.x = sinPhi * cx;
                ray.direction.y = sinPhi * cy;
                ax2 = a * a * cx * cx + b * b * cy * cy;
                ay2 = a * a * cy * cy + b * b * cx * cx;
            }
            else
            {
                ray.direction.x = sinPhi;
                ray.direction.y = 0.0f;
                ax2 = ay2 = a * a;
            }
            ray.direction.z = cosf(phi);
            ray.raySpread = m_halfPixel * sqrtf(sqrtf(ax2 * ay2));
        }
    }

private:
    DicingHint const m_dicing = k_Spherical;
    DeepMetric const m_deep = k_rayLength;
    RtFloat m_fov = 180.0f;
    RtFloat m_fieldOfView = 180.0f;
    float m_halfFov = 0.0f, m_halfPixel = 0.0f, m_near = 0.0f, m_far = 0.0f;
    bool m_fullCircle = false;
};

class RmanFisheyeFactory : public RixProjectionFactory
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
        return new RmanFisheye();
    }
    void DestroyProjection(RixProjection const* projection) override { delete (RmanFisheye*)projection; }
};

RIX_PROJECTIONFACTORYCREATE
{
    PIXAR_ARGUSED(hint);
    return new RmanFisheyeFactory();
}

RIX_PROJECTIONFACTORYDESTROY
{
    delete reinterpret_cast<RmanFisheyeFactory*>(factory);
}

// OdsStereo — omnidirectional stereo (RenderMan 23-27 interface), a lat-long panorama whose ray origins
// sit on a circle of diameter interpupillaryDistance, tangent to the viewing direction: the string
// parameter "eye" picks "left", "right" or "center". With u, v ∈ [-1, 1] across the screen window,
// longitude φ = u·π, latitude λ = v·π/2, direction (cos λ sin φ, sin λ, cos λ cos φ) and origin
// ∓(ipd/2)·(cos φ, 0, −sin φ) (left −, right +). Build: obscura build-plugin OdsStereo.cpp
#include "RixProjection.h"
#include "RixIntegrator.h"

static RtUString const US_EYE("eye");
static RtUString const US_IPD("interpupillaryDistance");
static RtUString const US_LEFT("left");
static RtUString const US_RIGHT("right");

class OdsStereo : public RixProjection
{
public:
    RixSCDetail GetProperty(ProjectionProperty property, void const** result) const override
    {
        switch (property)
        {
            case k_DicingHint: *result = &m_dicing; return k_RixSCUniform;
            case k_DeepMetric: *result = &m_deep; return k_RixSCUniform;
            case k_FieldOfView: *result = &m_fov; return k_RixSCUniform;
            default: return k_RixSCInvalidDetail;
        }
    }

    void RenderBegin(RixContext& ctx, RixProjectionEnvironment const& env, RixParameterList const* parms) override
    {
        PIXAR_ARGUSED(ctx);
        RtInt id;
        RtUString eye = US_LEFT;
        if (parms->GetParamId(US_EYE, &id) == 0) parms->EvalParam(id, 0, &eye);
        if (parms->GetParamId(US_IPD, &id) == 0) parms->EvalParam(id, 0, &m_ipd);
        // Compare is strcmp-like: 0 when equal.
        m_side = eye.Compare(US_LEFT) == 0 ? -1.0f : (eye.Compare(US_RIGHT) == 0 ? 1.0f : 0.0f);
        m_l = env.screenWindowLeft;
        m_r = env.screenWindowRight;
        m_b = env.screenWindowBottom;
        m_t = env.screenWindowTop;
        // half a pixel: 2π across the width, π across the height
        float ax = 2.0f * F_PI / env.width, ay = F_PI / env.height;
        m_halfPixel = 0.5f * sqrtf(ax * ay);
        // the dicing rate's angle: the finest angular resolution over the shorter side
        float s = std::max(env.width / (m_r - m_l), env.height / (m_t - m_b));
        m_fov = 2.0f * s * std::min(ax, ay) * F_RADTODEG;
    }

    void Project(RixProjectionContext& pCtx) override
    {
        for (int i = 0; i < pCtx.numRays; ++i)
        {
            RtPoint2 const& s = pCtx.screen[i];
            RtRayGeometry& ray = pCtx.rays[i];
            float u = (2.0f * s.x - m_l - m_r) / (m_r - m_l);
            float v = (2.0f * s.y - m_b - m_t) / (m_t - m_b);
            float lon = u * F_PI, lat = std::max(-1.0f, std::min(1.0f, v)) * 0.5f * F_PI;
            ray.direction = RtVector3(cosf(lat) * sinf(lon), sinf(lat), cosf(lat) * cosf(lon));
            float k = m_side * 0.5f * m_ipd;
            ray.origin = RtPoint3(k * cosf(lon), 0.0f, -k * sinf(lon));
            ray.originRadius = 0.0f;
            ray.raySpread = m_halfPixel * sqrtf(std::max(cosf(lat), 1e-4f));
        }
    }

private:
    DicingHint const m_dicing = k_Spherical;
    DeepMetric const m_deep = k_rayLength;
    RtFloat m_fov = 180.0f;
    RtFloat m_ipd = 0.065f;
    float m_side = -1.0f;
    float m_l = -1.0f, m_r = 1.0f, m_b = -1.0f, m_t = 1.0f, m_halfPixel = 0.0f;
};

class OdsStereoFactory : public RixProjectionFactory
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
            RixSCParamInfo(US_EYE, k_RixSCString),
            RixSCParamInfo(US_IPD, k_RixSCFloat),
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
    RixProjection* CreateProjection(RixContext& ctx, RtUString const handle, RixParameterList const* pList) override
    {
        PIXAR_ARGUSED(ctx);
        PIXAR_ARGUSED(handle);
        PIXAR_ARGUSED(pList);
        return new OdsStereo();
    }
    void DestroyProjection(RixProjection const* projection) override { delete (OdsStereo*)projection; }
};

RIX_PROJECTIONFACTORYCREATE
{
    PIXAR_ARGUSED(hint);
    return new OdsStereoFactory();
}

RIX_PROJECTIONFACTORYDESTROY
{
    delete reinterpret_cast<OdsStereoFactory*>(factory);
}

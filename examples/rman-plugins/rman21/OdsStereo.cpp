// OdsStereo — omnidirectional stereo (RenderMan 19-21 interface: the projection is the plugin), a lat-long panorama whose ray origins
// sit on a circle of diameter interpupillaryDistance, tangent to the viewing direction: the string
// parameter "eye" picks "left", "right" or "center". With u, v ∈ [-1, 1] across the screen window,
// longitude φ = u·π, latitude λ = v·π/2, direction (cos λ sin φ, sin λ, cos λ cos φ) and origin
// ∓(ipd/2)·(cos φ, 0, −sin φ) (left −, right +). Build: obscura build-plugin OdsStereo.cpp
#include "RixProjection.h"
#include "RixIntegrator.h"

class OdsStereo : public RixProjection
{
public:
    OdsStereo() {}
    virtual ~OdsStereo() {}

    virtual int Init(RixContext& ctx, char const* pluginPath)
    {
        PIXAR_ARGUSED(ctx);
        PIXAR_ARGUSED(pluginPath);
        return 0;
    }

    virtual RixSCParamInfo const* GetParamTable()
    {
        static RixSCParamInfo s_ptable[] = {
            RixSCParamInfo("eye", k_RixSCString),
            RixSCParamInfo("interpupillaryDistance", k_RixSCFloat),
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
            RtConstString eye = "left";
            if (parms->GetParamId("eye", &id) == 0) parms->EvalParam(id, 0, &eye);
            if (parms->GetParamId("interpupillaryDistance", &id) == 0) parms->EvalParam(id, 0, &m_ipd);
            // the eye by name; any other value is the centre
            m_side = strcmp(eye, "left") == 0 ? -1.0f : (strcmp(eye, "right") == 0 ? 1.0f : 0.0f);
        }
    }

    virtual void RenderBegin(RixContext& ctx, RixProjectionEnvironment& env, RixParameterList const* parms)
    {
        Synchronize(ctx, k_RixSCInstanceEdit, parms);
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

    virtual void Project(RixProjectionContext& pCtx)
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
    RtFloat m_fov = 180.0f;
    RtFloat m_ipd = 0.065f;
    float m_side = -1.0f;
    float m_l = -1.0f, m_r = 1.0f, m_b = -1.0f, m_t = 1.0f, m_halfPixel = 0.0f;
};

RIX_PROJECTIONCREATE
{
    return new OdsStereo();
}

RIX_PROJECTIONDESTROY
{
    delete reinterpret_cast<OdsStereo*>(projection);
}

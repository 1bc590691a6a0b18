// FourView — a four-view contact-sheet camera (RenderMan 19-21 interface: the projection is the plugin): the screen window's
// quadrants are four pinhole cameras of field of view `fov`, each placed by a matrix parameter
// (view0 top-left, view1 top-right, view2 bottom-left, view3 bottom-right; camera-to-view, row
// vectors as RenderMan's). In a quadrant, with u, v ∈ [-1, 1] across the whole window, the local screen
// point is (2u ∓ 1, 2v ∓ 1), the ray normalize(lu, lv, 1/tan(fov/2)) turned by the view's matrix and
// starting at its translation. Build: obscura build-plugin FourView.cpp
#include "RixProjection.h"
#include "RixIntegrator.h"
#include "RixShadingUtils.h"

static RtUString const US_VIEW[4] = {RtUString("view0"), RtUString("view1"), RtUString("view2"), RtUString("view3")};

class FourView : public RixProjection
{
public:
    FourView() {}
    virtual ~FourView() {}

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
            RixSCParamInfo("view0", k_RixSCMatrix),
            RixSCParamInfo("view1", k_RixSCMatrix),
            RixSCParamInfo("view2", k_RixSCMatrix),
            RixSCParamInfo("view3", k_RixSCMatrix),
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
            static char const* const views[4] = {"view0", "view1", "view2", "view3"};
            RtInt id;
            if (parms->GetParamId("fov", &id) == 0) parms->EvalParam(id, 0, &m_fov);
            for (int q = 0; q < 4; ++q)
                if (parms->GetParamId(views[q], &id) == 0) parms->EvalParam(id, 0, &m_view[q]);
        }
    }

    virtual void RenderBegin(RixContext& ctx, RixProjectionEnvironment& env, RixParameterList const* parms)
    {
        Synchronize(ctx, k_RixSCInstanceEdit, parms);
        m_l = env.screenWindowLeft;
        m_r = env.screenWindowRight;
        m_b = env.screenWindowBottom;
        m_t = env.screenWindowTop;
        m_d = 1.0f / tanf(0.5f * m_fov * F_DEGTORAD);
        // half a pixel at a quadrant's centre: a quadrant spans 2 local units over half the pixels
        float dx = 4.0f / env.width, dy = 4.0f / env.height;
        m_halfPixel = 0.5f * sqrtf(dx * dy);
        // dicing: the finest angle between neighbouring pixels (at a quadrant's corner, |lu| = |lv| = 1,
        // it is Δ·sqrt(1 + d²)/(2 + d²)) as a rate over the shorter side's pixels
        float s = std::max(env.width / (m_r - m_l), env.height / (m_t - m_b));
        float finest = std::min(dx, dy) * sqrtf(1.0f + m_d * m_d) / (2.0f + m_d * m_d);
        m_dicingFov = std::min(360.0f, 2.0f * s * finest * F_RADTODEG);
    }

    virtual void Project(RixProjectionContext& pCtx)
    {
        for (int i = 0; i < pCtx.numRays; ++i)
        {
            RtPoint2 const& s = pCtx.screen[i];
            RtRayGeometry& ray = pCtx.rays[i];
            float u = (2.0f * s.x - m_l - m_r) / (m_r - m_l);
            float v = (2.0f * s.y - m_b - m_t) / (m_t - m_b);
            int q = (u >= 0.0f ? 1 : 0) + (v < 0.0f ? 2 : 0);
            float lu = 2.0f * u - (u >= 0.0f ? 1.0f : -1.0f);
            float lv = 2.0f * v - (v >= 0.0f ? 1.0f : -1.0f);
            RtVector3 local(lu, lv, m_d);
            float l2 = local.LengthSq();
            local.Normalize();
            RtVector3 dir = m_view[q].vTransform(local);
            dir.Normalize();
            ray.direction = dir;
            ray.origin = m_view[q].pTransform(RtPoint3(0.0f, 0.0f, 0.0f));
            ray.originRadius = 0.0f;
            ray.raySpread = m_halfPixel * sqrtf(sqrtf((lu * lu + m_d * m_d) * (lv * lv + m_d * m_d))) / l2;
        }
    }

private:
    RtFloat m_fov = 90.0f;
    RtFloat m_dicingFov = 90.0f;
    RtMatrix4x4 m_view[4];
    float m_l = -1.0f, m_r = 1.0f, m_b = -1.0f, m_t = 1.0f, m_d = 1.0f, m_halfPixel = 0.0f;
};

RIX_PROJECTIONCREATE
{
    return new FourView();
}

RIX_PROJECTIONDESTROY
{
    delete reinterpret_cast<FourView*>(projection);
}

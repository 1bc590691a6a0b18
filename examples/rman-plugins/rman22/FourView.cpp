// FourView — a four-view contact-sheet camera (RenderMan 22 interface): the screen window's
// quadrants are four pinhole cameras of field of view `fov`, each placed by a matrix parameter
// (view0 top-left, view1 top-right, view2 bottom-left, view3 bottom-right; camera-to-view, row
// vectors as RenderMan's). In a quadrant, with u, v ∈ [-1, 1] across the whole window, the local screen
// point is (2u ∓ 1, 2v ∓ 1), the ray normalize(lu, lv, 1/tan(fov/2)) turned by the view's matrix and
// starting at its translation. Build: obscura build-plugin FourView.cpp
#include "RixProjection.h"
#include "RixIntegrator.h"
#include "RixShadingUtils.h"

static RtUString const US_FOV("fov");
static RtUString const US_VIEW[4] = {RtUString("view0"), RtUString("view1"), RtUString("view2"), RtUString("view3")};

class FourView : public RixProjection
{
public:
    RixSCDetail GetProperty(ProjectionProperty property, void const** result) const override
    {
        switch (property)
        {
            case k_DicingHint: *result = &m_dicing; return k_RixSCUniform;
            case k_FieldOfView: *result = &m_dicingFov; return k_RixSCUniform;
            default: return k_RixSCInvalidDetail;
        }
    }

    FourView(RixContext& ctx, RixProjectionEnvironment& env, RtUString const handle, RixParameterList const* parms)
    {
        PIXAR_ARGUSED(handle);
        env.deepMetric = RixProjectionEnvironment::k_rayLength;
        PIXAR_ARGUSED(ctx);
        RtInt id;
        if (parms->GetParamId(US_FOV, &id) == 0) parms->EvalParam(id, 0, &m_fov);
        for (int q = 0; q < 4; ++q)
            if (parms->GetParamId(US_VIEW[q], &id) == 0) parms->EvalParam(id, 0, &m_view[q]);
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

    void Project(RixProjectionContext& pCtx) override
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
    DicingHint const m_dicing = k_Spherical;
    RtFloat m_fov = 90.0f;
    RtFloat m_dicingFov = 90.0f;
    RtMatrix4x4 m_view[4];
    float m_l = -1.0f, m_r = 1.0f, m_b = -1.0f, m_t = 1.0f, m_d = 1.0f, m_halfPixel = 0.0f;
};

class FourViewFactory : public RixProjectionFactory
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
            RixSCParamInfo(US_VIEW[0], k_RixSCMatrix),
            RixSCParamInfo(US_VIEW[1], k_RixSCMatrix),
            RixSCParamInfo(US_VIEW[2], k_RixSCMatrix),
            RixSCParamInfo(US_VIEW[3], k_RixSCMatrix),
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
        return new FourView(ctx, env, handle, pList);
    }
    void DestroyProjection(RixProjection const* projection) override { delete static_cast<FourView const*>(projection); }
};

RIX_PROJECTIONFACTORYCREATE
{
    PIXAR_ARGUSED(hint);
    return new FourViewFactory();
}

RIX_PROJECTIONFACTORYDESTROY
{
    delete reinterpret_cast<FourViewFactory*>(factory);
}

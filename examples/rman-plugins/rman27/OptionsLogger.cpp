// OptionsLogger — an orthographic camera (RenderMan 23-27 interface) that reads the render's options
// through RixRenderState and logs through RixMessages: the image size from "DeviceResolution" and the
// screen window from "Ri:ScreenWindow" give the pixel footprint, ½·sqrt(Δx·Δy)·scale with
// Δx = (right − left)/width, Δy = (top − bottom)/height; rays start at (sx·scale, sy·scale, 0) along +Z.
// Build: obscura build-plugin OptionsLogger.cpp
#include "RixProjection.h"
#include "RixIntegrator.h"
#include "RixInterfaces.h"

static RtUString const US_SCALE("scale");

class OptionsLogger : public RixProjection
{
public:
    RixSCDetail GetProperty(ProjectionProperty property, void const** result) const override
    {
        if (property == k_DicingHint)
        {
            *result = &m_dicing;
            return k_RixSCUniform;
        }
        return k_RixSCInvalidDetail;
    }

    void RenderBegin(RixContext& ctx, RixProjectionEnvironment const& env, RixParameterList const* parms) override
    {
        PIXAR_ARGUSED(env);
        m_msg = (RixMessages*)ctx.GetRixInterface(k_RixMessages);
        RixRenderState& state = *reinterpret_cast<RixRenderState*>(ctx.GetRixInterface(k_RixRenderState));
        RtInt id;
        if (parms->GetParamId(US_SCALE, &id) == 0) parms->EvalParam(id, 0, &m_scale);

        RixRenderState::Type type;
        int count = 0;
        float res[3] = {0, 0, 0};
        float window[4] = {0, 0, 0, 0};
        if (state.GetOption("DeviceResolution", res, sizeof(res), &type, &count) != 0 ||
            state.GetOption("Ri:ScreenWindow", window, sizeof(window), &type, &count) != 0)
        {
            m_msg->Error("OptionsLogger: the render state has no DeviceResolution or Ri:ScreenWindow");
            return;
        }
        float dx = (window[1] - window[0]) / res[0];
        float dy = (window[3] - window[2]) / res[1];
        m_radius = 0.5f * sqrtf(fabsf(dx * dy)) * m_scale;
        m_msg->Info("OptionsLogger: %dx%d pixels, screen window [%g %g %g %g], scale %g", (int)res[0], (int)res[1],
                    window[0], window[1], window[2], window[3], m_scale);
    }

    void RenderEnd(RixContext& ctx) override
    {
        PIXAR_ARGUSED(ctx);
        if (m_msg) m_msg->Info("OptionsLogger: render ended");
    }

    void Project(RixProjectionContext& pCtx) override
    {
        for (int i = 0; i < pCtx.numRays; ++i)
        {
            RtRayGeometry& ray = pCtx.rays[i];
            ray.origin = RtPoint3(pCtx.screen[i].x * m_scale, pCtx.screen[i].y * m_scale, 0.0f);
            ray.direction = RtVector3(0.0f, 0.0f, 1.0f);
            ray.originRadius = m_radius;
            ray.raySpread = 0.0f;
        }
    }

private:
    DicingHint const m_dicing = k_Orthographic;
    RtFloat m_scale = 1.0f;
    float m_radius = 0.0f;
    RixMessages* m_msg = nullptr;
};

class OptionsLoggerFactory : public RixProjectionFactory
{
public:
    int Init(RixContext& ctx, RtUString const pluginPath) override
    {
        RixMessages* msg = (RixMessages*)ctx.GetRixInterface(k_RixMessages);
        msg->Info("OptionsLogger: loaded from %s", pluginPath.CStr());
        return 0;
    }
    void Finalize(RixContext& ctx) override { PIXAR_ARGUSED(ctx); }
    RixSCParamInfo const* GetParamTable() override
    {
        static RixSCParamInfo s_ptable[] = {RixSCParamInfo(US_SCALE, k_RixSCFloat, k_RixSCInput), RixSCParamInfo()};
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
        return new OptionsLogger();
    }
    void DestroyProjection(RixProjection const* projection) override { delete (OptionsLogger*)projection; }
};

RIX_PROJECTIONFACTORYCREATE
{
    PIXAR_ARGUSED(hint);
    return new OptionsLoggerFactory();
}

RIX_PROJECTIONFACTORYDESTROY
{
    delete reinterpret_cast<OptionsLoggerFactory*>(factory);
}

// OptionsLogger — an orthographic camera (RenderMan 19-21 interface: the projection is the plugin) that reads the render's options
// through RixRenderState and logs through RixMessages: the image size from "DeviceResolution" and the
// screen window from "Ri:ScreenWindow" give the pixel footprint, ½·sqrt(Δx·Δy)·scale with
// Δx = (right − left)/width, Δy = (top − bottom)/height; rays start at (sx·scale, sy·scale, 0) along +Z.
// Build: obscura build-plugin OptionsLogger.cpp
#include "RixProjection.h"
#include "RixIntegrator.h"
#include "RixInterfaces.h"

class OptionsLogger : public RixProjection
{
public:
    OptionsLogger() {}
    virtual ~OptionsLogger() {}

    virtual int Init(RixContext& ctx, char const* pluginPath)
    {
        PIXAR_ARGUSED(ctx);
        PIXAR_ARGUSED(pluginPath);
        return 0;
    }

    virtual RixSCParamInfo const* GetParamTable()
    {
        static RixSCParamInfo s_ptable[] = {
            RixSCParamInfo("scale", k_RixSCFloat, k_RixSCInput),
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
            if (parms->GetParamId("scale", &id) == 0) parms->EvalParam(id, 0, &m_scale);
        }
    }

    virtual void RenderBegin(RixContext& ctx, RixProjectionEnvironment& env, RixParameterList const* parms)
    {
        Synchronize(ctx, k_RixSCInstanceEdit, parms);
        PIXAR_ARGUSED(env);
        m_msg = (RixMessages*)ctx.GetRixInterface(k_RixMessages);
        RixRenderState& state = *reinterpret_cast<RixRenderState*>(ctx.GetRixInterface(k_RixRenderState));

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

    virtual void RenderEnd(RixContext& ctx)
    {
        PIXAR_ARGUSED(ctx);
        if (m_msg) m_msg->Info("OptionsLogger: render ended");
    }

    virtual void Project(RixProjectionContext& pCtx)
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
    RtFloat m_scale = 1.0f;
    float m_radius = 0.0f;
    RixMessages* m_msg = nullptr;
};

RIX_PROJECTIONCREATE
{
    return new OptionsLogger();
}

RIX_PROJECTIONDESTROY
{
    delete reinterpret_cast<OptionsLogger*>(projection);
}

// TimeTint — a projection modifier (RenderMan 19-21 interface: the projection is the plugin): it writes no ray, only time and tint.
// Declared after a built-in projection (Projection "PxrPerspective" …, then Projection "TimeTint"),
// it edits that camera's rays: a stroboscope that holds time at `strobes` instants,
// t' = floor(t·strobes)/strobes, and multiplies the beauty by the colour `tint`.
// Build: obscura build-plugin TimeTint.cpp
#include "RixProjection.h"
#include "RixIntegrator.h"

class TimeTint : public RixProjection
{
public:
    TimeTint() {}
    virtual ~TimeTint() {}

    virtual int Init(RixContext& ctx, char const* pluginPath)
    {
        PIXAR_ARGUSED(ctx);
        PIXAR_ARGUSED(pluginPath);
        return 0;
    }

    virtual RixSCParamInfo const* GetParamTable()
    {
        static RixSCParamInfo s_ptable[] = {
            RixSCParamInfo("strobes", k_RixSCInteger),
            RixSCParamInfo("tint", k_RixSCColor),
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
            if (parms->GetParamId("strobes", &id) == 0) parms->EvalParam(id, 0, &m_strobes);
            if (parms->GetParamId("tint", &id) == 0) parms->EvalParam(id, 0, &m_tint);
            m_strobes = std::max(1, m_strobes);
        }
    }

    virtual void RenderBegin(RixContext& ctx, RixProjectionEnvironment& env, RixParameterList const* parms)
    {
        Synchronize(ctx, k_RixSCInstanceEdit, parms);
        PIXAR_ARGUSED(env);
    }

    virtual void Project(RixProjectionContext& pCtx)
    {
        for (int i = 0; i < pCtx.numRays; ++i)
        {
            pCtx.shutter[i] = floorf(pCtx.shutter[i] * m_strobes) / m_strobes;
            pCtx.tint[i] = pCtx.tint[i] * m_tint;
        }
    }

private:
    RtInt m_strobes = 4;
    RtColorRGB m_tint = RtColorRGB(1.0f);
};

RIX_PROJECTIONCREATE
{
    return new TimeTint();
}

RIX_PROJECTIONDESTROY
{
    delete reinterpret_cast<TimeTint*>(projection);
}

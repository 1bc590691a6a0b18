// TimeTint — a projection modifier (RenderMan 22 interface): it writes no ray, only time and tint.
// Declared after a built-in projection (Projection "PxrPerspective" …, then Projection "TimeTint"),
// it edits that camera's rays: a stroboscope that holds time at `strobes` instants,
// t' = floor(t·strobes)/strobes, and multiplies the beauty by the colour `tint`.
// Build: obscura build-plugin TimeTint.cpp
#include "RixProjection.h"
#include "RixIntegrator.h"

static RtUString const US_STROBES("strobes");
static RtUString const US_TINT("tint");

class TimeTint : public RixProjection
{
public:
    RixSCDetail GetProperty(ProjectionProperty property, void const** result) const override
    {
        PIXAR_ARGUSED(property);
        PIXAR_ARGUSED(result);
        return k_RixSCInvalidDetail;
    }

    TimeTint(RixContext& ctx, RixProjectionEnvironment& env, RtUString const handle, RixParameterList const* parms)
    {
        PIXAR_ARGUSED(handle);
        PIXAR_ARGUSED(ctx);
        PIXAR_ARGUSED(env);
        RtInt id;
        if (parms->GetParamId(US_STROBES, &id) == 0) parms->EvalParam(id, 0, &m_strobes);
        if (parms->GetParamId(US_TINT, &id) == 0) parms->EvalParam(id, 0, &m_tint);
        m_strobes = std::max(1, m_strobes);
    }

    void Project(RixProjectionContext& pCtx) override
    {
        for (int i = 0; i < pCtx.numRays; ++i)
        {
            // RenderMan 22 style: through the ray's own time field
            RtRayGeometry& ray = pCtx.rays[i];
            ray.time = floorf(ray.time * m_strobes) / m_strobes;
            pCtx.tint[i] = pCtx.tint[i] * m_tint;
        }
    }

private:
    RtInt m_strobes = 4;
    RtColorRGB m_tint = RtColorRGB(1.0f);
};

class TimeTintFactory : public RixProjectionFactory
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
            RixSCParamInfo(US_STROBES, k_RixSCInteger),
            RixSCParamInfo(US_TINT, k_RixSCColor),
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
        return new TimeTint(ctx, env, handle, pList);
    }
    void DestroyProjection(RixProjection const* projection) override { delete (TimeTint*)projection; }
};

RIX_PROJECTIONFACTORYCREATE
{
    PIXAR_ARGUSED(hint);
    return new TimeTintFactory();
}

RIX_PROJECTIONFACTORYDESTROY
{
    delete reinterpret_cast<TimeTintFactory*>(factory);
}

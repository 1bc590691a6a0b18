// Broken — a RenderMan 23-27 projection with one mistake chosen by a -D definition, for the tests of
// located errors (crates/obscura-cli/tests/rman_plugins.rs). Without one it is a correct pinhole.
#include "RixProjection.h"
#include "RixIntegrator.h"

#include <stdexcept>

class Broken : public RixProjection
{
public:
    Broken()
    {
#ifdef THROW_IN_PROJECTION_CONSTRUCTOR
        throw std::runtime_error("the lens table is missing");
#endif
    }
    ~Broken() override {}

    RixSCDetail GetProperty(ProjectionProperty property, void const** result) const override
    {
#ifdef NULL_PROPERTY
        if (property == k_FieldOfView)
        {
            *result = nullptr;
            return k_RixSCUniform;
        }
#endif
        if (property == k_DicingHint)
        {
            *result = &m_dicing;
            return k_RixSCUniform;
        }
        return k_RixSCInvalidDetail;
    }

    void RenderBegin(RixContext& ctx, RixProjectionEnvironment const& env, RixParameterList const* parms) override
    {
        PIXAR_ARGUSED(ctx);
        PIXAR_ARGUSED(env);
        PIXAR_ARGUSED(parms);
    }

    void Project(RixProjectionContext& pCtx) override
    {
#ifdef THROW_IN_PROJECT
        if (pCtx.numRays > 0) throw std::out_of_range("sample outside the distortion grid");
#endif
        for (int i = 0; i < pCtx.numRays; ++i)
        {
            pCtx.rays[i].direction = RtVector3(pCtx.screen[i].x, pCtx.screen[i].y, 1.0f);
            pCtx.rays[i].direction.Normalize();
        }
    }

private:
    DicingHint const m_dicing = k_Perspective;
};

class BrokenFactory : public RixProjectionFactory
{
public:
    BrokenFactory()
    {
#ifdef THROW_IN_FACTORY_CONSTRUCTOR
        throw std::runtime_error("no licence for this camera");
#endif
    }
    int Init(RixContext& ctx, RtUString const pluginPath) override
    {
        PIXAR_ARGUSED(ctx);
        PIXAR_ARGUSED(pluginPath);
        return 0;
    }
    void Finalize(RixContext& ctx) override { PIXAR_ARGUSED(ctx); }
    RixSCParamInfo const* GetParamTable() override
    {
#ifdef NULL_TABLE
        return nullptr;
#else
        static RixSCParamInfo s_ptable[] = {RixSCParamInfo()};
        return &s_ptable[0];
#endif
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
#ifdef NULL_PROJECTION
        return nullptr;
#else
        return new Broken();
#endif
    }
    void DestroyProjection(RixProjection const* projection) override { delete static_cast<Broken const*>(projection); }
};

RIX_PROJECTIONFACTORYCREATE
{
    PIXAR_ARGUSED(hint);
#ifdef NULL_FACTORY
    return nullptr;
#else
    return new BrokenFactory();
#endif
}

RIX_PROJECTIONFACTORYDESTROY
{
    delete reinterpret_cast<BrokenFactory*>(factory);
}

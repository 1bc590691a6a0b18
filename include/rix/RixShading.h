/*
 * RixShading.h — Obscura's RenderMan-compatible plugin headers: parameter tables, parameter lists,
 * synchronisation messages and the shading-plugin base class. Written for Obscura from RenderMan's
 * public documentation; see RixInterfaces.h for the generation macro.
 */
#ifndef OBSCURA_RIX_SHADING_H
#define OBSCURA_RIX_SHADING_H

#include "RixInterfaces.h"

/** A parameter's type. */
enum RixSCType {
    k_RixSCInvalidType = 0,
    k_RixSCInteger,
    k_RixSCFloat,
    k_RixSCFloat2,
    k_RixSCFloat3,
    k_RixSCColor,
    k_RixSCPoint,
    k_RixSCVector,
    k_RixSCNormal,
    k_RixSCMatrix,
    k_RixSCString,
};

/** How a value varies; for projections only Uniform (answered) and InvalidDetail (not) occur. */
enum RixSCDetail {
    k_RixSCInvalidDetail = 0,
    k_RixSCUniform,
    k_RixSCVertex,
    k_RixSCVarying,
    k_RixSCFaceVarying,
    k_RixSCReference,
};

/** Input or output parameter. Projections have inputs only: output rows are ignored. */
enum RixSCAccess {
    k_RixSCInput = 0,
    k_RixSCOutput,
};

/** Whether a parameter is connected (projections' parameters never are). */
enum RixSCConnectionInfo {
    k_RixSCDefaultValue = 0,
    k_RixSCParameterListValue,
    k_RixSCNetworkValue,
    k_RixSCAnyValue,
};

/** What Synchronize is told. Obscura sends RenderBegin, RenderEnd and InstanceEdit. */
enum RixSCSyncMsg {
    k_RixSCRenderBegin = 0,
    k_RixSCRenderEnd,
    k_RixSCInstanceEdit,
    k_RixSCCancel,
    k_RixSCCheckpointRecover,
    k_RixSCCheckpointWrite,
    k_RixSCIncrementBarrier,
};

/**
 * One row of a plugin's parameter table; a default-constructed row ends the table. `arraySize` -1 is a
 * single value, n > 0 a fixed array (float[n]), 0 a variable-length float array. Defaults live in the
 * plugin's code (and in Args/<Name>.args), not here.
 */
struct RixSCParamInfo {
    RtUString name;
    RtUString customtype;
    RixSCType type;
    RixSCAccess access;
    int arraySize;
    bool isArray;

    RixSCParamInfo()
        : name(), customtype(), type(k_RixSCInvalidType), access(k_RixSCInput), arraySize(-1), isArray(false) {}
    RixSCParamInfo(RtUString const nm, RixSCType t, RixSCAccess a = k_RixSCInput, int len = -1)
        : name(nm), customtype(), type(t), access(a), arraySize(len), isArray(len >= 0) {}
    RixSCParamInfo(char const *nm, RixSCType t, RixSCAccess a = k_RixSCInput, int len = -1)
        : name(nm), customtype(), type(t), access(a), arraySize(len), isArray(len >= 0) {}
    /** Whether this is the terminating row. */
    bool IsEnd() const { return name.Empty() && type == k_RixSCInvalidType; }
};

/**
 * The parameters a scene gave a projection. GetParamId returns 0 (found) and the row's position in the
 * plugin's table as the id, or non-zero when the scene did not give the parameter (declared or not).
 * EvalParam writes the value and returns k_RixSCUniform; for an id the scene did not give, or a
 * destination of another type, it returns k_RixSCInvalidDetail and leaves the destination untouched, so
 * a plugin's own default stays. Colour, point, vector and normal values are interchangeable.
 */
class RixParameterList {
public:
    /** How many rows the plugin's table has (given or not). */
    virtual int GetNumParams() const = 0;
    virtual int GetParamId(RtUString const name, int *id) const = 0;
    int GetParamId(char const *name, int *id) const { return GetParamId(RtUString(name), id); }
    /** Type and array length of row `id`; non-zero for an id outside the table. */
    virtual int GetParamInfo(int id, RixSCType *type, RixSCConnectionInfo *cinfo, int *arrayLength = nullptr) const = 0;

    RixSCDetail EvalParam(int id, int arrayIndex, RtFloat *v) const { return Eval(id, arrayIndex, k_RixSCFloat, v); }
    RixSCDetail EvalParam(int id, int arrayIndex, RtInt *v) const { return Eval(id, arrayIndex, k_RixSCInteger, v); }
    RixSCDetail EvalParam(int id, int arrayIndex, RtUString *v) const { return Eval(id, arrayIndex, k_RixSCString, v); }
    RixSCDetail EvalParam(int id, int arrayIndex, RtConstString *v) const {
        RtUString s;
        RixSCDetail d = Eval(id, arrayIndex, k_RixSCString, &s);
        if (d != k_RixSCInvalidDetail) *v = s.CStr();
        return d;
    }
    RixSCDetail EvalParam(int id, int arrayIndex, RtColorRGB *v) const { return Eval(id, arrayIndex, k_RixSCColor, v); }
    RixSCDetail EvalParam(int id, int arrayIndex, RtFloat3 *v) const { return Eval(id, arrayIndex, k_RixSCFloat3, v); }
    RixSCDetail EvalParam(int id, int arrayIndex, RtMatrix4x4 *v) const { return Eval(id, arrayIndex, k_RixSCMatrix, v); }

    /** The one evaluator behind EvalParam: `want` names the destination's type. */
    virtual RixSCDetail Eval(int id, int arrayIndex, RixSCType want, void *out) const = 0;

protected:
    virtual ~RixParameterList() {}
};

#if OBSCURA_RMAN_GENERATION >= 2
/** What every RenderMan 22+ shading plugin factory is: Init/Finalize once, a parameter table, signals. */
class RixShadingPlugin {
public:
    /** Lightweight instance data (projections have none; see RixProjectionFactory). */
    struct InstanceData {
        RtPointer data;
        size_t datalen;
        void (*freefunc)(RtPointer);
        InstanceData() : data(nullptr), datalen(0), freefunc(nullptr) {}
    };
    enum SynchronizeHints { k_None = 0, k_All = 0xFFFFFFFF };

    virtual int GetVersion() const { return m_version; }
    virtual int Init(RixContext &ctx, RtUString const pluginPath) = 0;
    virtual RixSCParamInfo const *GetParamTable() = 0;
    virtual void Finalize(RixContext &ctx) = 0;
    virtual void Synchronize(RixContext &ctx, RixSCSyncMsg syncMsg, RixParameterList const *parameterList) = 0;
    virtual int CreateInstanceData(RixContext &ctx, RtUString const handle, RixParameterList const *parameterList,
                                   InstanceData *result) {
        PIXAR_ARGUSED(ctx); PIXAR_ARGUSED(handle); PIXAR_ARGUSED(parameterList); PIXAR_ARGUSED(result);
        return -1;
    }

protected:
    explicit RixShadingPlugin(int version) : m_version(version) {}
    virtual ~RixShadingPlugin() {}
    int m_version;
};
#endif

#endif /* OBSCURA_RIX_SHADING_H */

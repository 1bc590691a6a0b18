/*
 * obscura_rman_glue.cpp — turns a RenderMan projection plugin (a RixProjectionFactory, or a RenderMan
 * 19–21 self-contained RixProjection) into an Obscura plugin: it implements Obscura's C ABI entry
 * `obscura_projection_entry` (obscura/projection.h) on top of the plugin's classes. `obscura build-plugin`
 * compiles it into every RenderMan-style plugin, with the same OBSCURA_RMAN_VERSION as the plugin's source.
 *
 * What each Obscura call becomes, in RenderMan's order:
 *   library load (entry)   RIX_PROJECTIONFACTORYCREATE (19–21: RIX_PROJECTIONCREATE), GetParamTable, the
 *                          table translated into Obscura's (one row per input parameter)
 *   init                   Init(ctx, pluginPath) once (19–21: per projection object, see create)
 *   synchronize            Synchronize(ctx, k_RixSCRenderBegin / k_RixSCRenderEnd / k_RixSCInstanceEdit)
 *   create_projection      23–27: CreateProjection(ctx, handle, params), RenderBegin(ctx, env, params);
 *                          22: CreateProjection(ctx, env, handle, params), env.deepMetric read back;
 *                          19–21: RIX_PROJECTIONCREATE, Init, RenderBegin(ctx, env, params)
 *                          then every property is asked once to check its pointer
 *   property               GetProperty, the answer read through the pointer it hands back (19–21, which
 *                          have no GetProperty: dicing Spherical, deep metric RayLength, the description
 *                          that holds for any rays)
 *   project                Project on the batch (rays pre-filled by the host)
 *   destroy_projection     RenderEnd (23–27, 19–21), DestroyProjection (19–21: Finalize,
 *                          RIX_PROJECTIONDESTROY)
 *   finalize               Finalize(ctx)
 * A C++ exception never crosses into the host: it becomes the call's error, naming the plugin and the
 * RenderMan method that threw.
 */
#include "RixProjection.h"

#include <obscura/projection.h>

#include <cxxabi.h>
#include <dlfcn.h>

#include <exception>
#include <memory>
#include <mutex>
#include <new>
#include <string>
#include <typeinfo>
#include <unordered_set>
#include <vector>

static_assert(sizeof(RtPoint2) == sizeof(ObscuraPoint2), "RtPoint2 must be two floats");
static_assert(sizeof(RtColorRGB) == sizeof(ObscuraRgb), "RtColorRGB must be three floats");
static_assert(sizeof(RtFloat3) == sizeof(ObscuraVec3), "RtFloat3 must be three floats");
static_assert(sizeof(RtRayGeometry) == sizeof(ObscuraRayGeometry),
              "RtRayGeometry must be laid out as ObscuraRayGeometry (a batch crosses in place)");
static_assert(alignof(RtRayGeometry) == alignof(ObscuraRayGeometry), "RtRayGeometry's alignment");

/* ------------------------------------------------------------------------------------------------ */
/* Interned strings.                                                                                */

char const *obscura_rman_intern(char const *s) {
    // Never destroyed: plugins' namespace-scope RtUStrings outlive any static destructor order.
    static std::mutex *mu = new std::mutex;
    static std::unordered_set<std::string> *set = new std::unordered_set<std::string>;
    std::lock_guard<std::mutex> lock(*mu);
    return set->insert(std::string(s)).first->c_str();
}

/* ------------------------------------------------------------------------------------------------ */
/* The plugin's entry points, defined by its entry macros (weak: a missing one is a clear error).     */

#if OBSCURA_RMAN_GENERATION == 1
extern "C" RixProjection *CreateRixProjection() __attribute__((weak));
extern "C" void DestroyRixProjection(RixProjection *projection) __attribute__((weak));
#define OBSCURA_CREATE_MACRO "RIX_PROJECTIONCREATE"
#define OBSCURA_DESTROY_MACRO "RIX_PROJECTIONDESTROY"
#else
extern "C" RixProjectionFactory *CreateRixProjectionFactory(RtConstString hint) __attribute__((weak));
extern "C" void DestroyRixProjectionFactory(RixProjectionFactory *factory) __attribute__((weak));
#define OBSCURA_CREATE_MACRO "RIX_PROJECTIONFACTORYCREATE"
#define OBSCURA_DESTROY_MACRO "RIX_PROJECTIONFACTORYDESTROY"
#endif

namespace {

std::string demangle(char const *n) {
    int status = 0;
    char *d = abi::__cxa_demangle(n, nullptr, nullptr, &status);
    std::string s = status == 0 && d ? d : n;
    free(d);
    return s;
}

/** "threw std::runtime_error: what" for the exception being handled. */
std::string current_exception_text() {
    try {
        throw;
    } catch (std::exception const &e) {
        return "threw " + demangle(typeid(e).name()) + ": " + e.what();
    } catch (char const *s) {
        return std::string("threw a C string: ") + (s ? s : "(null)");
    } catch (std::string const &s) {
        return "threw a std::string: " + s;
    } catch (...) {
        std::type_info *t = abi::__cxa_current_exception_type();
        return "threw an exception of type " + (t ? demangle(t->name()) : std::string("(unknown)"));
    }
}

void report(ObscuraErrorSink const *sink, std::string const &msg) { obscura_report(sink, msg.c_str()); }

/* The library's file stem: RenderMan's rule, the projection's name is the file's name. */
std::string library_stem() {
    Dl_info info;
    std::string path;
    if (dladdr(reinterpret_cast<void *>(&obscura_rman_intern), &info) && info.dli_fname) path = info.dli_fname;
    size_t slash = path.find_last_of('/');
    std::string file = slash == std::string::npos ? path : path.substr(slash + 1);
    size_t dot = file.find('.');
    std::string stem = dot == std::string::npos ? file : file.substr(0, dot);
    return stem.empty() ? std::string("RenderManProjection") : stem;
}

char const *type_name(RixSCType t) {
    switch (t) {
    case k_RixSCInteger: return "int";
    case k_RixSCFloat: return "float";
    case k_RixSCFloat2: return "float2";
    case k_RixSCFloat3: return "float3";
    case k_RixSCColor: return "color";
    case k_RixSCPoint: return "point";
    case k_RixSCVector: return "vector";
    case k_RixSCNormal: return "normal";
    case k_RixSCMatrix: return "matrix";
    case k_RixSCString: return "string";
    default: return "invalid type";
    }
}

/** The library: the plugin's factory (or RenderMan 21 prototype) and its table in Obscura's terms. */
struct Library {
    std::string name;
    std::string summary;
    std::string plugin_path;
    std::string load_error; /* non-empty: the entry could not use the plugin; init reports it */
#if OBSCURA_RMAN_GENERATION == 1
    RixProjection *prototype = nullptr;
#else
    RixProjectionFactory *factory = nullptr;
#endif
    std::vector<RixSCParamInfo> table;         /* the plugin's rows, terminator excluded */
    std::vector<int> row_of_table;             /* table index -> Obscura row, or -1 (skipped) */
    std::vector<ObscuraParamDecl> decls;
    std::vector<std::vector<float>> default_floats;
    std::vector<std::vector<int32_t>> default_ints;
    ObscuraProjectionDescriptor desc;
};

Library *g_lib = nullptr;

void log_line(char const *level, std::string const &msg) {
    fprintf(stderr, "%s: %s: %s\n", g_lib ? g_lib->name.c_str() : "plugin", level, msg.c_str());
    fflush(stderr);
}

/* ------------------------------------------------------------------------------------------------ */
/* Renderer services.                                                                               */

class Messages final : public RixMessages {
public:
#define OBSCURA_MSG(fn, level)                                                                                 \
    void fn(char const *fmt, ...) override {                                                                   \
        char buf[2048];                                                                                        \
        va_list ap;                                                                                            \
        va_start(ap, fmt);                                                                                     \
        vsnprintf(buf, sizeof buf, fmt ? fmt : "", ap);                                                        \
        va_end(ap);                                                                                            \
        log_line(level, buf);                                                                                  \
    }
    OBSCURA_MSG(Info, "info")
    OBSCURA_MSG(InfoAlways, "info")
    OBSCURA_MSG(Warning, "warning")
    OBSCURA_MSG(WarningAlways, "warning")
    OBSCURA_MSG(Error, "error")
    OBSCURA_MSG(ErrorAlways, "error")
    OBSCURA_MSG(Severe, "severe")
    OBSCURA_MSG(SevereAlways, "severe")
#undef OBSCURA_MSG
};

Messages g_messages;

/** Options from the environment a projection was made with (none before the first projection). */
class RenderState final : public RixRenderState {
public:
    ObscuraEnvironment env{};
    bool has_env = false;

    int GetOption(RtUString const name, void *result, int resultLength, Type *resultType,
                  int *resultCount) const override {
        if (!has_env || !result) return -1;
        float f[4];
        int ints[2];
        int n = 0;
        Type t = k_Float;
        std::string nm = name.CStr();
        float l = env.screen_left, r = env.screen_right, b = env.screen_bottom, tp = env.screen_top;
        if (nm == "Ri:FormatResolution") {
            ints[0] = (int)env.width; ints[1] = (int)env.height; n = 2; t = k_Integer;
        } else if (nm == "Ri:FormatPixelAspectRatio") {
            f[0] = env.pixel_aspect; n = 1;
        } else if (nm == "DeviceResolution") {
            f[0] = (float)env.width; f[1] = (float)env.height; f[2] = env.pixel_aspect; n = 3;
        } else if (nm == "Ri:ScreenWindow") {
            f[0] = l; f[1] = r; f[2] = b; f[3] = tp; n = 4;
        } else if (nm == "Ri:FrameAspectRatio") {
            f[0] = env.height ? (float)env.width * env.pixel_aspect / (float)env.height : 1.0f; n = 1;
        } else if (nm == "Ri:Shutter") {
            f[0] = env.shutter_open; f[1] = env.shutter_close; n = 2;
        } else if (nm == "Ri:Clipping") {
            f[0] = env.clipping_near; f[1] = env.clipping_far; n = 2;
        } else {
            return -1;
        }
        size_t bytes = (size_t)n * (t == k_Integer ? sizeof(int) : sizeof(float));
        if (resultLength >= 0 && (size_t)resultLength < bytes) return -1;
        memcpy(result, t == k_Integer ? (void const *)ints : (void const *)f, bytes);
        if (resultType) *resultType = t;
        if (resultCount) *resultCount = n;
        return 0;
    }

    int GetFrameInfo(FrameInfo *info) const override {
        if (!info) return -1;
        info->frame = 0;
        info->shutterOpen = has_env ? env.shutter_open : 0.0f;
        info->shutterClose = has_env ? env.shutter_close : 0.0f;
        return -1; /* Obscura's environment carries no frame number */
    }
};

/** The context of factory calls and of one projection's calls. */
class Context final : public RixContext {
public:
    RenderState state;
    RixInterface *GetRixInterface(RixInterfaceId id) const override {
        switch (id) {
        case k_RixMessages: return &g_messages;
        case k_RixRenderState: return const_cast<RenderState *>(&state);
        }
        return nullptr;
    }
};

Context g_factory_ctx;

class ProjectContext final : public RixProjectionContext {
public:
    explicit ProjectContext(Context const *c) : m_ctx(c) {}
    RixInterface *GetRixInterface(RixInterfaceId id) const override { return m_ctx->GetRixInterface(id); }

private:
    Context const *m_ctx;
};

/* ------------------------------------------------------------------------------------------------ */
/* Parameters.                                                                                      */

class ParamList final : public RixParameterList {
public:
    ParamList(Library const *lib, ObscuraParamList const *p) : m_lib(lib), m_p(p) {}

    int GetNumParams() const override { return (int)m_lib->table.size(); }

    int GetParamId(RtUString const name, int *id) const override {
        for (size_t i = 0; i < m_lib->table.size(); ++i) {
            if (m_lib->table[i].name == name && given(i)) {
                if (id) *id = (int)i;
                return 0;
            }
        }
        if (id) *id = -1;
        return -1;
    }

    int GetParamInfo(int id, RixSCType *type, RixSCConnectionInfo *cinfo, int *arrayLength) const override {
        if (id < 0 || (size_t)id >= m_lib->table.size()) return -1;
        if (type) *type = m_lib->table[id].type;
        if (cinfo) *cinfo = given(id) ? k_RixSCParameterListValue : k_RixSCDefaultValue;
        if (arrayLength) *arrayLength = m_lib->table[id].arraySize;
        return 0;
    }

    RixSCDetail Eval(int id, int arrayIndex, RixSCType want, void *out) const override {
        if (!out || id < 0 || (size_t)id >= m_lib->table.size() || !given(id) || arrayIndex < 0)
            return k_RixSCInvalidDetail;
        ObscuraParam const &p = m_p->params[m_lib->row_of_table[id]];
        switch (p.type) {
        case OBSCURA_PARAM_FLOAT:
            if (want != k_RixSCFloat || !p.floats || (size_t)arrayIndex >= p.count) return k_RixSCInvalidDetail;
            *static_cast<float *>(out) = p.floats[arrayIndex];
            return k_RixSCUniform;
        case OBSCURA_PARAM_INT:
            if (want != k_RixSCInteger || !p.ints || (size_t)arrayIndex >= p.count) return k_RixSCInvalidDetail;
            *static_cast<int *>(out) = p.ints[arrayIndex];
            return k_RixSCUniform;
        case OBSCURA_PARAM_STRING:
            if (want != k_RixSCString || !p.strings || (size_t)arrayIndex >= p.count) return k_RixSCInvalidDetail;
            *static_cast<RtUString *>(out) = RtUString(p.strings[arrayIndex]);
            return k_RixSCUniform;
        case OBSCURA_PARAM_COLOR:
        case OBSCURA_PARAM_POINT:
        case OBSCURA_PARAM_VECTOR:
        case OBSCURA_PARAM_NORMAL:
            if ((want != k_RixSCColor && want != k_RixSCFloat3) || !p.floats || (size_t)arrayIndex * 3 + 3 > p.count)
                return k_RixSCInvalidDetail;
            memcpy(out, p.floats + 3 * arrayIndex, 3 * sizeof(float));
            return k_RixSCUniform;
        case OBSCURA_PARAM_MATRIX:
            if (want != k_RixSCMatrix || !p.floats || (size_t)arrayIndex * 16 + 16 > p.count)
                return k_RixSCInvalidDetail;
            memcpy(static_cast<RtMatrix4x4 *>(out)->m, p.floats + 16 * arrayIndex, 16 * sizeof(float));
            return k_RixSCUniform;
        }
        return k_RixSCInvalidDetail;
    }

private:
    bool given(size_t i) const {
        if (!m_p || i >= m_lib->row_of_table.size()) return false;
        int r = m_lib->row_of_table[i];
        return r >= 0 && (uint32_t)r < m_p->num_params && m_p->params[r].given;
    }
    Library const *m_lib;
    ObscuraParamList const *m_p;
};

/* ------------------------------------------------------------------------------------------------ */
/* One projection.                                                                                  */

struct Projection {
    Context ctx;
    RixProjectionEnvironment env;
    std::vector<RtMatrix4x4> w2c;
    std::vector<float> w2c_times;
    RixProjection *p = nullptr;
};

void fill_environment(Projection &w, ObscuraEnvironment const &e) {
    w.ctx.state.env = e;
    w.ctx.state.env.world_to_camera = nullptr;
    w.ctx.state.has_env = true;
    RixProjectionEnvironment &r = w.env;
    r.width = (int)e.width;
    r.height = (int)e.height;
    r.pixelAspectRatio = e.pixel_aspect;
    r.clippingNear = e.clipping_near;
    r.clippingFar = e.clipping_far;
    r.screenWindowLeft = e.screen_left;
    r.screenWindowRight = e.screen_right;
    r.screenWindowTop = e.screen_top;
    r.screenWindowBottom = e.screen_bottom;
    r.shutterOpen = e.shutter_open;
    r.shutterClose = e.shutter_close;
    for (uint32_t i = 0; e.world_to_camera && i < e.num_motion_samples; ++i) {
        RtMatrix4x4 m;
        memcpy(m.m, e.world_to_camera[i].world_to_camera.m, sizeof m.m);
        w.w2c.push_back(m);
        w.w2c_times.push_back(e.world_to_camera[i].time);
    }
    r.worldToCameraNumSamples = (unsigned)w.w2c.size();
    r.worldToCameraMatrix = w.w2c.empty() ? nullptr : w.w2c.data();
    r.worldToCameraTimes = w.w2c_times.empty() ? nullptr : w.w2c_times.data();
}

/** RenderMan's property for Obscura's, or -1 where this generation has none. */
int rix_property(ObscuraProjectionProperty p) {
    switch (p) {
#if OBSCURA_RMAN_GENERATION >= 2
    case OBSCURA_PROPERTY_DICING_HINT: return RixProjection::k_DicingHint;
#if OBSCURA_RMAN_GENERATION == 3
    case OBSCURA_PROPERTY_DEEP_METRIC: return RixProjection::k_DeepMetric;
#endif
    case OBSCURA_PROPERTY_FIELD_OF_VIEW: return RixProjection::k_FieldOfView;
    case OBSCURA_PROPERTY_FSTOP: return RixProjection::k_FStop;
    case OBSCURA_PROPERTY_FOCAL_LENGTH: return RixProjection::k_FocalLength;
    case OBSCURA_PROPERTY_FOCAL_DISTANCE: return RixProjection::k_FocalDistance;
#endif
    default: return -1;
    }
}

char const *property_name(ObscuraProjectionProperty p) {
    switch (p) {
    case OBSCURA_PROPERTY_DICING_HINT: return "k_DicingHint";
    case OBSCURA_PROPERTY_DEEP_METRIC: return "k_DeepMetric";
    case OBSCURA_PROPERTY_FIELD_OF_VIEW: return "k_FieldOfView";
    case OBSCURA_PROPERTY_FSTOP: return "k_FStop";
    case OBSCURA_PROPERTY_FOCAL_LENGTH: return "k_FocalLength";
    case OBSCURA_PROPERTY_FOCAL_DISTANCE: return "k_FocalDistance";
    }
    return "?";
}

/** Releases a projection in RenderMan's order; exceptions are logged, never thrown on. */
void release(Projection *w) {
    if (w->p) {
#if OBSCURA_RMAN_GENERATION != 2
        try {
            w->p->RenderEnd(w->ctx);
        } catch (...) {
            log_line("error", "RenderEnd " + current_exception_text());
        }
#endif
#if OBSCURA_RMAN_GENERATION == 1
        try {
            w->p->Finalize(w->ctx);
        } catch (...) {
            log_line("error", "Finalize " + current_exception_text());
        }
        try {
            if (DestroyRixProjection) DestroyRixProjection(w->p);
        } catch (...) {
            log_line("error", OBSCURA_DESTROY_MACRO " " + current_exception_text());
        }
#else
        try {
            g_lib->factory->DestroyProjection(w->p);
        } catch (...) {
            log_line("error", "DestroyProjection " + current_exception_text());
        }
#endif
    }
    delete w;
}

/* ------------------------------------------------------------------------------------------------ */
/* The C ABI.                                                                                       */

ObscuraStatus c_init(ObscuraProjectionDescriptor const *, char const *plugin_path, void **factory,
                     ObscuraErrorSink const *error) {
    Library *lib = g_lib;
    if (!lib->load_error.empty()) {
        report(error, lib->load_error);
        return OBSCURA_ERROR;
    }
    lib->plugin_path = plugin_path ? plugin_path : "";
#if OBSCURA_RMAN_GENERATION >= 2
    try {
        int rc = lib->factory->Init(g_factory_ctx, RtUString(lib->plugin_path.c_str()));
        if (rc != 0) {
            report(error, "RixProjectionFactory::Init returned " + std::to_string(rc) +
                              " (RenderMan's convention: 0 is success)");
            return OBSCURA_ERROR;
        }
    } catch (...) {
        report(error, "RixProjectionFactory::Init " + current_exception_text());
        return OBSCURA_ERROR;
    }
#endif
    *factory = lib;
    return OBSCURA_OK;
}

void c_finalize(void *) {
#if OBSCURA_RMAN_GENERATION >= 2
    try {
        g_lib->factory->Finalize(g_factory_ctx);
    } catch (...) {
        log_line("error", "Finalize " + current_exception_text());
    }
#endif
}

void c_synchronize(void *, ObscuraSyncMessage message, ObscuraParamList const *params) {
    RixSCSyncMsg msg;
    switch (message) {
    case OBSCURA_SYNC_RENDER_BEGIN: msg = k_RixSCRenderBegin; break;
    case OBSCURA_SYNC_RENDER_END: msg = k_RixSCRenderEnd; break;
    case OBSCURA_SYNC_INSTANCE_EDIT: msg = k_RixSCInstanceEdit; break;
    default: return;
    }
    ParamList pl(g_lib, params);
    try {
#if OBSCURA_RMAN_GENERATION >= 2
        g_lib->factory->Synchronize(g_factory_ctx, msg, &pl);
#else
        PIXAR_ARGUSED(msg);
#endif
    } catch (...) {
        log_line("error", "Synchronize " + current_exception_text());
    }
}

/** Asks every property once after the projection is set up: a pointer must come with an answer. */
bool check_properties(Projection const *w, std::string *why) {
#if OBSCURA_RMAN_GENERATION >= 2
    for (ObscuraProjectionProperty p = OBSCURA_PROPERTY_DICING_HINT; p <= OBSCURA_PROPERTY_FOCAL_DISTANCE; ++p) {
        int rp = rix_property(p);
        if (rp < 0) continue;
        void const *result = nullptr;
        RixSCDetail d;
        try {
            d = w->p->GetProperty(static_cast<RixProjection::ProjectionProperty>(rp), &result);
        } catch (...) {
            *why = std::string("GetProperty(") + property_name(p) + ") " + current_exception_text();
            return false;
        }
        if (d != k_RixSCInvalidDetail && result == nullptr) {
            *why = std::string("GetProperty(") + property_name(p) +
                   ") answered k_RixSCUniform but left *result NULL: point it at a member of the projection "
                   "(valid until DestroyProjection), or answer k_RixSCInvalidDetail";
            return false;
        }
    }
#else
    PIXAR_ARGUSED(w);
    PIXAR_ARGUSED(why);
#endif
    return true;
}

ObscuraStatus c_create(void *, ObscuraEnvironment *env, ObscuraParamList const *params, void **projection,
                       ObscuraErrorSink const *error) {
    Library *lib = g_lib;
    Projection *w = new (std::nothrow) Projection;
    if (!w) return OBSCURA_ERROR;
    fill_environment(*w, *env);
    ParamList pl(lib, params);
    RtUString handle(lib->name.c_str());
    char const *stage = "CreateProjection";
    try {
#if OBSCURA_RMAN_GENERATION == 3
        w->p = lib->factory->CreateProjection(w->ctx, handle, &pl);
        if (!w->p) {
            report(error, "CreateProjection returned NULL (the factory made no projection)");
            delete w;
            return OBSCURA_ERROR;
        }
        stage = "RenderBegin";
        w->p->RenderBegin(w->ctx, w->env, &pl);
#elif OBSCURA_RMAN_GENERATION == 2
        w->p = lib->factory->CreateProjection(w->ctx, w->env, handle, &pl);
        if (!w->p) {
            report(error, "CreateProjection returned NULL (the factory made no projection)");
            delete w;
            return OBSCURA_ERROR;
        }
        env->deep_metric = (int32_t)w->env.deepMetric;
#else
        stage = OBSCURA_CREATE_MACRO;
        w->p = CreateRixProjection();
        if (!w->p) {
            report(error, OBSCURA_CREATE_MACRO " returned NULL (the plugin made no projection)");
            delete w;
            return OBSCURA_ERROR;
        }
        stage = "Init";
        int rc = w->p->Init(w->ctx, lib->plugin_path.c_str());
        if (rc != 0) {
            report(error, "RixProjection::Init returned " + std::to_string(rc) + " (RenderMan's convention: 0 is success)");
            release(w);
            return OBSCURA_ERROR;
        }
        stage = "RenderBegin";
        w->p->RenderBegin(w->ctx, w->env, &pl);
        env->deep_metric = (int32_t)w->env.deepMetric;
#endif
    } catch (...) {
        report(error, std::string(stage) + " " + current_exception_text());
        release(w);
        return OBSCURA_ERROR;
    }
    std::string why;
    if (!check_properties(w, &why)) {
        report(error, why);
        release(w);
        return OBSCURA_ERROR;
    }
    *projection = w;
    return OBSCURA_OK;
}

void c_destroy(void *, void *projection) { release(static_cast<Projection *>(projection)); }

ObscuraStatus c_property(void const *projection, ObscuraProjectionProperty property, ObscuraPropertyValue *value) {
#if OBSCURA_RMAN_GENERATION >= 2
    Projection const *w = static_cast<Projection const *>(projection);
    int rp = rix_property(property);
    if (rp < 0) return OBSCURA_UNSUPPORTED;
    void const *result = nullptr;
    RixSCDetail d;
    try {
        d = w->p->GetProperty(static_cast<RixProjection::ProjectionProperty>(rp), &result);
    } catch (...) {
        log_line("error", std::string("GetProperty(") + property_name(property) + ") " + current_exception_text());
        return OBSCURA_PANIC;
    }
    if (d == k_RixSCInvalidDetail) return OBSCURA_UNSUPPORTED;
    if (!result) return OBSCURA_ERROR;
    switch (property) {
    case OBSCURA_PROPERTY_DICING_HINT:
        value->kind = OBSCURA_VALUE_DICING_HINT;
        value->enum_value = (int32_t) * static_cast<RixProjection::DicingHint const *>(result);
        return OBSCURA_OK;
#if OBSCURA_RMAN_GENERATION == 3
    case OBSCURA_PROPERTY_DEEP_METRIC:
        value->kind = OBSCURA_VALUE_DEEP_METRIC;
        value->enum_value = (int32_t) * static_cast<RixProjection::DeepMetric const *>(result);
        return OBSCURA_OK;
#endif
    default:
        value->kind = OBSCURA_VALUE_FLOAT;
        value->float_value = *static_cast<float const *>(result);
        return OBSCURA_OK;
    }
#else
    // RenderMan 19-21 projections cannot describe themselves: Obscura takes the description that holds
    // for any rays they may write (spherical dicing, depth along the ray, clipping spheres).
    PIXAR_ARGUSED(projection);
    switch (property) {
    case OBSCURA_PROPERTY_DICING_HINT:
        value->kind = OBSCURA_VALUE_DICING_HINT;
        value->enum_value = OBSCURA_DICING_SPHERICAL;
        return OBSCURA_OK;
    case OBSCURA_PROPERTY_DEEP_METRIC:
        value->kind = OBSCURA_VALUE_DEEP_METRIC;
        value->enum_value = OBSCURA_DEEP_RAY_LENGTH;
        return OBSCURA_OK;
    default:
        return OBSCURA_UNSUPPORTED;
    }
#endif
}

/** The batch `Project` is working on, on this thread: RtRayGeometry::time finds its entry here. */
struct BatchView {
    RtRayGeometry *rays = nullptr;
    float *time = nullptr;
    uint32_t n = 0;
};
thread_local BatchView t_batch;

/** The time entry of `ray`, or NULL when it is not one of the current batch's rays. */
float *time_of(void const *time_member) {
    static ptrdiff_t const offset = [] {
        RtRayGeometry probe;
        return reinterpret_cast<char const *>(&probe.time) - reinterpret_cast<char const *>(&probe);
    }();
    BatchView const &b = t_batch;
    if (!b.rays || !b.time) return nullptr;
    char const *ray = reinterpret_cast<char const *>(time_member) - offset;
    char const *base = reinterpret_cast<char const *>(b.rays);
    if (ray < base) return nullptr;
    size_t bytes = (size_t)(ray - base);
    if (bytes % sizeof(RtRayGeometry) != 0) return nullptr;
    size_t i = bytes / sizeof(RtRayGeometry);
    return i < b.n ? b.time + i : nullptr;
}

ObscuraStatus c_project(void const *projection, ObscuraProjectionContext const *c, ObscuraErrorSink const *error) {
    Projection const *w = static_cast<Projection const *>(projection);
    ProjectContext pc(&w->ctx);
    pc.numRays = (int)c->num_rays;
    pc.screen = const_cast<RtPoint2 *>(reinterpret_cast<RtPoint2 const *>(c->screen));
    pc.lens = const_cast<RtPoint2 *>(reinterpret_cast<RtPoint2 const *>(c->lens));
    pc.aperture = const_cast<RtPoint2 *>(reinterpret_cast<RtPoint2 const *>(c->aperture));
    pc.time = c->time;
    pc.rays = reinterpret_cast<RtRayGeometry *>(c->rays);
    pc.tint = reinterpret_cast<RtColorRGB *>(c->tint);
    BatchView saved = t_batch;
    t_batch = BatchView{pc.rays, c->time, c->num_rays};
    try {
        w->p->Project(pc);
    } catch (...) {
        t_batch = saved;
        report(error, "Project " + current_exception_text());
        return OBSCURA_PANIC;
    }
    t_batch = saved;
    return OBSCURA_OK;
}

/** Translates the plugin's table into Obscura's rows (defaults are the plugin's business). */
void translate_table(Library *lib, RixSCParamInfo const *t) {
    const size_t kMaxRows = 4096;
    size_t n = 0;
    while (n < kMaxRows && !t[n].IsEnd()) ++n;
    if (n == kMaxRows) {
        lib->load_error = "GetParamTable(): no terminating RixSCParamInfo() within 4096 rows";
        return;
    }
    lib->table.assign(t, t + n);
    lib->row_of_table.assign(n, -1);
    static std::vector<char const *> empty_strings(kMaxRows, "");
    lib->default_floats.reserve(n);
    lib->default_ints.reserve(n);
    for (size_t i = 0; i < n; ++i) {
        RixSCParamInfo const &row = t[i];
        if (row.access == k_RixSCOutput) continue;
        ObscuraParamDecl d;
        memset(&d, 0, sizeof d);
        d.name = row.name.CStr();
        int comps = 1;
        switch (row.type) {
        case k_RixSCInteger: d.type = OBSCURA_PARAM_INT; break;
        case k_RixSCFloat: d.type = OBSCURA_PARAM_FLOAT; break;
        case k_RixSCColor: d.type = OBSCURA_PARAM_COLOR; comps = 3; break;
        case k_RixSCPoint: d.type = OBSCURA_PARAM_POINT; comps = 3; break;
        case k_RixSCFloat3:
        case k_RixSCVector: d.type = OBSCURA_PARAM_VECTOR; comps = 3; break;
        case k_RixSCNormal: d.type = OBSCURA_PARAM_NORMAL; comps = 3; break;
        case k_RixSCMatrix: d.type = OBSCURA_PARAM_MATRIX; comps = 16; break;
        case k_RixSCString: d.type = OBSCURA_PARAM_STRING; break;
        default:
            log_line("warning", std::string("parameter \"") + d.name + "\" has type " + type_name(row.type) +
                                    ", which a projection cannot be given; it is left out of the table");
            continue;
        }
        size_t count = (size_t)comps;
        if (row.arraySize > 0) {
            d.array_len = row.arraySize;
            count *= (size_t)row.arraySize;
        } else if (row.arraySize == 0) {
            if (d.type != OBSCURA_PARAM_FLOAT) {
                log_line("warning", std::string("parameter \"") + d.name + "\" is a variable-length " +
                                        type_name(row.type) + " array; only float lists are offered: left out");
                continue;
            }
            d.array_len = OBSCURA_ARRAY_VARIABLE;
            count = 0;
        } else {
            d.array_len = OBSCURA_ARRAY_SINGLE;
        }
        d.default_count = count;
        if (d.type == OBSCURA_PARAM_INT) {
            lib->default_ints.emplace_back(count, 0);
            d.default_ints = lib->default_ints.back().data();
        } else if (d.type == OBSCURA_PARAM_STRING) {
            d.default_strings = empty_strings.data();
        } else {
            std::vector<float> v(count, 0.0f);
            if (d.type == OBSCURA_PARAM_MATRIX)
                for (size_t k = 0; k < count; k += 16)
                    for (int j = 0; j < 4; ++j) v[k + 5 * j] = 1.0f;
            lib->default_floats.push_back(v);
            d.default_floats = count ? lib->default_floats.back().data() : nullptr;
        }
        lib->row_of_table[i] = (int)lib->decls.size();
        lib->decls.push_back(d);
    }
}

Library *load() {
    Library *lib = new Library;
    g_lib = lib;
    lib->name = library_stem();
    lib->summary = "RenderMan " OBSCURA_RMAN_STR(OBSCURA_RMAN_VERSION) " projection plugin (C++, built by obscura build-plugin)";
    RixSCParamInfo const *table = nullptr;
#if OBSCURA_RMAN_GENERATION == 1
    if (!CreateRixProjection || !DestroyRixProjection) {
        lib->load_error = "the library defines no " OBSCURA_CREATE_MACRO " / " OBSCURA_DESTROY_MACRO
                          " (is it a RenderMan 19-21 projection plugin? RenderMan 22+ sources use "
                          "RIX_PROJECTIONFACTORYCREATE: rebuild with --rman-version 22..27)";
    } else {
        char const *stage = OBSCURA_CREATE_MACRO;
        try {
            lib->prototype = CreateRixProjection();
            stage = "GetParamTable";
            if (!lib->prototype)
                lib->load_error = OBSCURA_CREATE_MACRO " returned NULL (the plugin made no projection)";
            else if (!(table = lib->prototype->GetParamTable()))
                lib->load_error = "GetParamTable() returned NULL: a table is a static array ending in an empty "
                                  "RixSCParamInfo() (it may hold only that)";
        } catch (...) {
            lib->load_error = std::string(stage) + " " + current_exception_text();
            table = nullptr;
        }
    }
#else
    if (!CreateRixProjectionFactory || !DestroyRixProjectionFactory) {
        lib->load_error = "the library defines no " OBSCURA_CREATE_MACRO " / " OBSCURA_DESTROY_MACRO
#if OBSCURA_RMAN_GENERATION == 3
                          " (built as RenderMan 23-27)"
#else
                          " (built as RenderMan 22)"
#endif
                          ;
    } else {
        char const *stage = "the factory's constructor (" OBSCURA_CREATE_MACRO ")";
        try {
            lib->factory = CreateRixProjectionFactory(lib->name.c_str());
            stage = "GetParamTable";
            if (!lib->factory)
                lib->load_error = OBSCURA_CREATE_MACRO " returned NULL (the plugin made no factory)";
            else if (!(table = lib->factory->GetParamTable()))
                lib->load_error = "GetParamTable() returned NULL: a table is a static array ending in an empty "
                                  "RixSCParamInfo() (it may hold only that)";
        } catch (...) {
            lib->load_error = std::string(stage) + " " + current_exception_text();
            table = nullptr;
        }
    }
#endif
    if (table) translate_table(lib, table);
    ObscuraProjectionDescriptor &d = lib->desc;
    memset(&d, 0, sizeof d);
    d.abi_version = OBSCURA_PROJECTION_ABI_VERSION;
    d.struct_size = sizeof d;
    d.name = lib->name.c_str();
    d.summary = lib->summary.c_str();
    d.params = lib->load_error.empty() && !lib->decls.empty() ? lib->decls.data() : nullptr;
    d.num_params = lib->load_error.empty() ? lib->decls.size() : 0;
    d.init = c_init;
    d.finalize = c_finalize;
    d.synchronize = c_synchronize;
    d.create_projection = c_create;
    d.destroy_projection = c_destroy;
    d.property = c_property;
    d.project = c_project;
    d.unproject = nullptr;
    return lib;
}

} // namespace

obscura_rman::RayTime::operator float() const {
    float const *t = time_of(this);
    return t ? *t : 0.0f;
}

obscura_rman::RayTime &obscura_rman::RayTime::operator=(float v) {
    if (float *t = time_of(this)) *t = v;
    return *this;
}

extern "C" OBSCURA_EXPORT const ObscuraProjectionDescriptor *obscura_projection_entry(uint32_t host_abi_version) {
    if (host_abi_version != OBSCURA_PROJECTION_ABI_VERSION) return nullptr;
    static Library *lib = load();
    return &lib->desc;
}

/*
 * RixInterfaces.h — Obscura's RenderMan-compatible plugin headers: value types, strings, the context and
 * the renderer services a projection plugin may ask for (RixMessages, RixRenderState).
 *
 * Written for Obscura from RenderMan's public documentation; not Pixar's header. Identifiers, member
 * names and signatures follow the spelling RenderMan plugins use, so their sources compile unchanged.
 * Every definition is inline here or in the glue translation unit (obscura_rman_glue.cpp) that
 * `obscura build-plugin` compiles into the same library: nothing is left for libprman to resolve.
 *
 * GENERATION. OBSCURA_RMAN_VERSION (21 … 27) selects the interface generation where the three truly
 * conflict (RixProjection.h): 19–21 one self-contained RixProjection, 22 the factory with the
 * environment in CreateProjection, 23–27 the factory with RenderBegin(env const&). `obscura build-plugin`
 * finds it from the source when --rman-version is not given; unset, it is 27.
 */
#ifndef OBSCURA_RIX_INTERFACES_H
#define OBSCURA_RIX_INTERFACES_H

#ifndef OBSCURA_RMAN_VERSION
#define OBSCURA_RMAN_VERSION 27
#endif
#if OBSCURA_RMAN_VERSION < 19 || OBSCURA_RMAN_VERSION > 27
#error "OBSCURA_RMAN_VERSION must be a RenderMan release from 19 to 27 (the projection interface's generations: 19-21, 22, 23-27)"
#endif
/** 1 for RenderMan 19–21 (self-contained RixProjection), 2 for 22, 3 for 23–27. */
#if OBSCURA_RMAN_VERSION <= 21
#define OBSCURA_RMAN_GENERATION 1
#elif OBSCURA_RMAN_VERSION == 22
#define OBSCURA_RMAN_GENERATION 2
#else
#define OBSCURA_RMAN_GENERATION 3
#endif

/* What RenderMan's headers bring in and plugins rely on without their own includes. */
#include <math.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>

#define PIXAR_ARGUSED(x) ((void)(x))
#define PRMANAPI
#define PRMANEXPORT __attribute__((visibility("default")))
#define OBSCURA_RMAN_EXPORT __attribute__((visibility("default")))

#ifndef F_PI
#define F_PI 3.14159265358979323846f
#endif
#ifndef F_TWOPI
#define F_TWOPI 6.28318530717958647692f
#endif
#ifndef F_PIO2
#define F_PIO2 1.57079632679489661923f
#endif
#ifndef F_INVPI
#define F_INVPI 0.31830988618379067154f
#endif
#ifndef F_DEGTORAD
#define F_DEGTORAD (F_PI / 180.0f)
#endif
#ifndef F_RADTODEG
#define F_RADTODEG (180.0f / F_PI)
#endif
#ifndef RI_INFINITY
#define RI_INFINITY 1.0e38f
#endif
#ifndef RI_EPSILON
#define RI_EPSILON 1.0e-10f
#endif

typedef float RtFloat;
typedef int RtInt;
typedef char const *RtConstString;
typedef char *RtString;
typedef void *RtPointer;
typedef bool RtBoolean;

/** Interns a NUL-terminated string: equal text, equal pointer, valid for the life of the process.
 *  Defined in the glue; safe during static initialisation (before any renderer exists). */
char const *obscura_rman_intern(char const *s);

/**
 * RtUString: an interned string. Constructing one works at library load, with no renderer.
 * Compare is strcmp-like (0 when equal, like std::string::compare): `a.Compare(b)` is false for equal
 * strings. (RenderMan's documentation does not say; Obscura documents this choice.)
 */
class RtUString {
public:
    RtUString() : m_str(nullptr) {}
    RtUString(char const *s) : m_str(s ? obscura_rman_intern(s) : nullptr) {}
    /** The characters, NUL-terminated; "" for the empty string. */
    char const *CStr() const { return m_str ? m_str : ""; }
    bool Empty() const { return m_str == nullptr || m_str[0] == '\0'; }
    size_t Length() const { return m_str ? strlen(m_str) : 0; }
    /** strcmp-like: negative, 0 (equal) or positive. */
    int Compare(RtUString const &o) const { return m_str == o.m_str ? 0 : strcmp(CStr(), o.CStr()); }
    bool operator==(RtUString const &o) const { return CStr() == o.CStr() || strcmp(CStr(), o.CStr()) == 0; }
    bool operator!=(RtUString const &o) const { return !(*this == o); }
    bool operator<(RtUString const &o) const { return strcmp(CStr(), o.CStr()) < 0; }
    bool operator==(char const *o) const { return strcmp(CStr(), o ? o : "") == 0; }
    bool operator!=(char const *o) const { return !(*this == o); }

private:
    char const *m_str;
};

/** Three floats: RtPoint3, RtVector3 and RtNormal3 are this type, so they mix freely. */
struct RtFloat3 {
    RtFloat x, y, z;
    RtFloat3() : x(0.0f), y(0.0f), z(0.0f) {}
    explicit RtFloat3(RtFloat v) : x(v), y(v), z(v) {}
    RtFloat3(RtFloat ax, RtFloat ay, RtFloat az) : x(ax), y(ay), z(az) {}
    RtFloat &operator[](int i) { return (&x)[i]; }
    RtFloat operator[](int i) const { return (&x)[i]; }
    RtFloat3 operator+(RtFloat3 const &o) const { return RtFloat3(x + o.x, y + o.y, z + o.z); }
    RtFloat3 operator-(RtFloat3 const &o) const { return RtFloat3(x - o.x, y - o.y, z - o.z); }
    RtFloat3 operator-() const { return RtFloat3(-x, -y, -z); }
    RtFloat3 operator*(RtFloat s) const { return RtFloat3(x * s, y * s, z * s); }
    RtFloat3 operator/(RtFloat s) const { return RtFloat3(x / s, y / s, z / s); }
    RtFloat3 &operator+=(RtFloat3 const &o) { x += o.x; y += o.y; z += o.z; return *this; }
    RtFloat3 &operator-=(RtFloat3 const &o) { x -= o.x; y -= o.y; z -= o.z; return *this; }
    RtFloat3 &operator*=(RtFloat s) { x *= s; y *= s; z *= s; return *this; }
    bool operator==(RtFloat3 const &o) const { return x == o.x && y == o.y && z == o.z; }
    bool operator!=(RtFloat3 const &o) const { return !(*this == o); }
    RtFloat Dot(RtFloat3 const &o) const { return x * o.x + y * o.y + z * o.z; }
    RtFloat3 Cross(RtFloat3 const &o) const {
        return RtFloat3(y * o.z - z * o.y, z * o.x - x * o.z, x * o.y - y * o.x);
    }
    RtFloat LengthSq() const { return x * x + y * y + z * z; }
    RtFloat Length() const { return sqrtf(LengthSq()); }
    /** Scales to unit length in place (a zero vector stays zero); returns the former length. */
    RtFloat Normalize() {
        RtFloat l = Length();
        if (l > 0.0f) { RtFloat inv = 1.0f / l; x *= inv; y *= inv; z *= inv; }
        return l;
    }
    /** A unit-length copy. */
    RtFloat3 Normalized() const { RtFloat3 c(*this); c.Normalize(); return c; }
};
inline RtFloat3 operator*(RtFloat s, RtFloat3 const &v) { return v * s; }
inline RtFloat Dot(RtFloat3 const &a, RtFloat3 const &b) { return a.Dot(b); }
inline RtFloat3 Cross(RtFloat3 const &a, RtFloat3 const &b) { return a.Cross(b); }
typedef RtFloat3 RtPoint3;
typedef RtFloat3 RtVector3;
typedef RtFloat3 RtNormal3;

/** Two floats (screen, lens and aperture samples). */
struct RtFloat2 {
    RtFloat x, y;
    RtFloat2() : x(0.0f), y(0.0f) {}
    RtFloat2(RtFloat ax, RtFloat ay) : x(ax), y(ay) {}
    RtFloat &operator[](int i) { return (&x)[i]; }
    RtFloat operator[](int i) const { return (&x)[i]; }
};
typedef RtFloat2 RtPoint2;
typedef RtFloat2 RtVector2;

/** A linear RGB colour. */
struct RtColorRGB {
    RtFloat r, g, b;
    RtColorRGB() : r(0.0f), g(0.0f), b(0.0f) {}
    RtColorRGB(RtFloat v) : r(v), g(v), b(v) {}
    RtColorRGB(RtFloat ar, RtFloat ag, RtFloat ab) : r(ar), g(ag), b(ab) {}
    RtFloat &operator[](int i) { return (&r)[i]; }
    RtFloat operator[](int i) const { return (&r)[i]; }
    RtColorRGB operator*(RtColorRGB const &o) const { return RtColorRGB(r * o.r, g * o.g, b * o.b); }
    RtColorRGB operator*(RtFloat s) const { return RtColorRGB(r * s, g * s, b * s); }
    RtColorRGB operator+(RtColorRGB const &o) const { return RtColorRGB(r + o.r, g + o.g, b + o.b); }
    RtColorRGB &operator*=(RtFloat s) { r *= s; g *= s; b *= s; return *this; }
    RtColorRGB &operator*=(RtColorRGB const &o) { r *= o.r; g *= o.g; b *= o.b; return *this; }
};

/**
 * A 4×4 matrix acting on row vectors, as RenderMan's: a point p maps to [p 1]·M (translation in the
 * last row), a vector v to [v 0]·M. Default-constructed it is the identity.
 */
struct RtMatrix4x4 {
    RtFloat m[4][4];
    RtMatrix4x4() { Identity(); }
    RtMatrix4x4(RtFloat a00, RtFloat a01, RtFloat a02, RtFloat a03, RtFloat a10, RtFloat a11, RtFloat a12,
                RtFloat a13, RtFloat a20, RtFloat a21, RtFloat a22, RtFloat a23, RtFloat a30, RtFloat a31,
                RtFloat a32, RtFloat a33) {
        RtFloat v[16] = {a00, a01, a02, a03, a10, a11, a12, a13, a20, a21, a22, a23, a30, a31, a32, a33};
        memcpy(m, v, sizeof m);
    }
    void Identity() {
        for (int i = 0; i < 4; ++i)
            for (int j = 0; j < 4; ++j) m[i][j] = i == j ? 1.0f : 0.0f;
    }
    RtFloat *operator[](int i) { return m[i]; }
    RtFloat const *operator[](int i) const { return m[i]; }
    RtMatrix4x4 operator*(RtMatrix4x4 const &o) const {
        RtMatrix4x4 r;
        for (int i = 0; i < 4; ++i)
            for (int j = 0; j < 4; ++j) {
                RtFloat s = 0.0f;
                for (int k = 0; k < 4; ++k) s += m[i][k] * o.m[k][j];
                r.m[i][j] = s;
            }
        return r;
    }
    /** [p 1]·M with the homogeneous divide. */
    RtPoint3 pTransform(RtPoint3 const &p) const {
        RtFloat x = p.x * m[0][0] + p.y * m[1][0] + p.z * m[2][0] + m[3][0];
        RtFloat y = p.x * m[0][1] + p.y * m[1][1] + p.z * m[2][1] + m[3][1];
        RtFloat z = p.x * m[0][2] + p.y * m[1][2] + p.z * m[2][2] + m[3][2];
        RtFloat w = p.x * m[0][3] + p.y * m[1][3] + p.z * m[2][3] + m[3][3];
        if (w != 1.0f && w != 0.0f) { x /= w; y /= w; z /= w; }
        return RtPoint3(x, y, z);
    }
    /** [v 0]·M: the upper 3×3 only. */
    RtVector3 vTransform(RtVector3 const &v) const {
        return RtVector3(v.x * m[0][0] + v.y * m[1][0] + v.z * m[2][0],
                         v.x * m[0][1] + v.y * m[1][1] + v.z * m[2][1],
                         v.x * m[0][2] + v.y * m[1][2] + v.z * m[2][2]);
    }
    /** Normals transform by the inverse transpose: n·(M⁻¹)ᵀ. */
    RtNormal3 nTransform(RtNormal3 const &n) const {
        RtMatrix4x4 inv;
        Inverse(&inv);
        return RtNormal3(n.x * inv.m[0][0] + n.y * inv.m[0][1] + n.z * inv.m[0][2],
                         n.x * inv.m[1][0] + n.y * inv.m[1][1] + n.z * inv.m[1][2],
                         n.x * inv.m[2][0] + n.y * inv.m[2][1] + n.z * inv.m[2][2]);
    }
    RtMatrix4x4 Transpose() const {
        RtMatrix4x4 r;
        for (int i = 0; i < 4; ++i)
            for (int j = 0; j < 4; ++j) r.m[i][j] = m[j][i];
        return r;
    }
    /** Writes the inverse into *out (Gauss–Jordan with partial pivoting, in double); false when
     *  singular, then *out is the identity. */
    bool Inverse(RtMatrix4x4 *out) const {
        double a[4][8];
        for (int i = 0; i < 4; ++i)
            for (int j = 0; j < 4; ++j) { a[i][j] = m[i][j]; a[i][j + 4] = i == j ? 1.0 : 0.0; }
        for (int c = 0; c < 4; ++c) {
            int p = c;
            for (int r = c + 1; r < 4; ++r)
                if (fabs(a[r][c]) > fabs(a[p][c])) p = r;
            if (fabs(a[p][c]) < 1e-300) { if (out) out->Identity(); return false; }
            if (p != c)
                for (int j = 0; j < 8; ++j) std::swap(a[p][j], a[c][j]);
            double inv = 1.0 / a[c][c];
            for (int j = 0; j < 8; ++j) a[c][j] *= inv;
            for (int r = 0; r < 4; ++r)
                if (r != c) {
                    double f = a[r][c];
                    for (int j = 0; j < 8; ++j) a[r][j] -= f * a[c][j];
                }
        }
        if (out)
            for (int i = 0; i < 4; ++i)
                for (int j = 0; j < 4; ++j) out->m[i][j] = (RtFloat)a[i][j + 4];
        return true;
    }
};
typedef RtMatrix4x4 RtMatrix;

/** The interfaces a plugin may ask its context for. Only RixMessages and RixRenderState exist in
 *  Obscura: naming another interface is a compile error (see docs/renderman-plugins.md). */
enum RixInterfaceId {
    k_RixMessages = 1,
    k_RixRenderState = 2,
};

/** Base of every interface: never deleted by the plugin. */
class RixInterface {
public:
    virtual int GetVersion() const { return m_version; }

protected:
    explicit RixInterface(int version) : m_version(version) {}
    virtual ~RixInterface() {}
    int m_version;
};

/** What a plugin's calls receive: the way to the renderer's services. */
class RixContext {
public:
    /** The interface `id`, or NULL. Cast it to its class; never delete it. */
    virtual RixInterface *GetRixInterface(RixInterfaceId id) const = 0;

protected:
    virtual ~RixContext() {}
};

/** Messages to the renderer's log, printf-style (Obscura writes them to stderr naming the plugin). */
class RixMessages : public RixInterface {
public:
    virtual void Info(char const *fmt, ...) = 0;
    virtual void InfoAlways(char const *fmt, ...) = 0;
    virtual void Warning(char const *fmt, ...) = 0;
    virtual void WarningAlways(char const *fmt, ...) = 0;
    virtual void Error(char const *fmt, ...) = 0;
    virtual void ErrorAlways(char const *fmt, ...) = 0;
    virtual void Severe(char const *fmt, ...) = 0;
    virtual void SevereAlways(char const *fmt, ...) = 0;

protected:
    RixMessages() : RixInterface(1) {}
};

/**
 * The render's options. GetOption answers, for a name as RenderMan spells it:
 *   "Ri:FormatResolution" int[2], "Ri:FormatPixelAspectRatio" float, "DeviceResolution" float[3]
 *   (width, height, pixel aspect), "Ri:ScreenWindow" float[4] (left, right, bottom, top — the RI's
 *   order), "Ri:Shutter" float[2], "Ri:Clipping" float[2] (near, far), "Ri:FrameAspectRatio" float,
 *   "Ri:DepthOfField" float[3] (f-stop, focal length, focal distance; f-stop RI_INFINITY for a pinhole),
 *   "Ri:Frame" int. It returns 0 and fills result, type and count; -1 for an unknown name or a result
 *   smaller than the value (nothing written).
 */
class RixRenderState : public RixInterface {
public:
    enum Type { k_Invalid = 0, k_Float, k_Integer, k_StringV, k_Color, k_Normal, k_Vector, k_Point,
                k_HPoint, k_MPoint, k_Matrix };
    struct FrameInfo {
        int frame;
        RtFloat shutterOpen, shutterClose;
    };
    virtual int GetOption(RtUString const name, void *result, int resultLength, Type *resultType,
                          int *resultCount) const = 0;
    /** The current frame (the RIB FrameBegin number, 1 when the scene has none). */
    virtual int GetFrameInfo(FrameInfo *info) const = 0;

protected:
    RixRenderState() : RixInterface(1) {}
};

#endif /* OBSCURA_RIX_INTERFACES_H */

// Embree side of `scripts/bench/trace_vs_embree.sh`: reads the mesh, the ray sets and Obscura's
// answers written by `OBSCURA_TRACE_VS_EMBREE=<file> cargo bench -p obscura-render --bench trace`,
// traces the same rays one at a time with rtcIntersect1 / rtcOccluded1 on one thread, prints
// Mrays/s (fastest of five passes) and counts where Embree's answer differs from Obscura's.
// A benchmark harness only: built by the script with the system C++ compiler, never by cargo.
#include <embree3/rtcore.h>

#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <vector>

namespace {

struct RayRecord {
    float org[3], dir[3], tnear, tfar;
    float t;        // Obscura's hit distance (inf: miss); shadow rays: 1 occluded, 0 not
    uint32_t prim;  // Obscura's triangle (UINT32_MAX: miss)
};
static_assert(sizeof(RayRecord) == 40, "record layout");

struct Reader {
    const std::vector<unsigned char>& bytes;
    size_t at = 0;
    void read(void* out, size_t n) {
        if (at + n > bytes.size()) {
            std::fprintf(stderr, "trace_embree: the dump ends early (byte %zu of %zu)\n", at, bytes.size());
            std::exit(2);
        }
        std::memcpy(out, bytes.data() + at, n);
        at += n;
    }
    uint32_t u32() {
        uint32_t v;
        read(&v, 4);
        return v;
    }
};

void on_error(void*, RTCError code, const char* message) {
    std::fprintf(stderr, "trace_embree: Embree error %d: %s\n", static_cast<int>(code), message ? message : "");
    std::exit(3);
}

// This thread's CPU time: time the thread was descheduled by other processes on a loaded machine
// does not count (the Rust side measures the same way).
double thread_seconds() {
    timespec ts;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return ts.tv_sec + ts.tv_nsec * 1e-9;
}

double seconds_since(std::chrono::steady_clock::time_point start) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

RTCRayHit make_rayhit(const RayRecord& r) {
    RTCRayHit rh{};
    rh.ray.org_x = r.org[0];
    rh.ray.org_y = r.org[1];
    rh.ray.org_z = r.org[2];
    rh.ray.dir_x = r.dir[0];
    rh.ray.dir_y = r.dir[1];
    rh.ray.dir_z = r.dir[2];
    rh.ray.tnear = r.tnear;
    rh.ray.tfar = r.tfar;
    rh.ray.mask = 0xffffffffu;
    rh.ray.flags = 0;
    rh.ray.time = 0.0f;
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.primID = RTC_INVALID_GEOMETRY_ID;
    return rh;
}

}  // namespace

int main(int argc, char** argv) {
    if (argc != 2) {
        std::fprintf(stderr, "usage: trace_embree <dump file>\n");
        return 2;
    }
    FILE* f = std::fopen(argv[1], "rb");
    if (!f) {
        std::perror(argv[1]);
        return 2;
    }
    std::vector<unsigned char> bytes;
    unsigned char buf[1 << 16];
    size_t n;
    while ((n = std::fread(buf, 1, sizeof buf, f)) > 0) bytes.insert(bytes.end(), buf, buf + n);
    std::fclose(f);
    Reader in{bytes};
    char magic[8];
    in.read(magic, 8);
    if (std::memcmp(magic, "OBTR\x01\0\0\0", 8) != 0) {
        std::fprintf(stderr, "%s: not a trace dump (version 1)\n", argv[1]);
        return 2;
    }
    uint32_t nv = in.u32(), nt = in.u32();
    std::vector<float> positions(3 * size_t(nv));
    std::vector<uint32_t> triangles(3 * size_t(nt));
    in.read(positions.data(), positions.size() * 4);
    in.read(triangles.data(), triangles.size() * 4);
    std::vector<RayRecord> sets[3];
    for (auto& set : sets) {
        set.resize(in.u32());
        in.read(set.data(), set.size() * sizeof(RayRecord));
    }

    RTCDevice device = rtcNewDevice("threads=1,set_affinity=0");
    if (!device) {
        std::fprintf(stderr, "trace_embree: rtcNewDevice failed\n");
        return 3;
    }
    rtcSetDeviceErrorFunction(device, on_error, nullptr);
    auto start = std::chrono::steady_clock::now();
    RTCScene scene = rtcNewScene(device);
    rtcSetSceneBuildQuality(scene, RTC_BUILD_QUALITY_HIGH);
    RTCGeometry geom = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
    // Embree reads vertices with 16-byte loads: one float of padding at the end.
    auto* v = static_cast<float*>(
        rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 12, nv + 1));
    std::memcpy(v, positions.data(), positions.size() * 4);
    auto* t = static_cast<uint32_t*>(
        rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 12, nt));
    std::memcpy(t, triangles.data(), triangles.size() * 4);
    rtcCommitGeometry(geom);
    rtcAttachGeometry(scene, geom);
    rtcReleaseGeometry(geom);
    rtcCommitScene(scene);
    std::printf("embree build %.1f ms (version %s, RTC_BUILD_QUALITY_HIGH, one thread)\n",
                seconds_since(start) * 1e3, RTC_VERSION_STRING);

    const char* names[3] = {"primary", "incoherent", "shadow"};
    for (int s = 0; s < 3; ++s) {
        const auto& rays = sets[s];
        const bool shadow = s == 2;
        double best = INFINITY;
        size_t count = 0;
        for (int pass = 0; pass < 5; ++pass) {
            RTCIntersectContext context;
            rtcInitIntersectContext(&context);
            double t0 = thread_seconds();
            count = 0;
            for (const auto& r : rays) {
                RTCRayHit rh = make_rayhit(r);
                if (shadow) {
                    rtcOccluded1(scene, &context, &rh.ray);
                    count += rh.ray.tfar < 0.0f;  // Embree sets tfar = -inf on occlusion
                } else {
                    rtcIntersect1(scene, &context, &rh);
                    count += rh.hit.geomID != RTC_INVALID_GEOMETRY_ID;
                }
            }
            best = std::fmin(best, thread_seconds() - t0);
        }
        std::printf("embree %s %.3f Mrays/s\n", names[s], rays.size() / best / 1e6);

        // Agreement with Obscura, ray by ray.
        RTCIntersectContext context;
        rtcInitIntersectContext(&context);
        size_t hit_miss = 0, other_triangle = 0, same_t = 0, far_t = 0, ours = 0, theirs = 0;
        double worst = 0.0;
        for (const auto& r : rays) {
            RTCRayHit rh = make_rayhit(r);
            if (shadow) {
                rtcOccluded1(scene, &context, &rh.ray);
                bool e = rh.ray.tfar < 0.0f, o = r.t != 0.0f;
                ours += o;
                theirs += e;
                hit_miss += e != o;
                continue;
            }
            rtcIntersect1(scene, &context, &rh);
            bool e = rh.hit.geomID != RTC_INVALID_GEOMETRY_ID, o = r.prim != UINT32_MAX;
            ours += o;
            theirs += e;
            if (e != o) {
                ++hit_miss;
            } else if (e) {
                double rel = std::fabs(double(rh.ray.tfar) - r.t) / std::fmax(1e-30, std::fabs(double(r.t)));
                worst = std::fmax(worst, rel);
                if (rh.hit.primID != r.prim) {
                    ++other_triangle;
                    same_t += rel <= 1e-5;
                } else {
                    far_t += rel > 1e-5;
                }
            }
        }
        if (shadow) {
            std::printf("agree shadow rays %zu occluded obscura %zu embree %zu disagree %zu\n", rays.size(), ours,
                        theirs, hit_miss);
        } else {
            std::printf(
                "agree %s rays %zu hits obscura %zu embree %zu hit/miss %zu other-triangle %zu (same t %zu) "
                "same-triangle-t-off %zu worst-rel-t %.2e\n",
                names[s], rays.size(), ours, theirs, hit_miss, other_triangle, same_t, far_t, worst);
        }
        (void)count;
    }
    rtcReleaseScene(scene);
    rtcReleaseDevice(device);
    return 0;
}

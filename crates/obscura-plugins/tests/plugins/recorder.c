/*
 * "Recorder": a test plugin for crates/obscura-plugins/tests/abi.rs that writes down every
 * factory-level call it receives, one line each, in a static buffer the test reads through the extra
 * export `recorder_calls` (on the same, already loaded, library):
 *
 *   entry                           the entry point
 *   init <plugin_path>
 *   synchronize <message> params    (or `null` when the host passed no list)
 *   create
 *   destroy
 *   finalize
 *
 * Once `init` has named the plugin path, the record is also written to the file `<plugin_path>.calls`
 * (what came before, then each call as it comes): that is how tests/isolate.rs reads the record of a
 * plugin run in a worker process.
 *
 * `property`, `project` and `unproject` are not recorded: the host calls them from many threads, and
 * the lifecycle is the point. Otherwise it is the smallest modifier: no parameters, no properties, the
 * host's default rays left alone. The host serialises the recorded calls, so the buffer needs no lock.
 */
#include <stddef.h>
#include <stdio.h>

#include "obscura/projection.h"

OBSCURA_EXPORT const char *recorder_calls(void);

static char CALLS[8192];
static size_t CALLS_LEN;
/* The length of CALLS already in the file, and the file (once init named the plugin path). */
static size_t FLUSHED;
static char LOG_PATH[4096];

/* Appends what the file lacks to `<plugin_path>.calls`, when init has named it. */
static void flush_log(void) {
    if (LOG_PATH[0] == '\0' || FLUSHED == CALLS_LEN) {
        return;
    }
    FILE *f = fopen(LOG_PATH, "a");
    if (f) {
        fwrite(CALLS + FLUSHED, 1, CALLS_LEN - FLUSHED, f);
        fclose(f);
        FLUSHED = CALLS_LEN;
    }
}

/* Appends `what` (and ` detail` when not NULL) as one line; a full buffer keeps what fits. */
static void record(const char *what, const char *detail) {
    size_t room = sizeof(CALLS) - CALLS_LEN;
    int n = snprintf(CALLS + CALLS_LEN, room, "%s%s%s\n", what, detail ? " " : "", detail ? detail : "");
    if (n > 0) {
        CALLS_LEN += (size_t)n < room ? (size_t)n : room - 1;
    }
    flush_log();
}

OBSCURA_EXPORT const char *recorder_calls(void) {
    return CALLS;
}

static int FACTORY_STATE;
static int PROJECTION_STATE;

static ObscuraStatus recorder_init(const ObscuraProjectionDescriptor *self, const char *plugin_path,
                                   void **factory, const ObscuraErrorSink *error) {
    (void)self;
    (void)error;
    if (plugin_path) {
        snprintf(LOG_PATH, sizeof(LOG_PATH), "%s.calls", plugin_path);
    }
    record("init", plugin_path ? plugin_path : "(NULL)");
    *factory = &FACTORY_STATE;
    return OBSCURA_OK;
}

static void recorder_finalize(void *factory) {
    (void)factory;
    record("finalize", NULL);
}

static void recorder_synchronize(void *factory, ObscuraSyncMessage message,
                                 const ObscuraParamList *params) {
    (void)factory;
    const char *name = message == OBSCURA_SYNC_RENDER_BEGIN ? "RenderBegin"
                       : message == OBSCURA_SYNC_RENDER_END ? "RenderEnd"
                       : message == OBSCURA_SYNC_INSTANCE_EDIT ? "InstanceEdit"
                                                               : "unknown";
    char line[64];
    snprintf(line, sizeof(line), "%s %s", name, params ? "params" : "null");
    record("synchronize", line);
}

static ObscuraStatus recorder_create(void *factory, ObscuraEnvironment *env,
                                     const ObscuraParamList *params, void **projection,
                                     const ObscuraErrorSink *error) {
    (void)factory;
    (void)env;
    (void)params;
    (void)error;
    record("create", NULL);
    *projection = &PROJECTION_STATE;
    return OBSCURA_OK;
}

static void recorder_destroy(void *factory, void *projection) {
    (void)factory;
    (void)projection;
    record("destroy", NULL);
}

static ObscuraStatus recorder_property(const void *projection, ObscuraProjectionProperty property,
                                       ObscuraPropertyValue *value) {
    (void)projection;
    (void)property;
    (void)value;
    return OBSCURA_UNSUPPORTED;
}

static ObscuraStatus recorder_project(const void *projection, const ObscuraProjectionContext *ctx,
                                      const ObscuraErrorSink *error) {
    (void)projection;
    (void)ctx;
    (void)error;
    return OBSCURA_OK;
}

static const ObscuraProjectionDescriptor DESCRIPTOR = {
    .abi_version = OBSCURA_PROJECTION_ABI_VERSION,
    .struct_size = sizeof(ObscuraProjectionDescriptor),
    .name = "Recorder",
    .summary = "test plugin that records the calls it receives",
    .params = NULL,
    .num_params = 0,
    .init = recorder_init,
    .finalize = recorder_finalize,
    .synchronize = recorder_synchronize,
    .create_projection = recorder_create,
    .destroy_projection = recorder_destroy,
    .property = recorder_property,
    .project = recorder_project,
    .unproject = NULL,
};

OBSCURA_EXPORT const ObscuraProjectionDescriptor *obscura_projection_entry(uint32_t host_abi_version) {
    (void)host_abi_version;
    record("entry", NULL);
    return &DESCRIPTOR;
}

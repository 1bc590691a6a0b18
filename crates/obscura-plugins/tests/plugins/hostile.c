/*
 * "Hostile": a test plugin for crates/obscura-plugins/tests/{validate,isolate}.rs, compiled once per
 * hazard with -D. Without a define it is a well-behaved modifier: a 90-degree field of view, the host's
 * default pinhole rays left alone. Each define makes it one way a native library can take a host down:
 *
 * Caught by validation before the system loader sees the file:
 *   DATA_ENTRY        `obscura_projection_entry` is a data object (an array in .data)
 *   RODATA_ENTRY      it is typed a function but its bytes are garbage in .rodata
 *   ABS_ENTRY         it is typed a function at an absolute address (0xdeadbeef) in no section
 *
 * Survivable only with --isolate-plugins (the call runs in a worker process):
 *   ABORT_CONSTRUCTOR a library constructor calls abort() as soon as the library is loaded
 *   CRASH_ENTRY       the entry point dereferences NULL
 *   SEGV_PROJECT      project dereferences NULL on batches holding a sample right of screen x = 0
 *   ABORT_PROJECT     project calls abort() on those batches
 *   HANG_PROJECT      project spins forever on those batches
 *   EXIT_PROJECT      project calls exit(3) on those batches
 *   SEGV_PROPERTY     property dereferences NULL
 *   INIT_ONCE         init succeeds once per plugin path, then crashes (it leaves `<plugin_path>.init`):
 *                     a restarted worker cannot come up
 */
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>

#include "obscura/projection.h"

#if defined(DATA_ENTRY)

OBSCURA_EXPORT unsigned char obscura_projection_entry[64] = {1, 2, 3};

#elif defined(RODATA_ENTRY)

__asm__(".section .rodata\n"
        ".globl obscura_projection_entry\n"
        ".type obscura_projection_entry, @function\n"
        "obscura_projection_entry:\n"
        ".byte 0xff, 0xff, 0xff, 0xff, 0x0f, 0x0b\n"
        ".size obscura_projection_entry, 6\n"
        ".text\n");

#elif defined(ABS_ENTRY)

__asm__(".globl obscura_projection_entry\n"
        ".type obscura_projection_entry, @function\n"
        ".set obscura_projection_entry, 0xdeadbeef\n");

#else

#if defined(ABORT_CONSTRUCTOR)
__attribute__((constructor)) static void hostile_constructor(void) {
    abort();
}
#endif

static int FACTORY_STATE;
static int PROJECTION_STATE;

/* True when the batch holds a sample right of the screen centre: the hazard strikes there only, so a
 * render loses part of its batches and keeps the rest. */
static int strikes(const ObscuraProjectionContext *ctx) {
    for (uint32_t i = 0; i < ctx->num_rays; i++) {
        if (ctx->screen[i].x > 0.0f) {
            return 1;
        }
    }
    return 0;
}

static ObscuraStatus hostile_init(const ObscuraProjectionDescriptor *self, const char *plugin_path,
                                  void **factory, const ObscuraErrorSink *error) {
    (void)self;
    (void)plugin_path;
    (void)error;
#if defined(INIT_ONCE)
    char marker[4096];
    snprintf(marker, sizeof(marker), "%s.init", plugin_path);
    FILE *seen = fopen(marker, "r");
    if (seen) {
        *(volatile int *)(uintptr_t)0 = 1;
    }
    FILE *mark = fopen(marker, "w");
    if (mark) {
        fclose(mark);
    }
#endif
    *factory = &FACTORY_STATE;
    return OBSCURA_OK;
}

static ObscuraStatus hostile_create(void *factory, ObscuraEnvironment *env,
                                    const ObscuraParamList *params, void **projection,
                                    const ObscuraErrorSink *error) {
    (void)factory;
    (void)env;
    (void)params;
    (void)error;
    *projection = &PROJECTION_STATE;
    return OBSCURA_OK;
}

static void hostile_destroy(void *factory, void *projection) {
    (void)factory;
    (void)projection;
}

static ObscuraStatus hostile_property(const void *projection, ObscuraProjectionProperty property,
                                      ObscuraPropertyValue *value) {
    (void)projection;
#if defined(SEGV_PROPERTY)
    *(volatile int *)(uintptr_t)0 = 1;
#endif
    if (property == OBSCURA_PROPERTY_FIELD_OF_VIEW) {
        value->kind = OBSCURA_VALUE_FLOAT;
        value->float_value = 90.0f;
        return OBSCURA_OK;
    }
    return OBSCURA_UNSUPPORTED;
}

static ObscuraStatus hostile_project(const void *projection, const ObscuraProjectionContext *ctx,
                                     const ObscuraErrorSink *error) {
    (void)projection;
    (void)error;
    if (strikes(ctx)) {
#if defined(SEGV_PROJECT)
        *(volatile int *)(uintptr_t)0 = 1;
#elif defined(ABORT_PROJECT)
        abort();
#elif defined(HANG_PROJECT)
        for (volatile int spin = 1; spin;) {
        }
#elif defined(EXIT_PROJECT)
        exit(3);
#endif
    }
    return OBSCURA_OK;
}

static const ObscuraProjectionDescriptor DESCRIPTOR = {
    .abi_version = OBSCURA_PROJECTION_ABI_VERSION,
    .struct_size = sizeof(ObscuraProjectionDescriptor),
    .name = "Hostile",
    .summary = "test plugin that crashes in the way it was compiled to",
    .params = NULL,
    .num_params = 0,
    .init = hostile_init,
    .finalize = NULL,
    .synchronize = NULL,
    .create_projection = hostile_create,
    .destroy_projection = hostile_destroy,
    .property = hostile_property,
    .project = hostile_project,
    .unproject = NULL,
};

OBSCURA_EXPORT const ObscuraProjectionDescriptor *obscura_projection_entry(uint32_t host_abi_version) {
    (void)host_abi_version;
#if defined(CRASH_ENTRY)
    *(volatile int *)(uintptr_t)0 = 1;
#endif
    return &DESCRIPTOR;
}

#endif

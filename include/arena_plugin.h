/* arena_plugin.h -- the C binding of Denoise Arena's one denoiser interface.
 *
 * It mirrors denoisers/denoiser.hpp: a registry entry (name, description, typed parameter schema,
 * required channels, which signal an instance filters), then per instance set-up (allocation, not
 * timed), reset (history cleared) and a per-frame call with the shared frame context (NRD's
 * CommonSettings), planar float image views and a place to report each pass's time (PassStats).
 * One interface, two bindings: a plugin is timed exactly like a built-in (the harness's wall clock
 * around `denoise`, in ms and bilateral units). Version 1 does not carry what only some built-ins
 * read or report: gradient samples and the low-resolution buffer (needsGradients, wantsLowres),
 * the rays a pass traced (setRays) and a pass's GPU traffic (docs/external-denoisers.md).
 *
 * A plugin is a shared library exporting one C function, `arena_plugin`, returning a pointer to a
 * static ArenaPlugin whose first field is the ABI version it was compiled against. The harness
 * refuses any other version. Images are views into the harness's memory: zero copy.
 *
 * Load it with `arena run --plugin ./libfoo.so` (or `--denoisers plugin:./libfoo.so`, or a
 * manifest {"library": "libfoo.so"}); see docs/external-denoisers.md. A manifest that adds
 * "isolated": true runs each instance in a process of its own (`arena serve`), where a crash or a
 * hang fails only its pair. */
#ifndef ARENA_PLUGIN_H
#define ARENA_PLUGIN_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Bumped on every incompatible change of the structs below. */
#define ARENA_PLUGIN_ABI_VERSION 1u
/* The name of the one exported symbol: const ArenaPlugin* arena_plugin(void). */
#define ARENA_PLUGIN_ENTRY_POINT "arena_plugin"
/* Layers have 1 to 3 channels (depth.Z; motion.XY; normal.XYZ, diffuse.RGB); 4 leaves room. */
#define ARENA_MAX_CHANNELS 4

#if defined(__GNUC__)
#define ARENA_PLUGIN_EXPORT __attribute__((visibility("default")))
#else
#define ARENA_PLUGIN_EXPORT
#endif

/* Which signal one instance filters (denoiser.hpp SignalKind). Demodulated plugins get one
 * instance for DIFFUSE and one for SPECULAR and the harness remodulates
 * (albedo * diffuse + specAlbedo * specular + emission); COLOR plugins get one instance on the
 * full colour and their output is the final image. */
typedef enum ArenaSignal {
  ARENA_SIGNAL_DIFFUSE = 0,
  ARENA_SIGNAL_SPECULAR = 1,
  ARENA_SIGNAL_COLOR = 2
} ArenaSignal;

typedef enum ArenaSignalMode {
  ARENA_SIGNALS_DEMODULATED = 0, /* diffuse and specular instances, remodulated by the harness */
  ARENA_SIGNALS_COLOR = 1        /* one instance on the remodulated colour */
} ArenaSignalMode;

/* Planar float image: channel c of pixel (x, y) is planes[c][y * width + x], y down. */
typedef struct ArenaImage {
  int width, height, channels;
  const float* planes[ARENA_MAX_CHANNELS];
} ArenaImage;

typedef struct ArenaMutableImage {
  int width, height, channels;
  float* planes[ARENA_MAX_CHANNELS];
} ArenaMutableImage;

/* A sequence layer by its name in core/sequence.hpp: "normal", "depth", "motion", "meshId", ... */
typedef struct ArenaLayer {
  const char* name;
  ArenaImage image;
} ArenaLayer;

/* core/camera.hpp's pinhole camera; view/projection are glm (OpenGL) column-major matrices. */
typedef struct ArenaCamera {
  float eye[3], forward[3], right[3], up[3];
  float tanHalfFovY, aspect;
  int width, height;
  float view[16], projection[16];
} ArenaCamera;

/* Per-frame state shared by every denoiser (denoiser.hpp FrameContext). */
typedef struct ArenaFrameContext {
  int frameIndex;
  int width, height;
  int reset; /* nonzero: discard history (first frame, camera cut) */
  ArenaCamera camera, previousCamera;
} ArenaFrameContext;

/* The noisy signal (NaN/Inf already replaced by 0) and the layers the plugin asked for, in the
 * order of ArenaPlugin.requiredChannels. */
typedef struct ArenaInputs {
  ArenaImage signal;
  const ArenaLayer* layers;
  int layerCount;
} ArenaInputs;

/* Reports one pass of the current frame (denoiser.hpp PassStats): its wall time as the plugin
 * measured it and the neighbour fetches per pixel. Optional; call in pass order. */
typedef struct ArenaHost {
  void* context;
  void (*reportPass)(void* context, const char* name, double milliseconds, double tapsPerPixel);
} ArenaHost;

/* The typed parameter schema of denoisers/params.hpp. Bool: default 0/1. Int/Float: inclusive
 * range [min, max]. Choice: default is an index into choices. */
typedef enum ArenaParamType {
  ARENA_PARAM_BOOL = 0,
  ARENA_PARAM_INT = 1,
  ARENA_PARAM_FLOAT = 2,
  ARENA_PARAM_CHOICE = 3
} ArenaParamType;

typedef struct ArenaParamSpec {
  const char* name;
  ArenaParamType type;
  double defaultValue;
  double min, max;
  const char* const* choices;
  int choiceCount;
  const char* meaning; /* one line, with the source of the default */
} ArenaParamSpec;

/* A resolved value: bool/int/float in `number`, a choice's name in `choice` (NULL otherwise).
 * create() receives one value per spec, in schema order, already range-checked by the harness. */
typedef struct ArenaParamValue {
  const char* name;
  double number;
  const char* choice;
} ArenaParamValue;

/* Entry points. Those returning int return 0 on success; otherwise they write a message (what
 * failed and why) into error[0..errorSize) and the harness fails the pair with it. */
typedef struct ArenaPlugin {
  uint32_t abiVersion; /* ARENA_PLUGIN_ABI_VERSION; must stay the first field */
  const char* name;    /* registry name: letters, digits, '_' and '-' */
  const char* description;
  ArenaSignalMode signals;
  const ArenaParamSpec* params;
  int paramCount;
  const char* const* requiredChannels;
  int requiredChannelCount;

  void* (*create)(const ArenaParamValue* values, int valueCount, ArenaSignal signal, char* error,
                  size_t errorSize);
  /* Allocates every buffer (history included) for this resolution; not timed. */
  int (*setup)(void* instance, int width, int height, char* error, size_t errorSize);
  /* Clears the history (camera cut). */
  void (*reset)(void* instance);
  /* Filters ctx->frameIndex's signal into `output` (width x height x 3, harness-owned); timed. */
  int (*denoise)(void* instance, const ArenaFrameContext* ctx, const ArenaInputs* inputs,
                 const ArenaMutableImage* output, const ArenaHost* host, char* error,
                 size_t errorSize);
  void (*destroy)(void* instance);
} ArenaPlugin;

typedef const ArenaPlugin* (*ArenaPluginEntryPoint)(void);

#ifdef __cplusplus
}
#endif

#endif /* ARENA_PLUGIN_H */

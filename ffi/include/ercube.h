/*
 * ercube.h: the ercube model behind a C ABI (crate ercube-ffi; link
 * libercube_ffi.a with -lpthread -ldl -lm, or libercube_ffi.so).
 *
 * Volumes load from files, scenes or caller buffers; a frame of any golden
 * method or of the bit-accurate pipeline renders exactly as `ercube render`
 * renders it (same defaults, same bits); the final image, the pipeline's
 * raw accumulator words and the statistics (JSON text) come back.
 *
 * Every int-returning entry returns an ercube_status (0 is success) and,
 * when it fails, leaves a one-line message for ercube_last_error(). Handles
 * are opaque: created by one call, released by its _free (null is ignored).
 * No Rust panic crosses this boundary (ERCUBE_PANIC instead).
 * Documentation: docs/verify.md.
 */
#ifndef ERCUBE_H
#define ERCUBE_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* The version of this header; compare with ercube_abi_version(). */
#define ERCUBE_ABI_VERSION 1u

typedef enum ercube_status {
    ERCUBE_OK = 0,
    /* A null pointer, text that is not UTF-8, a buffer that does not match
     * its dimensions, or a question the object cannot answer. */
    ERCUBE_ARGUMENT = 1,
    /* Malformed `ercube render` arguments (the command line's usage errors). */
    ERCUBE_USAGE = 2,
    /* The run failed on its input (file, configuration, camera...). */
    ERCUBE_FAILED = 3,
    /* A bug: the model panicked; the message says where. */
    ERCUBE_PANIC = 4
} ercube_status;

typedef struct ErcubeConfig ErcubeConfig; /* a pipeline configuration */
typedef struct ErcubeVolume ErcubeVolume; /* voxels, dimensions, spacing */
typedef struct ErcubeFrame ErcubeFrame;   /* a rendered frame */

/* The library's ABI version (ERCUBE_ABI_VERSION of the header it was built
 * with); refuse a library whose version differs from yours. */
uint32_t ercube_abi_version(void);

/* The last failure's one-line message on this thread ("" if none); valid
 * until the next failing call on the same thread. */
const char *ercube_last_error(void);

/* A pipeline configuration from TOML text (what a `--config` file holds;
 * missing keys keep their defaults), checked as the command line checks it. */
int ercube_config_from_toml(const char *toml, ErcubeConfig **out);
void ercube_config_free(ErcubeConfig *cfg);

/* A volume file in any format `ercube render --volume` reads (.den, NIfTI,
 * NRRD, MetaImage, TIFF, DICOM folders). */
int ercube_volume_load(const char *path, ErcubeVolume **out);
/* A synthetic scene, as `--scene SPEC` (e.g. "ml:40", "checker:32"). */
int ercube_volume_scene(const char *spec, ErcubeVolume **out);
/* A volume copied from dims[0] * dims[1] * dims[2] voxels, x fastest, then
 * y, then z; spacing (x, y, z) or NULL for 1, 1, 1. */
int ercube_volume_from_u8(const uint8_t *voxels, const size_t dims[3],
                          const double spacing[3], ErcubeVolume **out);
int ercube_volume_from_u16(const uint16_t *voxels, const size_t dims[3],
                           const double spacing[3], ErcubeVolume **out);
/* Dimensions (x, y, z), spacing and bits per voxel (8 or 16); any output
 * may be NULL. */
int ercube_volume_shape(const ErcubeVolume *vol, size_t dims[3],
                        double spacing[3], uint32_t *bits);
void ercube_volume_free(ErcubeVolume *vol);

/* Renders one frame of vol as `ercube render ARGV` would: argv holds argc
 * flags and values, e.g. {"--method", "pipeline", "--size", "64x64"}
 * (argv may be NULL when argc is 0); every flag not given keeps the
 * command line's default. No --scene, --volume or output-file flags
 * (--out, --npy, --stats, --raw-npy, --baseplane-npy): the values come
 * back through the frame. cfg, when not NULL, is the pipeline
 * configuration (instead of --config). The default transfer function is
 * a file's, grey-ramp. */
int ercube_render(const ErcubeVolume *vol, const ErcubeConfig *cfg,
                  const char *const *argv, size_t argc, ErcubeFrame **out);

/* The final image: *height rows of *width pixels of premultiplied RGBA
 * float32, rows from the top (what --npy writes). Lives with the frame. */
int ercube_frame_image(const ErcubeFrame *frame, const float **rgba,
                       size_t *width, size_t *height);
/* The pipeline's raw accumulator words: *height rows of *width R, G, B, A
 * int64 words, in the fixed-point formats the statistics' "raw_format"
 * names (what --raw-npy writes). ERCUBE_ARGUMENT for a golden method's
 * frame. Lives with the frame. */
int ercube_frame_raw(const ErcubeFrame *frame, const int64_t **words,
                     size_t *width, size_t *height);
/* The statistics as JSON text (what --stats writes); NULL for a NULL
 * frame. Lives with the frame. */
const char *ercube_frame_stats_json(const ErcubeFrame *frame);
void ercube_frame_free(ErcubeFrame *frame);

#ifdef __cplusplus
}
#endif

#endif /* ERCUBE_H */

/*
 * ercube.h: the ercube model behind a C ABI (crate ercube-ffi; link
 * libercube_ffi.a with -lpthread -ldl -lm, or libercube_ffi.so).
 *
 * Volumes load from files, scenes or caller buffers; a frame of any golden
 * method or of the bit-accurate pipeline renders exactly as `ercube render`
 * renders it (same defaults, same bits); the final image, the pipeline's
 * raw accumulator words and the statistics (JSON text) come back. One
 * sample of the datapath (the whole plain sample, or its bilinear or
 * composite unit) evaluates from its input words to its output words, bit
 * for bit the model's.
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
#define ERCUBE_ABI_VERSION 2u

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
typedef struct ErcubeDatapath ErcubeDatapath; /* one unit of the datapath */

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

/* ---- One datapath sample ----
 * A unit of the PE's datapath as the model describes it: "sample" (the
 * whole plain sample: position, bilinear interpolation, classification,
 * path length, opacity correction, compositing), "bilinear" or
 * "composite". Inputs and outputs are raw two's-complement words (the
 * value is word * 2^-frac); the unit's Verilog takes the same words on
 * ports of the same names and gives the outputs `latency` clocks later.
 * Table contents ("sample" only) start as the grey-ramp transfer
 * function's. */

/* The unit `unit` (NULL or "": "sample") of the configuration `toml`
 * (NULL or "": the defaults), composited in `order` ("btf" or "ftb"; NULL
 * or "": the configuration's). */
int ercube_datapath_new(const char *toml, const char *order,
                        const char *unit, ErcubeDatapath **out);
void ercube_datapath_free(ErcubeDatapath *dp);
/* Inputs, outputs, latency in clocks; any output may be NULL. */
int ercube_datapath_shape(const ErcubeDatapath *dp, uint32_t *n_inputs,
                          uint32_t *n_outputs, uint32_t *latency);
/* Port `index` of the inputs (side 0) or outputs (side 1): name (lives
 * with the datapath), width, fraction bits, 1 if signed; any output may be
 * NULL. */
int ercube_datapath_port(const ErcubeDatapath *dp, uint32_t side,
                         uint32_t index, const char **name, uint32_t *bits,
                         int32_t *frac, uint32_t *is_signed);
/* The index of the input (side 0) or output (side 1) named `name`. */
int ercube_datapath_find(const ErcubeDatapath *dp, uint32_t side,
                         const char *name, uint32_t *index);
/* Loads table `name` (class_r, class_g, class_b, class_a, log_table,
 * exp_table) with exactly its depth of raw words. */
int ercube_datapath_load_table(ErcubeDatapath *dp, const char *name,
                               const int64_t *words, size_t n);
/* Fills every table from a transfer-function preset ("grey-ramp", "ml",
 * "brain", ...), as a pipeline frame with --tf fills them. */
int ercube_datapath_fill_tables(ErcubeDatapath *dp, const char *tf);
/* One word of table `name`: read it, or set it (a raw word of the table's
 * format), as a host port writes one word (what DPI-C passes simply). */
int ercube_datapath_table_get(const ErcubeDatapath *dp, const char *name,
                              uint32_t addr, int64_t *word);
int ercube_datapath_table_set(ErcubeDatapath *dp, const char *name,
                              uint32_t addr, int64_t word);
/* One sample: n_inputs words in port order to n_outputs words. */
int ercube_datapath_eval(const ErcubeDatapath *dp, const int64_t *inputs,
                         size_t n_inputs, int64_t *outputs,
                         size_t n_outputs);
/* The same one scalar at a time (what DPI-C passes simply): hold input
 * words, evaluate, read output words. */
int ercube_datapath_set(ErcubeDatapath *dp, uint32_t index, int64_t word);
int ercube_datapath_step(ErcubeDatapath *dp);
int ercube_datapath_get(const ErcubeDatapath *dp, uint32_t index,
                        int64_t *word);
/* The unit as a Verilog module named `module` (the cuts only), released
 * with ercube_string_free. */
int ercube_datapath_verilog(const ErcubeDatapath *dp, const char *module,
                            char **out);
void ercube_string_free(char *s);

#ifdef __cplusplus
}
#endif

#endif /* ERCUBE_H */

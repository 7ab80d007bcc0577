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
 * for bit the model's. The PE array steps one clock at a time, every PE's
 * signals, ports and report lines read out per cycle.
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
#define ERCUBE_ABI_VERSION 3u

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
    ERCUBE_PANIC = 4,
    /* ercube_chip_step: the frame has no cycle left (not a failure). */
    ERCUBE_DONE = 5
} ercube_status;

typedef struct ErcubeConfig ErcubeConfig; /* a pipeline configuration */
typedef struct ErcubeVolume ErcubeVolume; /* voxels, dimensions, spacing */
typedef struct ErcubeFrame ErcubeFrame;   /* a rendered frame */
typedef struct ErcubeDatapath ErcubeDatapath; /* one unit of the datapath */
typedef struct ErcubeChip ErcubeChip;     /* the array, stepped a cycle at a time */

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

/* ---- The array, one clock at a time ----
 * A chip begins a pipeline frame as ercube_render would render it, then
 * clocks it one cycle per ercube_chip_step: the same cycles as the frame
 * `ercube render --vcd` traces, each PE's values exactly the waveform's
 * for that cycle (signal `top.pe_K.NAME`, `top.pe_K.left.NAME`, ...: the
 * field named after it). Widths are the configuration's: C = max(
 * accum_color, merge) bits, A = max(accum_alpha, merge) bits, V = voxel
 * bits, S = sample bits; every word sits in the low bits of its field,
 * two's complement over its width; a payload is 0 while its valid is 0. */

/* What a PE drove on one link port in the cycle (top.pe_K.left/right). */
typedef struct ErcubeLinkPort {
    uint64_t ray_rgba[4];    /* ray_r, ray_g, ray_b (C bits), ray_a (A bits) */
    uint64_t ray_prev;       /* S bits: previous sample (pre-integrated) */
    uint64_t parent_rgba[4]; /* parent_r, _g, _b (C), parent_a (A): a pass's edge ray */
    uint16_t ray_mx;         /* 16 bits, two's complement: the ray's index */
    uint16_t ray_row;        /* 16 bits: its row in the region */
    uint16_t edge[2];        /* edge_0, edge_1 (V bits): edge voxels, rows y0, y0+1 */
    uint16_t halo[8];        /* halo_0..halo_7 (V bits): shaded frames */
    uint16_t parent_mx;      /* 16 bits, two's complement */
    uint8_t ray_valid;       /* 1 bit */
    uint8_t edge_valid;      /* 1 bit */
    uint8_t parent_valid;    /* 1 bit */
} ErcubeLinkPort;

/* What a PE streamed to the host in a readout cycle (top.pe_K.host). */
typedef struct ErcubeHostPort {
    uint64_t rgba[4];        /* r, g, b (C bits), a (A bits): final words */
    uint16_t mx;             /* 16 bits, two's complement */
    uint16_t row;            /* 16 bits: row in region 0 */
    uint8_t valid;           /* 1 bit */
} ErcubeHostPort;

/* A PE's own signals (top.pe_K): its sample path's output registers after
 * its last sampling cycle, counters and registers. Words in the
 * configuration's formats (sample, alpha, opacity_corr, accum_color /
 * accum_alpha, gradient, grad_norm, normal_dot, color, voi_weight,
 * voi_factor, sample, preint_tau bits); a unit's words are 0 without it. */
typedef struct ErcubePeSignals {
    uint64_t sample, alpha, alpha_corr;
    uint64_t acc[4];         /* acc_r, acc_g, acc_b, acc_a */
    uint64_t grad[3];        /* grad_x, grad_y, grad_z (shaded) */
    uint64_t grad_norm, n_dot_l;
    uint64_t shaded[3];      /* shaded_r, _g, _b (shaded) */
    uint64_t voi_weight, voi_factor;
    uint64_t pre_back, pre_tau; /* pre-integrated frames */
    uint32_t rays_sent;      /* 32 bits: rays sent so far */
    uint32_t stalls;         /* 32 bits: stall cycles so far */
    uint16_t ray_mx;         /* 16 bits, two's complement */
    uint16_t ray_row;        /* 16 bits */
    uint16_t rays_held;      /* 16 bits: columns in the compositing buffer */
    uint16_t fifo[2];        /* fifo_left, fifo_right (16 bits) */
    uint16_t edge_reg[2];    /* edge_reg_0, _1 (V bits) */
    uint16_t halo_reg[8];    /* halo_reg_0.._7 (V bits, shaded) */
    uint16_t pass_children;  /* 16 bits */
    uint8_t incoming;        /* 8 bits: columns being received */
    uint8_t busy;            /* 1 bit: it sampled this cycle */
    uint8_t terminated;      /* 1 bit: front to back only */
    uint8_t in_flight;       /* 1 bit: samples in its datapath */
} ErcubePeSignals;

/* A PE's report lines to the controller after the cycle (not traced). */
typedef struct ErcubePeReport {
    uint64_t drained_at;     /* cycle by which its datapath is empty */
    uint64_t lands_by;       /* bound on its held rays' scoreboard stamps */
    uint64_t merge_outputs;  /* child rays its merges (folds) wrote */
    uint64_t split_outputs;  /* child rays its splits wrote */
    uint32_t active;         /* held columns it samples this slice */
    uint32_t pass_width;     /* children of its current pass */
    uint32_t slot_work;      /* its sparse pass slot's work list */
    uint8_t settled;         /* 1: FIFOs and receive buffer empty */
    uint8_t readout_done;    /* 1: its readout streamed every ray */
} ErcubePeReport;

/* PE k in the cycle. */
typedef struct ErcubePe {
    ErcubePeSignals pe;
    ErcubeLinkPort left;     /* towards PE k - 1 */
    ErcubeLinkPort right;    /* towards PE k + 1 */
    ErcubeHostPort host;
    ErcubePeReport report;
} ErcubePe;

/* The controller in the cycle (top.ctrl). */
typedef struct ErcubeBroadcast {
    uint64_t cycle;          /* the cycle, counting from 1 */
    uint32_t n_commands;     /* commands broadcast since the previous cycle */
    uint16_t slice, row;     /* 16 bits each */
    uint16_t pass_x, pass_y, pass_col, drive_row; /* 16 bits each */
    uint8_t stage;           /* 4 bits: 0 sample, 1 migrate, 2 merge,
                              * 3 readout, 4 skip, 5 split, 6 fold,
                              * 7 drain, 8 stall, 9 memory */
    uint8_t pass_x_valid, pass_y_valid, drive_valid; /* 1 bit each */
} ErcubeBroadcast;

/* A command the controller broadcast to every PE between two cycles.
 * kind: 0 begin slice (a, b: first and last ray index), 1 plan rows (a:
 * the slice's first row in the region's grid, b: its rows), 2 begin row
 * (a: the slice's row), 3 begin merge, 4 begin split, 5 begin fold, 6 end
 * merge, 7 end split, 8 end fold, 9 plan moves (a: 1 around a ring, 0
 * along the line), 10 begin readout. */
typedef struct ErcubeCommand {
    uint32_t kind;
    int64_t a, b;
} ErcubeCommand;

/* A chip with the pipeline configuration cfg (NULL: the defaults). */
int ercube_chip_new(const ErcubeConfig *cfg, ErcubeChip **out);
/* Begins the frame ercube_render(vol, cfg, argv, argc) renders (a
 * pipeline --method; no --repeat), dropping any frame in progress. No
 * cycle runs before ercube_chip_step. */
int ercube_chip_begin(ErcubeChip *chip, const ErcubeVolume *vol,
                      const char *const *argv, size_t argc);
/* Clocks one cycle: ERCUBE_OK when it ran, ERCUBE_DONE when the frame has
 * no cycle left, or the frame's failure. */
int ercube_chip_step(ErcubeChip *chip);
/* Cycles clocked so far (after ERCUBE_DONE: the frame's, the statistics'
 * "cycles"). */
int ercube_chip_cycle(const ErcubeChip *chip, uint64_t *cycle);
/* The array's PEs, PE k and the controller in the last cycle clocked,
 * and command i of those broadcast before it. */
int ercube_chip_pes(const ErcubeChip *chip, uint32_t *n);
int ercube_chip_ports(const ErcubeChip *chip, uint32_t k, ErcubePe *out);
int ercube_chip_broadcast(const ErcubeChip *chip, ErcubeBroadcast *out);
int ercube_chip_command(const ErcubeChip *chip, uint32_t i,
                        ErcubeCommand *out);
/* Runs the rest of the frame without handing over and returns it: the
 * frame ercube_render returns (image, raw words, statistics). */
int ercube_chip_finish(ErcubeChip *chip, ErcubeFrame **out);
/* Releases the chip, stopping its frame (NULL is ignored). */
void ercube_chip_free(ErcubeChip *chip);

#ifdef __cplusplus
}
#endif

#endif /* ERCUBE_H */

/* Runs frames through the C ABI (ffi/include/ercube.h) and writes the
 * pipeline's raw words for the test (ffi/tests/c_abi.rs) to compare with
 * `ercube render --raw-npy`.
 *
 * usage: frame VOLUME CONFIG.toml OUT_FILE_RAW OUT_BUFFER_RAW
 *   OUT_FILE_RAW:   the raw words of VOLUME's 64x64 pipeline frame
 *   OUT_BUFFER_RAW: the raw words of a 24x20x16 u16 ramp volume given as a
 *                   buffer, 32x32 pipeline frame (voxel (x,y,z) = 97x + 31y
 *                   + 7z + 40, x fastest)
 * Each output file is int64 words, little-endian, H x W x 4. Prints one
 * line per check; exits 1 on the first failure. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ercube.h"

static int fail(const char *what, int status) {
    fprintf(stderr, "FAIL %s: status %d: %s\n", what, status, ercube_last_error());
    return 1;
}

static char *read_text(const char *path) {
    FILE *f = fopen(path, "rb");
    if (!f) return NULL;
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    char *t = malloc((size_t)n + 1);
    if (t && fread(t, 1, (size_t)n, f) != (size_t)n) { free(t); t = NULL; }
    if (t) t[n] = 0;
    fclose(f);
    return t;
}

/* Writes frame's raw words to path; 0 on success. */
static int dump_raw(const ErcubeFrame *frame, const char *path) {
    const int64_t *words;
    size_t w, h;
    int s = ercube_frame_raw(frame, &words, &w, &h);
    if (s != ERCUBE_OK) return fail("ercube_frame_raw", s);
    FILE *f = fopen(path, "wb");
    if (!f || fwrite(words, sizeof(int64_t), w * h * 4, f) != w * h * 4) {
        fprintf(stderr, "FAIL cannot write %s\n", path);
        return 1;
    }
    fclose(f);
    printf("raw %zux%zu -> %s\n", w, h, path);
    return 0;
}

int main(int argc, char **argv) {
    if (argc != 5) {
        fprintf(stderr, "usage: frame VOLUME CONFIG.toml OUT_FILE_RAW OUT_BUFFER_RAW\n");
        return 2;
    }
    if (ercube_abi_version() != ERCUBE_ABI_VERSION) {
        fprintf(stderr, "FAIL abi version %u, header %u\n", ercube_abi_version(), ERCUBE_ABI_VERSION);
        return 1;
    }
    int s;

    /* A file volume with a configuration from TOML text. */
    char *toml = read_text(argv[2]);
    if (!toml) { fprintf(stderr, "FAIL cannot read %s\n", argv[2]); return 1; }
    ErcubeConfig *cfg = NULL;
    if ((s = ercube_config_from_toml(toml, &cfg)) != ERCUBE_OK) return fail("config", s);
    free(toml);
    ErcubeVolume *vol = NULL;
    if ((s = ercube_volume_load(argv[1], &vol)) != ERCUBE_OK) return fail("volume_load", s);
    size_t dims[3];
    uint32_t bits;
    if ((s = ercube_volume_shape(vol, dims, NULL, &bits)) != ERCUBE_OK) return fail("shape", s);
    printf("volume %zux%zux%zu, %u bits\n", dims[0], dims[1], dims[2], bits);
    const char *args[] = {"--method", "pipeline", "--size", "64x64"};
    ErcubeFrame *frame = NULL;
    if ((s = ercube_render(vol, cfg, args, 4, &frame)) != ERCUBE_OK) return fail("render", s);
    const float *rgba;
    size_t w, h;
    if ((s = ercube_frame_image(frame, &rgba, &w, &h)) != ERCUBE_OK) return fail("image", s);
    const char *stats = ercube_frame_stats_json(frame);
    if (!stats || !strstr(stats, "\"raw_format\"")) { fprintf(stderr, "FAIL stats: %s\n", stats); return 1; }
    if (dump_raw(frame, argv[3])) return 1;
    ercube_frame_free(frame);

    /* A u16 volume from a buffer, the default configuration. */
    size_t bd[3] = {24, 20, 16};
    uint16_t *vox = malloc(bd[0] * bd[1] * bd[2] * sizeof(uint16_t));
    for (size_t z = 0; z < bd[2]; z++)
        for (size_t y = 0; y < bd[1]; y++)
            for (size_t x = 0; x < bd[0]; x++)
                vox[(z * bd[1] + y) * bd[0] + x] = (uint16_t)(97 * x + 31 * y + 7 * z + 40);
    ErcubeVolume *buf = NULL;
    if ((s = ercube_volume_from_u16(vox, bd, NULL, &buf)) != ERCUBE_OK) return fail("from_u16", s);
    free(vox);
    const char *small[] = {"--method", "pipeline", "--size", "32x32"};
    if ((s = ercube_render(buf, NULL, small, 4, &frame)) != ERCUBE_OK) return fail("render buffer", s);
    if (dump_raw(frame, argv[4])) return 1;
    ercube_frame_free(frame);

    /* A scene. */
    ErcubeVolume *sc = NULL;
    if ((s = ercube_volume_scene("ml:16", &sc)) != ERCUBE_OK) return fail("scene", s);
    double sp[3];
    if ((s = ercube_volume_shape(sc, dims, sp, &bits)) != ERCUBE_OK) return fail("scene shape", s);
    printf("scene %zux%zux%zu, spacing %g,%g,%g, %u bits\n", dims[0], dims[1], dims[2], sp[0], sp[1], sp[2], bits);
    if (dims[0] != 16 || dims[1] != 16 || dims[2] != 16) return 1;
    ercube_volume_free(sc);

    /* Error paths: each a status and a one-line message. */
    const char *bad_size[] = {"--size", "0x0"};
    s = ercube_render(buf, NULL, bad_size, 2, &frame);
    printf("bad size: status %d: %s\n", s, ercube_last_error());
    if (s == ERCUBE_OK || strlen(ercube_last_error()) == 0) return 1;
    const char *bad_flag[] = {"--no-such-flag"};
    s = ercube_render(buf, NULL, bad_flag, 1, &frame);
    printf("bad flag: status %d: %s\n", s, ercube_last_error());
    if (s != ERCUBE_USAGE) return 1;
    ErcubeVolume *missing = NULL;
    s = ercube_volume_load("/nonexistent/volume.den", &missing);
    printf("missing file: status %d: %s\n", s, ercube_last_error());
    if (s != ERCUBE_FAILED || missing != NULL) return 1;
    const uint8_t one = 7;
    size_t zero_dims[3] = {0, 1, 1};
    ErcubeVolume *empty = NULL;
    s = ercube_volume_from_u8(&one, zero_dims, NULL, &empty);
    printf("zero dims: status %d: %s\n", s, ercube_last_error());
    if (s != ERCUBE_FAILED || empty != NULL) return 1;
    ErcubeConfig *bad_cfg = NULL;
    s = ercube_config_from_toml("pes = 0", &bad_cfg);
    printf("bad config: status %d: %s\n", s, ercube_last_error());
    if (s != ERCUBE_FAILED) return 1;
    const char *golden[] = {"--method", "er", "--size", "16x16"};
    if ((s = ercube_render(buf, NULL, golden, 4, &frame)) != ERCUBE_OK) return fail("render er", s);
    const int64_t *words;
    s = ercube_frame_raw(frame, &words, &w, &h);
    printf("golden raw: status %d: %s\n", s, ercube_last_error());
    if (s != ERCUBE_ARGUMENT) return 1;
    ercube_frame_free(frame);
    s = ercube_render(NULL, NULL, NULL, 0, &frame);
    printf("null volume: status %d: %s\n", s, ercube_last_error());
    if (s != ERCUBE_ARGUMENT) return 1;

    ercube_volume_free(buf);
    ercube_volume_free(vol);
    ercube_config_free(cfg);
    printf("ok\n");
    return 0;
}

/* Evaluates datapath samples through the C ABI (ffi/include/ercube.h) for
 * the test (ffi/tests/c_abi.rs) to compare with the model.
 *
 * usage: datapath UNIT ORDER TF < WORDS
 *   Prints the unit's latency and ports ("in NAME BITS FRAC SIGNED", then
 *   "out ..."), then, per line of input words on stdin (in port order,
 *   space-separated), one line of output words. Before that it walks the
 *   error paths, printing "NAME: status S: MESSAGE" for each. Exits 1 on an
 *   unexpected failure. */
#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ercube.h"

static int fail(const char *what, int status) {
    fprintf(stderr, "FAIL %s: status %d: %s\n", what, status, ercube_last_error());
    return 1;
}

/* Prints an expected failure; returns 1 if the call succeeded instead. */
static int expect_error(const char *what, int status) {
    if (status == ERCUBE_OK) {
        fprintf(stderr, "FAIL %s succeeded\n", what);
        return 1;
    }
    printf("%s: status %d: %s\n", what, status, ercube_last_error());
    return 0;
}

static int errors(void) {
    ErcubeDatapath *dp = NULL;
    int bad = 0;
    bad |= expect_error("unknown unit", ercube_datapath_new(NULL, NULL, "nope", &dp));
    bad |= expect_error("bad order", ercube_datapath_new(NULL, "sideways", NULL, &dp));
    bad |= expect_error("bad config", ercube_datapath_new("pes = 0", NULL, NULL, &dp));
    if (ercube_datapath_new(NULL, "btf", "composite", &dp) != ERCUBE_OK) return fail("new", 1);
    int64_t in[8] = {0}, out[4];
    bad |= expect_error("few inputs", ercube_datapath_eval(dp, in, 7, out, 4));
    in[0] = INT64_C(1) << 40;
    bad |= expect_error("wide input", ercube_datapath_eval(dp, in, 8, out, 4));
    bad |= expect_error("no table", ercube_datapath_load_table(dp, "class_r", in, 1));
    uint32_t i;
    bad |= expect_error("no port", ercube_datapath_find(dp, 0, "acc_x", &i));
    bad |= expect_error("null datapath", ercube_datapath_step(NULL));
    int64_t w = 0;
    bad |= expect_error("no table word", ercube_datapath_table_get(dp, "class_r", 0, &w));
    ercube_datapath_free(dp);
    /* A table word of the whole sample: set, read back, refused past the
     * table or outside its format. */
    if (ercube_datapath_new(NULL, "btf", "sample", &dp) != ERCUBE_OK) return fail("new sample", 1);
    if (ercube_datapath_table_set(dp, "class_a", 7, 123) != ERCUBE_OK) return fail("table_set", 1);
    if (ercube_datapath_table_get(dp, "class_a", 7, &w) != ERCUBE_OK || w != 123)
        return fail("table_get after table_set", 1);
    bad |= expect_error("table address", ercube_datapath_table_get(dp, "class_a", 1u << 30, &w));
    bad |= expect_error("table word", ercube_datapath_table_set(dp, "class_a", 0, -1));
    ercube_datapath_free(dp);
    return bad;
}

int main(int argc, char **argv) {
    if (argc != 4) {
        fprintf(stderr, "usage: datapath UNIT ORDER TF < WORDS\n");
        return 2;
    }
    if (ercube_abi_version() != ERCUBE_ABI_VERSION) {
        fprintf(stderr, "FAIL abi version %u, header %u\n", ercube_abi_version(), ERCUBE_ABI_VERSION);
        return 1;
    }
    if (errors()) return 1;
    ErcubeDatapath *dp = NULL;
    int s = ercube_datapath_new(NULL, argv[2], argv[1], &dp);
    if (s != ERCUBE_OK) return fail("ercube_datapath_new", s);
    s = ercube_datapath_fill_tables(dp, argv[3]);
    if (s != ERCUBE_OK) return fail("ercube_datapath_fill_tables", s);
    uint32_t n_in, n_out, latency;
    s = ercube_datapath_shape(dp, &n_in, &n_out, &latency);
    if (s != ERCUBE_OK) return fail("ercube_datapath_shape", s);
    printf("latency %u\n", latency);
    for (uint32_t side = 0; side < 2; side++) {
        for (uint32_t k = 0; k < (side ? n_out : n_in); k++) {
            const char *name;
            uint32_t bits, is_signed, found;
            int32_t frac;
            s = ercube_datapath_port(dp, side, k, &name, &bits, &frac, &is_signed);
            if (s != ERCUBE_OK) return fail("ercube_datapath_port", s);
            s = ercube_datapath_find(dp, side, name, &found);
            if (s != ERCUBE_OK || found != k) return fail("ercube_datapath_find", s);
            printf("%s %s %u %d %u\n", side ? "out" : "in", name, bits, frac, is_signed);
        }
    }
    int64_t *in = calloc(n_in, sizeof *in), *out = calloc(n_out, sizeof *out);
    for (;;) {
        uint32_t k = 0;
        while (k < n_in && scanf("%" SCNd64, &in[k]) == 1) k++;
        if (k == 0) break;
        if (k != n_in) return fail("a short line of input words", 0);
        s = ercube_datapath_eval(dp, in, n_in, out, n_out);
        if (s != ERCUBE_OK) return fail("ercube_datapath_eval", s);
        /* The scalar route gives the same words. */
        for (k = 0; k < n_in; k++)
            if ((s = ercube_datapath_set(dp, k, in[k])) != ERCUBE_OK) return fail("set", s);
        if ((s = ercube_datapath_step(dp)) != ERCUBE_OK) return fail("step", s);
        for (k = 0; k < n_out; k++) {
            int64_t w;
            if ((s = ercube_datapath_get(dp, k, &w)) != ERCUBE_OK) return fail("get", s);
            if (w != out[k]) return fail("set/step/get differs from eval", 0);
            printf("%s%" PRId64, k ? " " : "", out[k]);
        }
        printf("\n");
    }
    free(in);
    free(out);
    ercube_datapath_free(dp);
    return 0;
}

/* Steps pipeline frames one clock at a time through the C ABI
 * (ffi/include/ercube.h) and checks them against ercube_render's frame of
 * the same volume and arguments: the raw words equal, the cycles stepped
 * equal the statistics' "cycles". A 24x20x16 u16 ramp volume (voxel
 * (x,y,z) = 97x + 31y + 7z + 40), 4 PEs, a 32x32 frame.
 *
 * usage: chip
 * Prints one line per check; exits 1 on the first failure. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ercube.h"

/* The layout the library's structs have (ffi/src/chip.rs asserts the
 * same sizes). */
_Static_assert(sizeof(ErcubeLinkPort) == 104, "ErcubeLinkPort");
_Static_assert(sizeof(ErcubeHostPort) == 40, "ErcubeHostPort");
_Static_assert(sizeof(ErcubePeSignals) == 200, "ErcubePeSignals");
_Static_assert(sizeof(ErcubePeReport) == 48, "ErcubePeReport");
_Static_assert(sizeof(ErcubePe) == 200 + 2 * 104 + 40 + 48, "ErcubePe");
_Static_assert(sizeof(ErcubeBroadcast) == 32, "ErcubeBroadcast");
_Static_assert(sizeof(ErcubeCommand) == 24, "ErcubeCommand");

static int fail(const char *what, int status) {
    fprintf(stderr, "FAIL %s: status %d: %s\n", what, status, ercube_last_error());
    return 1;
}

/* The statistics' "cycles". */
static unsigned long long stats_cycles(const ErcubeFrame *f) {
    const char *s = strstr(ercube_frame_stats_json(f), "\"cycles\":");
    return s ? strtoull(s + 9, NULL, 10) : 0;
}

/* Whether two pipeline frames' raw words are the same. */
static int same_raw(const ErcubeFrame *a, const ErcubeFrame *b) {
    const int64_t *wa, *wb;
    size_t w1, h1, w2, h2;
    if (ercube_frame_raw(a, &wa, &w1, &h1) || ercube_frame_raw(b, &wb, &w2, &h2)) return 0;
    return w1 == w2 && h1 == h2 && memcmp(wa, wb, w1 * h1 * 4 * sizeof(int64_t)) == 0;
}

int main(void) {
    if (ercube_abi_version() != ERCUBE_ABI_VERSION) {
        fprintf(stderr, "FAIL abi version %u, header %u\n", ercube_abi_version(), ERCUBE_ABI_VERSION);
        return 1;
    }
    enum { NX = 24, NY = 20, NZ = 16 };
    static uint16_t vox[NX * NY * NZ];
    for (int z = 0; z < NZ; z++)
        for (int y = 0; y < NY; y++)
            for (int x = 0; x < NX; x++)
                vox[(z * NY + y) * NX + x] = (uint16_t)(97 * x + 31 * y + 7 * z + 40);
    const size_t dims[3] = {NX, NY, NZ};
    ErcubeVolume *vol = NULL;
    ErcubeConfig *cfg = NULL;
    ErcubeChip *chip = NULL;
    ErcubeFrame *want = NULL, *got = NULL;
    int s;
    if ((s = ercube_volume_from_u16(vox, dims, NULL, &vol))) return fail("volume", s);
    if ((s = ercube_config_from_toml("pes = 4\n", &cfg))) return fail("config", s);
    const char *args[] = {"--method", "pipeline", "--size", "32x32"};
    if ((s = ercube_render(vol, cfg, args, 4, &want))) return fail("render", s);
    unsigned long long cycles = stats_cycles(want);

    if ((s = ercube_chip_new(cfg, &chip))) return fail("chip", s);
    /* Errors before a frame: a status and a message, no crash. */
    s = ercube_chip_step(chip);
    printf("step before begin: status %d: %s\n", s, ercube_last_error());
    if (s != ERCUBE_ARGUMENT) return 1;
    const char *golden[] = {"--method", "er"};
    s = ercube_chip_begin(chip, vol, golden, 2);
    printf("golden begin: status %d: %s\n", s, ercube_last_error());
    if (s != ERCUBE_USAGE) return 1;

    /* The whole frame, one cycle at a time. */
    if ((s = ercube_chip_begin(chip, vol, args, 4))) return fail("begin", s);
    unsigned long long stepped = 0, busy = 0, commands = 0, migrating = 0, readout = 0;
    uint32_t pes = 0;
    while ((s = ercube_chip_step(chip)) == ERCUBE_OK) {
        stepped++;
        ErcubeBroadcast b;
        if ((s = ercube_chip_broadcast(chip, &b))) return fail("broadcast", s);
        if (b.cycle != stepped) {
            fprintf(stderr, "FAIL cycle %llu reported as %llu\n", stepped, (unsigned long long)b.cycle);
            return 1;
        }
        for (uint32_t i = 0; i < b.n_commands; i++) {
            ErcubeCommand c;
            if ((s = ercube_chip_command(chip, i, &c))) return fail("command", s);
            if (c.kind > 10) return fail("command kind", (int)c.kind);
            commands++;
        }
        if ((s = ercube_chip_pes(chip, &pes))) return fail("pes", s);
        for (uint32_t k = 0; k < pes; k++) {
            ErcubePe p;
            if ((s = ercube_chip_ports(chip, k, &p))) return fail("ports", s);
            busy += p.pe.busy;
            migrating += p.left.ray_valid + p.right.ray_valid;
            readout += p.host.valid;
            if (p.pe.busy && b.stage != 0) return fail("busy outside sampling", (int)b.stage);
        }
    }
    if (s != ERCUBE_DONE) return fail("step", s);
    uint64_t total = 0;
    ercube_chip_cycle(chip, &total);
    ErcubePe none;
    s = ercube_chip_ports(chip, pes, &none);
    printf("ports past the end: status %d: %s\n", s, ercube_last_error());
    if ((s = ercube_chip_finish(chip, &got))) return fail("finish", s);
    printf("stepped %llu cycles (chip says %llu, stats %llu) of %u PEs: %llu busy PE-cycles, "
           "%llu commands, %llu ray moves, %llu readout words\n",
           stepped, (unsigned long long)total, cycles, pes, busy, commands, migrating, readout);
    if (stepped != cycles || total != cycles || cycles == 0) return fail("cycles", 0);
    if (!busy || !commands || !readout) return fail("an idle frame proves nothing", 0);
    if (!same_raw(want, got)) return fail("raw words differ from ercube_render's", 0);
    printf("stepped frame: raw words equal ercube_render's\n");
    ercube_frame_free(got);

    /* A hundred cycles, then the rest at once. */
    if ((s = ercube_chip_begin(chip, vol, args, 4))) return fail("begin", s);
    for (int i = 0; i < 100; i++)
        if ((s = ercube_chip_step(chip))) return fail("step", s);
    if ((s = ercube_chip_finish(chip, &got))) return fail("finish", s);
    if (!same_raw(want, got)) return fail("finished frame's raw words differ", 0);
    printf("finished after 100 cycles: raw words equal ercube_render's\n");
    ercube_frame_free(got);

    /* Dropped mid-frame: freeing stops the frame and returns. */
    if ((s = ercube_chip_begin(chip, vol, args, 4))) return fail("begin", s);
    for (int i = 0; i < 10; i++)
        if ((s = ercube_chip_step(chip))) return fail("step", s);
    ercube_chip_free(chip);
    printf("freed mid-frame\n");

    ercube_frame_free(want);
    ercube_config_free(cfg);
    ercube_volume_free(vol);
    printf("ok\n");
    return 0;
}

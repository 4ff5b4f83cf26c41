/* SPDX-License-Identifier: Apache-2.0 */
/*
 * CAN bus load, CSP at 1 kHz against evenfeed's segment mode, measured side by side in one
 * run (docs/benchmarks-can.md).
 *
 * The standard path (samples/profile.ngc, smoothed with the streamer's defaults) is streamed
 * to three drives, one per axis, by the real master (ef_comaster) to the real drive code
 * (ef_codrive) over an in-memory bus at 1 Mbit/s in simulated time (ef_canload.h): every
 * frame either side sends is counted with its bits on the wire, frame overhead and
 * worst-case bit stuffing included (ef_can_frame_bits()). Counted from the moment the master
 * is in RUN (bring-up is excluded, being the same for both) to the moment all drives are at
 * rest at the program's end; divided by that time, which is the program's own duration plus
 * the start-up of each mode.
 *
 * usage: bench_canbus [program.ngc]    (default samples/profile.ngc from the working dir)
 */
#include <stdio.h>

#include "evenfeed/host/can/ef_canload.h"

extern const ef_table_t ef_tbl_g1_default;
extern const ef_table_t ef_tbl_g2_default;

#define BC_BITRATE 1000000u

/* One mode's figures, by function code. */
static void bc_print(const char *name, const ef_canload_result_t *r)
{
    printf("%s: %.0f frames, %.0f bits in %.3f s: %.1f kbit/s, %.1f %% of 1 Mbit/s"
           " (end within %.2g mm, following error max %.4f mm, resends %u, starved cycles %u)\n",
           name, r->frames, r->bits, r->seconds, r->bits / r->seconds * 1e-3,
           r->bits / r->seconds / BC_BITRATE * 100.0, r->end_err, r->ferr_max, r->resends,
           r->starved);
    for (int fn = 0; fn < 16; fn++)
        if (r->frames_fn[fn] > 0)
            printf("    %-32s %8.0f frames %10.0f bits  %7.1f kbit/s\n", ef_canload_fn_name(fn),
                   r->frames_fn[fn], r->bits_fn[fn], r->bits_fn[fn] / r->seconds * 1e-3);
}

int main(int argc, char **argv)
{
    const char *prog = argc > 1 ? argv[1] : "samples/profile.ngc";
    ef_gcode_t rd;
    ef_msg_t m = {{0}};
    if (ef_gcode_open(&rd, prog, &m) != EF_OK) {
        fprintf(stderr, "%s\n", m.text);
        return 2;
    }
    ef_pipe_cfg_t pc;
    ef_pipe_cfg_default(&pc);
    pc.g2 = &ef_tbl_g2_default;
    pc.g1 = &ef_tbl_g1_default;
    pc.period_us = 1000; /* the CSP cycle */
    ef_canload_path_t path;
    int rc = ef_canload_path(&rd, &pc, &path, &m);
    ef_gcode_free(&rd);
    if (rc != EF_OK) {
        fprintf(stderr, "%s\n", m.text);
        return 2;
    }
    printf("path %s: %zu moves, %.3f s at the programmed feed, %zu setpoints at 1 kHz; 3 axes,"
           " 3 drives, bus 1 Mbit/s\n",
           prog, path.nmv, path.duration, path.nsp);
    ef_canload_result_t csp, seg;
    ef_msg_t m2 = {{0}};
    int rc1 = ef_canload_run(&path, EF_COM_MODE_CSP, BC_BITRATE, &csp, &m);
    int rc2 = ef_canload_run(&path, EF_COM_MODE_SEGMENT, BC_BITRATE, &seg, &m2);
    ef_canload_path_free(&path);
    if (rc1 != EF_OK || rc2 != EF_OK) {
        fprintf(stderr, "bench_canbus: %s %s\n", rc1 ? m.text : "", rc2 ? m2.text : "");
        return 1;
    }
    bc_print("CSP, SYNC 1 kHz", &csp);
    bc_print("segment mode, SYNC 100 Hz", &seg);
    printf("segment mode: segments completed per drive %u %u %u\n", seg.executed[0],
           seg.executed[1], seg.executed[2]);
    double ratio = (seg.bits / seg.seconds) / (csp.bits / csp.seconds);
    printf("segment mode / CSP bus load: %.3f (1/%.1f); target <= 1/5: %s\n", ratio, 1.0 / ratio,
           ratio <= 0.2 ? "met" : "NOT MET");
    return 0;
}

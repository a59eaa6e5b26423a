/*
 * The hand-written baseline: a straightforward hand-written
 * per-trajectory RK4 loop in C, the way one would write it without this tool. Fixed
 * step T/N, the contact force switched on whenever g > 0 at a stage (no crossing
 * location), the forcing from libm cos/sin at every stage, one trajectory after the
 * other. With -fopenmp the lanes are shared among threads by one pragma.
 *
 * Model and defaults: MODEL.md 2-3 (corrected equations, Table 1). The lanes are the
 * workload of `jeffcott bench` (src/bench.rs, `bench_lane`): W = 133 rad/s, start
 * states scattered over the rotor's (x_r, vx_r) inside the gap, every other coordinate
 * at the static equilibrium.
 *
 * Usage: rk4_loop N PERIODS LANES OUT.bin  -> writes LANES x 8 f64 final states,
 * prints the wall time and lane-steps per second.
 * Build: gcc -O3 -march=native [-fopenmp] rk4_loop.c -o rk4_loop -lm
 */
#include <stdlib.h>
#include <string.h>

#include "../common/rotor.h"

/* Start state of lane i (must match `bench_lane` in src/bench.rs). */
static void init(long i, double *x) {
    double u = fmod((double)i * 0.6180339887498949, 1.0);
    double v = fmod((double)i * 0.7548776662466927, 1.0);
    for (int d = 0; d < 8; d++) x[d] = 0.0;
    x[0] = 0.008 * u - 0.004;
    x[1] = 1.0 * v - 0.5;
    x[2] = -A_G / (W_R * W_R);
    x[6] = -A_G / (W_S * W_S);
}

int main(int argc, char **argv) {
    if (argc != 5) {
        fprintf(stderr, "usage: %s N PERIODS LANES OUT.bin\n", argv[0]);
        return 2;
    }
    long n = atol(argv[1]), periods = atol(argv[2]), lanes = atol(argv[3]);
    double *out = malloc(sizeof(double) * 8 * lanes);
    double h = 2.0 * M_PI / OMEGA / (double)n;
    struct timespec t0;
    clock_gettime(CLOCK_MONOTONIC, &t0);
#pragma omp parallel for schedule(dynamic, 16)
    for (long i = 0; i < lanes; i++) {
        double x[8], y[8];
        init(i, x);
        for (long s = 0; s < n * periods; s++) {
            rk4((double)s * h, h, x, y);
            memcpy(x, y, sizeof x);
        }
        for (int d = 0; d < 8; d++) out[i * 8 + d] = x[d];
    }
    double secs = seconds_since(&t0);
    if (write_states(argv[4], out, lanes)) return 1;
    printf("N=%ld periods=%ld lanes=%ld wall=%.3f s lane_steps_per_s=%.4e\n", n, periods,
           lanes, secs, (double)lanes * (double)n * (double)periods / secs);
    free(out);
    return 0;
}

/*
 * The strong baseline: what a competent user writes instead of jeffcott.
 * Fixed-step RK4, T/N per step, the contact force switched per stage (g > 0), and every
 * step whose contact state changes between its start and its end redone as SUB sub-steps
 * of h/SUB (so a switch costs the step its order only inside one short sub-step), lanes
 * shared among threads by OpenMP. The unbalance forcing at the stage times of a regular
 * step (multiples of h/2 within the period) comes from a table computed once and indexed
 * by the step's number, as a careful user would (libm cos/sin only in redone sub-steps). `plain` mode skips the redo
 * (the event-free loop of benches/handwritten).
 *
 * The lanes are the standard job: W = 133 rad/s, x_r0 evenly spread over
 * [-4, 4] mm, every other coordinate at the static equilibrium, from t = 0.
 *
 * Usage: rk4_switch plain|substep N PERIODS LANES OUT.bin -> LANES x 8 f64 final states
 * (little endian), prints the wall time.
 * Build: gcc -O3 -march=native -fno-tree-vectorize -fopenmp rk4_switch.c -o rk4_switch -lm
 * (without -fno-tree-vectorize gcc 12 packs the 8-element loops into AVX-512 shuffles
 * and the loop runs 1.9x slower: benches/baseline/run.sh)
 */
#include <stdlib.h>
#include <string.h>

#include "../common/rotor.h"

enum { SUB = 8 };

static int contact(const double *x) {
    double dx = x[0] - x[4], dy = x[2] - x[6];
    return sqrt(dx * dx + dy * dy) > DELTA;
}

/* A regular step s of the period: its stage times are the table's entries 2s, 2s + 1
 * (twice) and 2s + 2, indexed directly (no division, rounding or test per stage). */
static void rk4_tab(const double *tc, const double *ts, long s, double h, const double *x,
                    double *out) {
    double k1[8], k2[8], k3[8], k4[8], y[8];
    rhs_cs(tc[2 * s], ts[2 * s], x, k1);
    for (int d = 0; d < 8; d++) y[d] = x[d] + 0.5 * h * k1[d];
    rhs_cs(tc[2 * s + 1], ts[2 * s + 1], y, k2);
    for (int d = 0; d < 8; d++) y[d] = x[d] + 0.5 * h * k2[d];
    rhs_cs(tc[2 * s + 1], ts[2 * s + 1], y, k3);
    for (int d = 0; d < 8; d++) y[d] = x[d] + h * k3[d];
    rhs_cs(tc[2 * s + 2], ts[2 * s + 2], y, k4);
    for (int d = 0; d < 8; d++) out[d] = x[d] + h / 6.0 * (k1[d] + 2.0 * k2[d] + 2.0 * k3[d] + k4[d]);
}

int main(int argc, char **argv) {
    if (argc != 6 || (strcmp(argv[1], "plain") && strcmp(argv[1], "substep"))) {
        fprintf(stderr, "usage: %s plain|substep N PERIODS LANES OUT.bin\n", argv[0]);
        return 2;
    }
    int redo = !strcmp(argv[1], "substep");
    long n = atol(argv[2]), periods = atol(argv[3]), lanes = atol(argv[4]);
    double *out = malloc(sizeof(double) * 8 * lanes);
    double period = 2.0 * M_PI / OMEGA, h = period / (double)n;
    long redone = 0;
    struct timespec t0;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    /* The table is part of the timed work (it is negligible: 2N + 1 entries). */
    double *tc = malloc(sizeof(double) * (2 * n + 1)), *ts = malloc(sizeof(double) * (2 * n + 1));
    for (long j = 0; j <= 2 * n; j++) {
        tc[j] = cos(OMEGA * (0.5 * h) * (double)j);
        ts[j] = sin(OMEGA * (0.5 * h) * (double)j);
    }
#pragma omp parallel for schedule(dynamic, 16) reduction(+ : redone)
    for (long i = 0; i < lanes; i++) {
        double x[8] = {0}, y[8];
        x[0] = lanes > 1 ? -0.004 + 0.008 * (double)i / (double)(lanes - 1) : 0.0;
        x[2] = -A_G / (W_R * W_R);
        x[6] = -A_G / (W_S * W_S);
        for (long q = 0; q < periods; q++) {
            for (long s = 0; s < n; s++) {
                /* Time within the period, as the forcing only needs its phase. */
                double t = (double)s * h;
                rk4_tab(tc, ts, s, h, x, y);
                if (redo && contact(x) != contact(y)) {
                    redone++;
                    double z[8];
                    memcpy(z, x, sizeof z);
                    for (int k = 0; k < SUB; k++) {
                        rk4(t + k * (h / SUB), h / SUB, z, y);
                        memcpy(z, y, sizeof z);
                    }
                }
                memcpy(x, y, sizeof x);
            }
        }
        for (int d = 0; d < 8; d++) out[i * 8 + d] = x[d];
    }
    double secs = seconds_since(&t0);
    if (write_states(argv[5], out, lanes)) return 1;
    printf("mode=%s N=%ld periods=%ld lanes=%ld wall=%.3f s redone_steps=%ld\n", argv[1], n,
           periods, lanes, secs, redone);
    free(out);
    free(tc);
    free(ts);
    return 0;
}

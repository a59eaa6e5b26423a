/*
 * The baseline of the performance target in issue 3: a straightforward hand-written
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
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

static const double W_R = 140.0, W_S = 540.0, XI_R = 0.02, XI_S = 0.05;
static const double DELTA = 0.006, MU = 0.0, M_R = 50.0, M_S = 50.0, E = 0.001;
static const double K_C = 1e8, A_G = 9.81, OMEGA = 133.0;

static void rhs(double t, const double *x, double *f) {
    double dx = x[0] - x[4], dy = x[2] - x[6];
    double r = sqrt(dx * dx + dy * dy);
    double fx = 0.0, fy = 0.0;
    if (r - DELTA > 0.0) {
        double s = K_C * (r - DELTA) / r;
        fx = -s * dx + MU * s * dy;
        fy = -s * dy - MU * s * dx;
    }
    double ph = OMEGA * t;
    f[0] = x[1];
    f[1] = -W_R * W_R * x[0] - 2 * XI_R * W_R * x[1] + E * OMEGA * OMEGA * cos(ph) + fx / M_R;
    f[2] = x[3];
    f[3] = -W_R * W_R * x[2] - 2 * XI_R * W_R * x[3] + E * OMEGA * OMEGA * sin(ph) - A_G + fy / M_R;
    f[4] = x[5];
    f[5] = -W_S * W_S * x[4] - 2 * XI_S * W_S * x[5] - fx / M_S;
    f[6] = x[7];
    f[7] = -W_S * W_S * x[6] - 2 * XI_S * W_S * x[7] - A_G - fy / M_S;
}

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
    struct timespec t0, t1;
    clock_gettime(CLOCK_MONOTONIC, &t0);
#pragma omp parallel for schedule(dynamic, 16)
    for (long i = 0; i < lanes; i++) {
        double x[8], k1[8], k2[8], k3[8], k4[8], y[8];
        init(i, x);
        for (long s = 0; s < n * periods; s++) {
            double t = (double)s * h;
            rhs(t, x, k1);
            for (int d = 0; d < 8; d++) y[d] = x[d] + 0.5 * h * k1[d];
            rhs(t + 0.5 * h, y, k2);
            for (int d = 0; d < 8; d++) y[d] = x[d] + 0.5 * h * k2[d];
            rhs(t + 0.5 * h, y, k3);
            for (int d = 0; d < 8; d++) y[d] = x[d] + h * k3[d];
            rhs(t + h, y, k4);
            for (int d = 0; d < 8; d++)
                x[d] += h / 6.0 * (k1[d] + 2.0 * k2[d] + 2.0 * k3[d] + k4[d]);
        }
        for (int d = 0; d < 8; d++) out[i * 8 + d] = x[d];
    }
    clock_gettime(CLOCK_MONOTONIC, &t1);
    double secs = (double)(t1.tv_sec - t0.tv_sec) + 1e-9 * (double)(t1.tv_nsec - t0.tv_nsec);
    FILE *f = fopen(argv[4], "wb");
    if (!f || fwrite(out, sizeof(double), 8 * lanes, f) != (size_t)(8 * lanes)) {
        fprintf(stderr, "cannot write %s\n", argv[4]);
        return 1;
    }
    fclose(f);
    printf("N=%ld periods=%ld lanes=%ld wall=%.3f s lane_steps_per_s=%.4e\n", n, periods,
           lanes, secs, (double)lanes * (double)n * (double)periods / secs);
    free(out);
    return 0;
}

/*
 * What the two C baselines share (benches/baseline/rk4_switch.c, the strong peer, and
 * benches/handwritten/rk4_loop.c, the event-free loop): the model at Table 1's defaults
 * (MODEL.md 2-3, corrected equations), its right-hand side with the unbalance forcing
 * (cos, sin of W t) given by the caller, and the programs' timing and output.
 */
#ifndef JEFFCOTT_BENCH_ROTOR_H
#define JEFFCOTT_BENCH_ROTOR_H

#include <math.h>
#include <stdio.h>
#include <time.h>

static const double W_R = 140.0, W_S = 540.0, XI_R = 0.02, XI_S = 0.05;
static const double DELTA = 0.006, MU = 0.0, M_R = 50.0, M_S = 50.0, E = 0.001;
static const double K_C = 1e8, A_G = 9.81, OMEGA = 133.0;

/* Right-hand side with the forcing phasor (c, sn) = (cos W t, sin W t) given; the
 * contact force whenever the gap is closed (g > 0). */
static void rhs_cs(double c, double sn, const double *x, double *f) {
    double dx = x[0] - x[4], dy = x[2] - x[6];
    double r = sqrt(dx * dx + dy * dy);
    double fx = 0.0, fy = 0.0;
    if (r - DELTA > 0.0) {
        double s = K_C * (r - DELTA) / r;
        fx = -s * dx + MU * s * dy;
        fy = -s * dy - MU * s * dx;
    }
    f[0] = x[1];
    f[1] = -W_R * W_R * x[0] - 2 * XI_R * W_R * x[1] + E * OMEGA * OMEGA * c + fx / M_R;
    f[2] = x[3];
    f[3] = -W_R * W_R * x[2] - 2 * XI_R * W_R * x[3] + E * OMEGA * OMEGA * sn - A_G + fy / M_R;
    f[4] = x[5];
    f[5] = -W_S * W_S * x[4] - 2 * XI_S * W_S * x[5] - fx / M_S;
    f[6] = x[7];
    f[7] = -W_S * W_S * x[6] - 2 * XI_S * W_S * x[7] - A_G - fy / M_S;
}

/* The right-hand side at time t, the forcing by libm. */
static void rhs(double t, const double *x, double *f) {
    rhs_cs(cos(OMEGA * t), sin(OMEGA * t), x, f);
}

/* One classical RK4 step of h from (t, x) into out. */
static void rk4(double t, double h, const double *x, double *out) {
    double k1[8], k2[8], k3[8], k4[8], y[8];
    rhs(t, x, k1);
    for (int d = 0; d < 8; d++) y[d] = x[d] + 0.5 * h * k1[d];
    rhs(t + 0.5 * h, y, k2);
    for (int d = 0; d < 8; d++) y[d] = x[d] + 0.5 * h * k2[d];
    rhs(t + 0.5 * h, y, k3);
    for (int d = 0; d < 8; d++) y[d] = x[d] + h * k3[d];
    rhs(t + h, y, k4);
    for (int d = 0; d < 8; d++) out[d] = x[d] + h / 6.0 * (k1[d] + 2.0 * k2[d] + 2.0 * k3[d] + k4[d]);
}

/* Seconds from t0 to now (monotonic clock). */
static double seconds_since(const struct timespec *t0) {
    struct timespec t1;
    clock_gettime(CLOCK_MONOTONIC, &t1);
    return (double)(t1.tv_sec - t0->tv_sec) + 1e-9 * (double)(t1.tv_nsec - t0->tv_nsec);
}

/* Writes LANES x 8 f64 final states to `path` (little endian on the machines we run);
 * 0 on success, 1 (with a message) otherwise. */
static int write_states(const char *path, const double *out, long lanes) {
    FILE *f = fopen(path, "wb");
    if (!f || fwrite(out, sizeof(double), 8 * lanes, f) != (size_t)(8 * lanes)) {
        fprintf(stderr, "cannot write %s\n", path);
        return 1;
    }
    fclose(f);
    return 0;
}

#endif

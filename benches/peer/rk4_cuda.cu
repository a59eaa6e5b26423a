// The CUDA kernel of benches/peer/rk4_cuda.py: the loop of rk4_numba.py, one thread per
// lane, the lane's state in registers.
//
// One source for two compilers. rk4_cuda.py hands this text to NVRTC (cupy.RawKernel) with
// `#define REAL double` or `#define REAL float` prepended. rk4_cuda_check.sh compiles it as
// plain C++ with `g++ -DHOST_CHECK -DREAL=double -ffp-contract=off`, where the CUDA
// keywords are empty and main() below runs the kernel block by block, thread by thread, so
// the host result can be compared bit for bit with the numba loop.
//
// The arithmetic is written operation for operation as in rk4_numba.py (same operand
// order, same association), so that without FMA contraction the f64 results are those of
// numba's. On the GPU NVRTC contracts a*b + c into FMAs by default, which is what a user
// of RawKernel gets; the check only holds on the host.

#ifndef REAL
#error "define REAL as double or float"
#endif

#ifdef HOST_CHECK
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <vector>
#define __device__
#define __global__
#define __forceinline__ inline
// Stand-ins for the launch coordinates, set by main() before every "thread".
struct HostDim { unsigned x; };
static HostDim threadIdx, blockIdx, blockDim;
using std::cos;
using std::sin;
using std::sqrt;
#endif

// Table 1 of the article (MODEL.md), the standard job's speed: the constants of
// rk4_numba.py. In f32 they are rounded to float and all arithmetic stays in float.
#define C(v) static_cast<REAL>(v)
// constexpr scalars: usable in device code and folded by the compiler, as numba folds its
// globals.
static constexpr REAL W_R = C(140.0), W_S = C(540.0), XI_R = C(0.02), XI_S = C(0.05);
static constexpr REAL DELTA = C(0.006), MU = C(0.0), M_R = C(50.0), M_S = C(50.0);
static constexpr REAL ECC = C(0.001), K_C = C(1e8), A_G = C(9.81), OMEGA = C(133.0);
#define SUB 8

// Overloads that keep f32 in float (sqrtf, cosf, sinf) under NVRTC and g++ alike.
__device__ __forceinline__ float r_sqrt(float v) { return sqrtf(v); }
__device__ __forceinline__ double r_sqrt(double v) { return sqrt(v); }
__device__ __forceinline__ float r_cos(float v) { return cosf(v); }
__device__ __forceinline__ double r_cos(double v) { return cos(v); }
__device__ __forceinline__ float r_sin(float v) { return sinf(v); }
__device__ __forceinline__ double r_sin(double v) { return sin(v); }

// f = dx/dt with forcing (cos, sin) of the phase = (c, s); true in contact (g > 0).
// Every array index is a compile-time constant after inlining, so x and f stay in
// registers.
__device__ __forceinline__ bool rhs(const REAL (&x)[8], REAL c, REAL s, REAL (&f)[8]) {
    const REAL dx = x[0] - x[4];
    const REAL dy = x[2] - x[6];
    const REAL r = r_sqrt(dx * dx + dy * dy);
    REAL fx = C(0.0);
    REAL fy = C(0.0);
    const bool contact = r - DELTA > C(0.0);
    if (contact) {
        const REAL k = K_C * (r - DELTA) / r;
        fx = -k * dx + MU * k * dy;
        fy = -k * dy - MU * k * dx;
    }
    const REAL ew2 = ECC * OMEGA * OMEGA;
    f[0] = x[1];
    f[1] = -W_R * W_R * x[0] - C(2.0) * XI_R * W_R * x[1] + ew2 * c + fx / M_R;
    f[2] = x[3];
    f[3] = -W_R * W_R * x[2] - C(2.0) * XI_R * W_R * x[3] + ew2 * s - A_G + fy / M_R;
    f[4] = x[5];
    f[5] = -W_S * W_S * x[4] - C(2.0) * XI_S * W_S * x[5] - fx / M_S;
    f[6] = x[7];
    f[7] = -W_S * W_S * x[6] - C(2.0) * XI_S * W_S * x[7] - A_G - fy / M_S;
    return contact;
}

// One RK4 step of x in place, stage forcing (c0, s0), (c1, s1) twice, (c2, s2); true when
// the four stages disagree on the contact state.
__device__ __forceinline__ bool rk4(REAL (&x)[8], REAL h, REAL c0, REAL s0, REAL c1, REAL s1,
                                    REAL c2, REAL s2) {
    REAL k1[8], k2[8], k3[8], k4[8], y[8];
    const bool a = rhs(x, c0, s0, k1);
#pragma unroll
    for (int d = 0; d < 8; ++d) y[d] = x[d] + C(0.5) * h * k1[d];
    const bool b = rhs(y, c1, s1, k2);
#pragma unroll
    for (int d = 0; d < 8; ++d) y[d] = x[d] + C(0.5) * h * k2[d];
    const bool c = rhs(y, c1, s1, k3);
#pragma unroll
    for (int d = 0; d < 8; ++d) y[d] = x[d] + h * k3[d];
    const bool e = rhs(y, c2, s2, k4);
#pragma unroll
    for (int d = 0; d < 8; ++d)
        x[d] += h / C(6.0) * (k1[d] + C(2.0) * k2[d] + C(2.0) * k3[d] + k4[d]);
    return !(a == b && b == c && c == e);
}

// The whole integration of one lane: `periods` periods of n steps of h = T/n from t = 0.
// tc/ts hold cos/sin of OMEGA t at t = j h/2, j = 0..2n (one period; the forcing repeats
// every period, so the step's number within its period indexes it). Returns the number of
// steps redone as SUB sub-steps (always 0 unless redo).
__device__ __forceinline__ int run_lane(REAL (&x)[8], const REAL* __restrict__ tc,
                                        const REAL* __restrict__ ts, REAL h, int n, int periods,
                                        bool redo) {
    int redone = 0;
    for (int p = 0; p < periods; ++p) {
        for (int s = 0; s < n; ++s) {
            REAL x0[8];
#pragma unroll
            for (int d = 0; d < 8; ++d) x0[d] = x[d];
            // Every thread of a warp reads the same entries at the same time: one broadcast
            // load each, cached.
            const bool changed = rk4(x, h, tc[2 * s], ts[2 * s], tc[2 * s + 1], ts[2 * s + 1],
                                     tc[2 * s + 2], ts[2 * s + 2]);
            if (redo && changed) {
                // The step crossed a contact switch: redo it from its start in SUB equal
                // sub-steps, the forcing from libm at the sub-step times (the table only
                // has multiples of h/2).
                ++redone;
#pragma unroll
                for (int d = 0; d < 8; ++d) x[d] = x0[d];
                const REAL hs = h / C(SUB);
                for (int k = 0; k < SUB; ++k) {
                    const REAL ta = static_cast<REAL>(s) * h + static_cast<REAL>(k) * hs;
                    const REAL tb = ta + C(0.5) * hs;
                    const REAL te = ta + hs;
                    rk4(x, hs, r_cos(OMEGA * ta), r_sin(OMEGA * ta), r_cos(OMEGA * tb),
                        r_sin(OMEGA * tb), r_cos(OMEGA * te), r_sin(OMEGA * te));
                }
            }
        }
    }
    return redone;
}

// One thread per lane. States come and go as f64 [lanes][8] whatever REAL is; the
// strided loads and stores happen once per lane, outside the loop that matters.
extern "C" __global__ void rk4_lanes(const double* __restrict__ x_in, double* __restrict__ x_out,
                                     int* __restrict__ redone, const REAL* __restrict__ tc,
                                     const REAL* __restrict__ ts, REAL h, int n, int periods,
                                     int lanes, int redo) {
    const long long lane = static_cast<long long>(blockIdx.x) * blockDim.x + threadIdx.x;
    if (lane >= lanes) return;
    REAL x[8];
#pragma unroll
    for (int d = 0; d < 8; ++d) x[d] = static_cast<REAL>(x_in[lane * 8 + d]);
    const int r = run_lane(x, tc, ts, h, n, periods, redo != 0);
#pragma unroll
    for (int d = 0; d < 8; ++d) x_out[lane * 8 + d] = static_cast<double>(x[d]);
    redone[lane] = r;
}

#ifdef HOST_CHECK
// Host harness: rk4_cuda_host plain|substep N PERIODS DIR OUT.bin [BLOCK]
// DIR holds what `rk4_cuda.py ... --dry --dump DIR` wrote: states.f64 (lanes x 8),
// cos.f64 and sin.f64 (2N + 1 each), h.f64 (1), all little-endian f64, so the host run
// uses exactly the table and start states the GPU run would get.
static std::vector<double> read_f64(const char* dir, const char* name) {
    char path[4096];
    std::snprintf(path, sizeof path, "%s/%s", dir, name);
    FILE* f = std::fopen(path, "rb");
    if (!f) { std::perror(path); std::exit(1); }
    std::vector<double> v;
    double buf[4096];
    size_t got;
    while ((got = std::fread(buf, sizeof(double), 4096, f)) > 0) v.insert(v.end(), buf, buf + got);
    std::fclose(f);
    return v;
}

int main(int argc, char** argv) {
    if (argc < 6 || argc > 7 || (std::strcmp(argv[1], "plain") && std::strcmp(argv[1], "substep"))) {
        std::fprintf(stderr, "usage: %s plain|substep N PERIODS DIR OUT.bin [BLOCK]\n", argv[0]);
        return 2;
    }
    const int redo = std::strcmp(argv[1], "substep") == 0;
    const int n = std::atoi(argv[2]), periods = std::atoi(argv[3]);
    const int block = argc == 7 ? std::atoi(argv[6]) : 128;
    const std::vector<double> states = read_f64(argv[4], "states.f64");
    const std::vector<double> c64 = read_f64(argv[4], "cos.f64"), s64 = read_f64(argv[4], "sin.f64");
    const std::vector<double> h64 = read_f64(argv[4], "h.f64");
    if (states.size() % 8 || c64.size() != size_t(2 * n + 1) || s64.size() != c64.size() || h64.size() != 1) {
        std::fprintf(stderr, "inputs in %s do not match N = %d\n", argv[4], n);
        return 1;
    }
    const int lanes = static_cast<int>(states.size() / 8);
    const std::vector<REAL> tc(c64.begin(), c64.end()), ts(s64.begin(), s64.end());
    std::vector<double> out(states.size());
    std::vector<int> redone(lanes);
    blockDim.x = block;
    const int blocks = (lanes + block - 1) / block;
    for (blockIdx.x = 0; blockIdx.x < unsigned(blocks); ++blockIdx.x)
        for (threadIdx.x = 0; threadIdx.x < unsigned(block); ++threadIdx.x)
            rk4_lanes(states.data(), out.data(), redone.data(), tc.data(), ts.data(),
                      static_cast<REAL>(h64[0]), n, periods, lanes, redo);
    FILE* f = std::fopen(argv[5], "wb");
    if (!f || std::fwrite(out.data(), sizeof(double), out.size(), f) != out.size()) {
        std::perror(argv[5]);
        return 1;
    }
    std::fclose(f);
    long long total = 0;
    for (int r : redone) total += r;
    std::printf("mode=%s N=%d periods=%d lanes=%d redone_steps=%lld\n", argv[1], n, periods,
                lanes, total);
    return 0;
}
#endif

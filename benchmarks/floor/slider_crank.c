/* The hand-tight floor of issue 23: the slider-crank of benchmarks/peers.py
 * (slider_crank_case) analysed the way kinem analyses it, written tightly in C.
 *
 * Built by the benchmark at run time into a temporary directory
 * (benchmarks/floor/__init__.py: gcc -O3 -march=native -shared -fPIC) and
 * loaded with ctypes; kinem itself never compiles anything at run time.
 *
 * Coordinates (x, y, phi) of ground (0-2), crank (3-5, origin at O), rod
 * (6-8, origin at B) and slider (9-11, origin at A), as kinem orders them.
 * The 12 equations are kinem's, row by row (kinem.compile of the case):
 *   0-2   ground            x_g, y_g, phi_g
 *   3     driver            phi_c - (phi0 + w t)
 *   4-5   revolute O        r_g - r_c                      (both local points 0)
 *   6-7   revolute B        r_c + A_c (R, 0) - r_r          (rod's point 0)
 *   8-9   revolute A        r_r + A_r (L, 0) - r_s          (slider's point 0)
 *   10    translational     u x d, u = A_g (-R, 0), d = r_s - r_g   (Eq. 4.12)
 *   11    translational     phi_g - phi_s
 * with kinem's residual scales (lengths by the model's length Ls = L, the
 * line row by R Ls, angles by 1). Terms that are identically zero for this
 * case (products with a zero local point) are left out: that is the "hand"
 * in hand-tight. One sincos per body angle that appears (ground, crank, rod)
 * per configuration, shared by the residual, the Jacobian and gamma.
 *
 * The analysis, per output instant, is kinem.newton.settle's sequence:
 * Taylor predictor q + h qd + h^2/2 qdd; Newton (steps limited to MAX_STEP
 * in dimensionless coordinates) until every |Phi_i| / scale_i <= tol; the
 * final correction with the last iteration's factorisation (a fresh one when
 * the predictor already converged); one more correction when that one was
 * above POLISH; the factorisation at the corrected q; velocities
 * (Phi_q qd = nu) and accelerations (Phi_q qdd = gamma) from it.
 *
 * The LU: the Jacobian's structure has 27 entries (PATTERN), 20 of them constant +-1.
 * A greedy Markowitz order over that structure (cost (r-1)(c-1) in the
 * active submatrix, then constant entries first, then the lowest row and
 * column; benchmarks/peers.py markowitz_order reproduces it and the tests
 * check it against PIVOTS below) gives the pivots
 *   (0,0) (1,1) (2,2) (3,5) (4,3) (5,4) (6,6) (7,7) (11,11) (8,9) (9,10) (10,8)
 * (row, column). Eleven are constant +-1; the twelfth is the one filled
 * entry of row 10, -R L cos(phi_r - phi_g); the only fill-in is (10,8).
 * Its factors are written out below with the constant multipliers folded
 * in. Each pivot is checked numerically (threshold THRESH against the other
 * entries of its column in the active submatrix; the variable pivot also
 * against R L); when a check fails, that factorisation is a dense LU with
 * partial pivoting instead (counted in info[1]).
 */
#define _GNU_SOURCE
#include <math.h>
#include <string.h>
#include <time.h>

#define N 12
#define MAX_STEP 0.5   /* kinem.newton.MAX_STEP */
#define POLISH 1e-10   /* kinem.newton.POLISH */
#define MAX_ITER 25    /* kinem.Options().max_iterations */
#define THRESH 0.1     /* threshold pivoting: |pivot| >= THRESH * |other entries of its column| */
#define VAR_PIVOT 1e-3 /* the variable pivot: |cos(phi_r - phi_g)| >= VAR_PIVOT */

/* The static pivot order (row, column), for the tests. */
const int PIVOTS[N][2] = {{0, 0}, {1, 1}, {2, 2}, {3, 5}, {4, 3}, {5, 4}, {6, 6}, {7, 7},
                          {11, 11}, {8, 9}, {9, 10}, {10, 8}};
/* The Jacobian's structure (row, column, 1 when the entry is a constant +-1). */
const int PATTERN[][3] = {
    {0, 0, 1}, {1, 1, 1}, {2, 2, 1}, {3, 5, 1},
    {4, 0, 1}, {4, 3, 1}, {5, 1, 1}, {5, 4, 1},
    {6, 3, 1}, {6, 5, 0}, {6, 6, 1}, {7, 4, 1}, {7, 5, 0}, {7, 7, 1},
    {8, 6, 1}, {8, 8, 0}, {8, 9, 1}, {9, 7, 1}, {9, 8, 0}, {9, 10, 1},
    {10, 0, 0}, {10, 1, 0}, {10, 2, 0}, {10, 9, 0}, {10, 10, 0},
    {11, 2, 1}, {11, 11, 1}};
const int PATTERN_SIZE = sizeof(PATTERN) / sizeof(PATTERN[0]);

int force_dense = 0; /* the tests set it: every factorisation dense */

typedef struct {   /* the mechanism */
    double r, l, phi0, w, ls; /* crank, rod, driver phi0 + w t, the model's length */
    double scale[N], cscale[N];
} Mech;

typedef struct {   /* one configuration's trig, shared by phi, the Jacobian and gamma */
    double cg, sg, cc, sc, cr, sr;
} Trig;

typedef struct {   /* a factorisation: the sparse one's variable entries, or a dense LU */
    int dense;
    /* sparse: the variable entries of J and the pivot (10,8) */
    double a10_0, a10_1, a10_2, a6_5, a7_5, a8_8, a9_8, a10_9, a10_10, inv_p;
    double lu[N][N];
    int piv[N];
} Factor;

static inline void trig(const double *q, Trig *g) {
    sincos(q[2], &g->sg, &g->cg);
    sincos(q[5], &g->sc, &g->cc);
    sincos(q[8], &g->sr, &g->cr);
}

/* Phi(q, t) into f; returns the max scaled residual (NaN-propagating: a NaN gives NaN). */
static inline double evaluate(const Mech *m, const double *q, const Trig *g, double t, double *f) {
    const double r = m->r, l = m->l;
    f[0] = q[0];
    f[1] = q[1];
    f[2] = q[2];
    f[3] = q[5] - (m->phi0 + m->w * t);
    f[4] = q[0] - q[3];
    f[5] = q[1] - q[4];
    f[6] = q[3] + r * g->cc - q[6];
    f[7] = q[4] + r * g->sc - q[7];
    f[8] = q[6] + l * g->cr - q[9];
    f[9] = q[7] + l * g->sr - q[10];
    const double dx = q[9] - q[0], dy = q[10] - q[1];
    f[10] = r * (g->sg * dx - g->cg * dy); /* u x d, u = -r (cg, sg) */
    f[11] = q[2] - q[11];
    double worst = 0.0;
    for (int i = 0; i < N; i++) {
        double e = fabs(f[i]) / m->scale[i];
        if (!(e <= worst)) worst = e; /* NaN wins */
    }
    return worst;
}

/* Dense 12 x 12 J at q (the fallback's input). */
static void dense_jacobian(const Mech *m, const double *q, const Trig *g, double J[N][N]) {
    const double r = m->r, l = m->l, dx = q[9] - q[0], dy = q[10] - q[1];
    memset(J, 0, sizeof(double) * N * N);
    J[0][0] = J[1][1] = J[2][2] = J[3][5] = 1.0;
    J[4][0] = 1.0; J[4][3] = -1.0;
    J[5][1] = 1.0; J[5][4] = -1.0;
    J[6][3] = 1.0; J[6][5] = -r * g->sc; J[6][6] = -1.0;
    J[7][4] = 1.0; J[7][5] = r * g->cc; J[7][7] = -1.0;
    J[8][6] = 1.0; J[8][8] = -l * g->sr; J[8][9] = -1.0;
    J[9][7] = 1.0; J[9][8] = l * g->cr; J[9][10] = -1.0;
    J[10][0] = -r * g->sg; J[10][1] = r * g->cg; J[10][2] = r * (g->cg * dx + g->sg * dy);
    J[10][9] = r * g->sg; J[10][10] = -r * g->cg;
    J[11][2] = 1.0; J[11][11] = -1.0;
}

static void dense_factor(Factor *F, const Mech *m, const double *q, const Trig *g) {
    double (*a)[N] = F->lu;
    dense_jacobian(m, q, g, a);
    for (int j = 0; j < N; j++) {
        int p = j;
        for (int i = j + 1; i < N; i++)
            if (fabs(a[i][j]) > fabs(a[p][j])) p = i;
        F->piv[j] = p;
        if (p != j)
            for (int c = 0; c < N; c++) { double t = a[j][c]; a[j][c] = a[p][c]; a[p][c] = t; }
        double d = 1.0 / a[j][j];
        for (int i = j + 1; i < N; i++) {
            double mult = a[i][j] * d;
            if (mult != 0.0) {
                a[i][j] = mult;
                for (int c = j + 1; c < N; c++) a[i][c] -= mult * a[j][c];
            }
        }
    }
    F->dense = 1;
}

static void dense_solve(const Factor *F, double *b) {
    const double (*a)[N] = F->lu;
    for (int j = 0; j < N; j++) {
        int p = F->piv[j];
        if (p != j) { double t = b[j]; b[j] = b[p]; b[p] = t; }
    }
    for (int j = 0; j < N; j++)
        for (int i = j + 1; i < N; i++) b[i] -= a[i][j] * b[j];
    for (int j = N - 1; j >= 0; j--) {
        b[j] /= a[j][j];
        for (int i = 0; i < j; i++) b[i] -= a[i][j] * b[j];
    }
}

/* The factorisation at q: the static order, or the dense fallback when a pivot check fails. */
static inline void factor(Factor *F, const Mech *m, const double *q, const Trig *g, int *fallbacks) {
    const double r = m->r, l = m->l, dx = q[9] - q[0], dy = q[10] - q[1];
    F->a6_5 = -r * g->sc;
    F->a7_5 = r * g->cc;
    F->a8_8 = -l * g->sr;
    F->a9_8 = l * g->cr;
    F->a10_0 = -r * g->sg;
    F->a10_1 = r * g->cg;
    F->a10_2 = r * (g->cg * dx + g->sg * dy);
    F->a10_9 = r * g->sg;
    F->a10_10 = -r * g->cg;
    /* The pivots in order: (0,0) (1,1) (2,2) (3,5) are 1; (4,3) (5,4) (6,6) (7,7) (11,11) (8,9)
     * (9,10) are -1. The other entries of their columns in the active submatrix: col 0 a10_0,
     * col 1 a10_1, col 2 a10_2 and 1, col 5 a6_5 and a7_5, cols 3, 4, 6, 7 a 1 each, col 11
     * none, col 9 a10_9 (= -a10_0), col 10 a10_10 (= -a10_1): (8,9) adds nothing to column 10.
     * The fill (10,8): 0 - (-a10_9) a8_8 after (8,9), then - (-a10_10) a9_8 after (9,10):
     * -r l cos(phi_r - phi_g), the last pivot, alone in its column. */
    const double p = F->a10_9 * F->a8_8 + F->a10_10 * F->a9_8;
    double other = fabs(F->a10_0);
    other = fmax(other, fabs(F->a10_1));
    other = fmax(other, fabs(F->a10_2));
    other = fmax(other, fabs(F->a6_5));
    other = fmax(other, fabs(F->a7_5));
    if (THRESH * other <= 1.0 && fabs(p) >= VAR_PIVOT * r * l && !force_dense) {
        F->dense = 0;
        F->inv_p = 1.0 / p;
    } else {
        dense_factor(F, m, q, g);
        ++*fallbacks;
    }
}

/* b <- Phi_q^-1 b with the factorisation: L then U in the pivot order, the constant
 * multipliers (+-1) folded in. */
static inline void solve(const Factor *F, double *b) {
    if (F->dense) {
        dense_solve(F, b);
        return;
    }
    const double y0 = b[0], y1 = b[1], y2 = b[2], y3 = b[3];
    const double y4 = b[4] - y0, y5 = b[5] - y1;
    const double y11 = b[11] - y2;
    const double y6 = b[6] - F->a6_5 * y3 + y4;
    const double y7 = b[7] - F->a7_5 * y3 + y5;
    const double y8 = b[8] + y6, y9 = b[9] + y7;
    const double y10 = b[10] - F->a10_0 * y0 - F->a10_1 * y1 - F->a10_2 * y2 + F->a10_9 * y8 + F->a10_10 * y9;
    const double x8 = y10 * F->inv_p;
    b[0] = y0; b[1] = y1; b[2] = y2;
    b[3] = -y4; b[4] = -y5; b[5] = y3;
    b[6] = -y6; b[7] = -y7; b[8] = x8;
    b[9] = F->a8_8 * x8 - y8; b[10] = F->a9_8 * x8 - y9; b[11] = -y11;
}

/* q -= Phi_q^-1 f, the step limited to ``limit`` (dimensionless); returns its size before the limit. */
static inline double correct(const Mech *m, const Factor *F, double *q, double *f, double limit) {
    solve(F, f);
    double size = 0.0;
    for (int i = 0; i < N; i++) size = fmax(size, fabs(f[i]) / m->cscale[i]);
    const double c = size > limit ? limit / size : 1.0;
    for (int i = 0; i < N; i++) q[i] -= c * f[i];
    return size;
}

/* The analysis over ``steps`` output instants t_k = k h from the assembled q0 at t = 0 (rates
 * zero before the first instant, as the numba floor). Q, QD, QDD: steps x 12, row-major.
 * info[0]: Newton iterations in all, info[1]: dense fallbacks, info[2]: polishing corrections.
 * Returns 0, or k + 1 when instant k did not converge. */
int floor_march(const double *q0, double phi0, double w, double r, double l, double ls, double h,
                int steps, double tol, double *Q, double *QD, double *QDD, int *info) {
    Mech m = {r, l, phi0, w, ls, {ls, ls, 1, 1, ls, ls, ls, ls, ls, ls, r * ls, 1},
              {ls, ls, 1, ls, ls, 1, ls, ls, 1, ls, ls, 1}};
    double q[N], qd[N] = {0}, qdd[N] = {0}, f[N];
    Trig g;
    Factor F;
    int iterations = 0, fallbacks = 0, polished = 0;
    memcpy(q, q0, sizeof q);
    for (int k = 0; k < steps; k++) {
        const double t = k * h;
        if (k > 0)
            for (int i = 0; i < N; i++) q[i] += h * qd[i] + 0.5 * h * h * qdd[i];
        int it = 0;
        for (;;) {
            trig(q, &g);
            const double res = evaluate(&m, q, &g, t, f);
            if (res <= tol) break;
            if (!(res < INFINITY) || it == MAX_ITER) {
                info[0] = iterations; info[1] = fallbacks; info[2] = polished;
                return k + 1;
            }
            factor(&F, &m, q, &g, &fallbacks);
            correct(&m, &F, q, f, MAX_STEP);
            it++;
        }
        iterations += it;
        if (it == 0) factor(&F, &m, q, &g, &fallbacks); /* converged at the predictor: a fresh LU */
        double step = correct(&m, &F, q, f, INFINITY);    /* the final correction */
        trig(q, &g);
        factor(&F, &m, q, &g, &fallbacks);                /* the LU at the corrected q */
        if (step > POLISH) {                              /* one more correction, and the LU again */
            evaluate(&m, q, &g, t, f);
            correct(&m, &F, q, f, INFINITY);
            trig(q, &g);
            factor(&F, &m, q, &g, &fallbacks);
            polished++;
        }
        /* velocities: Phi_q qd = nu (the driver's row: w) */
        memset(qd, 0, sizeof qd);
        qd[3] = w;
        solve(&F, qd);
        /* accelerations: Phi_q qdd = gamma (Table 4.3) */
        const double wc2 = qd[5] * qd[5], wr2 = qd[8] * qd[8], wg = qd[2];
        const double dx = q[9] - q[0], dy = q[10] - q[1], dvx = qd[9] - qd[0], dvy = qd[10] - qd[1];
        const double ux = -r * g.cg, uy = -r * g.sg;
        memset(qdd, 0, sizeof qdd);
        qdd[6] = r * g.cc * wc2;
        qdd[7] = r * g.sc * wc2;
        qdd[8] = l * g.cr * wr2;
        qdd[9] = l * g.sr * wr2;
        qdd[10] = wg * wg * (ux * dy - uy * dx) + 2 * wg * (ux * dvx + uy * dvy);
        solve(&F, qdd);
        memcpy(Q + N * k, q, sizeof q);
        memcpy(QD + N * k, qd, sizeof qd);
        memcpy(QDD + N * k, qdd, sizeof qdd);
    }
    info[0] = iterations; info[1] = fallbacks; info[2] = polished;
    return 0;
}

/* floor_march ``repeats`` times, each timed with CLOCK_MONOTONIC: seconds[i]. Returns the
 * first nonzero status of floor_march, else 0. */
int floor_time(const double *q0, double phi0, double w, double r, double l, double ls, double h,
               int steps, double tol, double *Q, double *QD, double *QDD, int *info, int repeats,
               double *seconds) {
    int status = 0;
    for (int i = 0; i < repeats; i++) {
        struct timespec a, b;
        clock_gettime(CLOCK_MONOTONIC, &a);
        int s = floor_march(q0, phi0, w, r, l, ls, h, steps, tol, Q, QD, QDD, info);
        clock_gettime(CLOCK_MONOTONIC, &b);
        seconds[i] = (b.tv_sec - a.tv_sec) + 1e-9 * (b.tv_nsec - a.tv_nsec);
        if (s && !status) status = s;
    }
    return status;
}

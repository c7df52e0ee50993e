/* C reference of the subloading return map (the scalar path of the package,
 * subfric_dolfinx/constitutive/_subloading/point.py and the modules it calls), for the throughput
 * comparison of benchmarks/return_map_throughput.py. Same algorithm, statement by statement:
 * contact band and loading margin (constitutive/tolerances.py), split of the elastic trial at
 * the elastic-to-plastic switch (switch.py: a cusp through zero, or the first root of
 * d ln r_el / ds by safeguarded Newton), predictor radial return, rotation of the flow direction
 * (blended model of |f_t| with the elastic path subtracted, 3 x 2 Gauss points), corrector,
 * Newton in z (dl = z (2c + z)) from dl = 0 with a quadratic model, slope-bound certificate,
 * forward derivatives for the tangent. (The scalar fast paths `collinear` and `rotate_fixed`
 * give the general path's numbers to 3e-14; C has the general path only.)
 *
 * Not included: main's branch-and-bound scan for roots that the slope bound does not certify
 * (strong softening). Such points get status 5 ("needs the scan") and are counted by the
 * benchmark; numpy then does extra work that C does not (the benchmark prints the count).
 *
 * Build: gcc -O2 -shared -fPIC -o return_map.so return_map.c -lm
 */
#include <math.h>
#include <string.h>

#define EPS 2.220446049250313e-16
#define TINY 2.2250738585072014e-308
#define S_SERIES 1e-3
#define HERMITE_MIN 0.5
#define SPLIT_EPS (8.0 * EPS)
#define ROT_LO 1e-100
#define ROT_HI 1e100
#define M 3 /* max components */
#define CUSP 1
#define ROOT 2
#define CUSP_REL 1e-8
#define SPLIT_IT 60

/* Gauss on [0, 1]: NO outer points (and x = 1), NI inner points per outer node */
#define NO 3
#define NI 2
static const double GXO[NO] = {0.1127016653792583, 0.5, 0.8872983346207417};
static const double GWO[NO] = {0.2777777777777778, 0.4444444444444444, 0.2777777777777778};
static const double GXI[NI] = {0.2113248654051871, 0.7886751345948129};
static const double GWI[NI] = {0.5, 0.5};

typedef struct {
    double at, an, mu_s, mu_k, kappa, xi, ut, cn, k, sqrt2k_inv, zc_cap, len_n;
} Law;

typedef struct {
    double A, g, r0, mu0, b, c0, s0, sin0, d_k, d_s, mu_rec, dmu0, c;
} Br;

typedef struct {
    double phi, r, U, mu, dmu, w, sn, E, dE;
} Ev;

static void e_de(double s, double *E, double *dE) {
    if (s < S_SERIES) {
        *E = s > 0.0 ? -expm1(-s) / s : 1.0;
        *dE = -0.5 + s * (1.0 / 3.0 - 0.125 * s);
    } else {
        double em = expm1(-s);
        *E = -em / s;
        *dE = (em * (1.0 + s) + s) / (s * s);
    }
}

static double gfun(const Law *L, double fn) { return fn > 0.0 ? -expm1(-L->cn * fn) : 0.0; }

static double clamp(double x, double lo, double hi) { return x < lo ? lo : (x > hi ? hi : x); }

/* d_s: mu0 - mu_s if known without cancellation (after a split), else NAN */
static void br_init(Br *b, const Law *L, double A, double g, double r0, double mu0, double bb,
                    double d_s) {
    double qq = 0.25 * M_PI * r0, sq = sin(qq), Eb, dEb;
    b->A = A; b->g = g; b->r0 = r0; b->mu0 = mu0; b->b = bb;
    b->c0 = cos(2.0 * qq);
    b->s0 = sq * sq;
    b->sin0 = 2.0 * sqrt(b->s0 * (1.0 - b->s0));
    b->d_k = mu0 - L->mu_k;
    b->d_s = isnan(d_s) ? mu0 - L->mu_s : d_s;
    e_de(bb, &Eb, &dEb);
    b->mu_rec = clamp(mu0 - bb * b->d_s * Eb, L->mu_k, L->mu_s);
    b->dmu0 = L->kappa * (-b->d_k * Eb - bb * b->d_s * dEb);
    if (b->s0 < 0.5) {
        double dn = -log1p(-2.0 * b->s0) / L->k;
        b->c = fmin(sqrt(dn), L->zc_cap);
    } else {
        b->c = L->zc_cap;
    }
}

static void br_ev(const Br *b, const Law *L, double dl, Ev *e) {
    double c0 = b->c0, em = expm1(-L->k * dl), w = c0 * (1.0 + em);
    double q = clamp(b->s0 - 0.5 * c0 * em, 0.0, 1.0);
    double r = (4.0 / M_PI) * asin(sqrt(q)), sn = 2.0 * sqrt(q * (1.0 - q));
    double a = L->kappa * dl, s = a + b->b, E, dE, D, mu;
    e->U = w > 0.0 ? (sn > 0.0 ? L->ut * w / sn : INFINITY) : 0.0;
    e_de(s, &E, &dE);
    D = a * b->d_k + b->b * b->d_s;
    mu = clamp(b->mu0 - D * E, L->mu_k, L->mu_s);
    e->dmu = L->kappa * (-b->d_k * E - D * dE);
    e->phi = b->A - L->at * dl - b->g * r * mu;
    e->r = r; e->mu = mu; e->w = w; e->sn = sn; e->E = E; e->dE = dE;
}

/* returns converged; *cert set; dl and e at the root */
/* e_start (may be NULL): the evaluation at dl_start, if known (the corrector reuses the
 * predictor's evaluation: same start state, phi shifted by A_eff - A) */
static int solve(const Br *b, const Law *L, double tol_f, int max_iter, double dl_start,
                 const Ev *e_start, double *dl_out, Ev *e, int *iters, int *cert) {
    double at = L->at, c = b->c, A = b->A, g = b->g;
    double dl_max = A / at, hi = dl_max / (sqrt(c * c + dl_max) + c), lo = 0.0;
    double f_lo = INFINITY, f_hi = -INFINITY, z, dz_old;
    int it = 0, conv;
    if (dl_start > 0.0) {
        z = dl_start / (sqrt(c * c + dl_start) + c);
        if (e_start) {
            *e = *e_start;
        } else {
            br_ev(b, L, dl_start, e);
            it = 1;
        }
    } else {
        z = 0.0;
        e->r = b->r0;
        e->U = b->sin0 > 0.0 ? L->ut * b->c0 / b->sin0 : INFINITY;
        e->mu = b->mu_rec;
        e->dmu = b->dmu0;
        e->w = b->c0;
        e->sn = b->sin0;
        e_de(b->b, &e->E, &e->dE);
        e->phi = A - g * b->r0 * e->mu;
    }
    if (e->phi > 0.0) { lo = z; f_lo = e->phi; } else { hi = z; f_hi = e->phi; }
    conv = fabs(e->phi) <= tol_f;
    dz_old = hi - lo;
    while (!conv && it < max_iter) {
        double cz = c + z, drdz, h, hp, B, Q, disc, zn = -1.0;
        drdz = e->sn > 0.0 ? 2.0 * L->ut * e->w * cz / e->sn : 2.0 * L->ut * L->sqrt2k_inv;
        h = g * e->r * e->mu;
        hp = g * (e->mu * drdz + e->r * e->dmu * 2.0 * cz);
        B = 2.0 * at * c + hp;
        Q = A - h + hp * z;
        disc = B * B + 4.0 * at * Q;
        if (disc >= 0.0 && isfinite(disc)) {
            double sd = sqrt(disc);
            zn = B > 0.0 ? 2.0 * Q / (B + sd) : (sd - B) / (2.0 * at);
        }
        if (!(lo < zn && zn < hi) || (fabs(zn - z) > 0.5 * fabs(dz_old) && it > 0))
            zn = hi > 1e3 * lo ? sqrt(fmax(lo, TINY)) * sqrt(hi) : 0.5 * (lo + hi);
        dz_old = zn - z;
        z = zn;
        br_ev(b, L, z * (2.0 * c + z), e);
        it++;
        if (e->phi > 0.0) { lo = z; f_lo = e->phi; } else { hi = z; f_hi = e->phi; }
        if (fabs(e->phi) <= tol_f) {
            conv = 1;
        } else if (f_lo - f_hi <= 2.0 * tol_f || hi - lo <= 4.0 * EPS * hi) {
            z = f_lo < -f_hi ? lo : hi;
            br_ev(b, L, z * (2.0 * c + z), e);
            it++;
            conv = 1;
        }
    }
    *dl_out = z * (2.0 * c + z);
    *iters += it;
    *cert = conv && (at + g * e->U * e->mu - g * e->r * fabs(b->dmu0) > 0.0);
    return conv;
}

static void partials(const Br *b, const Law *L, double dl, const Ev *e, double *H, double *R,
                     double *Mmu, double *Mb) {
    double a = L->kappa * dl, s = a + b->b, D = a * b->d_k + b->b * b->d_s;
    *H = L->at + b->g * (e->U * e->mu + e->r * e->dmu);
    if (!isfinite(*H)) *H = L->at;
    *H = fmax(*H, 1e-12 * L->at);
    if (e->sn > 0.0 && b->c0 > 0.0)
        *R = (e->w / b->c0) * b->sin0 / e->sn;
    else
        *R = dl == 0.0 ? 1.0 : 0.0;
    *Mmu = exp(-s);
    *Mb = -b->d_s * e->E - D * e->dE;
}

/* elastic path rho_el(y) = |f_s + y w| and J_el(y) = int_0^y 1/rho_el (closed form) with partials
 * in (rho_s, P, W); returns rho_el; *q = D / N (see _v2_scalar._el) */
static double el_path(double rho_s, double P, double W, double y, double *dr, double *J, double *dJ,
                      double *q) {
    double rel = sqrt(rho_s * rho_s + 2.0 * y * P + y * y * W * W);
    double D = W * rho_s + P, ND, N;
    dr[0] = rho_s / rel;
    dr[1] = y / rel;
    dr[2] = y * y * W / rel;
    ND = W * (2.0 * y * P + y * y * W * W) / (rel + rho_s) + W * W * y;
    N = D + ND;
    *J = log1p(ND / D) / W;
    dJ[0] = (W * dr[0] / N - W / D) / W;
    dJ[1] = ((W * dr[1] + 1.0) / N - 1.0 / D) / W;
    dJ[2] = -*J / W + ((rel + W * dr[2] + 2.0 * W * y) / N - rho_s / D) / W;
    *q = D / N;
    return rel;
}

/* ---- the split point of the elastic trial segment (switch.py) ---- */

typedef struct {
    const double *f0t, *w;
    double ww, fn0, dfn, mu_c, b;
    int nt;
} HArgs;

/* h(s) = d ln r_el / ds, h'(s); optionally f_s, q = |f_s|^2, N1 = f_s.w, g_s */
static void h_of(const Law *L, const HArgs *a, double s, double *h, double *hp, double *fs,
                 double *q_, double *N1_, double *g_) {
    double f[2], q = 0.0, N1 = 0.0, g, mu_e, mr;
    int i;
    for (i = 0; i < a->nt; i++) {
        f[i] = a->f0t[i] + s * a->w[i];
        q += f[i] * f[i];
        N1 += f[i] * a->w[i];
    }
    g = -expm1(-L->cn * (a->fn0 + s * a->dfn));
    mu_e = fmin(a->mu_c + (L->mu_s - a->mu_c) * -expm1(-a->b * s), L->mu_s);
    mr = (L->mu_s - a->mu_c) * exp(-a->b * s) / mu_e;
    *h = N1 / q - L->cn * (1.0 - g) * a->dfn / g - a->b * mr;
    *hp = (a->ww * q - 2.0 * N1 * N1) / (q * q) +
          L->cn * L->cn * (1.0 - g) * a->dfn * a->dfn / (g * g) + a->b * a->b * L->mu_s * mr / mu_e;
    if (fs) for (i = 0; i < a->nt; i++) fs[i] = f[i];
    if (q_) *q_ = q;
    if (N1_) *N1_ = N1;
    if (g_) *g_ = g;
}

static double h_newton(const Law *L, const HArgs *a, double lo, double hi, double x, double hx,
                       double hpx) {
    double dx_old = hi - lo;
    int k;
    for (k = 0; k < SPLIT_IT; k++) {
        double xn = -1.0;
        if (hpx > 0.0) {
            double step = hx / hpx;
            if (fabs(step) <= 4.0 * EPS * x) break; /* converged: step below rounding */
            xn = x - step;
        }
        if (!(lo < xn && xn < hi) || fabs(xn - x) > 0.5 * fabs(dx_old)) xn = 0.5 * (lo + hi);
        dx_old = xn - x;
        x = xn;
        h_of(L, a, x, &hx, &hpx, NULL, NULL, NULL, NULL);
        if (hx < 0.0) lo = x;
        else if (hx > 0.0) hi = x;
        else break;
        if (fabs(dx_old) <= 4.0 * EPS * x || hi - lo <= 4.0 * EPS * hi) break;
    }
    return x;
}

static double h_at(const Law *L, const HArgs *a, double s) {
    double h, hp;
    h_of(L, a, s, &h, &hp, NULL, NULL, NULL, NULL);
    return h;
}

/* kind (0 none, CUSP, ROOT) and *s of the split (switch.split_point) */
static int split_point(const Law *L, int nt, const double *f0t, double fn0, const double *ft,
                       double fn, double A, double mu_c, double b, double *s_out) {
    double w[2], fw = 0.0, ww = 0.0, rho0, W, s;
    int i, ok_h;
    HArgs a;
    for (i = 0; i < nt; i++) {
        w[i] = ft[i] - f0t[i];
        fw += f0t[i] * w[i];
        ww += w[i] * w[i];
    }
    rho0 = nt == 1 ? fabs(f0t[0]) : hypot(f0t[0], f0t[1]);
    if (!(ww > 0.0 && rho0 > 0.0)) return 0;
    W = sqrt(ww);
    a.f0t = f0t; a.w = w; a.ww = ww; a.fn0 = fn0; a.dfn = fn - fn0; a.mu_c = mu_c; a.b = b;
    a.nt = nt;
    ok_h = ROT_LO < rho0 && rho0 < ROT_HI && ROT_LO < W && W < ROT_HI && A < ROT_HI &&
           b < ROT_HI && -expm1(-L->cn * fn0) > ROT_LO && -expm1(-L->cn * fn) > ROT_LO;
    if (fw < 0.0) {
        double s_f, fm[2], hm, hpm, lo, hi;
        if (!(ww + fw > SPLIT_EPS * W * (rho0 + A))) return 0;
        s_f = -fw / ww;
        *s_out = s_f;
        if (!ok_h) return CUSP;
        for (i = 0; i < nt; i++) fm[i] = f0t[i] + s_f * w[i];
        if ((nt == 1 ? fabs(fm[0]) : hypot(fm[0], fm[1])) <= CUSP_REL * (rho0 + A)) return CUSP;
        h_of(L, &a, s_f, &hm, &hpm, NULL, NULL, NULL, NULL);
        if (hm < 0.0) {
            if (!(h_at(L, &a, 1.0) > 0.0)) return CUSP;
            lo = s_f; hi = 1.0;
        } else if (hm > 0.0) {
            if (!(h_at(L, &a, 0.0) < 0.0)) return 0;
            lo = 0.0; hi = s_f;
        } else {
            return ROOT;
        }
        s = h_newton(L, &a, lo, hi, s_f, hm, hpm);
    } else {
        double h0, hp0;
        if (!ok_h) return 0;
        h_of(L, &a, 0.0, &h0, &hp0, NULL, NULL, NULL, NULL);
        if (!(h0 < 0.0) || !(h_at(L, &a, 1.0) > 0.0)) return 0;
        s = h_newton(L, &a, 0.0, 1.0, 0.0, h0, hp0);
    }
    if (!((1.0 - s) * W > SPLIT_EPS * (rho0 + A))) return 0;
    *s_out = s;
    return ROOT;
}

/* phi rises at the start of a plastic part from (r0, mu0): H(0) <= 0 (switch.unstable_start) */
static int unstable_start(const Law *L, double g, double r0, double mu0, double b, double d_s) {
    double qq, sq, s0, sin0, U0, Eb, dEb, mu_rec, dmu0;
    if (!(r0 > 0.0)) return 0;
    qq = 0.25 * M_PI * r0;
    sq = sin(qq);
    s0 = sq * sq;
    sin0 = 2.0 * sqrt(s0 * (1.0 - s0));
    if (!(sin0 > 0.0)) return 0;
    U0 = L->ut * cos(2.0 * qq) / sin0;
    e_de(b, &Eb, &dEb);
    mu_rec = clamp(mu0 - b * d_s * Eb, L->mu_k, L->mu_s);
    dmu0 = L->kappa * (-(mu0 - L->mu_k) * Eb - b * d_s * dEb);
    return L->at + g * (U0 * mu_rec + r0 * dmu0) <= 0.0;
}

/* derivative of the split point over the m gap components (switch.split_ds) */
static void split_ds(const Law *L, int nt, const double *f0t, const double *ft, double fn0,
                     double fn, double mu_c, double b, double s, int kind, double *ds) {
    double w[2], ww = 0.0;
    int i, j;
    for (i = 0; i < nt; i++) { w[i] = ft[i] - f0t[i]; ww += w[i] * w[i]; }
    for (j = 0; j <= nt; j++) ds[j] = 0.0;
    if (kind == CUSP) {
        for (j = 0; j < nt; j++) ds[j] = -(f0t[j] + 2.0 * s * w[j]) * L->at / ww;
        return;
    }
    {
        HArgs a;
        double h, hp, fs[2], q, N1, g, c, dfn = fn - fn0;
        a.f0t = f0t; a.w = w; a.ww = ww; a.fn0 = fn0; a.dfn = dfn; a.mu_c = mu_c; a.b = b;
        a.nt = nt;
        h_of(L, &a, s, &h, &hp, fs, &q, &N1, &g);
        c = 2.0 * s * N1 / q;
        for (j = 0; j < nt; j++) ds[j] = -L->at * (fs[j] + s * w[j] - c * fs[j]) / (q * hp);
        ds[nt] = L->cn * L->an * ((1.0 / g - 1.0) - dfn * L->cn * (1.0 - g) * s / (g * g)) / hp;
    }
}

/* status codes as Status: 0 elastic, 1 plastic, 2 separated, 3 jump, 4 failed; 5 = needs scan */
static int finish(const Law *L, const Ev *e, double g, double *mu1, double *r1, int *unst) {
    double den = -L->kappa * (e->mu - L->mu_k) * e->r + e->U * e->mu + L->at / g;
    *mu1 = e->mu;
    *r1 = clamp(e->r, 0.0, 1.0);
    *unst = den <= 0.0;
    return 1;
}

static int point(const Law *L, int nt, const double *gap, const double *up, double mu_n,
                 double r_n, const double *f0, double dt, double tol, int max_iter,
                 double contact_tol, double *tr, double *tg, double *up1, double *mu1, double *r1,
                 int *unst, int *iters) {
    int m = nt + 1, i, j, ok = 1, split = 0, rotate = 0, conv, cert, touching;
    double at = L->at, an = L->an, mu_k = L->mu_k, mu_s = L->mu_s, band;
    double ft[2], A, un, fn, g, b, mu_rec, mu_c, r_c, f_s[2] = {0, 0}, rho_s = 0.0, g_s = 0.0;
    double mu_st, r_st, b_st, d_st = NAN, fn0 = 0.0, s = 0.0, fn_s = 0.0, tol_f, dl0, tstar[2];
    Br br;
    Ev e0;
    memset(tr, 0, sizeof(double) * m);
    memset(tg, 0, sizeof(double) * m * m);
    *unst = 0;
    *iters = 0;
    for (i = 0; i < m; i++) ok &= isfinite(gap[i]);
    for (i = 0; i < nt; i++) ok &= isfinite(up[i]);
    ok &= isfinite(mu_n) && isfinite(r_n) && r_n >= -1e-9 && r_n <= 1.0 + 1e-9;
    ok &= mu_n >= mu_k * (1 - 1e-12) && mu_n <= mu_s * (1 + 1e-12);
    if (f0) for (i = 0; i < m; i++) ok &= isfinite(f0[i]);
    if (!ok) {
        for (i = 0; i < nt; i++) up1[i] = 0.0;
        *mu1 = mu_s; *r1 = 0.0;
        return 4;
    }
    mu_c = clamp(mu_n, mu_k, mu_s);
    r_c = clamp(r_n, 0.0, 1.0);
    for (i = 0; i < nt; i++) { ft[i] = at * (gap[i] - up[i]); up1[i] = up[i]; }
    A = nt == 1 ? fabs(ft[0]) : hypot(ft[0], ft[1]);
    un = gap[nt];
    fn = an * un;
    g = gfun(L, fn);
    b = L->xi * dt;
    mu_rec = fmin(mu_c + (mu_s - mu_c) * -expm1(-b), mu_s);
    /* contact band (constitutive/tolerances.py) */
    if (nt == 1)
        band = fmax(fmax(fabs(gap[0]), fabs(up[0])), L->len_n) * contact_tol;
    else
        band = fmax(fmax(hypot(gap[0], gap[1]), hypot(up[0], up[1])), L->len_n) * contact_tol;
    touching = contact_tol > 0.0 ? fabs(un) <= band : un == 0.0;
    if (touching || !(un > 0.0 && g > 0.0)) {
        if (touching) { for (i = 0; i < nt; i++) tg[i * m + i] = at; tg[nt * m + nt] = an; }
        *mu1 = mu_rec; *r1 = 0.0;
        return 2;
    }
    mu_st = mu_c; r_st = r_c; b_st = b;
    if (f0 && f0[nt] > 0.0) {
        fn0 = f0[nt];
        for (i = 0; i < nt; i++) f_s[i] = f0[i];
        split = split_point(L, nt, f0, fn0, ft, fn, A, mu_c, b, &s);
        if (split) {
            double w[2], bs = b * s;
            for (i = 0; i < nt; i++) { w[i] = ft[i] - f0[i]; f_s[i] += s * w[i]; }
            fn_s = fn0 + s * (fn - fn0);
            g_s = gfun(L, fn_s);
            mu_st = fmin(mu_c + (mu_s - mu_c) * -expm1(-bs), mu_s);
            d_st = (mu_c - mu_s) * exp(-bs);
            rho_s = nt == 1 ? fabs(f_s[0]) : hypot(f_s[0], f_s[1]);
            if (split == ROOT) { /* r scaled by r_el(s) / r_el(0) */
                double rho0 = nt == 1 ? fabs(f0[0]) : hypot(f0[0], f0[1]);
                double q = (rho_s / rho0) * (gfun(L, fn0) / g_s) * (mu_c / mu_st);
                r_st = fmin(r_c * q, 1.0);
            } else {
                double gm = g_s * mu_st;
                r_st = gm > 0.0 ? (rho_s < gm ? rho_s / gm : 1.0) : (rho_s > 0.0 ? 1.0 : 0.0);
            }
            b_st = b - bs;
            if (split == ROOT && unstable_start(L, g, r_st, mu_st, b_st, d_st)) {
                /* no continuous branch from the switch: the whole step's loading test */
                split = 0;
                for (i = 0; i < nt; i++) f_s[i] = f0[i];
                mu_st = mu_c; r_st = r_c; b_st = b; d_st = NAN;
                rho_s = nt == 1 ? fabs(f_s[0]) : hypot(f_s[0], f_s[1]);
                fn_s = fn0;
                g_s = gfun(L, fn0);
            }
        } else {
            rho_s = nt == 1 ? fabs(f_s[0]) : hypot(f_s[0], f_s[1]);
            fn_s = fn0;
            g_s = gfun(L, fn0);
        }
    }
    {
        double mrs = split ? fmin(mu_st + (mu_s - mu_st) * -expm1(-b_st), mu_s) : mu_rec;
        if (!(A > 0.0 && A - g * r_st * mrs > tol * g * mrs)) {
            double gm = g * mu_rec;
            for (i = 0; i < nt; i++) { tr[i] = ft[i]; tg[i * m + i] = at; }
            tr[nt] = fn;
            tg[nt * m + nt] = an;
            *mu1 = mu_rec;
            *r1 = A == 0.0 ? 0.0 : (A < gm ? A / gm : 1.0);
            return 0;
        }
        if (!isfinite(A)) { *mu1 = mu_c; *r1 = r_c; return 4; }
    }
    tol_f = fmax(tol * g * mu_s, 8.0 * EPS * A);
    br_init(&br, L, A, g, r_st, mu_st, b_st, d_st);
    conv = solve(&br, L, tol_f, max_iter, 0.0, NULL, &dl0, &e0, iters, &cert);
    if (!conv) { *mu1 = mu_c; *r1 = r_c; return 4; }
    if (!cert) { *mu1 = mu_c; *r1 = r_c; return 5; }
    for (i = 0; i < nt; i++) tstar[i] = ft[i] / A;
    if (nt == 2 && f0 && f0[nt] > 0.0 && rho_s > tol_f && g > ROT_LO) {
        double ws0 = ft[0] - f_s[0], ws1 = ft[1] - f_s[1], W = hypot(ws0, ws1);
        /* also at theta_0 = 0; not if |f_t| shrinks all through; only within 1e-100 .. 1e100
         * (see _v2_scalar.point) */
        rotate = fmin(rho_s, W) > ROT_LO && fmax(fmax(rho_s, W), A) < ROT_HI &&
                 gfun(L, f0[nt]) > ROT_LO && (split || ws0 * f_s[0] + ws1 * f_s[1] >= 0.0);
    }
    if (!rotate && !split) {
        double H = at + g * (e0.U * e0.mu + e0.r * e0.dmu), rho1, dg, fa, c1;
        if (!isfinite(H)) H = at;
        H = fmax(H, 1e-12 * at);
        rho1 = fmin(g * e0.r * e0.mu, A);
        dg = L->cn * (1.0 - g);
        fa = rho1 / A;
        c1 = 1.0 - at / H;
        for (i = 0; i < nt; i++) {
            for (j = 0; j < nt; j++) {
                double nn = tstar[i] * tstar[j];
                tg[i * m + j] = at * (c1 * nn + fa * ((i == j ? 1.0 : 0.0) - nn));
            }
            tg[i * m + nt] = at * an * dg * e0.r * e0.mu / H * tstar[i];
            tr[i] = rho1 * tstar[i];
            up1[i] = up[i] + dl0 * tstar[i];
        }
        tg[nt * m + nt] = an;
        tr[nt] = fn;
        finish(L, &e0, g, mu1, r1, unst);
        return 1;
    }
    /* ---- general: split and/or rotation, forward derivatives over the m gap components */
    {
        double dft[2][M] = {{0}}, dfn1[M] = {0}, dg1[M] = {0}, df_s[2][M] = {{0}};
        double drho_s[M] = {0}, dr0[M] = {0}, dmu0[M] = {0}, db[M] = {0}, dg_s[M] = {0};
        double dfn_s[M] = {0}, dA[M] = {0}, ddl0[M], H, R, Mmu, Mb;
        double r0 = br.r0, mu0 = br.mu0, b0 = br.b;
        for (i = 0; i < nt; i++) dft[i][i] = at;
        dfn1[nt] = an;
        for (j = 0; j < m; j++) dg1[j] = L->cn * (1.0 - g) * dfn1[j];
        if (split) {
            double w[2], ds[M] = {0};
            for (i = 0; i < nt; i++) w[i] = ft[i] - f0[i];
            split_ds(L, nt, f0, ft, fn0, fn, mu_c, b, s, split, ds);
            for (i = 0; i < nt; i++)
                for (j = 0; j < m; j++) df_s[i][j] = ds[j] * w[i] + s * dft[i][j];
            for (j = 0; j < m; j++) {
                dfn_s[j] = ds[j] * (fn - fn0) + s * dfn1[j];
                dg_s[j] = L->cn * (1.0 - g_s) * dfn_s[j];
                dmu0[j] = -br.d_s * b * ds[j]; /* d_s = mu0 - mu_s without cancellation */
                db[j] = -b * ds[j];
            }
            if (rho_s > 0.0)
                for (j = 0; j < m; j++) {
                    drho_s[j] = 0.0;
                    for (i = 0; i < nt; i++) drho_s[j] += f_s[i] * df_s[i][j];
                    drho_s[j] /= rho_s;
                }
            if (rho_s > 0.0 && r0 < 1.0) {
                double c_r = split == ROOT ? r0 / rho_s : 1.0 / (g_s * mu0);
                for (j = 0; j < m; j++)
                    dr0[j] = c_r * drho_s[j] - r0 * (dg_s[j] / g_s + dmu0[j] / mu0);
            }
        }
        for (j = 0; j < nt; j++) dA[j] = at * tstar[j];
        partials(&br, L, dl0, &e0, &H, &R, &Mmu, &Mb);
        for (j = 0; j < m; j++)
            ddl0[j] = (dA[j] - dg1[j] * e0.r * e0.mu - g * e0.mu * R * dr0[j] -
                       g * e0.r * (Mmu * dmu0[j] + Mb * db[j])) / H;
        if (!rotate) {
            double rho1 = fmin(g * e0.r * e0.mu, A);
            for (i = 0; i < nt; i++) {
                for (j = 0; j < m; j++) {
                    double d = (dA[j] - at * ddl0[j]) * tstar[i];
                    if (j < nt) d += rho1 * ((i == j ? 1.0 : 0.0) - tstar[i] * tstar[j]) * at / A;
                    tg[i * m + j] = d;
                }
                tr[i] = rho1 * tstar[i];
                up1[i] = up[i] + dl0 * tstar[i];
            }
            tg[nt * m + nt] = an;
            tr[nt] = fn;
            finish(L, &e0, g, mu1, r1, unst);
            return 1;
        }
        {
            double ws[2], dws[2][M], W, ew[2], dW[M], dphi_w[M], dphi_f[M], dth0[M], cth1, sth1;
            double cth0, sth0, tau0, dtau0[M], ddirect[M], d0, dd0[M], rho1p, drho1p[M];
            double C = 0.0, dC[M] = {0}, T1 = 0.0, dT1[M] = {0}, dth1[M], Aeff, dAeff[M];
            double dl, ddl[M], rho1, drho1[M], dph1[M], t1[2], n1[2];
            int xi_, jj;
            Br br2;
            Ev e;
            for (i = 0; i < 2; i++) {
                ws[i] = ft[i] - f_s[i];
                for (j = 0; j < m; j++) dws[i][j] = dft[i][j] - df_s[i][j];
            }
            W = hypot(ws[0], ws[1]);
            ew[0] = ws[0] / W; ew[1] = ws[1] / W;
            cth0 = (ws[0] * f_s[0] + ws[1] * f_s[1]) / (W * rho_s);
            sth0 = (ws[0] * f_s[1] - ws[1] * f_s[0]) / (W * rho_s);
            tau0 = sth0 / (1.0 + cth0);
            for (j = 0; j < m; j++) {
                dW[j] = ew[0] * dws[0][j] + ew[1] * dws[1][j];
                dphi_w[j] = (ws[0] * dws[1][j] - ws[1] * dws[0][j]) / (W * W);
                dphi_f[j] = (f_s[0] * df_s[1][j] - f_s[1] * df_s[0][j]) / (rho_s * rho_s);
                dth0[j] = dphi_f[j] - dphi_w[j];
                dtau0[j] = 0.5 * (1.0 + tau0 * tau0) * dth0[j];
                ddirect[j] = dW[j] * cth0 - W * sth0 * dth0[j];
                dd0[j] = ddirect[j];
            }
            d0 = W * cth0;
            if (br.sin0 > 0.0 && g_s > 0.0) {
                double U0 = L->ut * br.c0 / br.sin0, gp = L->cn * (1.0 - g_s), dfr = fn - fn_s;
                double num = W * cth0 / g_s - rho_s * gp * dfr / (g_s * g_s) + b0 * br.d_s * r0;
                double den = -L->kappa * (mu0 - mu_k) * r0 + U0 * mu0 + at / g_s;
                /* at a ROOT split num = 0 by construction: the elastic slope */
                if (num > 0.0 && den > 0.0 && split != ROOT) {
                    double lam = num / den;
                    d0 = W * cth0 - at * lam;
                    for (j = 0; j < m; j++) {
                        double dgp = -L->cn * dg_s[j], ddfr = dfn1[j] - dfn_s[j];
                        double dnum = ddirect[j] / g_s - W * cth0 * dg_s[j] / (g_s * g_s) -
                                      (drho_s[j] * gp * dfr + rho_s * dgp * dfr + rho_s * gp * ddfr) /
                                          (g_s * g_s) +
                                      2.0 * rho_s * gp * dfr * dg_s[j] / (g_s * g_s * g_s) -
                                      (-db[j] * br.d_s * r0 - b0 * dmu0[j] * r0 -
                                       b0 * br.d_s * dr0[j]);
                        double dU = -L->ut * 0.5 * M_PI / (br.sin0 * br.sin0) * dr0[j];
                        double dden = -L->kappa * (dmu0[j] * r0 + (mu0 - mu_k) * dr0[j]) + dU * mu0 +
                                      U0 * dmu0[j] - at * dg_s[j] / (g_s * g_s);
                        dd0[j] = ddirect[j] - at * (dnum - lam * dden) / den;
                    }
                }
            }
            rho1p = A - at * dl0;
            for (j = 0; j < m; j++) drho1p[j] = dA[j] - at * ddl0[j];
            /* model of |f_t| over the step: rho = rho_H + beta e_el, the elastic path subtracted
             * (see _v2_scalar._rotation) */
            {
                double P = ws[0] * f_s[0] + ws[1] * f_s[1], dP[M], Pr = P / rho_s;
                double den_b = A - rho_s, braw = den_b > 0.0 ? (rho1p - rho_s) / den_b : 1.0;
                double beta = clamp(braw, 0.0, 1.0), b_1 = 0, b_s = 0, b_A = 0;
                double node[(NO + 1) * NI][6], rmin_n = INFINITY, rel1, drel1[3], cC[7], cT[7];
                int lin, kk = 0, q;
                if (braw > 0.0 && braw < 1.0) {
                    b_1 = 1.0 / den_b;
                    b_s = (rho1p - A) / (den_b * den_b);
                    b_A = -braw / den_b;
                }
                for (j = 0; j < m; j++) {
                    dP[j] = 0.0;
                    for (i = 0; i < 2; i++) dP[j] += ws[i] * df_s[i][j] + f_s[i] * dws[i][j];
                }
                for (xi_ = 0; xi_ <= NO; xi_++) {
                    double x = xi_ < NO ? GXO[xi_] : 1.0;
                    for (jj = 0; jj < NI; jj++, kk++) {
                        double y = x * GXI[jj], y2 = y * y, Jd, dJd[3], qd;
                        double e_, rel = el_path(rho_s, P, W, y, drel1, &Jd, dJd, &qd);
                        e_ = rel - rho_s * (1.0 - y2) - Pr * (y - y2) - A * y2;
                        node[kk][0] = rho_s * (1.0 - y2) + d0 * (y - y2) + rho1p * y2 + beta * e_;
                        node[kk][1] = rel;
                        node[kk][2] = e_;
                        node[kk][3] = drel1[0];
                        node[kk][4] = drel1[1];
                        node[kk][5] = drel1[2];
                        rmin_n = fmin(rmin_n, node[kk][0]);
                    }
                }
                lin = !(rmin_n >= HERMITE_MIN * fmin(rho_s, rho1p));
                {   /* C_el = (rho_el(1) - rho_s) / W */
                    double Jd, dJd[3], qd;
                    rel1 = el_path(rho_s, P, W, 1.0, drel1, &Jd, dJd, &qd);
                }
                C = (2.0 * P + W * W) / (rel1 + rho_s) / W;
                for (q = 0; q < 7; q++) cC[q] = cT[q] = 0.0;
                cC[1] = (drel1[0] - 1.0) / W;
                cC[4] = drel1[1] / W;
                cC[5] = drel1[2] / W - C / W;
                kk = 0;
                for (xi_ = 0; xi_ <= NO; xi_++) {
                    double x = xi_ < NO ? GXO[xi_] : 1.0, Je, dJe[3], q_el, Jv, pJ[6], ex, T, TW, dT[7];
                    double dre[3];
                    (void)el_path(rho_s, P, W, x, dre, &Je, dJe, &q_el);
                    Jv = 0.0;
                    pJ[0] = dJe[0]; pJ[1] = 0.0; pJ[2] = 0.0; pJ[3] = dJe[1]; pJ[4] = dJe[2]; pJ[5] = 0.0;
                    for (jj = 0; jj < NI; jj++, kk++) {
                        double y = x * GXI[jj], y2 = y * y, r_, dr[6], wx = GWI[jj] * x, iv2, ie2;
                        double rel = node[kk][1], e_ = node[kk][2], *drel = node[kk] + 3;
                        if (lin) {
                            r_ = rho_s + (rho1p - rho_s) * y;
                            dr[0] = 1.0 - y; dr[1] = 0.0; dr[2] = y; dr[3] = dr[4] = dr[5] = 0.0;
                        } else {
                            r_ = node[kk][0];
                            dr[0] = 1.0 - y2 + beta * (drel[0] - 1.0 + y2 + Pr / rho_s * (y - y2)) + e_ * b_s;
                            dr[1] = y - y2;
                            dr[2] = y2 + e_ * b_1;
                            dr[3] = beta * (drel[1] - (y - y2) / rho_s);
                            dr[4] = beta * drel[2];
                            dr[5] = -beta * y2 + e_ * b_A;
                        }
                        Jv += wx * (1.0 / r_ - 1.0 / rel);
                        iv2 = wx / (r_ * r_);
                        ie2 = wx / (rel * rel);
                        pJ[0] += ie2 * drel[0] - iv2 * dr[0];
                        pJ[1] -= iv2 * dr[1];
                        pJ[2] -= iv2 * dr[2];
                        pJ[3] += ie2 * drel[1] - iv2 * dr[3];
                        pJ[4] += ie2 * drel[2] - iv2 * dr[4];
                        pJ[5] -= iv2 * dr[5];
                    }
                    Jv += Je;
                    ex = exp(-W * Jv);
                    T = tau0 * ex;
                    TW = T * W;
                    /* partials of T in (tau0, rho_s, d0, rho1, P, W, A) */
                    dT[0] = ex;
                    dT[1] = -TW * pJ[0];
                    dT[2] = -TW * pJ[1];
                    dT[3] = -TW * pJ[2];
                    dT[4] = -TW * pJ[3];
                    dT[5] = -T * Jv - TW * pJ[4];
                    dT[6] = -TW * pJ[5];
                    if (xi_ < NO) {
                        double Te = tau0 * q_el, den2 = 1.0 + T * T, de2 = 1.0 + Te * Te, TeW = Te * W;
                        double cw = -4.0 * T / (den2 * den2) * GWO[xi_];
                        double ce = -4.0 * Te / (de2 * de2) * GWO[xi_];
                        double dTe[7] = {q_el, -TeW * dJe[0], 0.0, 0.0, -TeW * dJe[1],
                                         -Te * Je - TeW * dJe[2], 0.0};
                        C += GWO[xi_] * ((1.0 - T * T) / den2 - (1.0 - Te * Te) / de2);
                        for (q = 0; q < 7; q++) cC[q] += cw * dT[q] - ce * dTe[q];
                    } else {
                        T1 = T;
                        for (q = 0; q < 7; q++) cT[q] = dT[q];
                    }
                }
                for (j = 0; j < m; j++) {
                    double base[7] = {dtau0[j], drho_s[j], dd0[j], drho1p[j], dP[j], dW[j], dA[j]};
                    dC[j] = 0.0;
                    dT1[j] = 0.0;
                    for (q = 0; q < 7; q++) {
                        dC[j] += cC[q] * base[q];
                        dT1[j] += cT[q] * base[q];
                    }
                }
            }
            cth1 = (1.0 - T1 * T1) / (1.0 + T1 * T1);
            sth1 = 2.0 * T1 / (1.0 + T1 * T1);
            Aeff = rho_s + W * C;
            for (j = 0; j < m; j++) {
                dth1[j] = 2.0 * dT1[j] / (1.0 + T1 * T1);
                dAeff[j] = drho_s[j] + dW[j] * C + W * dC[j];
            }
            br2 = br;
            br2.A = Aeff; /* the same start state (Br.with_A) */
            if (!(Aeff - g * r0 * br.mu_rec > 0.0)) {
                br2 = br;
                Aeff = A;
                for (j = 0; j < m; j++) dAeff[j] = dA[j];
            }
            {
                Ev e_st = e0;
                e_st.phi += Aeff - A;
                conv = solve(&br2, L, fmax(tol_f, 8.0 * EPS * Aeff), max_iter, dl0, &e_st, &dl, &e,
                             iters, &cert);
            }
            if (!conv) {
                memset(tr, 0, sizeof(double) * m);
                memset(tg, 0, sizeof(double) * m * m);
                for (i = 0; i < nt; i++) up1[i] = up[i];
                *mu1 = mu_c;
                *r1 = r0;
                return 4;
            }
            if (!cert) { *mu1 = mu_c; *r1 = r_c; return 5; }
            partials(&br2, L, dl, &e, &H, &R, &Mmu, &Mb);
            rho1 = fmin(g * e.r * e.mu, Aeff);
            t1[0] = cth1 * ew[0] - sth1 * ew[1];
            t1[1] = sth1 * ew[0] + cth1 * ew[1];
            n1[0] = -t1[1]; n1[1] = t1[0];
            for (j = 0; j < m; j++) {
                ddl[j] = (dAeff[j] - dg1[j] * e.r * e.mu - g * e.mu * R * dr0[j] -
                          g * e.r * (Mmu * dmu0[j] + Mb * db[j])) / H;
                drho1[j] = dAeff[j] - at * ddl[j];
                dph1[j] = dphi_w[j] + dth1[j];
                for (i = 0; i < 2; i++) tg[i * m + j] = drho1[j] * t1[i] + rho1 * n1[i] * dph1[j];
            }
            tg[2 * m + 2] = an;
            for (i = 0; i < 2; i++) {
                tr[i] = rho1 * t1[i];
                up1[i] = up[i] + (ft[i] - tr[i]) / at;
            }
            tr[2] = fn;
            finish(L, &e, g, mu1, r1, unst);
            return 1;
        }
    }
}

/* Batched: arrays row-major (n, m), (n, nt), (n,); f may be NULL. Returns points needing the scan. */
int rm_batch(const double *law, int n, int nt, const double *gap, const double *up,
             const double *mu, const double *r, const double *f, double dt, double tol,
             int max_iter, double contact_tol, double *tr, double *tan, double *up1, double *mu1,
             double *r1, signed char *status, unsigned char *unstable, long long *iters) {
    Law L;
    int p, m = nt + 1, nscan = 0;
    L.at = law[0]; L.an = law[1]; L.mu_s = law[2]; L.mu_k = law[3]; L.kappa = law[4];
    L.xi = law[5]; L.ut = law[6]; L.cn = law[7];
    L.k = 0.5 * M_PI * L.ut;
    L.sqrt2k_inv = 1.0 / sqrt(2.0 * L.k);
    L.zc_cap = sqrt(36.0 / L.k);
    L.len_n = 1.0 / (L.cn * L.an);
    for (p = 0; p < n; p++) {
        int un, it, st;
        st = point(&L, nt, gap + (size_t)p * m, up + (size_t)p * nt, mu[p], r[p],
                   f ? f + (size_t)p * m : NULL, dt, tol, max_iter, contact_tol, tr + (size_t)p * m,
                   tan + (size_t)p * m * m, up1 + (size_t)p * nt, mu1 + p, r1 + p, &un, &it);
        nscan += st == 5;
        status[p] = (signed char)st;
        unstable[p] = (unsigned char)un;
        iters[p] = it;
    }
    return nscan;
}

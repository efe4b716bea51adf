// filter.wgsl: the rules of filtered evaluation (src/filter/: rules.rs, moments.rs, noise.rs)
// in f64, for the filtered form of a tape (`filtered.rs` generates `fn ftape`). A value over the
// footprint is a `D`: mean `m`, linear part `g` (per unit of sample position) and residual
// variance `v`, as the CPU's `Dist`. The exact rules (piecewise polynomials of a spread value)
// are computed here by a different exact method than the CPU's (Gauss-Legendre on the pieces
// between the spread's density breakpoints and the function's knots, exact for the polynomial
// integrands): both are exact to rounding, so they agree; the approximate rules (products, the
// delta method, the noise fade) are the CPU's formulas, term for term.

struct D {
    m: f64,
    g: vec3<f64>,
    v: f64,
}

// A rule's result where it may decline (`ok` false: the caller's fallback).
struct Opt {
    d: D,
    ok: bool,
}

struct Mo {
    mean: f64,
    variance: f64,
    slope: f64,
}

// A spread (moments.rs `Spread`): widths descending, or unbounded.
struct Sp {
    w: vec3<f64>,
    unbounded: bool,
}

// A noise table's statistics (noise.rs `Stats`).
struct St {
    mean: f64,
    var_: f64,
    kappa2: f64,
    grad_sq: f64,
    // noise.rs `Stats::faces`: 1 where small boxes take the six face centres.
    faces: f64,
}

// The statistics of sampler `s`'s table, from its record in the filtered form's data
// (`filtered.rs` `Gen::sampler`: table offset, period, cellular codes and jitter, statistics).
fn smp_stats(s: u32) -> St {
    return St(fdata[s + 7u], fdata[s + 8u], fdata[s + 9u], fdata[s + 10u], fdata[s + 11u]);
}

// A piecewise cubic (moments.rs `Piecewise`): knots k[0..n], pieces p[0..=n] as coefficients
// in u = x - anchor (anchor k[i-1] for piece i >= 1, k[0] for piece 0, 0 without knots).
// `PW_KNOTS` is the most knots of the tape's shapes (`filtered.rs` writes it in: the arrays
// are copied per rule, and their size is much of what a driver compiles and runs).
struct Pw {
    k: array<f64, PW_KNOTS>,
    p: array<vec4<f64>, PW_PIECES>,
    n: u32,
}

// The invocation's footprint (`fp_set`): edges, `quad` = Σ e eᵀ / 12 by rows, the non-zero
// edges and the inverse of their Gram matrix (rules.rs `Footprint`).
var<private> fp_e: array<vec3<f64>, 3>;
var<private> fp_q: array<vec3<f64>, 3>;
var<private> fp_live: array<u32, 3>;
var<private> fp_n: u32;
var<private> fp_inv: array<vec3<f64>, 3>;
var<private> fp_inv_ok: bool;

fn fp_set(e0: vec3<f64>, e1: vec3<f64>, e2: vec3<f64>) {
    fp_e = array<vec3<f64>, 3>(e0, e1, e2);
    for (var i = 0u; i < 3u; i += 1u) {
        var row = vec3<f64>(0.0lf);
        for (var j = 0u; j < 3u; j += 1u) {
            row[j] = (fp_e[0][i] * fp_e[0][j] + fp_e[1][i] * fp_e[1][j] + fp_e[2][i] * fp_e[2][j]) / 12.0lf;
        }
        fp_q[i] = row;
    }
    fp_n = 0u;
    for (var k = 0u; k < 3u; k += 1u) {
        if (v_dot(fp_e[k], fp_e[k]) > 0.0lf) {
            fp_live[fp_n] = k;
            fp_n += 1u;
        }
    }
    var m: array<vec3<f64>, 3>;
    for (var i = 0u; i < 3u; i += 1u) {
        for (var j = 0u; j < 3u; j += 1u) {
            if (i < fp_n && j < fp_n) {
                m[i][j] = v_dot(fp_e[fp_live[i]], fp_e[fp_live[j]]);
            } else {
                m[i][j] = 0.0lf;
            }
        }
    }
    fp_inv = array<vec3<f64>, 3>(vec3<f64>(0.0lf), vec3<f64>(0.0lf), vec3<f64>(0.0lf));
    fp_inv_ok = true;
    if (fp_n > 0u) {
        fp_inv_ok = invert(m, fp_n);
    }
}

// rules.rs `invert`: the leading n × n block's inverse into `fp_inv`; false where singular.
fn invert(m: array<vec3<f64>, 3>, n: u32) -> bool {
    var diagonal = 1.0lf;
    for (var i = 0u; i < n; i += 1u) {
        diagonal = diagonal * m[i][i];
    }
    var det: f64;
    if (n == 1u) {
        det = m[0][0];
    } else if (n == 2u) {
        det = m[0][0] * m[1][1] - m[0][1] * m[1][0];
    } else {
        det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
    }
    if (is_nan_d(det) || det <= 1e-9lf * diagonal || det <= 0.0lf) {
        return false;
    }
    if (n == 1u) {
        fp_inv[0][0] = 1.0lf / det;
    } else if (n == 2u) {
        fp_inv[0][0] = m[1][1] / det;
        fp_inv[1][1] = m[0][0] / det;
        fp_inv[0][1] = -m[0][1] / det;
        fp_inv[1][0] = -m[1][0] / det;
    } else {
        for (var i = 0u; i < 3u; i += 1u) {
            for (var j = 0u; j < 3u; j += 1u) {
                let r0 = (j + 1u) % 3u;
                let r1 = (j + 2u) % 3u;
                let c0 = (i + 1u) % 3u;
                let c1 = (i + 2u) % 3u;
                fp_inv[i][j] = (m[r0][c0] * m[r1][c1] - m[r0][c1] * m[r1][c0]) / det;
            }
        }
    }
    return true;
}

fn is_finite_d(x: f64) -> bool {
    return !is_nan_d(x) && !d_is_inf(x);
}

fn dc(x: f64) -> D {
    return D(x, vec3<f64>(0.0lf), 0.0lf);
}

fn d_is_const(d: D) -> bool {
    return d.v == 0.0lf && d.g.x == 0.0lf && d.g.y == 0.0lf && d.g.z == 0.0lf;
}

// rules.rs `Dist::same_value`: equal distributions with a linear part.
fn d_same(a: D, b: D) -> bool {
    let equal = a.m == b.m && a.g.x == b.g.x && a.g.y == b.g.y && a.g.z == b.g.z && a.v == b.v;
    return equal && (a.g.x != 0.0lf || a.g.y != 0.0lf || a.g.z != 0.0lf);
}

fn d_position(p: vec3<f64>, axis: u32) -> D {
    var g = vec3<f64>(0.0lf);
    g[axis] = 1.0lf;
    return D(p[axis], g, 0.0lf);
}

fn d_scale(d: D, c: f64) -> D {
    return D(c * d.m, c * d.g, c * c * d.v);
}

// `|g · e_k|` per edge.
fn f_widths(g: vec3<f64>) -> vec3<f64> {
    return vec3<f64>(abs(v_dot(g, fp_e[0])), abs(v_dot(g, fp_e[1])), abs(v_dot(g, fp_e[2])));
}

// Written out (the same sums in the same order as a loop over i): it runs several times in
// every rule, and every loop iteration counts against llvmpipe's budget (docs/gpu.md).
fn f_cov(a: vec3<f64>, b: vec3<f64>) -> f64 {
    let s0 = 0.0lf + a[0] * (fp_q[0][0] * b[0] + fp_q[0][1] * b[1] + fp_q[0][2] * b[2]);
    let s1 = s0 + a[1] * (fp_q[1][0] * b[0] + fp_q[1][1] * b[1] + fp_q[1][2] * b[2]);
    return s1 + a[2] * (fp_q[2][0] * b[0] + fp_q[2][1] * b[1] + fp_q[2][2] * b[2]);
}

fn f_linvar(g: vec3<f64>) -> f64 {
    return max(f_cov(g, g), 0.0lf);
}

fn f_total(d: D) -> f64 {
    return f_linvar(d.g) + d.v;
}

fn f_residual(total: f64, linear: f64) -> f64 {
    let r = total - linear;
    if (is_finite_d(r) && r > 1e-9lf * abs(total)) {
        return r;
    }
    return 0.0lf;
}

fn f_out(d: D, mo: Mo) -> D {
    var g = vec3<f64>(0.0lf);
    if (mo.slope != 0.0lf) {
        g = mo.slope * d.g;
    }
    return D(mo.mean, g, f_residual(mo.variance, f_linvar(g)));
}

fn hypot_d(a: f64, b: f64) -> f64 {
    let m = max(a, b);
    if (m == 0.0lf) {
        return 0.0lf;
    }
    let x = a / m;
    let y = b / m;
    return m * sqrt(x * x + y * y);
}

// moments.rs `Spread::new`.
fn sp_new(widths: vec3<f64>, residual: f64) -> Sp {
    if (!is_finite_d(residual) || !is_finite_d(widths.x) || !is_finite_d(widths.y) || !is_finite_d(widths.z)) {
        return Sp(vec3<f64>(f64(inf_f32()), 0.0lf, 0.0lf), true);
    }
    let half = sqrt(6.0lf * max(residual, 0.0lf));
    var five = array<f64, 5>(abs(widths.x), abs(widths.y), abs(widths.z), half, half);
    if (half == 0.0lf) {
        // No residual (most values): the three widths sorted without a loop, the same order
        // as the merge below leaves them (hypot(x, 0) = x). Every loop iteration counts
        // against llvmpipe's budget (docs/gpu.md), and this runs for every rule.
        sort_desc3(&five);
    } else {
        sort_desc5(&five, 5u);
        for (var n = 5u; n >= 4u; n -= 1u) {
            five[n - 2u] = hypot_d(five[n - 2u], five[n - 1u]);
            sort_desc5(&five, n - 1u);
        }
    }
    // The three largest, each below 1e-4 of the one kept before it merged into that one
    // (`sp_take` three times: the widths descend, so a subnormal ends the list).
    var w = vec3<f64>(0.0lf);
    var k = 0u;
    sp_take(&w, &k, five[0]);
    sp_take(&w, &k, five[1]);
    sp_take(&w, &k, five[2]);
    if (w.y > w.x) {
        w = vec3<f64>(w.y, w.x, w.z);
    }
    if (w.z > w.y) {
        w = vec3<f64>(w.x, w.z, w.y);
    }
    if (!is_finite_d(w.x) || !is_finite_d(w.y) || !is_finite_d(w.z)) {
        return Sp(vec3<f64>(f64(inf_f32()), 0.0lf, 0.0lf), true);
    }
    return Sp(w, false);
}

// `sp_new`'s step for one width x of a descending list: none below the smallest normal,
// merged into the last kept where below 1e-4 of it, else kept.
fn sp_take(w: ptr<function, vec3<f64>>, k: ptr<function, u32>, x: f64) {
    if (x < 2.2250738585072014e-308lf) {
        return;
    }
    if (*k > 0u && x < 1e-4lf * (*w)[*k - 1u]) {
        (*w)[*k - 1u] = hypot_d((*w)[*k - 1u], x);
    } else {
        (*w)[*k] = x;
        *k += 1u;
    }
}

// The eight values (±w.x ± w.y ± w.z) / 2 in ascending order, without a loop: with the widths
// sorted a >= b >= c only the middle two can swap.
fn corners_sorted(w: vec3<f64>) -> array<f64, 8> {
    var a = max(w.x, w.y);
    var b = min(w.x, w.y);
    var c = w.z;
    if (c > b) {
        let t = c;
        c = b;
        b = t;
    }
    if (b > a) {
        let t = b;
        b = a;
        a = t;
    }
    let mid_lo = (-a + b + c) / 2.0lf;
    let mid_hi = (a - b - c) / 2.0lf;
    return array<f64, 8>((-a - b - c) / 2.0lf, (-a - b + c) / 2.0lf, (-a + b - c) / 2.0lf,
        min(mid_lo, mid_hi), max(mid_lo, mid_hi), (a - b + c) / 2.0lf, (a + b - c) / 2.0lf,
        (a + b + c) / 2.0lf);
}

// The first three of `a` in descending order by three exchanges (no loop).
fn sort_desc3(a: ptr<function, array<f64, 5>>) {
    if ((*a)[0] < (*a)[1]) {
        let t = (*a)[0];
        (*a)[0] = (*a)[1];
        (*a)[1] = t;
    }
    if ((*a)[1] < (*a)[2]) {
        let t = (*a)[1];
        (*a)[1] = (*a)[2];
        (*a)[2] = t;
    }
    if ((*a)[0] < (*a)[1]) {
        let t = (*a)[0];
        (*a)[0] = (*a)[1];
        (*a)[1] = t;
    }
}

fn sort_desc5(a: ptr<function, array<f64, 5>>, n: u32) {
    for (var i = 1u; i < n; i += 1u) {
        let x = (*a)[i];
        var j = i;
        while (j > 0u && (*a)[j - 1u] < x) {
            (*a)[j] = (*a)[j - 1u];
            j -= 1u;
        }
        (*a)[j] = x;
    }
}

fn f_spread(d: D) -> Sp {
    return sp_new(f_widths(d.g), d.v);
}

// The CDF of a U + b U' (a >= b >= 0, U, U' uniform on [-1/2, 1/2]) at v: a trapezoid's.
fn cdf2(v: f64, a: f64, b: f64) -> f64 {
    if (a == 0.0lf) {
        return select(0.0lf, 1.0lf, v >= 0.0lf);
    }
    let lo = (a - b) / 2.0lf;
    let hi = (a + b) / 2.0lf;
    let u = -abs(v);
    var c: f64;
    if (u <= -hi) {
        c = 0.0lf;
    } else if (u <= -lo) {
        c = (u + hi) * (u + hi) / (2.0lf * a * b);
    } else {
        c = b / (2.0lf * a) + (u + lo) / a;
    }
    if (v <= 0.0lf) {
        return c;
    }
    return 1.0lf - c;
}

// The density of S = Σ w_k U_k at s (even in s; taken at -|s|, where the difference of the
// two CDFs is of their smaller values).
fn sp_density(s: f64, sp: Sp) -> f64 {
    let w0 = sp.w.x;
    if (w0 == 0.0lf || sp.unbounded) {
        return 0.0lf;
    }
    // On the support's end or within 1e-12 of its half-width: 0 (moments.rs `EDGE`).
    let h = (sp.w.x + sp.w.y + sp.w.z) / 2.0lf;
    if (h - abs(s) <= 1e-12lf * h) {
        return 0.0lf;
    }
    let u = -abs(s);
    return (cdf2(u + w0 / 2.0lf, sp.w.y, sp.w.z) - cdf2(u - w0 / 2.0lf, sp.w.y, sp.w.z)) / w0;
}

fn horner4(c: vec4<f64>, u: f64) -> f64 {
    return ((c.w * u + c.z) * u + c.y) * u + c.x;
}

fn horner_slope(c: vec4<f64>, u: f64) -> f64 {
    return (3.0lf * c.w * u + 2.0lf * c.z) * u + c.y;
}

fn pw_anchor(f: Pw, j: u32) -> f64 {
    if (j == 0u) {
        if (f.n == 0u) {
            return 0.0lf;
        }
        return f.k[0];
    }
    return f.k[j - 1u];
}

fn pw_eval(f: Pw, x: f64) -> f64 {
    if (is_nan_d(x)) {
        return nan_d();
    }
    var j = 0u;
    while (j < f.n && f.k[j] <= x) {
        j += 1u;
    }
    return horner4(f.p[j], x - pw_anchor(f, j));
}

// The Gauss-Legendre node count, 5, as a value the driver cannot know (`filter_one()` is 1.0 at
// run time, bindings.wgsl): a loop it cannot unroll, so each rule's integrand is compiled once,
// not once per node (lavapipe took minutes and gigabytes on the unrolled periodic chains).
fn gl_nodes() -> u32 {
    return 5u * u32(filter_one());
}

const GL_X: array<f64, 5> = array<f64, 5>(-0.906179845938664lf, -0.5384693101056831lf, 0.0lf, 0.5384693101056831lf, 0.906179845938664lf);
const GL_W: array<f64, 5> = array<f64, 5>(0.23692688505618908lf, 0.47862867049936647lf, 0.5688888888888889lf, 0.47862867049936647lf, 0.23692688505618908lf);

// Mean, variance and slope of f(t + S), exact (moments.rs `Piecewise::moments`): in the
// spread's own coordinate s = x - t, the support cut at the density's breakpoints and at the
// knots inside it, each interval by 5-node Gauss-Legendre (the integrands are polynomials of
// degree <= 8 there); the slope adds each jump times the density at its knot.
fn pw_moments(f: Pw, t: f64, sp: Sp) -> Mo {
    return pw_stats(f, t, sp, true);
}

// `pw_moments`' mean alone (the same operations; no slope's jumps, no variance pass).
fn pw_mean(f: Pw, t: f64, sp: Sp) -> f64 {
    return pw_stats(f, t, sp, false).mean;
}

fn pw_stats(f: Pw, t: f64, sp: Sp, full: bool) -> Mo {
    if (is_nan_d(t)) {
        return Mo(nan_d(), nan_d(), nan_d());
    }
    if (sp.unbounded) {
        let l = f.p[0];
        let r = f.p[f.n];
        if (l.y != 0.0lf || l.z != 0.0lf || l.w != 0.0lf || r.y != 0.0lf || r.z != 0.0lf || r.w != 0.0lf) {
            return Mo(nan_d(), nan_d(), nan_d());
        }
        let gap = (l.x - r.x) / 2.0lf;
        return Mo((l.x + r.x) / 2.0lf, gap * gap, 0.0lf);
    }
    let w = sp.w;
    let h = (w.x + w.y + w.z) / 2.0lf;
    var j0 = 0u;
    while (j0 < f.n && f.k[j0] <= t) {
        j0 += 1u;
    }
    var inside = false;
    for (var i = 0u; i < f.n; i += 1u) {
        if (f.k[i] > t - h && f.k[i] < t + h) {
            inside = true;
        }
    }
    if (!inside) {
        // One piece covers the support: its Taylor coefficients at t and the moments of S.
        let c = f.p[j0];
        let u0 = t - pw_anchor(f, j0);
        let q0 = horner4(c, u0);
        let q1 = horner_slope(c, u0);
        let q2 = c.z + 3.0lf * c.w * u0;
        let q3 = c.w;
        let w2 = w * w;
        let s2 = (w2.x + w2.y + w2.z) / 12.0lf;
        let w4 = w2 * w2;
        let s4 = (w4.x + w4.y + w4.z) / 80.0lf
            + 6.0lf * (w2.x * w2.y + w2.x * w2.z + w2.y * w2.z) / 144.0lf;
        let w6 = w4 * w2;
        let s6 = (w6.x + w6.y + w6.z) / 448.0lf
            + 15.0lf * (w4.x * (w2.y + w2.z) + w4.y * (w2.x + w2.z) + w4.z * (w2.x + w2.y)) / 960.0lf
            + 90.0lf * w2.x * w2.y * w2.z / 1728.0lf;
        let variance = q1 * q1 * s2 + q2 * q2 * (s4 - s2 * s2) + q3 * q3 * s6 + 2.0lf * q1 * q3 * s4;
        return Mo(q0 + q2 * s2, max(variance, 0.0lf), q1 + 3.0lf * q3 * s2);
    }
    // Breakpoints in s: the density's (± w0/2 ± w1/2 ± w2/2), in ascending order without a
    // loop (`corners_sorted`), and the knots inside, each inserted in order. (Every loop
    // iteration counts against llvmpipe's budget, docs/gpu.md; this rule runs for most.)
    var b: array<f64, PW_BREAKS>;
    let corners = corners_sorted(w);
    for (var i = 0u; i < 8u; i += 1u) {
        b[i] = corners[i];
    }
    var nb = 8u;
    for (var i = 0u; i < f.n; i += 1u) {
        let x = f.k[i] - t;
        if (f.k[i] > t - h && f.k[i] < t + h) {
            var j = nb;
            while (j > 0u && b[j - 1u] > x) {
                b[j] = b[j - 1u];
                j -= 1u;
            }
            b[j] = x;
            nb += 1u;
        }
    }
    var mean = 0.0lf;
    var slope = 0.0lf;
    for (var i = 0u; i + 1u < nb; i += 1u) {
        let lo = b[i];
        let hi = b[i + 1u];
        if (!(hi > lo)) {
            continue;
        }
        let mid = (lo + hi) / 2.0lf;
        let half = (hi - lo) / 2.0lf;
        var j = 0u;
        while (j < f.n && f.k[j] - t <= mid) {
            j += 1u;
        }
        let c = f.p[j];
        let ta = t - pw_anchor(f, j);
        for (var g = 0u; g < gl_nodes(); g += 1u) {
            let s = mid + half * GL_X[g];
            let weight = GL_W[g] * half * sp_density(s, sp);
            let u = ta + s;
            mean = mean + weight * horner4(c, u);
            slope = slope + weight * horner_slope(c, u);
        }
    }
    if (!full) {
        return Mo(mean, 0.0lf, slope);
    }
    for (var i = 0u; i < f.n; i += 1u) {
        let k = f.k[i];
        if (k > t - h && k < t + h) {
            let jump = horner4(f.p[i + 1u], k - pw_anchor(f, i + 1u)) - horner4(f.p[i], k - pw_anchor(f, i));
            slope = slope + jump * sp_density(k - t, sp);
        }
    }
    var variance = 0.0lf;
    for (var i = 0u; i + 1u < nb; i += 1u) {
        let lo = b[i];
        let hi = b[i + 1u];
        if (!(hi > lo)) {
            continue;
        }
        let mid = (lo + hi) / 2.0lf;
        let half = (hi - lo) / 2.0lf;
        var j = 0u;
        while (j < f.n && f.k[j] - t <= mid) {
            j += 1u;
        }
        let c = f.p[j];
        let ta = t - pw_anchor(f, j);
        for (var g = 0u; g < gl_nodes(); g += 1u) {
            let s = mid + half * GL_X[g];
            let e = horner4(c, ta + s) - mean;
            variance = variance + GL_W[g] * half * sp_density(s, sp) * e * e;
        }
    }
    return Mo(mean, max(variance, 0.0lf), slope);
}

// rules.rs `Rules::piecewise`.
fn r_piecewise(f: Pw, d: D) -> D {
    if (d_is_const(d)) {
        return dc(pw_eval(f, d.m));
    }
    return f_out(d, pw_moments(f, d.m, f_spread(d)));
}

fn pw_one(k0: f64, p0: vec4<f64>, p1: vec4<f64>) -> Pw {
    var f: Pw;
    f.n = 1u;
    f.k[0] = k0;
    f.p[0] = p0;
    f.p[1] = p1;
    return f;
}

fn pw_two(k0: f64, k1: f64, p0: vec4<f64>, p1: vec4<f64>, p2: vec4<f64>) -> Pw {
    var f: Pw;
    f.n = 2u;
    f.k[0] = k0;
    f.k[1] = k1;
    f.p[0] = p0;
    f.p[1] = p1;
    f.p[2] = p2;
    return f;
}

// rules.rs `Shapes`.
fn shape_abs() -> Pw {
    return pw_one(0.0lf, vec4<f64>(0.0lf, -1.0lf, 0.0lf, 0.0lf), vec4<f64>(0.0lf, 1.0lf, 0.0lf, 0.0lf));
}
fn shape_sign() -> Pw {
    return pw_one(0.0lf, vec4<f64>(-1.0lf, 0.0lf, 0.0lf, 0.0lf), vec4<f64>(1.0lf, 0.0lf, 0.0lf, 0.0lf));
}
fn shape_step() -> Pw {
    return pw_one(0.0lf, vec4<f64>(0.0lf), vec4<f64>(1.0lf, 0.0lf, 0.0lf, 0.0lf));
}
fn shape_ramp() -> Pw {
    return pw_one(0.0lf, vec4<f64>(0.0lf), vec4<f64>(0.0lf, 1.0lf, 0.0lf, 0.0lf));
}
fn shape_unit_clamp() -> Pw {
    return pw_two(0.0lf, 1.0lf, vec4<f64>(0.0lf), vec4<f64>(0.0lf, 1.0lf, 0.0lf, 0.0lf), vec4<f64>(1.0lf, 0.0lf, 0.0lf, 0.0lf));
}
fn shape_unit_smoothstep() -> Pw {
    return pw_two(0.0lf, 1.0lf, vec4<f64>(0.0lf), vec4<f64>(0.0lf, 0.0lf, 3.0lf, -2.0lf), vec4<f64>(1.0lf, 0.0lf, 0.0lf, 0.0lf));
}

fn r_add(a: D, b: D) -> D {
    return D(a.m + b.m, a.g + b.g, a.v + b.v);
}

fn r_sub(a: D, b: D) -> D {
    if (d_same(a, b)) {
        return dc(0.0lf);
    }
    return D(a.m - b.m, a.g - b.g, a.v + b.v);
}

fn r_mul(a: D, b: D) -> D {
    if (d_is_const(b)) {
        return d_scale(a, b.m);
    }
    if (d_is_const(a)) {
        return d_scale(b, a.m);
    }
    let cov = f_cov(a.g, b.g);
    let ta = f_total(a);
    let tb = f_total(b);
    let g = a.m * b.g + b.m * a.g;
    let total = ta * tb + ta * b.m * b.m + tb * a.m * a.m + cov * cov + 2.0lf * a.m * b.m * cov;
    return D(a.m * b.m + cov, g, f_residual(total, f_linvar(g)));
}

// rules.rs `Rules::smooth`: the delta method.
fn r_smooth(d: D, f: f64, f1: f64, f2: f64, concave: bool) -> D {
    if (d_is_const(d)) {
        return dc(f);
    }
    let t = f_total(d);
    var mean = f + 0.5lf * f2 * t;
    if (concave && mean > f) {
        mean = f;
    }
    if (!is_finite_d(mean)) {
        mean = f;
    }
    let g = f1 * d.g;
    let total = f1 * f1 * t + 0.5lf * f2 * f2 * t * t;
    return D(mean, g, f_residual(total, f_linvar(g)));
}

fn r_smooth2(a: D, b: D, f: f64, fa: f64, fb: f64, faa: f64, fbb: f64, fab: f64) -> D {
    let ta = f_total(a);
    let tb = f_total(b);
    let cov = f_cov(a.g, b.g);
    var mean = f + 0.5lf * (faa * ta + fbb * tb) + fab * cov;
    if (!is_finite_d(mean)) {
        mean = f;
    }
    let g = fa * a.g + fb * b.g;
    let total = fa * fa * ta + fb * fb * tb + 2.0lf * fa * fb * cov;
    return D(mean, g, f_residual(total, f_linvar(g)));
}

fn r_reciprocal(b: D) -> D {
    let m = b.m;
    return r_smooth(b, 1.0lf / m, -1.0lf / (m * m), 2.0lf / (m * m * m), false);
}

fn sinc_d(x: f64) -> f64 {
    if (abs(x) < 1e-4lf) {
        return 1.0lf - x * x / 6.0lf;
    }
    if (d_is_inf(x)) {
        return 0.0lf;
    }
    return d_sin(x) / x;
}

fn r_sin_cos(d: D, cos: bool) -> D {
    let s = d_sin(d.m);
    let c = d_cos(d.m);
    var value = s;
    var slope = c;
    if (cos) {
        value = c;
        slope = -s;
    }
    if (d_is_const(d)) {
        return dc(value);
    }
    let w = f_widths(d.g);
    let attenuation = sinc_d(w.x / 2.0lf) * sinc_d(w.y / 2.0lf) * sinc_d(w.z / 2.0lf) * d_exp(-d.v / 2.0lf);
    let double = sinc_d(w.x) * sinc_d(w.y) * sinc_d(w.z) * d_exp(-2.0lf * d.v);
    let c2 = d_cos(2.0lf * d.m);
    var square = 0.5lf * (1.0lf - c2 * double);
    if (cos) {
        square = 0.5lf * (1.0lf + c2 * double);
    }
    let mean = value * attenuation;
    return f_out(d, Mo(mean, max(square - mean * mean, 0.0lf), slope * attenuation));
}

fn r_exp(d: D) -> D {
    let t = f_total(d);
    let mean = d_exp(d.m + t / 2.0lf);
    let g = mean * d.g;
    let total = (d_exp(t) - 1.0lf) * mean * mean;
    return D(mean, g, f_residual(total, f_linvar(g)));
}

// rules.rs `half_gamma_ratio`'s series: 1 − Γ(k + ½) / (Γ(k) √k) at k ≥ 8.
fn half_gamma_tail(k: f64) -> f64 {
    let u = 1.0lf / k;
    return u * (1.0lf / 8.0lf
        - u * (1.0lf / 128.0lf
            + u * (5.0lf / 1024.0lf
                + u * (-21.0lf / 32768.0lf + u * (-399.0lf / 262144.0lf + u * 869.0lf / 4194304.0lf)))));
}

// rules.rs `Rules::sqrt`: the moments of √X for a Gamma-distributed X ≥ 0 (the shift below
// k = 8 written out, no loop: llvmpipe's loop budget, docs/gpu.md).
fn r_sqrt(d: D) -> D {
    let m = d.m;
    let t = f_total(d);
    if (!(m > 0.0lf)) {
        return dc(d_sqrt(m));
    }
    let s = d_sqrt(m);
    if (t == 0.0lf) {
        return D(s, (0.5lf / s) * d.g, 0.0lf);
    }
    let k = m * m / t;
    var g = 0.0lf;
    var h = 1.0lf;
    if (k >= 8.0lf) {
        h = half_gamma_tail(k);
        g = 1.0lf - h;
    } else if (k > 0.0lf) {
        let p = d_sqrt((k + 8.0lf) / k) * (k / (k + 0.5lf)) * ((k + 1.0lf) / (k + 1.5lf))
            * ((k + 2.0lf) / (k + 2.5lf)) * ((k + 3.0lf) / (k + 3.5lf)) * ((k + 4.0lf) / (k + 4.5lf))
            * ((k + 5.0lf) / (k + 5.5lf)) * ((k + 6.0lf) / (k + 6.5lf)) * ((k + 7.0lf) / (k + 7.5lf));
        g = (1.0lf - half_gamma_tail(k + 8.0lf)) * p;
        h = 1.0lf - g;
    }
    let mean = s * g;
    return f_out(d, Mo(mean, m * h * (1.0lf + g), mean / (2.0lf * m)));
}

// rules.rs `Rules::min_max`.
fn r_min_max(a: D, b: D, is_max: bool) -> D {
    if (d_is_const(a) && d_is_const(b)) {
        if (is_max) {
            return dc(d_max(a.m, b.m));
        }
        return dc(d_min(a.m, b.m));
    }
    let d = r_sub(a, b);
    let r = pw_moments(shape_ramp(), d.m, f_spread(d));
    if (r.slope == 0.0lf && r.mean == 0.0lf) {
        if (is_max) {
            return b;
        }
        return a;
    }
    if (r.slope == 1.0lf && r.mean == d.m) {
        if (is_max) {
            return a;
        }
        return b;
    }
    var base = a;
    var sign = -1.0lf;
    var base_var = a.v;
    if (is_max) {
        base = b;
        sign = 1.0lf;
        base_var = -b.v;
    }
    let mean = base.m + sign * r.mean;
    let g = base.g + sign * r.slope * d.g;
    let cov_base_d = f_cov(base.g, d.g) + base_var;
    let total = f_total(base) + r.variance + 2.0lf * sign * r.slope * cov_base_d;
    return D(mean, g, f_residual(total, f_linvar(g)));
}

// rules.rs `Rules::select`: a where cond > 0, else b.
fn r_select(cond: D, a: D, b: D) -> D {
    let s = f_spread(cond);
    var p: f64;
    if (s.w.x == 0.0lf && s.w.y == 0.0lf && s.w.z == 0.0lf) {
        p = select(0.0lf, 1.0lf, cond.m > 0.0lf);
    } else {
        p = pw_mean(shape_step(), cond.m, s);
    }
    var density = 0.0lf;
    if (!d_is_const(cond)) {
        density = sp_density(cond.m, s);
    }
    let jump = a.m - b.m;
    let mean = p * a.m + (1.0lf - p) * b.m;
    var g = p * a.g + (1.0lf - p) * b.g;
    if (is_finite_d(density) && density != 0.0lf) {
        g = g + jump * density * cond.g;
    }
    let total = p * f_total(a) + (1.0lf - p) * f_total(b) + p * (1.0lf - p) * jump * jump;
    return D(mean, g, f_residual(total, f_linvar(g)));
}

fn r_clamp(a: D, b: D, c: D) -> D {
    if (d_is_const(b) && d_is_const(c) && b.m <= c.m) {
        let lo = b.m;
        let hi = c.m;
        if (lo == hi) {
            return dc(lo);
        }
        let t = d_scale(r_sub(a, b), 1.0lf / (hi - lo));
        let unit = r_piecewise(shape_unit_clamp(), t);
        return r_add(b, d_scale(unit, hi - lo));
    }
    return r_min_max(r_min_max(a, b, true), c, false);
}

fn r_div(a: D, b: D) -> D {
    if (d_is_const(b)) {
        return d_scale(a, 1.0lf / b.m);
    }
    return r_mul(a, r_reciprocal(b));
}

fn r_smoothstep(a: D, b: D, c: D) -> D {
    let span = r_sub(b, a);
    if (span.m == 0.0lf) {
        return r_piecewise(shape_step(), r_sub(c, a));
    }
    let x = r_sub(c, a);
    var t: D;
    if ((d_is_const(x) && d_is_const(span)) || is_nan_d(x.m) || is_nan_d(span.m)) {
        t = dc(d_div(x.m, span.m));
    } else {
        t = r_div(x, span);
    }
    return r_piecewise(shape_unit_smoothstep(), t);
}

fn r_pow(a: D, b: D) -> D {
    let x = a.m;
    let y = b.m;
    let f = d_pow(x, y);
    if (d_is_const(b)) {
        if (x <= 0.0lf && d_fract(y) != 0.0lf) {
            return dc(f);
        }
        let f1 = y * d_pow(x, y - 1.0lf);
        let f2 = y * (y - 1.0lf) * d_pow(x, y - 2.0lf);
        return r_smooth(a, f, f1, f2, y > 0.0lf && y < 1.0lf);
    }
    if (x <= 0.0lf) {
        return dc(f);
    }
    let l = d_log(x);
    return r_smooth2(a, b, f, y * d_pow(x, y - 1.0lf), f * l, y * (y - 1.0lf) * d_pow(x, y - 2.0lf),
        f * l * l, d_pow(x, y - 1.0lf) * (1.0lf + y * l));
}

fn r_atan2(a: D, b: D) -> D {
    let y = a.m;
    let x = b.m;
    let r2 = x * x + y * y;
    let f = d_atan2(y, x);
    if (r2 == 0.0lf) {
        return dc(f);
    }
    let r4 = r2 * r2;
    return r_smooth2(a, b, f, x / r2, -y / r2, -2.0lf * x * y / r4, 2.0lf * x * y / r4, (y * y - x * x) / r4);
}

fn r_mix(a: D, b: D, c: D) -> D {
    return r_add(a, r_mul(c, r_sub(b, a)));
}

fn r_dot(a: array<D, 3>, b: array<D, 3>) -> D {
    var s = r_mul(a[0], b[0]);
    s = r_add(s, r_mul(a[1], b[1]));
    return r_add(s, r_mul(a[2], b[2]));
}

fn r_length(a: array<D, 3>) -> D {
    let d = r_dot(a, a);
    if (d_is_const(d) || is_nan_d(d.m)) {
        return dc(d_sqrt(d.m));
    }
    return r_sqrt(d);
}

fn r_rotate(r0: vec3<f64>, r1: vec3<f64>, r2: vec3<f64>, v: array<D, 3>) -> array<D, 3> {
    let m = array<vec3<f64>, 3>(r0, r1, r2);
    var out: array<D, 3>;
    for (var i = 0u; i < 3u; i += 1u) {
        let row = m[i];
        out[i] = D(row.x * v[0].m + row.y * v[1].m + row.z * v[2].m,
                   row.x * v[0].g + row.y * v[1].g + row.z * v[2].g,
                   row.x * row.x * v[0].v + row.y * row.y * v[1].v + row.z * row.z * v[2].v);
    }
    return out;
}

fn d3_scale(p: array<D, 3>, c: f64) -> array<D, 3> {
    return array<D, 3>(d_scale(p[0], c), d_scale(p[1], c), d_scale(p[2], c));
}

// --- Noise (noise.rs): the fade, the centre rule, the sub-sampled octaves. ---

// noise.rs `fade_of`: (alpha, beta_0, beta_1, beta_2).
fn n_fade_of(st: St, l2: vec3<f64>, v: f64) -> vec4<f64> {
    if (st.kappa2 == 0.0lf) {
        return vec4<f64>(1.0lf);
    }
    var beta = vec3<f64>(1.0lf);
    let t = vec3<f64>(1.0lf) + st.kappa2 * l2 / 12.0lf;
    for (var k = 0u; k < 3u; k += 1u) {
        beta[k] = select(0.0lf, 1.0lf / t[k], is_finite_d(t[k]));
    }
    // One square root of the product (noise.rs `fade_of`).
    var alpha = 1.0lf / sqrt(t.x * t.y * t.z);
    if (v != 0.0lf) {
        alpha = alpha * d_exp(-st.kappa2 * v / 2.0lf);
    }
    if (is_nan_d(alpha)) {
        alpha = 0.0lf;
    }
    return vec4<f64>(alpha, beta);
}

// The footprint's edges in noise space, J e_k.
fn n_edges(p: array<D, 3>) -> array<vec3<f64>, 3> {
    var e: array<vec3<f64>, 3>;
    for (var k = 0u; k < 3u; k += 1u) {
        e[k] = vec3<f64>(v_dot(p[0].g, fp_e[k]), v_dot(p[1].g, fp_e[k]), v_dot(p[2].g, fp_e[k]));
    }
    return e;
}

fn n_fade(st: St, p: array<D, 3>) -> vec4<f64> {
    if (st.kappa2 == 0.0lf) {
        return vec4<f64>(1.0lf);
    }
    var l2 = vec3<f64>(0.0lf);
    let w0 = f_widths(p[0].g);
    let w1 = f_widths(p[1].g);
    let w2 = f_widths(p[2].g);
    for (var k = 0u; k < 3u; k += 1u) {
        l2[k] = w0[k] * w0[k] + w1[k] * w1[k] + w2[k] * w2[k];
    }
    return n_fade_of(st, l2, p[0].v + p[1].v + p[2].v);
}

// rules.rs `Footprint::damp_matrix`, made once per octave rule and applied to each slope
// (`n_damp_apply`); `on` false where it leaves slopes alone. (Made per application before, it
// ran about 40 loop iterations each time, four times an octave: llvmpipe's loop budget,
// docs/gpu.md.)
struct Damp {
    d: array<vec3<f64>, 3>,
    on: bool,
}

fn n_damp_matrix(beta: vec3<f64>) -> Damp {
    var d: array<vec3<f64>, 3>;
    if (abs(1.0lf - beta.x) < 1e-9lf && abs(1.0lf - beta.y) < 1e-9lf && abs(1.0lf - beta.z) < 1e-9lf) {
        return Damp(d, false);
    }
    if (fp_n == 0u) {
        return Damp(d, false);
    }
    if (!fp_inv_ok) {
        let least = min(1.0lf, min(beta.x, min(beta.y, beta.z)));
        d[0] = vec3<f64>(least, 0.0lf, 0.0lf);
        d[1] = vec3<f64>(0.0lf, least, 0.0lf);
        d[2] = vec3<f64>(0.0lf, 0.0lf, least);
    } else {
        d[0] = vec3<f64>(1.0lf, 0.0lf, 0.0lf);
        d[1] = vec3<f64>(0.0lf, 1.0lf, 0.0lf);
        d[2] = vec3<f64>(0.0lf, 0.0lf, 1.0lf);
        for (var a = 0u; a < fp_n; a += 1u) {
            for (var b = 0u; b < fp_n; b += 1u) {
                let c = fp_inv[a][b] * (beta[fp_live[b]] - 1.0lf);
                let ea = fp_e[fp_live[a]];
                let eb = fp_e[fp_live[b]];
                d[0] = d[0] + ea[0] * c * eb;
                d[1] = d[1] + ea[1] * c * eb;
                d[2] = d[2] + ea[2] * c * eb;
            }
        }
    }
    let finite = is_finite_d(d[0].x) && is_finite_d(d[0].y) && is_finite_d(d[0].z)
        && is_finite_d(d[1].x) && is_finite_d(d[1].y) && is_finite_d(d[1].z)
        && is_finite_d(d[2].x) && is_finite_d(d[2].y) && is_finite_d(d[2].z);
    return Damp(d, finite);
}

fn n_damp_apply(m: Damp, g: vec3<f64>) -> vec3<f64> {
    if (!m.on) {
        return g;
    }
    let out = vec3<f64>(v_dot(m.d[0], g), v_dot(m.d[1], g), v_dot(m.d[2], g));
    if (!is_finite_d(out.x) || !is_finite_d(out.y) || !is_finite_d(out.z)) {
        return g;
    }
    return out;
}

fn finite_or_zero(c: f64) -> f64 {
    return select(0.0lf, c, is_finite_d(c));
}

// noise.rs `sampled`: one octave from the value and gradient at the centre.
fn n_sampled(st: St, p: array<D, 3>, fade: vec4<f64>, value: f64, gin: vec3<f64>) -> D {
    let alpha = fade.x;
    let g = vec3<f64>(finite_or_zero(gin.x), finite_or_zero(gin.y), finite_or_zero(gin.z));
    let damp = n_damp_matrix(fade.yzw);
    var grad = alpha * (g.x * p[0].g + g.y * p[1].g + g.z * p[2].g);
    grad = n_damp_apply(damp, grad);
    let carried = g.x * g.x * p[0].v + g.y * g.y * p[1].v + g.z * g.z * p[2].v;
    // noise.rs `Fade::rest`: what the fade takes beyond the linear part's expectation over the
    // noise's gradients.
    let expected = 0.0lf + f_linvar(n_damp_apply(damp, p[0].g)) + f_linvar(n_damp_apply(damp, p[1].g))
        + f_linvar(n_damp_apply(damp, p[2].g));
    let within = f_residual((1.0lf - alpha * alpha) * st.var_, alpha * alpha * st.grad_sq * expected);
    let v = within + alpha * alpha * carried;
    return D(alpha * value + (1.0lf - alpha) * st.mean, grad, select(0.0lf, max(v, 0.0lf), is_finite_d(v)));
}

// rules.rs `Footprint::slope_with`; w = 0 marks "none" (nearly parallel edges).
fn n_slope_with(du: vec3<f64>) -> vec4<f64> {
    if (!fp_inv_ok) {
        return vec4<f64>(0.0lf);
    }
    var g = vec3<f64>(0.0lf);
    for (var a = 0u; a < fp_n; a += 1u) {
        var y = 0.0lf;
        for (var b = 0u; b < fp_n; b += 1u) {
            y = y + fp_inv[a][b] * du[fp_live[b]];
        }
        g = g + y * fp_e[fp_live[a]];
    }
    if (!is_finite_d(g.x) || !is_finite_d(g.y) || !is_finite_d(g.z)) {
        return vec4<f64>(0.0lf);
    }
    return vec4<f64>(g, 1.0lf);
}

// noise.rs `sub_centres`: sub-box j's centre in noise space.
fn n_sub_centre(p: array<D, 3>, e: array<vec3<f64>, 3>, j: u32) -> vec3<f64> {
    // The sums over k of every component at once, in the same order (no loop: llvmpipe's
    // budget, docs/gpu.md).
    let s0 = select(-0.25lf, 0.25lf, (j & 1u) == 1u);
    let s1 = select(-0.25lf, 0.25lf, ((j >> 1u) & 1u) == 1u);
    let s2 = select(-0.25lf, 0.25lf, ((j >> 2u) & 1u) == 1u);
    let s = vec3<f64>(0.0lf) + s0 * e[0] + s1 * e[1] + s2 * e[2];
    return vec3<f64>(p[0].m, p[1].m, p[2].m) + s;
}

// noise.rs `face_offsets`: face j's centre in noise space, +E_j/2 then -E_(j-3)/2.
fn n_face_centre(p: array<D, 3>, e: array<vec3<f64>, 3>, j: u32) -> vec3<f64> {
    let sign = select(-0.5lf, 0.5lf, j < 3u);
    return vec3<f64>(p[0].m, p[1].m, p[2].m) + sign * e[j % 3u];
}

// lanes.rs `faces`: one octave from its values at the six face centres (w; an input without
// residual variance), unfaded; `ok` false where the edges are degenerate.
fn n_faces(s: array<vec4<f64>, 8>) -> Opt {
    var mean = 0.0lf;
    for (var j = 0u; j < 6u; j += 1u) {
        mean = mean + finite_or_zero(s[j].w);
    }
    mean = mean / 6.0lf;
    var du = vec3<f64>(0.0lf);
    for (var k = 0u; k < 3u; k += 1u) {
        du[k] = finite_or_zero(s[k].w) - finite_or_zero(s[k + 3u].w);
    }
    let slope = n_slope_with(du);
    if (slope.w == 0.0lf || !is_finite_d(mean)) {
        return Opt(dc(0.0lf), false);
    }
    var spread = 0.0lf;
    for (var j = 0u; j < 6u; j += 1u) {
        let d = finite_or_zero(s[j].w) - mean;
        spread = spread + d * d;
    }
    let v = f_residual(spread / 6.0lf, f_linvar(slope.xyz));
    return Opt(D(mean, slope.xyz, select(0.0lf, v, is_finite_d(v))), true);
}

// noise.rs `subsampled`: one octave from its eight sub-boxes' values and gradients (xyz the
// gradient, w the value); `ok` false where the edges are degenerate.
fn n_subsampled(st: St, p: array<D, 3>, e: array<vec3<f64>, 3>, s: array<vec4<f64>, 8>) -> Opt {
    let l2 = vec3<f64>(v_dot(e[0], e[0]) / 4.0lf, v_dot(e[1], e[1]) / 4.0lf, v_dot(e[2], e[2]) / 4.0lf);
    let fade = n_fade_of(st, l2, p[0].v + p[1].v + p[2].v);
    let alpha = fade.x;
    var means: array<f64, 8>;
    var mean = 0.0lf;
    // Each edge's halves summed in the same pass, all three edges at once (one loop of 8, not
    // 8 and 3 × 8: llvmpipe's budget, docs/gpu.md).
    var plus = vec3<f64>(0.0lf);
    var minus = vec3<f64>(0.0lf);
    for (var j = 0u; j < 8u; j += 1u) {
        means[j] = alpha * finite_or_zero(s[j].w) + (1.0lf - alpha) * st.mean;
        mean = mean + means[j];
        let high = vec3<bool>((j & 1u) == 1u, ((j >> 1u) & 1u) == 1u, ((j >> 2u) & 1u) == 1u);
        let quarter = means[j] / 4.0lf;
        plus = plus + select(vec3<f64>(0.0lf), vec3<f64>(quarter), high);
        minus = minus + select(vec3<f64>(quarter), vec3<f64>(0.0lf), high);
    }
    mean = mean / 8.0lf;
    let du = 2.0lf * (plus - minus);
    let slope = n_slope_with(du);
    if (slope.w == 0.0lf) {
        return Opt(dc(0.0lf), false);
    }
    let grad = slope.xyz;
    var between = 0.0lf;
    var carried = 0.0lf;
    for (var j = 0u; j < 8u; j += 1u) {
        between = between + (means[j] - mean) * (means[j] - mean);
        let g = vec3<f64>(finite_or_zero(s[j].x), finite_or_zero(s[j].y), finite_or_zero(s[j].z));
        carried = carried + (g.x * g.x * p[0].v + g.y * g.y * p[1].v + g.z * g.z * p[2].v);
    }
    between = between / 8.0lf;
    carried = carried / 8.0lf;
    let within = (1.0lf - alpha * alpha) * st.var_ + alpha * alpha * carried;
    let v = f_residual(between + within, f_linvar(grad));
    if (!is_finite_d(mean)) {
        return Opt(dc(0.0lf), false);
    }
    return Opt(D(mean, grad, select(0.0lf, v, is_finite_d(v))), true);
}

// Guarded forms (rules.rs `unary`, `binary`): a constant or NaN operand takes the point
// operation on the means.
fn ru_abs(d: D) -> D {
    if (d_is_const(d) || is_nan_d(d.m)) {
        return dc(abs(d.m));
    }
    return r_piecewise(shape_abs(), d);
}

fn rb_min(a: D, b: D) -> D {
    if ((d_is_const(a) && d_is_const(b)) || is_nan_d(a.m) || is_nan_d(b.m)) {
        return dc(d_min(a.m, b.m));
    }
    return r_min_max(a, b, false);
}

fn rb_max(a: D, b: D) -> D {
    if ((d_is_const(a) && d_is_const(b)) || is_nan_d(a.m) || is_nan_d(b.m)) {
        return dc(d_max(a.m, b.m));
    }
    return r_min_max(a, b, true);
}

fn rb_pow(a: D, b: D) -> D {
    if ((d_is_const(a) && d_is_const(b)) || is_nan_d(a.m) || is_nan_d(b.m)) {
        return dc(d_pow(a.m, b.m));
    }
    return r_pow(a, b);
}

fn rb_div(a: D, b: D) -> D {
    if ((d_is_const(a) && d_is_const(b)) || is_nan_d(a.m) || is_nan_d(b.m)) {
        return dc(d_div(a.m, b.m));
    }
    return r_div(a, b);
}

fn r_cross(a: array<D, 3>, b: array<D, 3>) -> array<D, 3> {
    return array<D, 3>(
        r_sub(r_mul(a[1], b[2]), r_mul(a[2], b[1])),
        r_sub(r_mul(a[2], b[0]), r_mul(a[0], b[2])),
        r_sub(r_mul(a[0], b[1]), r_mul(a[1], b[0])));
}

// tape.rs `Normalize`: each component over the length; where a mean is not finite (a length
// whose spread reaches 0), the direction of the mean vector.
fn r_normalize(v: array<D, 3>) -> array<D, 3> {
    let l = r_length(v);
    var n = array<D, 3>(rb_div(v[0], l), rb_div(v[1], l), rb_div(v[2], l));
    let bad = !is_finite_d(n[0].m) || !is_finite_d(n[1].m) || !is_finite_d(n[2].m);
    let fine = is_finite_d(v[0].m) && is_finite_d(v[1].m) && is_finite_d(v[2].m);
    if (bad && fine) {
        let u = v_normalize(vec3<f64>(v[0].m, v[1].m, v[2].m));
        n = array<D, 3>(dc(u.x), dc(u.y), dc(u.z));
    }
    return n;
}

// tape.rs `rotate_varying`: the rotation at the mean angle, the angle's linear part and
// residual through d(R v)/dθ = axis × (R v).
fn r_rotate_varying(axis: vec3<f64>, v: array<D, 3>, degrees: D) -> array<D, 3> {
    let cx = v_rotate(axis, degrees.m, vec3<f64>(1.0lf, 0.0lf, 0.0lf));
    let cy = v_rotate(axis, degrees.m, vec3<f64>(0.0lf, 1.0lf, 0.0lf));
    let cz = v_rotate(axis, degrees.m, vec3<f64>(0.0lf, 0.0lf, 1.0lf));
    var out = r_rotate(vec3<f64>(cx.x, cy.x, cz.x), vec3<f64>(cx.y, cy.y, cz.y), vec3<f64>(cx.z, cy.z, cz.z), v);
    let rv = vec3<f64>(out[0].m, out[1].m, out[2].m);
    let d = vec3<f64>(axis.y * rv.z - axis.z * rv.y, axis.z * rv.x - axis.x * rv.z, axis.x * rv.y - axis.y * rv.x);
    let k = 3.141592653589793lf / 180.0lf;
    for (var i = 0u; i < 3u; i += 1u) {
        out[i].g = out[i].g + d[i] * k * degrees.g;
        out[i].v = out[i].v + d[i] * d[i] * k * k * degrees.v;
    }
    return out;
}

// --- Fused pairs (fusions.rs): `|sin x|` from the sine's argument. ---

// rules.rs `abs_sin_out`: |sin X|'s (|cos X|'s) distribution from its mean, slope and
// Re φ(2) = E[cos 2X].
fn r_abs_sin_out(x: D, mean: f64, slope: f64, re2: f64, cos: bool) -> D {
    var square = 0.5lf * (1.0lf - re2);
    if (cos) {
        square = 0.5lf * (1.0lf + re2);
    }
    return f_out(x, Mo(mean, max(square - mean * mean, 0.0lf), slope));
}

// rules.rs `abs_sin_line`: X = μ + a U, by the antiderivative of |sin|.
fn r_abs_sin_line(x: D, a: f64, cos: bool) -> D {
    let pi = 3.141592653589793lf;
    let x0 = x.m + select(0.0lf, pi / 2.0lf, cos);
    let lo = x0 - a / 2.0lf;
    let hi = x0 + a / 2.0lf;
    let klo = floor(lo / pi);
    let khi = floor(hi / pi);
    let rlo = lo - klo * pi;
    let rhi = hi - khi * pi;
    let mean = (2.0lf * (khi - klo) + d_cos(rlo) - d_cos(rhi)) / a;
    let slope = (abs(d_sin(hi)) - abs(d_sin(lo))) / a;
    let re2 = d_cos(2.0lf * x.m) * sinc_d(a);
    return r_abs_sin_out(x, mean, slope, re2, cos);
}

// abs_sine.rs `abs_sin_plan`: the Fourier series of |sin| over X's characteristic function
// (the CPU's one-sided case, the same model, is not taken here);
// `ok` false where it cannot converge in 64 terms (and the spread is not one line).
fn r_abs_sin_series(x: D, cos: bool) -> Opt {
    let none = Opt(dc(0.0lf), false);
    if (d_is_const(x) || !is_finite_d(x.m)) {
        return none;
    }
    let w = f_widths(x.g);
    let last = 64.0lf;
    var bound = 1.0lf;
    for (var k = 0u; k < 3u; k += 1u) {
        let la = abs(last * w[k]);
        if (la != 0.0lf) {
            bound = bound * min(1.0lf / la, 1.0lf);
        }
    }
    bound = bound * d_exp(-2.0lf * last * last * x.v);
    if (is_nan_d(bound) || bound >= 1e-7lf) {
        var count = 0u;
        var a = 0.0lf;
        for (var k = 0u; k < 3u; k += 1u) {
            if (w[k] > 0.0lf) {
                if (count == 0u) {
                    a = w[k];
                }
                count += 1u;
            }
        }
        if (count == 1u && is_finite_d(a)) {
            return Opt(r_abs_sin_line(x, a, cos), true);
        }
        return none;
    }
    let s1 = d_sin(2.0lf * x.m);
    let c1 = d_cos(2.0lf * x.m);
    var sm = s1;
    var cm = c1;
    var steps: array<vec2<f64>, 3>;
    for (var k = 0u; k < 3u; k += 1u) {
        steps[k] = vec2<f64>(d_sin(w[k]), d_cos(w[k]));
    }
    var sines = steps;
    let q = d_exp(-2.0lf * x.v);
    var gauss = q;
    var ratio = q * q * q;
    var series = 0.0lf;
    var slope = 0.0lf;
    var converged = false;
    var first = 0.0lf;
    for (var m = 1u; m <= 64u; m += 1u) {
        let mf = f64(m);
        var d = gauss;
        for (var k = 0u; k < 3u; k += 1u) {
            let ma = mf * w[k];
            if (abs(ma) < 1e-4lf) {
                d = d * (1.0lf - ma * ma / 6.0lf);
            } else {
                d = d * (sines[k].x / ma);
            }
        }
        if (m == 1u) {
            first = d;
        }
        let sign = select(1.0lf, -1.0lf, cos && (m % 2u) == 1u);
        let wt = sign * d / (4.0lf * mf * mf - 1.0lf);
        series = series + wt * cm;
        slope = slope + wt * 2.0lf * mf * sm;
        if (abs(d) < 1e-7lf) {
            converged = true;
            break;
        }
        let sm_next = sm * c1 + cm * s1;
        cm = cm * c1 - sm * s1;
        sm = sm_next;
        for (var k = 0u; k < 3u; k += 1u) {
            let sk = sines[k];
            sines[k] = vec2<f64>(sk.x * steps[k].y + sk.y * steps[k].x, sk.y * steps[k].y - sk.x * steps[k].x);
        }
        gauss = gauss * ratio;
        ratio = ratio * q * q;
    }
    if (!converged) {
        return none;
    }
    let pi = 3.141592653589793lf;
    let mean = 2.0lf / pi - 4.0lf / pi * series;
    return Opt(r_abs_sin_out(x, mean, 4.0lf / pi * slope, c1 * first, cos), true);
}

// tape.rs `Fusion::AbsSin`: the series, or where it declines the plain rules on the argument.
fn r_abs_sin(x: D, cos: bool) -> D {
    let o = r_abs_sin_series(x, cos);
    if (o.ok) {
        return o.d;
    }
    var s: D;
    if (d_is_const(x) || is_nan_d(x.m)) {
        s = dc(select(d_sin(x.m), d_cos(x.m), cos));
    } else {
        s = r_sin_cos(x, cos);
    }
    return ru_abs(s);
}

// --- fract and its family (rules.rs `fract_floor`, `lattice_mod`): `fract` is the periodic
// rule of the sawtooth `g(u) = u` (`PC_SAW`, always written). ---

fn r_fract(d: D) -> D {
    if (d_is_const(d)) {
        return dc(d_fract(d.m));
    }
    return f_out(d, per_moments(pc_shape(PC_SAW), d.m, f_spread(d)));
}

// floor d = d - fract d, its variance by Cov(d, fract d) ≈ slope · Var d.
fn r_floor(d: D) -> D {
    if (d_is_const(d)) {
        return dc(floor(d.m));
    }
    let m = per_moments(pc_shape(PC_SAW), d.m, f_spread(d));
    let t = f_total(d);
    return f_out(d, Mo(d.m - m.mean, max(t + m.variance - 2.0lf * m.slope * t, 0.0lf), 1.0lf - m.slope));
}

fn r_round(d: D) -> D {
    return r_floor(r_add(d, dc(0.5lf)));
}

// trunc x = floor x + [x < 0] (almost everywhere).
fn r_trunc(d: D) -> D {
    return r_add(r_floor(d), r_piecewise(shape_step(), d_scale(d, -1.0lf)));
}

// rules.rs `lattice_mod`: mod(K, P) of an integer-valued K by a whole P >= 1.
fn r_lattice_mod(k: D, p: f64) -> D {
    let mu = k.m;
    let t = f_total(k);
    let n = floor(mu);
    let q = mu - n;
    if (!is_finite_d(mu)) {
        return dc(nan_d());
    }
    var mean: f64;
    var variance: f64;
    var slope: f64;
    if (t <= q * (1.0lf - q) + 1e-12lf) {
        let g0 = n - p * floor(n / p);
        let g1 = (n + 1.0lf) - p * floor((n + 1.0lf) / p);
        mean = (1.0lf - q) * g0 + q * g1;
        let square = (1.0lf - q) * g0 * g0 + q * g1 * g1;
        variance = max(square - mean * mean, 0.0lf);
        slope = g1 - g0;
    } else {
        let widths = f_widths(k.g);
        let r = max(k.v - 1.0lf / 12.0lf, 0.0lf);
        let u = sp_new(widths, r);
        let scaled = sp_new(widths / p, r / (p * p));
        let whole = per_moments(pc_shape(PC_SAW), (mu + 0.5lf) / p, scaled);
        let unit = per_moments(pc_shape(PC_SAW), mu + 0.5lf, u);
        mean = p * whole.mean - unit.mean;
        let square = (p - 1.0lf) * (2.0lf * p - 1.0lf) / 6.0lf;
        variance = max(square - mean * mean, 0.0lf);
        slope = whole.slope - unit.slope;
    }
    let g = slope * k.g;
    return D(mean, g, f_residual(variance, f_linvar(g)));
}

// tape.rs `binary` and rules.rs `Mod`: the lattice rule for an integer-valued `a` and a whole
// constant `b`, else b · fract(a / b) with b at its mean.
fn r_mod(a: D, b: D, integer: bool) -> D {
    let whole = d_is_const(b) && d_fract(b.m) == 0.0lf && b.m >= 1.0lf;
    if (integer && whole && b.m <= 1e6lf) {
        return r_lattice_mod(a, b.m);
    }
    if ((d_is_const(a) && d_is_const(b)) || is_nan_d(a.m) || is_nan_d(b.m)) {
        return dc(d_mod(a.m, b.m));
    }
    let c = b.m;
    if (c == 0.0lf || !is_finite_d(c)) {
        return dc(d_mod(a.m, c));
    }
    return d_scale(r_fract(d_scale(a, 1.0lf / c)), c);
}

// --- White noise's cells per axis (noise.rs `cells`). ---

struct Axis {
    first: f64,
    count: u32,
    // 0: one cell (a constant); 1: the lattice's two-point law (probabilities 1 - q, q);
    // 2: the spread's exact step means.
    kind: u32,
    q: f64,
    mu: f64,
    shift: f64,
    sp: Sp,
    ok: bool,
}

fn w_axis(d: D, integer: bool) -> Axis {
    let mu = d.m;
    var a = Axis(floor(mu), 1u, 0u, 0.0lf, mu, 0.0lf, Sp(vec3<f64>(0.0lf), false), true);
    if (!is_finite_d(mu)) {
        a.ok = false;
        return a;
    }
    if (d_is_const(d)) {
        return a;
    }
    let widths = f_widths(d.g);
    var residual = d.v;
    if (integer) {
        let t = f_total(d);
        let q = mu - a.first;
        if (t <= q * (1.0lf - q) + 1e-12lf) {
            a.count = 2u;
            a.kind = 1u;
            a.q = q;
            return a;
        }
        residual = max(d.v - 1.0lf / 12.0lf, 0.0lf);
        a.shift = 0.5lf;
    }
    a.sp = sp_new(widths, residual);
    let half = (widths.x + widths.y + widths.z) / 2.0lf + sqrt(6.0lf * residual);
    let first = floor(mu + a.shift - half);
    let last = floor(mu + a.shift + half);
    if (!(last - first < 64.0lf)) {
        a.ok = false;
        return a;
    }
    a.first = first;
    a.count = u32(last - first) + 1u;
    a.kind = 2u;
    return a;
}

// The axis' cell probabilities and their derivatives along its mean, cell n at `at + n` of
// `pr` (noise.rs `cells`: P(X >= n - shift) - P(X >= n + 1 - shift), each edge's step mean
// taken once).
fn w_fill(a: Axis, at: u32, pr: ptr<function, array<vec2<f64>, 66>>) {
    if (a.kind == 0u) {
        (*pr)[at] = vec2<f64>(1.0lf, 0.0lf);
        return;
    }
    if (a.kind == 1u) {
        (*pr)[at] = vec2<f64>(1.0lf - a.q, -1.0lf);
        (*pr)[at + 1u] = vec2<f64>(a.q, 1.0lf);
        return;
    }
    var below = w_at_least(a, a.first - a.shift);
    for (var n = 0u; n < a.count; n += 1u) {
        let above = w_at_least(a, a.first + f64(n) + 1.0lf - a.shift);
        (*pr)[at + n] = below - above;
        below = above;
    }
}

// P(X >= e) and its derivative along the mean, X the axis' value over the footprint.
fn w_at_least(a: Axis, e: f64) -> vec2<f64> {
    let t = a.mu - e;
    return vec2<f64>(pw_mean(shape_step(), t, a.sp), sp_density(t, a.sp));
}

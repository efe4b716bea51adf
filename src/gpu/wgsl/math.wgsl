// math.wgsl: the per-lane operations of ops.rs. Scalars are f32 (`s_` functions); vec3 values
// and promoted ("wide") scalars are f64 (`d_` functions, applied per component to a vec3).
// SPIR-V has f64 forms of the arithmetic, floor, sqrt, min/max and friends but no f64
// transcendentals, so `d_sin` and the like reduce their argument in f64 (sin, cos, tan: into
// [-pi, pi], which keeps huge arguments right) and evaluate in f32. (f64 `round` is avoided:
// lavapipe rounds its argument to f32 first.) Guards give the CPU's
// (IEEE / Rust std) answers where the GPU built-ins leave a case undefined (negative sqrt and
// log arguments, NaN in min/max, pow of negative bases, atan2 at the origin).

const TWO_PI_64: f64 = 6.283185307179586lf;
const ONE_BELOW_F32: f32 = 0.99999994;
const ONE_BELOW_F64: f64 = 0.9999999999999999lf;

// `ldexp` through one function per width, so that the shader export puts its stepwise f32 form
// in their place (`shader/narrow.rs`: the languages leave `ldexp` past f32's exponent range to
// the driver; narrowed, both are that one function).
fn s_ldexp(x: f32, e: i32) -> f32 {
    return ldexp(x, e);
}

fn d_ldexp(x: f64, e: i32) -> f64 {
    return ldexp(x, e);
}

fn is_nan_d(x: f64) -> bool {
    return !(x == x) || (x != x);
}

fn nan_d() -> f64 {
    return f64(nan_f32());
}

fn inf_f32() -> f32 {
    return bitcast<f32>(0x7f800000u);
}

fn is_inf(x: f32) -> bool {
    return (bitcast<u32>(x) & 0x7fffffffu) == 0x7f800000u;
}

// x reduced into [-pi, pi] in f64 (an infinite x gives NaN, as sin(inf) does).
fn reduce_turn(x: f64) -> f32 {
    let k = floor(x / TWO_PI_64 + 0.5lf);
    return f32(x - k * TWO_PI_64);
}

// Division with IEEE's answers at a zero divisor: ±inf by the signs (the divisor's zero sign
// included), NaN for 0/0 and NaN/0. Drivers may divide through a reciprocal refined by a Newton
// step, which turns x/0 into NaN (lavapipe does for f64).
fn s_div(a: f32, b: f32) -> f32 {
    if (b == 0.0) {
        if (is_nan(a) || a == 0.0) {
            return nan_f32();
        }
        let negative = (bitcast<u32>(a) >> 31u) != (bitcast<u32>(b) >> 31u);
        return select(inf_f32(), -inf_f32(), negative);
    }
    return a / b;
}

fn d_div(a: f64, b: f64) -> f64 {
    if (b == 0.0lf) {
        if (a != a || a == 0.0lf) {
            return nan_d();
        }
        // The signs through f32, which keeps them (zeros and infinities included).
        let negative = (bitcast<u32>(f32(a)) >> 31u) != (bitcast<u32>(f32(b)) >> 31u);
        return f64(select(inf_f32(), -inf_f32(), negative));
    }
    return a / b;
}

fn s_sin(x: f32) -> f32 {
    if (is_inf(x)) { return nan_f32(); }
    return sin(reduce_turn(f64(x)));
}
fn s_cos(x: f32) -> f32 {
    if (is_inf(x)) { return nan_f32(); }
    return cos(reduce_turn(f64(x)));
}
fn s_tan(x: f32) -> f32 {
    if (is_inf(x)) { return nan_f32(); }
    let r = reduce_turn(f64(x));
    return sin(r) / cos(r);
}
fn s_sqrt(x: f32) -> f32 {
    if (x < 0.0) { return nan_f32(); }
    return sqrt(x);
}
fn s_fract(x: f32) -> f32 {
    let r = x - floor(x);
    if (r >= 1.0) { return ONE_BELOW_F32; }
    return r;
}
fn s_log(x: f32) -> f32 {
    if (x < 0.0 || is_nan(x)) { return nan_f32(); }
    if (x == 0.0) { return -inf_f32(); }
    if (is_inf(x)) { return x; }
    return log(x);
}
fn s_log2(x: f32) -> f32 {
    if (x < 0.0 || is_nan(x)) { return nan_f32(); }
    if (x == 0.0) { return -inf_f32(); }
    if (is_inf(x)) { return x; }
    return log2(x);
}
fn s_exp(x: f32) -> f32 {
    if (is_nan(x)) { return x; }
    if (x > 88.8) { return inf_f32(); }
    if (x < -104.0) { return 0.0; }
    return exp(x);
}
fn s_asin(x: f32) -> f32 {
    if (!(abs(x) <= 1.0)) { return nan_f32(); }
    return asin(x);
}
fn s_acos(x: f32) -> f32 {
    if (!(abs(x) <= 1.0)) { return nan_f32(); }
    return acos(x);
}
fn s_sign(x: f32) -> f32 {
    if (x > 0.0) { return 1.0; }
    if (x < 0.0) { return -1.0; }
    return x;
}
// Half away from zero.
fn s_round(x: f32) -> f32 {
    let t = trunc(x);
    if (abs(x - t) >= 0.5) { return t + s_sign(x); }
    return t;
}
fn s_min(a: f32, b: f32) -> f32 {
    if (is_nan(a) || is_nan(b)) { return nan_f32(); }
    if (b < a) { return b; }
    return a;
}
fn s_max(a: f32, b: f32) -> f32 {
    if (is_nan(a) || is_nan(b)) { return nan_f32(); }
    if (b > a) { return b; }
    return a;
}
fn s_is_odd_integer(y: f32) -> bool {
    // |y| < 2^24 integers only can be odd.
    return abs(y) < 16777216.0 && trunc(y) == y && (i32(y) & 1) != 0;
}
// IEEE pow (C99 Annex F, as Rust's powf).
fn s_pow(x: f32, y: f32) -> f32 {
    if (y == 0.0 || x == 1.0) { return 1.0; }
    if (is_nan(x) || is_nan(y)) { return nan_f32(); }
    let ax = abs(x);
    if (is_inf(y)) {
        if (ax == 1.0) { return 1.0; }
        if ((ax > 1.0) == (y > 0.0)) { return inf_f32(); }
        return 0.0;
    }
    let odd = s_is_odd_integer(y);
    if (x == 0.0 || is_inf(x)) {
        // |x|^y is 0 or inf; the sign is x's for odd integer y.
        var m = 0.0;
        if ((ax == 0.0) == (y < 0.0)) { m = inf_f32(); }
        if (odd && (bitcast<u32>(x) & 0x80000000u) != 0u) { return -m; }
        return m;
    }
    if (x < 0.0 && trunc(y) != y) { return nan_f32(); }
    let l = f64(y) * f64(log2(ax));
    var m: f32;
    if (l > 128.0lf) { m = inf_f32(); } else if (l < -150.0lf) { m = 0.0; } else {
        // 2^l = 2^k 2^r with k whole: exp2 of a small r keeps its relative error small.
        let k = floor(l);
        m = s_ldexp(exp2(f32(l - k)), i32(k));
    }
    if (x < 0.0 && odd) { return -m; }
    return m;
}
fn s_atan2(y: f32, x: f32) -> f32 {
    if (is_nan(x) || is_nan(y)) { return nan_f32(); }
    let pi = 3.14159265358979;
    let ysign = select(1.0, -1.0, (bitcast<u32>(y) & 0x80000000u) != 0u);
    let xneg = (bitcast<u32>(x) & 0x80000000u) != 0u;
    if (y == 0.0) {
        if (xneg) { return ysign * pi; }
        return y;
    }
    if (is_inf(x) && is_inf(y)) {
        if (xneg) { return ysign * 0.75 * pi; }
        return ysign * 0.25 * pi;
    }
    if (x == 0.0) { return ysign * 0.5 * pi; }
    return atan2(y, x);
}
// Rust's `%` on f64 (IEEE fmod: a - b trunc(a / b), the sign of a), exactly, for finite a and
// finite nonzero b. `a - b * trunc(a / b)` is not exact once the quotient passes 2^20 or so (the
// product rounds), which a rotation by 1e17 degrees shows. Long division instead: each step
// takes a quotient q below 2^22 of the remainder by the divisor scaled by 2^j (exact), and
// forms r - d q exactly: d = dh + dl with dh of 24 significant bits (through f32; any rounding
// will do) and dl of at most 30, so dh q and dl q are exact products, r - dh q is exact by
// Sterbenz's lemma and the last subtraction's result, below d, is representable. q is taken
// from a quotient nudged up by 1e-12, so it is never one too few; one too many leaves a
// negative remainder, moved up by d (exactly). Divisors outside f32's range are brought into it
// by powers of two first. Subnormal divisors split inexactly (rare; the result stays within an
// ulp of d).
fn d_rem(a: f64, b: f64) -> f64 {
    let two100 = 1267650600228229401496703205376.0lf;
    var m = abs(b);
    var r = abs(a);
    if (r < m) { return a; }
    // m = ms 2^e with ms in f32's range.
    var ms = m;
    var e = 0;
    for (var i = 0; i < 12 && ms > 1e30lf; i = i + 1) { ms = ms / two100; e = e + 100; }
    for (var i = 0; i < 12 && ms < 1e-30lf; i = i + 1) { ms = ms * two100; e = e - 100; }
    let msh = f64(f32(ms));
    let msl = ms - msh;
    for (var i = 0; i < 160; i = i + 1) {
        if (r < m) { break; }
        // j: the divisor m 2^j leaves a quotient in [2^20, 2^21) (or m itself below 2^20).
        var ratio = r / m;
        var j = 0;
        for (var k = 0; k < 24 && ratio > 1e30lf; k = k + 1) { ratio = ratio / two100; j = j + 100; }
        if (ratio >= 1048576.0lf) {
            let bits = bitcast<u32>(f32(ratio));
            j = j + i32((bits >> 23u) & 255u) - 127 - 20;
        }
        let d = d_ldexp(ms, e + j);
        let dh = d_ldexp(msh, e + j);
        let dl = d_ldexp(msl, e + j);
        let q = d_trunc((r / d) * (1.0lf + 1e-12lf));
        let t = r - dh * q;
        var rr = t - dl * q;
        if (rr < 0.0lf) { rr = rr + d; }
        r = rr;
    }
    if (a < 0.0lf) { return -r; }
    return r;
}

// Floored modulo (ops::floored_mod): fmod in f64 (`d_rem`, exact; an f32 operands' remainder
// is an f32), moved into b's half-line.
fn s_mod(a: f32, b: f32) -> f32 {
    if (b == 0.0 || is_inf(a) || is_nan(a) || is_nan(b)) { return nan_f32(); }
    if (is_inf(b)) {
        if (a == 0.0 || (a < 0.0) == (b < 0.0)) { return a; }
        return b;
    }
    let ad = f64(a);
    let bd = f64(b);
    let r = f32(d_rem(ad, bd));
    if (r != 0.0 && ((r < 0.0) != (b < 0.0))) {
        let moved = r + b;
        if (moved == b) { return b * ONE_BELOW_F32; }
        return moved;
    }
    return r;
}
fn s_step(edge: f32, x: f32) -> f32 {
    if (is_nan(edge) || is_nan(x)) { return nan_f32(); }
    if (x < edge) { return 0.0; }
    return 1.0;
}
fn s_clamp(x: f32, lo: f32, hi: f32) -> f32 {
    return s_min(s_max(x, lo), hi);
}
fn s_mix(a: f32, b: f32, c: f32) -> f32 {
    return a + c * (b - a);
}
fn s_smoothstep(e0: f32, e1: f32, x: f32) -> f32 {
    if (e0 == e1) { return s_step(e0, x); }
    let t = s_clamp((x - e0) / (e1 - e0), 0.0, 1.0);
    return t * t * (3.0 - 2.0 * t);
}
fn s_select(c: f32, a: f32, b: f32) -> f32 {
    if (c > 0.0) { return a; }
    return b;
}

// ---- f64 (vec3 components and promoted scalars) ----
// trunc through floor (lavapipe's f64 round and trunc go through f32).
fn d_trunc(x: f64) -> f64 {
    if (x < 0.0lf) { return -floor(-x); }
    return floor(x);
}
fn d_is_inf(x: f64) -> bool {
    return abs(x) > 1.7976931348623157e308lf;
}
// sin and cos in f64 (SPIR-V has no f64 transcendentals): x = k pi/2 + r (Cody-Waite with
// pi/2 in six parts; exact for |x| < 5e10, beyond which the reduction loses bits),
// then Taylor polynomials on |r| <= pi/4 (terms to r^17 / r^16: error below 1e-17), the
// quadrant picking sin or cos and the sign. Rotations by varying angles use these, since
// a rotated coordinate of 3e4 needs the angle's sine to 1e-12 to stay within 1e-7.
fn d_sin_cos_reduced(x: f64) -> vec3<f64> {
    // (sin r, cos r, quadrant k mod 4)
    let k = floor(x * 0.6366197723675814lf + 0.5lf);
    // pi/2 as six parts of 18 significant bits each (108 bits): every product k * part is
    // exact for |k| < 2^35 (|x| < 5e10), so the reduction is exact to about 2^-53 |r| there.
    let r = (((((x - k * 1.5707931518554688lf) - k * 3.1749368645250797e-06lf)
        - k * 2.5633384304057927e-12lf) - k * 5.721178163110765e-18lf)
        - k * 1.05629611168797e-23lf) - k * 3.7950064368161605e-29lf;
    let r2 = r * r;
    // sin r = r + r r2 P(r2), P's coefficients (-1)^(j+1) / (2j + 3)!.
    var sp = 1.0lf / 355687428096000.0lf;         // 1/17!
    sp = -1.0lf / 1307674368000.0lf + r2 * sp;    // 1/15!
    sp = 1.0lf / 6227020800.0lf + r2 * sp;        // 1/13!
    sp = -1.0lf / 39916800.0lf + r2 * sp;         // 1/11!
    sp = 1.0lf / 362880.0lf + r2 * sp;            // 1/9!
    sp = -1.0lf / 5040.0lf + r2 * sp;             // 1/7!
    sp = 1.0lf / 120.0lf + r2 * sp;               // 1/5!
    sp = -1.0lf / 6.0lf + r2 * sp;                // 1/3!
    let sine = r + r * r2 * sp;
    // cos r = 1 - r2 C(r2), C's coefficients (-1)^j / (2j + 2)!.
    var cp = -1.0lf / 20922789888000.0lf;         // 1/16!
    cp = 1.0lf / 87178291200.0lf + r2 * cp;       // 1/14!
    cp = -1.0lf / 479001600.0lf + r2 * cp;        // 1/12!
    cp = 1.0lf / 3628800.0lf + r2 * cp;           // 1/10!
    cp = -1.0lf / 40320.0lf + r2 * cp;            // 1/8!
    cp = 1.0lf / 720.0lf + r2 * cp;               // 1/6!
    cp = -1.0lf / 24.0lf + r2 * cp;               // 1/4!
    cp = 0.5lf + r2 * cp;
    let cosine = 1.0lf - r2 * cp;
    let q = k - 4.0lf * floor(k * 0.25lf);
    return vec3<f64>(sine, cosine, q);
}
fn d_sin(x: f64) -> f64 {
    if (d_is_inf(x) || is_nan_d(x)) { return nan_d(); }
    let v = d_sin_cos_reduced(x);
    if (v.z == 0.0lf) { return v.x; }
    if (v.z == 1.0lf) { return v.y; }
    if (v.z == 2.0lf) { return -v.x; }
    return -v.y;
}
fn d_cos(x: f64) -> f64 {
    if (d_is_inf(x) || is_nan_d(x)) { return nan_d(); }
    let v = d_sin_cos_reduced(x);
    if (v.z == 0.0lf) { return v.y; }
    if (v.z == 1.0lf) { return -v.x; }
    if (v.z == 2.0lf) { return -v.y; }
    return v.x;
}
fn d_tan(x: f64) -> f64 {
    return d_sin(x) / d_cos(x);
}
fn d_sqrt(x: f64) -> f64 {
    if (x < 0.0lf) { return nan_d(); }
    return sqrt(x);
}
fn d_fract(x: f64) -> f64 {
    let r = x - floor(x);
    if (r >= 1.0lf) { return ONE_BELOW_F64; }
    return r;
}
fn d_exp(x: f64) -> f64 {
    if (is_nan_d(x)) { return x; }
    if (x > 709.8lf) { return f64(inf_f32()); }
    if (x < -745.2lf) { return 0.0lf; }
    // e^x = 2^k e^r, r = x - k ln2 (ln2 in two parts, the first with 32 bits: k ln2_hi exact),
    // |r| <= ln2/2, Taylor to r^14 (error below 1e-17).
    let k = floor(x * 1.4426950408889634lf + 0.5lf);
    let r = (x - k * 0.6931471803691238lf) - k * 1.9082149292705877e-10lf;
    var t = 1.0lf / 87178291200.0lf;
    t = 1.0lf / 6227020800.0lf + r * t;
    t = 1.0lf / 479001600.0lf + r * t;
    t = 1.0lf / 39916800.0lf + r * t;
    t = 1.0lf / 3628800.0lf + r * t;
    t = 1.0lf / 362880.0lf + r * t;
    t = 1.0lf / 40320.0lf + r * t;
    t = 1.0lf / 5040.0lf + r * t;
    t = 1.0lf / 720.0lf + r * t;
    t = 1.0lf / 120.0lf + r * t;
    t = 1.0lf / 24.0lf + r * t;
    t = 1.0lf / 6.0lf + r * t;
    t = 0.5lf + r * t;
    t = 1.0lf + r * t;
    t = 1.0lf + r * t;
    // 2^k in two steps (k may be beyond the normal exponent range for subnormal results).
    let k1 = i32(floor(k * 0.5lf));
    return d_ldexp(d_ldexp(t, k1), i32(k) - k1);
}
fn d_log2_parts(x: f64) -> vec2<f64> {
    var m = x;
    var e = 0.0lf;
    let big = 1.2676506002282294e30lf;   // 2^100
    let small = 7.888609052210118e-31lf; // 2^-100
    for (var i = 0; i < 11 && m > 1e30lf; i = i + 1) {
        m = m * small;
        e = e + 100.0lf;
    }
    for (var i = 0; i < 11 && m < 1e-30lf; i = i + 1) {
        m = m * big;
        e = e - 100.0lf;
    }
    return vec2<f64>(m, e);
}
// ln x in f64: x = m 2^e with m in [sqrt(1/2), sqrt(2)), ln m = 2 atanh(s), s = (m-1)/(m+1)
// (|s| <= 0.172; terms to s^23: error below 1e-17).
fn d_ln_finite(x: f64) -> f64 {
    let me = d_log2_parts(x);
    let e1 = f64(floor(log2(f32(me.x))));
    var m = d_ldexp(me.x, -i32(e1));
    var e = me.y + e1;
    if (m > 1.4142135623730951lf) { m = m * 0.5lf; e = e + 1.0lf; }
    if (m < 0.7071067811865476lf) { m = m * 2.0lf; e = e - 1.0lf; }
    let s = (m - 1.0lf) / (m + 1.0lf);
    let s2 = s * s;
    var t = 1.0lf / 23.0lf;
    t = 1.0lf / 21.0lf + s2 * t;
    t = 1.0lf / 19.0lf + s2 * t;
    t = 1.0lf / 17.0lf + s2 * t;
    t = 1.0lf / 15.0lf + s2 * t;
    t = 1.0lf / 13.0lf + s2 * t;
    t = 1.0lf / 11.0lf + s2 * t;
    t = 1.0lf / 9.0lf + s2 * t;
    t = 1.0lf / 7.0lf + s2 * t;
    t = 1.0lf / 5.0lf + s2 * t;
    t = 1.0lf / 3.0lf + s2 * t;
    t = 1.0lf + s2 * t;
    return 2.0lf * s * t + e * 0.6931471805599453lf;
}
fn d_log(x: f64) -> f64 {
    if (x < 0.0lf || is_nan_d(x)) { return nan_d(); }
    if (x == 0.0lf) { return -f64(inf_f32()); }
    if (d_is_inf(x)) { return x; }
    return d_ln_finite(x);
}
fn d_log2(x: f64) -> f64 {
    if (x < 0.0lf || is_nan_d(x)) { return nan_d(); }
    if (x == 0.0lf) { return -f64(inf_f32()); }
    if (d_is_inf(x)) { return x; }
    return d_ln_finite(x) * 1.4426950408889634lf;
}
// atan in f64 for finite x: |x| > 1 by pi/2 - atan(1/x), then two argument halvings
// atan t = 2 atan(t / (1 + sqrt(1 + t^2))) to |t| <= 0.1, then Taylor to t^21.
fn d_atan(x: f64) -> f64 {
    var t = abs(x);
    var flip = false;
    if (t > 1.0lf) { t = 1.0lf / t; flip = true; }
    t = t / (1.0lf + sqrt(1.0lf + t * t));
    t = t / (1.0lf + sqrt(1.0lf + t * t));
    let t2 = t * t;
    var p = 1.0lf / 21.0lf;
    p = -1.0lf / 19.0lf + t2 * p;
    p = 1.0lf / 17.0lf + t2 * p;
    p = -1.0lf / 15.0lf + t2 * p;
    p = 1.0lf / 13.0lf + t2 * p;
    p = -1.0lf / 11.0lf + t2 * p;
    p = 1.0lf / 9.0lf + t2 * p;
    p = -1.0lf / 7.0lf + t2 * p;
    p = 1.0lf / 5.0lf + t2 * p;
    p = -1.0lf / 3.0lf + t2 * p;
    var a = 4.0lf * (t + t * t2 * p);
    if (flip) { a = 1.5707963267948966lf - a; }
    if (x < 0.0lf) { return -a; }
    return a;
}
fn d_asin(x: f64) -> f64 {
    if (!(abs(x) <= 1.0lf)) { return nan_d(); }
    return d_atan2(x, sqrt((1.0lf - x) * (1.0lf + x)));
}
fn d_acos(x: f64) -> f64 {
    if (!(abs(x) <= 1.0lf)) { return nan_d(); }
    return d_atan2(sqrt((1.0lf - x) * (1.0lf + x)), x);
}
fn d_sign(x: f64) -> f64 {
    if (x > 0.0lf) { return 1.0lf; }
    if (x < 0.0lf) { return -1.0lf; }
    return x;
}
fn d_round(x: f64) -> f64 {
    let t = d_trunc(x);
    if (abs(x - t) >= 0.5lf) { return t + d_sign(x); }
    return t;
}
fn d_min(a: f64, b: f64) -> f64 {
    if (is_nan_d(a) || is_nan_d(b)) { return nan_d(); }
    if (b < a) { return b; }
    return a;
}
fn d_max(a: f64, b: f64) -> f64 {
    if (is_nan_d(a) || is_nan_d(b)) { return nan_d(); }
    if (b > a) { return b; }
    return a;
}
fn d_pow(x: f64, y: f64) -> f64 {
    if (y == 0.0lf || x == 1.0lf) { return 1.0lf; }
    if (is_nan_d(x) || is_nan_d(y)) { return nan_d(); }
    let ax = abs(x);
    let whole = d_trunc(y) == y;
    let odd = whole && abs(y) < 9007199254740992.0lf && d_mod(y, 2.0lf) == 1.0lf;
    if (d_is_inf(y)) {
        if (ax == 1.0lf) { return 1.0lf; }
        if ((ax > 1.0lf) == (y > 0.0lf)) { return f64(inf_f32()); }
        return 0.0lf;
    }
    if (x == 0.0lf || d_is_inf(x)) {
        var m = 0.0lf;
        if ((ax == 0.0lf) == (y < 0.0lf)) { m = f64(inf_f32()); }
        if (odd && x < 0.0lf) { return -m; }
        return m;
    }
    if (x < 0.0lf && !whole) { return nan_d(); }
    let m = d_exp(y * d_ln_finite(ax));
    if (x < 0.0lf && odd) { return -m; }
    return m;
}
fn d_atan2(y: f64, x: f64) -> f64 {
    if (is_nan_d(x) || is_nan_d(y)) { return nan_d(); }
    let pi = 3.141592653589793lf;
    let yneg = y < 0.0lf || (y == 0.0lf && 1.0lf / y < 0.0lf);
    let xneg = x < 0.0lf || (x == 0.0lf && 1.0lf / x < 0.0lf);
    var a: f64;
    if (d_is_inf(x) || d_is_inf(y)) {
        // Either infinite: the f32 rules (exact multiples of pi/4).
        return f64(s_atan2(f32(y), f32(x)));
    } else if (y == 0.0lf) {
        a = select(0.0lf, pi, xneg);
    } else if (x == 0.0lf) {
        a = pi * 0.5lf;
    } else {
        a = d_atan(abs(y / x));
        if (abs(y / x) > 1e300lf || abs(y / x) < 1e-300lf) {
            // Quotients out of range: the ratio's size decides.
            a = select(0.0lf, pi * 0.5lf, abs(y) > abs(x));
        }
        if (xneg) { a = pi - a; }
    }
    if (yneg) { return -a; }
    return a;
}
fn d_mod(a: f64, b: f64) -> f64 {
    if (b == 0.0lf || d_is_inf(a) || is_nan_d(a) || is_nan_d(b)) { return nan_d(); }
    if (d_is_inf(b)) {
        if (a == 0.0lf || (a < 0.0lf) == (b < 0.0lf)) { return a; }
        return b;
    }
    let r = d_rem(a, b);
    if (r != 0.0lf && ((r < 0.0lf) != (b < 0.0lf))) {
        let moved = r + b;
        if (moved == b) { return b * ONE_BELOW_F64; }
        return moved;
    }
    return r;
}
fn d_step(edge: f64, x: f64) -> f64 {
    if (is_nan_d(edge) || is_nan_d(x)) { return nan_d(); }
    if (x < edge) { return 0.0lf; }
    return 1.0lf;
}
fn d_clamp(x: f64, lo: f64, hi: f64) -> f64 {
    return d_min(d_max(x, lo), hi);
}
fn d_mix(a: f64, b: f64, c: f64) -> f64 {
    return a + c * (b - a);
}
fn d_smoothstep(e0: f64, e1: f64, x: f64) -> f64 {
    if (e0 == e1) { return d_step(e0, x); }
    let t = d_clamp((x - e0) / (e1 - e0), 0.0lf, 1.0lf);
    return t * t * (3.0lf - 2.0lf * t);
}
fn d_select(c: f64, a: f64, b: f64) -> f64 {
    if (c > 0.0lf) { return a; }
    return b;
}

// ---- Geometry (ops.rs dot, length, normalize; vec3 values in f64) ----
fn v_dot(a: vec3<f64>, b: vec3<f64>) -> f64 {
    return a.x * b.x + a.y * b.y + a.z * b.z;
}
fn v_length(a: vec3<f64>) -> f64 {
    return sqrt(v_dot(a, a));
}
fn v_cross(a: vec3<f64>, b: vec3<f64>) -> vec3<f64> {
    return vec3<f64>(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}
fn v_normalize(v: vec3<f64>) -> vec3<f64> {
    // NaN first, as ops::normalize (WGSL's max need not skip a NaN, Rust's does).
    if (is_nan_d(v.x) || is_nan_d(v.y) || is_nan_d(v.z)) { return vec3<f64>(nan_d()); }
    let largest = max(max(abs(v.x), abs(v.y)), abs(v.z));
    if (largest == 0.0lf) { return vec3<f64>(0.0lf); }
    if (d_is_inf(largest)) { return vec3<f64>(nan_d()); }
    let s = v / largest;
    return s / v_length(s);
}
// Rows of a matrix times v, as ops::apply_matrix.
fn v_matrix(r0: vec3<f64>, r1: vec3<f64>, r2: vec3<f64>, p: vec3<f64>) -> vec3<f64> {
    return vec3<f64>(v_dot(r0, p), v_dot(r1, p), v_dot(r2, p));
}

// sin and cos of an angle in degrees, exact at quarter turns (ops::sin_cos_degrees), and the
// rotation of p about a unit axis by it (ops::rotation_matrix, Rodrigues' formula, rows).
fn v_rotate(axis: vec3<f64>, degrees: f64, p: vec3<f64>) -> vec3<f64> {
    let r = d_mod(degrees, 360.0lf);
    var s = 0.0lf;
    var c = 1.0lf;
    if (is_nan_d(r)) {
        s = nan_d();
        c = nan_d();
    } else if (r == 90.0lf) {
        s = 1.0lf;
        c = 0.0lf;
    } else if (r == 180.0lf) {
        s = 0.0lf;
        c = -1.0lf;
    } else if (r == 270.0lf) {
        s = -1.0lf;
        c = 0.0lf;
    } else if (r != 0.0lf) {
        let rad = r * 0.017453292519943295lf;
        s = d_sin(rad);
        c = d_cos(rad);
    }
    let x = axis.x;
    let y = axis.y;
    let z = axis.z;
    let t = 1.0lf - c;
    return v_matrix(
        vec3<f64>(t * x * x + c, t * x * y - s * z, t * x * z + s * y),
        vec3<f64>(t * x * y + s * z, t * y * y + c, t * y * z - s * x),
        vec3<f64>(t * x * z - s * y, t * y * z + s * x, t * z * z + c),
        p);
}

// The cubic Hermite spline of seed 000 (ops::Hermite::apply), in f32.
fn s_hermite(x: f32, p0: f32, p1: f32, m0: f32, m1: f32) -> f32 {
    let t = s_clamp(x, 0.0, 1.0);
    let t2 = t * t;
    let t3 = t2 * t;
    let h00 = 2.0 * t3 - 3.0 * t2 + 1.0;
    let h10 = t3 - 2.0 * t2 + t;
    let h01 = 3.0 * t2 - 2.0 * t3;
    let h11 = t3 - t2;
    return h00 * p0 + h10 * m0 + h01 * p1 + h11 * m1;
}

// ---- Level of detail per point (lod.rs `LaneLod`) ----
// The octaves a point at sample spacing h keeps (continuous), never more than the schedule's
// `kept`: all of them for h <= 0 (no footprint: a bake, whose tape is already compiled for
// its spacing) or below `fine`; else the octaves whose frequency stays at or below Nyquist.
fn lod_kept(h: f64, fine: f64, kept: f64, octaves: f64, first: f64, stretch: f64, ln_lacunarity: f64) -> f64 {
    if (!(h > 0.0lf) || d_is_inf(h) || h < fine) {
        return kept;
    }
    let highest = d_ln_finite((0.5lf / h) / stretch) / ln_lacunarity;
    return min(d_clamp(highest - first + 1.0lf, 0.0lf, octaves), kept);
}

// Octave k's amplitude at `kept` octaves (`LaneOctaves::lane`): its full power below the whole
// octaves, the faded share for the partial one (callers skip k >= kept).
fn lod_amplitude(kept: f64, power: f64, k: f64) -> f64 {
    let whole = floor(kept);
    if (k < whole) {
        return power;
    }
    return power * (kept - whole);
}

// Octave n's share of the dropped octaves' mean (lod.rs `dropped_share`).
fn lod_share(octaves: f64, n: f64, kept: f64, gain: f64, expected: f64) -> f64 {
    let written = d_clamp(octaves - n, 0.0lf, 1.0lf);
    let held = d_clamp(kept - n, 0.0lf, 1.0lf);
    return (written - held) * gain * expected;
}

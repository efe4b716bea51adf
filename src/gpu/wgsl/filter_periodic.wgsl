// filter_periodic.wgsl: the template of a periodic chain's rule (`filtered_periodic.rs` makes
// one copy per chain shape, `PC` replaced by its functions' name): E[g(fract X)], E[g(fract X)²]
// and the slope for X = t + S, exactly (the module docs of filtered_periodic.rs).

// F_L, G_L and the slope level at u: one loop over the three (one call site of `PC`).
fn PC_three(level: u32, slope_level: u32, u: f64) -> vec3<f64> {
    var out = vec3<f64>(0.0lf);
    var levels = vec3<u32>(level, level + 4u, slope_level);
    for (var i = 0u; i < 3u * u32(dispatch.one); i += 1u) {
        out[i] = PC(levels[i], u);
    }
    return out;
}

// Over the rest's spread (at most two periods wide): (E[F_L], E[G_L], slope part), F_L and
// G_L the level-L functions of g and g²; the slope part E[F_{L-1}] for L >= 1, else E[g'] plus
// each jump times the density at it.
fn per_local_PC(y: f64, sp: Sp, level: u32) -> vec3<f64> {
    let w = sp.w;
    let h = (w.x + w.y + w.z) / 2.0lf;
    var slope_level = 8u;
    if (level > 0u) {
        slope_level = level - 1u;
    }
    if (h == 0.0lf) {
        return PC_three(level, slope_level, y - floor(y));
    }
    var c: array<f64, 8>;
    for (var i = 0u; i < 8u; i += 1u) {
        let s0 = select(-w.x, w.x, (i & 1u) != 0u);
        let s1 = select(-w.y, w.y, (i & 2u) != 0u);
        let s2 = select(-w.z, w.z, (i & 4u) != 0u);
        c[i] = (s0 + s1 + s2) / 2.0lf;
    }
    for (var i = 1u; i < 8u; i += 1u) {
        let x = c[i];
        var j = i;
        while (j > 0u && c[j - 1u] > x) {
            c[j] = c[j - 1u];
            j -= 1u;
        }
        c[j] = x;
    }
    var acc = vec3<f64>(0.0lf);
    let lo = y - h;
    let hi = y + h;
    let count = PC_count();
    for (var k = floor(lo); k <= floor(hi); k += 1.0lf) {
        let yk = y - k;
        for (var j = 0u; j < count; j += 1u) {
            // This piece's part of the support, in s = x - y.
            let a = max(PC_start(j) - yk, -h);
            let b = min(PC_end(j) - yk, h);
            if (!(b > a)) {
                continue;
            }
            var prev = a;
            for (var i = 0u; i <= 8u; i += 1u) {
                var end = b;
                if (i < 8u) {
                    end = min(c[i], b);
                }
                if (end > prev) {
                    let mid = (prev + end) / 2.0lf;
                    let half = (end - prev) / 2.0lf;
                    for (var g = 0u; g < gl_nodes(); g += 1u) {
                        let s = mid + half * GL_X[g];
                        let weight = GL_W[g] * half * sp_density(s, sp);
                        let u = yk + s;
                        acc = acc + weight * PC_three(level, slope_level, u);
                    }
                    prev = end;
                }
            }
        }
        if (level == 0u) {
            for (var j = 0u; j < count; j += 1u) {
                let s = PC_start(j) - yk;
                if (s > -h && s < h) {
                    acc.z = acc.z + PC_jump(j) * sp_density(s, sp);
                }
            }
        }
    }
    return acc;
}

// Mean, variance and slope of g(fract X), X = t + S (periodic.rs `Periodic::moments`).
fn per_moments_PC(t: f64, sp: Sp) -> Mo {
    if (!is_finite_d(t)) {
        return Mo(nan_d(), nan_d(), nan_d());
    }
    let means = PC_mean();
    if (sp.unbounded) {
        return Mo(means.x, max(means.y - means.x * means.x, 0.0lf), 0.0lf);
    }
    let x = t - floor(t);
    let w = sp.w;
    // A support inside one line piece of one period: the line's exact moments.
    let h = (w.x + w.y + w.z) / 2.0lf;
    let k0 = floor(x - h);
    if (floor(x + h) == k0) {
        for (var j = 0u; j < PC_count(); j += 1u) {
            let b = PC_line(j);
            if (PC_start(j) <= x - h - k0 && x + h - k0 < PC_end(j) && !is_nan_d(b)) {
                let s2 = (w.x * w.x + w.y * w.y + w.z * w.z) / 12.0lf;
                return Mo(PC(0u, x - k0), b * b * s2, b);
            }
        }
    }
    var levels = 0u;
    var rest = w.x + w.y + w.z;
    while (levels < 3u && rest > 2.0lf) {
        rest -= w[levels];
        levels += 1u;
    }
    // Level 0: the whole spread integrated at x (one corner, no division); else the signed
    // sum over the corners of the widths taken off. One call site of `per_local`.
    var rw = vec3<f64>(0.0lf);
    var inv = 1.0lf;
    for (var i = 0u; i < 3u; i += 1u) {
        if (i < levels) {
            inv = inv / w[i];
        } else {
            rw[i - levels] = w[i];
        }
    }
    let rs = Sp(rw, false);
    var acc = vec3<f64>(0.0lf);
    for (var corner = 0u; corner < (1u << levels); corner += 1u) {
        var y = x;
        var sign = 1.0lf;
        for (var i = 0u; i < levels; i += 1u) {
            if (((corner >> i) & 1u) == 1u) {
                y = y + w[i] / 2.0lf;
            } else {
                y = y - w[i] / 2.0lf;
                sign = -sign;
            }
        }
        acc = acc + sign * per_local_PC(y, rs, levels);
    }
    if (levels == 0u) {
        return Mo(acc.x, max(acc.y - acc.x * acc.x, 0.0lf), acc.z);
    }
    let mean = means.x + inv * acc.x;
    let second = means.y + inv * acc.y;
    return Mo(mean, max(second - mean * mean, 0.0lf), inv * acc.z);
}

// rules.rs `Rules::periodic`.
fn r_periodic_PC(d: D) -> D {
    if (d_is_const(d)) {
        return dc(PC(0u, d.m - floor(d.m)));
    }
    return f_out(d, per_moments_PC(d.m, f_spread(d)));
}

// filter_periodic.wgsl: a periodic chain's rule (`filtered_periodic.rs`): E[g(fract X)],
// E[g(fract X)²] and the slope for X = t + S, exactly (the module docs of filtered_periodic.rs).
// One copy for every chain shape: a shape is a block of the filtered form's data `fdata` (a
// storage buffer on the GPU path, a module-scope array in the shader export) named by its
// offset (`Pc`: the offset and the piece count m):
//
//   pc + 0                     m, the piece count
//   pc + 1, pc + 2             ∫₀¹ g and ∫₀¹ g²
//   pc + 3 + j                 piece j's start (j < m), then its end (+ m), the jump of g at
//                              its start (+ 2m), its slope where it is a line (+ 3m) and 1 there,
//                              else 0 (+ 4m)
//   pc + 3 + 5m + pc_pre(L) m + j pc_len(L)
//                              piece j's polynomial of level L, its pc_len(L) ascending
//                              coefficients in u - start (in u a steep piece near 1 cancels
//                              terms of 1e7, which the export's f32 loses): levels 0-3 g and
//                              its antiderivatives H (4 to 7 coefficients), 4-7 the same for
//                              g² (7 to 10), 8 g' (3)
//
// The sawtooth g(u) = u (`fract`, `floor`, the lattice `mod`) is the block at PC_SAW.

const PC_SAW: u32 = 0u;

// The coefficients of a level-`level` polynomial (`filtered_periodic.rs` `LEVEL_COEFFS`).
fn pc_len(level: u32) -> u32 {
    if (level < 4u) {
        return 4u + level;
    }
    if (level < 8u) {
        return 3u + level;
    }
    return 3u;
}

// The coefficients of the levels before `level`, per piece.
fn pc_pre(level: u32) -> u32 {
    if (level <= 4u) {
        return 4u * level + level * (level - min(level, 1u)) / 2u;
    }
    let l = level - 4u;
    return 22u + 3u * l + l * (level + 3u) / 2u;
}

// A shape: its block's offset and its piece count (read once per rule).
struct Pc {
    at: u32,
    m: u32,
}

fn pc_shape(at: u32) -> Pc {
    return Pc(at, u32(fdata[at]));
}

// Field `field` (0 start, 1 end, 2 jump, 3 line slope, 4 is a line) of piece j.
fn pc_piece(pc: Pc, field: u32, j: u32) -> f64 {
    return fdata[pc.at + 3u + field * pc.m + j];
}

// Piece j's level-`level` polynomial at u, by Horner. (llvmpipe ends every loop of a shader
// once its SIMD group has run 65 535 loop iterations in all, docs/gpu.md: the piece comes from
// the integration's own loop, not from a search per node. Written out instead of this loop the
// polynomial took a third more time to compile on lavapipe.)
fn pc_poly(pc: Pc, level: u32, j: u32, u: f64) -> f64 {
    let len = pc_len(level);
    let base = pc.at + 3u + 5u * pc.m + pc_pre(level) * pc.m + j * len;
    let v = u - pc_piece(pc, 0u, j);
    var acc = fdata[base + len - 1u];
    for (var i = len - 1u; i > 0u; i -= 1u) {
        acc = acc * v + fdata[base + i - 1u];
    }
    return acc;
}

// The piece of u in [0, 1] by the starts.
fn pc_find(pc: Pc, u: f64) -> u32 {
    var j = 0u;
    for (var i = 1u; i < pc.m; i += 1u) {
        if (u >= fdata[pc.at + 3u + i]) {
            j = i;
        }
    }
    return j;
}

// The level-`level` function at u in [0, 1].
fn pc_eval(pc: Pc, level: u32, u: f64) -> f64 {
    return pc_poly(pc, level, pc_find(pc, u), u);
}

// F_L, G_L and the slope level at u in piece j.
fn pc_three(pc: Pc, level: u32, slope_level: u32, j: u32, u: f64) -> vec3<f64> {
    return vec3<f64>(pc_poly(pc, level, j, u), pc_poly(pc, level + 4u, j, u), pc_poly(pc, slope_level, j, u));
}

// Over the rest's spread (at most two periods wide): (E[F_L], E[G_L], slope part), F_L and
// G_L the level-L functions of g and g²; the slope part E[F_{L-1}] for L >= 1, else E[g'] plus
// each jump times the density at it.
fn per_local(pc: Pc, y: f64, sp: Sp, level: u32) -> vec3<f64> {
    let w = sp.w;
    let h = (w.x + w.y + w.z) / 2.0lf;
    var slope_level = 8u;
    if (level > 0u) {
        slope_level = level - 1u;
    }
    if (h == 0.0lf) {
        let u = y - floor(y);
        return pc_three(pc, level, slope_level, pc_find(pc, u), u);
    }
    // The density's breakpoints in ascending order, written out, not sorted by loops: every
    // loop iteration counts against llvmpipe's budget (docs/gpu.md).
    var c = corners_sorted(w);
    var acc = vec3<f64>(0.0lf);
    let lo = y - h;
    let hi = y + h;
    let count = pc.m;
    for (var k = floor(lo); k <= floor(hi); k += 1.0lf) {
        let yk = y - k;
        for (var j = 0u; j < count; j += 1u) {
            // This piece's part of the support, in s = x - y.
            let a = max(pc_piece(pc, 0u, j) - yk, -h);
            let b = min(pc_piece(pc, 1u, j) - yk, h);
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
                        acc = acc + weight * pc_three(pc, level, slope_level, j, u);
                    }
                    prev = end;
                }
            }
        }
        if (level == 0u) {
            for (var j = 0u; j < count; j += 1u) {
                let s = pc_piece(pc, 0u, j) - yk;
                if (s > -h && s < h) {
                    acc.z = acc.z + pc_piece(pc, 2u, j) * sp_density(s, sp);
                }
            }
        }
    }
    return acc;
}

// Mean, variance and slope of g(fract X), X = t + S (periodic.rs `Periodic::moments`).
fn per_moments(pc: Pc, t: f64, sp: Sp) -> Mo {
    if (!is_finite_d(t)) {
        return Mo(nan_d(), nan_d(), nan_d());
    }
    let means = vec2<f64>(fdata[pc.at + 1u], fdata[pc.at + 2u]);
    if (sp.unbounded) {
        return Mo(means.x, max(means.y - means.x * means.x, 0.0lf), 0.0lf);
    }
    let x = t - floor(t);
    let w = sp.w;
    // A support inside one line piece of one period, its ends allowed on the piece's (a jump
    // on the support's end, or within 1e-12 of its half-width, has no density: moments.rs
    // `EDGE`, as on the CPU): the line's exact moments. (A floor over a voxel whose edges lie
    // on its integers is then its integer exactly, not 1e-16 below it.)
    let h = (w.x + w.y + w.z) / 2.0lf;
    let k0 = floor(x - h);
    let lo = x - h - k0;
    let hi = x + h - k0;
    let edge = 1e-12lf * h;
    if (hi <= 1.0lf + edge) {
        for (var j = 0u; j < pc.m; j += 1u) {
            let b = pc_piece(pc, 3u, j);
            let line = pc_piece(pc, 4u, j) != 0.0lf;
            if (pc_piece(pc, 0u, j) - edge <= lo && hi <= pc_piece(pc, 1u, j) + edge && line) {
                let s2 = (w.x * w.x + w.y * w.y + w.z * w.z) / 12.0lf;
                return Mo(pc_eval(pc, 0u, x - k0), b * b * s2, b);
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
        acc = acc + sign * per_local(pc, y, rs, levels);
    }
    if (levels == 0u) {
        return Mo(acc.x, max(acc.y - acc.x * acc.x, 0.0lf), acc.z);
    }
    let mean = means.x + inv * acc.x;
    let second = means.y + inv * acc.y;
    return Mo(mean, max(second - mean * mean, 0.0lf), inv * acc.z);
}

// rules.rs `Rules::periodic`.
fn r_periodic(at: u32, d: D) -> D {
    let pc = pc_shape(at);
    if (d_is_const(d)) {
        return dc(pc_eval(pc, 0u, d.m - floor(d.m)));
    }
    return f_out(d, per_moments(pc, d.m, f_spread(d)));
}

// filter_octave.wgsl: the template of one noise octave over the footprint; `filtered.rs`
// makes one copy per noise kernel the tape samples (`SAMPLE`: its function's name, WGSL having
// no function values). Which table, period, cellular parameters and statistics a call samples
// with are run-time values: the sampler `s`, a record of the filtered form's data (`filtered.rs`
// `Gen::sampler`) that `smp_SAMPLE(s, x)` and `smp_stats(s)` read.

// One octave (or noise sample) of `p` by the sampler `s` (noise.rs `octave_lanes` for one
// lane).
fn n_octave_SAMPLE(p: array<D, 3>, s: u32) -> D {
    let st = smp_stats(s);
    let fade = n_fade(st, p);
    let alpha = fade.x;
    if (alpha < 1e-3lf) { // noise.rs FADED
        return D(st.mean, vec3<f64>(0.0lf), st.var_);
    }
    // The points to sample: the centre, or in the band the eight sub-box centres. One call
    // site of the sampler in a loop the driver cannot unroll (`filter_one()`): each call site
    // inlines the whole f64 noise kernel.
    let band = alpha >= 0.01lf && alpha <= 0.99lf;
    // noise.rs `FACES_FROM`: a small box of an input without residual, a smooth basis.
    let faces = band && alpha >= 0.9lf && st.faces != 0.0lf
        && p[0].v + p[1].v + p[2].v == 0.0lf;
    var e: array<vec3<f64>, 3>;
    var count = 1u;
    if (band) {
        e = n_edges(p);
        count = select(8u, 6u, faces);
    }
    var v: array<vec4<f64>, 8>;
    for (var j = 0u; j < count * u32(filter_one()); j += 1u) {
        var x = vec3<f64>(p[0].m, p[1].m, p[2].m);
        if (faces) {
            x = n_face_centre(p, e, j);
        } else if (band) {
            x = n_sub_centre(p, e, j);
        }
        v[j] = smp_SAMPLE(s, x);
    }
    if (alpha == 1.0lf && d_is_const(p[0]) && d_is_const(p[1]) && d_is_const(p[2])) {
        return dc(v[0].w);
    }
    if (faces) {
        let sub = n_faces(v);
        if (sub.ok) {
            return sub.d;
        }
    } else if (band) {
        let sub = n_subsampled(st, p, e, v);
        if (sub.ok) {
            return sub.d;
        }
    }
    return n_sampled(st, p, fade, v[0].w, v[0].xyz);
}

// noise.rs `noise_gradient`: the gradient of the noise at the centre, times `scale`, faded like
// the value; what the fade takes (`(1 − α²)` of a component's mean square) as residual variance.
fn n_gradient_SAMPLE(p: array<D, 3>, scale: f64, s: u32) -> array<D, 3> {
    let st = smp_stats(s);
    let g = smp_SAMPLE(s, vec3<f64>(p[0].m, p[1].m, p[2].m));
    let alpha = n_fade(st, p).x;
    let v = (1.0lf - alpha * alpha) * st.grad_sq * scale * scale;
    let var_ = select(0.0lf, v, is_finite_d(v));
    let z = vec3<f64>(0.0lf);
    return array<D, 3>(
        D(alpha * g.x * scale, z, var_),
        D(alpha * g.y * scale, z, var_),
        D(alpha * g.z * scale, z, var_),
    );
}

// noise.rs `cellular`: cellular noise over a footprint within a cell in noise space, from its
// eight sub-boxes; the fade (`n_octave_SAMPLE`) for a larger one or a non-finite centre.
fn n_cellular_SAMPLE(p: array<D, 3>, s: u32) -> D {
    let e = n_edges(p);
    let longest = max(v_dot(e[0], e[0]), max(v_dot(e[1], e[1]), v_dot(e[2], e[2])));
    let small = longest <= 1.0lf;
    let centre = vec3<f64>(p[0].m, p[1].m, p[2].m);
    if (!small || !is_finite_d(centre.x) || !is_finite_d(centre.y) || !is_finite_d(centre.z)) {
        return n_octave_SAMPLE(p, s);
    }
    var v: array<vec4<f64>, 8>;
    var mean = 0.0lf;
    for (var j = 0u; j < 8u; j += 1u) {
        v[j] = smp_SAMPLE(s, n_sub_centre(p, e, j));
        mean = mean + v[j].w;
    }
    mean = mean / 8.0lf;
    var g_mean = vec3<f64>(0.0lf);
    var within = 0.0lf;
    var carried = 0.0lf;
    var between = 0.0lf;
    for (var j = 0u; j < 8u; j += 1u) {
        let g = vec3<f64>(finite_or_zero(v[j].x), finite_or_zero(v[j].y), finite_or_zero(v[j].z));
        g_mean = g_mean + g / 8.0lf;
        let slope = g.x * p[0].g + g.y * p[1].g + g.z * p[2].g;
        within = within + f_linvar(slope) / 4.0lf / 8.0lf;
        carried = carried + (g.x * g.x * p[0].v + g.y * g.y * p[1].v + g.z * g.z * p[2].v) / 8.0lf;
    }
    for (var j = 0u; j < 8u; j += 1u) {
        between = between + (v[j].w - mean) * (v[j].w - mean);
    }
    between = between / 8.0lf;
    let slope = g_mean.x * p[0].g + g_mean.y * p[1].g + g_mean.z * p[2].g;
    let r = f_residual(between + within, f_linvar(slope)) + carried;
    if (!is_finite_d(mean)) {
        return n_octave_SAMPLE(p, s);
    }
    return D(mean, slope, select(0.0lf, r, is_finite_d(r)));
}

// noise.rs `white`: white noise over the footprint as the exact mixture of the cells the input
// reaches (at most 64), the axes independent; the fade for a wider box or a non-finite input.
fn n_white_SAMPLE(p: array<D, 3>, integer: vec3<bool>, s: u32) -> D {
    let ax = w_axis(p[0], integer.x);
    let ay = w_axis(p[1], integer.y);
    let az = w_axis(p[2], integer.z);
    if (!ax.ok || !ay.ok || !az.ok || ax.count * ay.count * az.count > 64u) {
        return n_octave_SAMPLE(p, s);
    }
    // The three axes' cells (at most 64 in all, so at most 66 along the axes).
    var pr: array<vec2<f64>, 66>;
    w_fill(ax, 0u, &pr);
    w_fill(ay, ax.count, &pr);
    w_fill(az, ax.count + ay.count, &pr);
    var mean = 0.0lf;
    var square = 0.0lf;
    var slope = vec3<f64>(0.0lf);
    for (var i = 0u; i < ax.count; i += 1u) {
        let x = pr[i];
        for (var j = 0u; j < ay.count; j += 1u) {
            let y = pr[ax.count + j];
            for (var k = 0u; k < az.count; k += 1u) {
                let z = pr[ax.count + ay.count + k];
                let centre = vec3<f64>(ax.first + f64(i), ay.first + f64(j), az.first + f64(k));
                let w = smp_SAMPLE(s, centre + vec3<f64>(0.5lf)).w;
                mean = mean + x.x * y.x * z.x * w;
                square = square + x.x * y.x * z.x * w * w;
                slope = slope + vec3<f64>(x.y * y.x * z.x, x.x * y.y * z.x, x.x * y.x * z.y) * w;
            }
        }
    }
    let grad = slope.x * p[0].g + slope.y * p[1].g + slope.z * p[2].g;
    if (!is_finite_d(mean)) {
        return n_octave_SAMPLE(p, s);
    }
    return D(mean, grad, f_residual(square - mean * mean, f_linvar(grad)));
}

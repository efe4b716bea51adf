// filter_octave.wgsl: the template of one noise octave over the footprint; `filtered.rs`
// makes one copy per sampler with `SAMPLE` replaced by its function (WGSL has no function
// values).

// One octave (or noise sample) of `p` by the sampler `SAMPLE` (noise.rs `octave_lanes` for
// one lane). `filtered.rs` makes one copy per sampler, `SAMPLE` replaced by its function.
fn n_octave_SAMPLE(st: St, p: array<D, 3>) -> D {
    let fade = n_fade(st, p);
    let alpha = fade.x;
    if (alpha < 1e-6lf) {
        return D(st.mean, vec3<f64>(0.0lf), st.var_);
    }
    let centre = vec3<f64>(p[0].m, p[1].m, p[2].m);
    if (alpha == 1.0lf && d_is_const(p[0]) && d_is_const(p[1]) && d_is_const(p[2])) {
        return dc(SAMPLE(centre).w);
    }
    if (alpha >= 0.01lf && alpha <= 0.99lf) {
        let e = n_edges(p);
        var s: array<vec4<f64>, 8>;
        for (var j = 0u; j < 8u; j += 1u) {
            s[j] = SAMPLE(n_sub_centre(p, e, j));
        }
        let sub = n_subsampled(st, p, e, s);
        if (sub.ok) {
            return sub.d;
        }
        return n_sampled(st, p, fade, s[0].w, s[0].xyz);
    }
    let c = SAMPLE(centre);
    return n_sampled(st, p, fade, c.w, c.xyz);
}

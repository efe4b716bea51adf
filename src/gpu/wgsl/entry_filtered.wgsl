// entry_filtered.wgsl: the entry points of a filtered shader (`filtered.rs`; after
// bindings.wgsl): as entry.wgsl's, each point's footprint set (`fp_set`) before `ftape`.
// bake: each voxel's box, its sides the grid's spacing (`bake::engine`'s footprint).
// points: `spacing` 0: one footprint for all, its three edges (9 values) after the x, y and z
// planes; 1: nine values per point there.

@compute @workgroup_size(64)
fn bake(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>,
        @builtin(local_invocation_index) local: u32) {
    let v = bake_voxel(thread_index(wg, groups, local));
    if (!v.ok) {
        return;
    }
    let p = v.p;
    let s = v.s;
    let i = v.i;
    fp_set(vec3<f64>(abs(inputs[3u] / inputs[6u]), 0.0lf, 0.0lf),
           vec3<f64>(0.0lf, abs(inputs[4u] / inputs[7u]), 0.0lf),
           vec3<f64>(0.0lf, 0.0lf, abs(inputs[5u] / inputs[8u])));
    let r = ftape(p);
    for (var c = 0u; c < CHANNELS; c = c + 1u) {
        results[(s * CHANNELS + c) * dispatch.segment_len + i] = r.c[c];
    }
}

@compute @workgroup_size(64)
fn points(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>,
          @builtin(local_invocation_index) local: u32) {
    let g = thread_index(wg, groups, local);
    let n = dispatch.count;
    if (g >= n) {
        return;
    }
    var at = 3u * n;
    if (dispatch.spacing != 0u) {
        at = 3u * n + 9u * g;
    }
    fp_set(vec3<f64>(inputs[at], inputs[at + 1u], inputs[at + 2u]),
           vec3<f64>(inputs[at + 3u], inputs[at + 4u], inputs[at + 5u]),
           vec3<f64>(inputs[at + 6u], inputs[at + 7u], inputs[at + 8u]));
    let r = ftape(vec3<f64>(inputs[g], inputs[n + g], inputs[2u * n + g]));
    for (var c = 0u; c < CHANNELS; c = c + 1u) {
        results[c * n + g] = r.c[c];
    }
}

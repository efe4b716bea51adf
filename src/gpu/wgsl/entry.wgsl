// entry.wgsl: the entry points of every generated point shader (after the tape's `fn tape`
// and bindings.wgsl).

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
    let r = tape(p, 0.0lf);
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
    var h = 0.0lf;
    if (dispatch.spacing != 0u) {
        h = inputs[3u * n + g];
    }
    let r = tape(vec3<f64>(inputs[g], inputs[n + g], inputs[2u * n + g]), h);
    for (var c = 0u; c < CHANNELS; c = c + 1u) {
        results[c * n + g] = r.c[c];
    }
}

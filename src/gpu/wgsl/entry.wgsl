// entry.wgsl: the entry points of every generated shader (after the tape's `fn tape`).

// bake: [lo.x, lo.y, lo.z, width.x, width.y, width.z, n.x, n.y, n.z] (voxel centre
// lo + (i + 0.5) * width / n, as `bake::Grid::centre`); points: the x, y and z planes of
// `count` positions.
@group(0) @binding(1) var<storage, read> inputs: array<f64>;

struct Dispatch {
    // bake: the window's first segment, its segments, the segment length, segments per row,
    // and the grid's x and y sizes. points: `count` positions.
    first_segment: u32,
    segments: u32,
    segment_len: u32,
    per_row: u32,
    nx: u32,
    ny: u32,
    count: u32,
    // points: 1 when `inputs` holds a fourth plane, each point's sample spacing (level of
    // detail per point); 0: none.
    spacing: u32,
    // Always 1.0. The tape's constants are multiplied by it (`fn tape`): a value the driver
    // cannot know, so it cannot fold two constants of a chain into one (reassociating
    // `(p * a) * b` into `p * (a * b)` rounds differently: at |p| ~ 10^12 one f64 ulp moves a
    // noise sample by 10^-3).
    one: f32,
}
@group(0) @binding(2) var<uniform> dispatch: Dispatch;

// bake: the window layout of `bake::Window` (segment-planar: channel c of voxel i of segment s
// at (s * CHANNELS + c) * segment_len + i); points: channel-planar, c * count + i.
@group(0) @binding(3) var<storage, read_write> results: array<f32>;

const GROUP: u32 = 64u;

fn thread_index(wg: vec3<u32>, groups: vec3<u32>, local: u32) -> u32 {
    return (wg.y * groups.x + wg.x) * GROUP + local;
}

fn centre(axis: u32, index: u32) -> f64 {
    return inputs[axis] + (f64(index) + 0.5lf) * inputs[3u + axis] / inputs[6u + axis];
}

@compute @workgroup_size(64)
fn bake(@builtin(workgroup_id) wg: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>,
        @builtin(local_invocation_index) local: u32) {
    let g = thread_index(wg, groups, local);
    let s = g / dispatch.segment_len;
    let i = g % dispatch.segment_len;
    if (s >= dispatch.segments) {
        return;
    }
    let segment = dispatch.first_segment + s;
    let row = segment / dispatch.per_row;
    let x = (segment % dispatch.per_row) * dispatch.segment_len + i;
    if (x >= dispatch.nx) {
        return;
    }
    let p = vec3<f64>(centre(0u, x), centre(1u, row % dispatch.ny), centre(2u, row / dispatch.ny));
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

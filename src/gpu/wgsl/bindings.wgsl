// bindings.wgsl: the bindings and helpers every generated shader's entry points share (the
// point entries in entry.wgsl, the filtered ones in entry_filtered.wgsl).

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

// The filtered form's loops run `n * filter_one()` times: a bound the driver cannot know, so it
// keeps one copy of each loop's body instead of unrolling it (the shader export defines its
// own `filter_one`, `shader::FILTER_ONE`).
fn filter_one() -> f32 {
    return dispatch.one;
}

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

// The voxel a `bake` thread evaluates: its segment in the window `s`, its index in the segment
// `i` and its centre; `ok` false for a thread past the window's segments or the row's end.
struct Voxel {
    s: u32,
    i: u32,
    p: vec3<f64>,
    ok: bool,
}

fn bake_voxel(g: u32) -> Voxel {
    let s = g / dispatch.segment_len;
    let i = g % dispatch.segment_len;
    var v = Voxel(s, i, vec3<f64>(0.0lf), false);
    if (s >= dispatch.segments) {
        return v;
    }
    let segment = dispatch.first_segment + s;
    let row = segment / dispatch.per_row;
    let x = (segment % dispatch.per_row) * dispatch.segment_len + i;
    if (x >= dispatch.nx) {
        return v;
    }
    v.p = vec3<f64>(centre(0u, x), centre(1u, row % dispatch.ny), centre(2u, row / dispatch.ny));
    v.ok = true;
    return v;
}

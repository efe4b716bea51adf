// A Bevy fragment shader for a custom `Material` (its `fragment_shader()` returns this file)
// that colours a mesh with a texgraph function (docs/shaders.md, "Engine templates"). Put the
// exported WGSL where the marker line is:
//
//     texgraph shader graphs/seed003_marble.ron --lang wgsl --output colour > colour.wgsl
//
// (with `--uniforms`, move its `@group(0) @binding(0)` to the material's group, `@group(2)`,
// and give the material a uniform buffer of the params in the graph's order). The world
// position, scaled, is the texture's `p`; the `_lod` form fades octaves finer than a pixel's
// footprint; `texgraph_colour_filtered(p, mat3x3<f32>(dpdx(p), dpdy(p), vec3<f32>(0.0)))`
// averages the texture over it (the antialiased form; more work per pixel). The tests validate
// this file with the marble's export pasted in (naga, as wgpu).
#import bevy_pbr::forward_io::VertexOutput

// TEXGRAPH EXPORT HERE

@fragment
fn fragment(mesh: VertexOutput) -> @location(0) vec4<f32> {
    let p = mesh.world_position.xyz * 0.5;
    let spacing = max(length(dpdx(p)), length(dpdy(p)));
    let colour = clamp(texgraph_colour_lod(p, spacing), vec3<f32>(0.0), vec3<f32>(1.0));
    return vec4<f32>(colour, 1.0);
}

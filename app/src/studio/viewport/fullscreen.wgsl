// One triangle over the viewport it is drawn in (no vertex buffer: three vertex indices);
// `uv` runs 0..1 across the viewport. Prepended to the shaders that copy or fill a viewport
// (the blit in shaders.wgsl, flat.rs).
struct FullscreenOut {
    @builtin(position) position: vec4<f32>,
    @location(0) uv: vec2<f32>,
};

@vertex
fn vs_fullscreen(@builtin(vertex_index) vi: u32) -> FullscreenOut {
    let x = f32((vi << 1u) & 2u);
    let y = f32(vi & 2u);
    var out: FullscreenOut;
    out.position = vec4<f32>(x * 2.0 - 1.0, 1.0 - y * 2.0, 0.0, 1.0);
    out.uv = vec2<f32>(x, y);
    return out;
}

// The studio viewport: shaded meshes, billboard points and lines, rendered offscreen with
// depth and MSAA, then copied into egui's pass. egui's target is a plain 8-bit format, so the
// scene passes write display (gamma-encoded) values.

struct Globals {
    view_proj: mat4x4<f32>,
    view: mat4x4<f32>,
    // x: mode (0 shaded, 1 normals), y: point size in pixels, z, w: viewport size in pixels
    params: vec4<f32>,
    light_dir: vec4<f32>,
};

@group(0) @binding(0) var<uniform> globals: Globals;

fn to_display(c: vec3<f32>) -> vec3<f32> {
    return pow(clamp(c, vec3<f32>(0.0), vec3<f32>(1.0)), vec3<f32>(1.0 / 2.2));
}

struct MeshOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) normal: vec3<f32>,
    @location(1) color: vec3<f32>,
    @location(2) view_pos: vec3<f32>,
};

@vertex
fn vs_mesh(@location(0) pos: vec3<f32>, @location(1) normal: vec3<f32>, @location(2) color: vec4<f32>) -> MeshOut {
    var out: MeshOut;
    out.clip = globals.view_proj * vec4<f32>(pos, 1.0);
    out.normal = normal;
    out.color = color.rgb;
    out.view_pos = (globals.view * vec4<f32>(pos, 1.0)).xyz;
    return out;
}

@fragment
fn fs_mesh(in: MeshOut, @builtin(front_facing) front: bool) -> @location(0) vec4<f32> {
    var n = normalize(in.normal);
    if (!front) {
        n = -n;
    }
    if (globals.params.x > 0.5) {
        // Normal view: world normal mapped to colour.
        return vec4<f32>(to_display(n * 0.5 + vec3<f32>(0.5)), 1.0);
    }
    // Three-point lighting in view space (the key from the studio's light direction, by default
    // the camera's upper left; fill, rim) plus a
    // soft hemisphere ambient, with a little Blinn-Phong specular.
    let vn = normalize((globals.view * vec4<f32>(n, 0.0)).xyz);
    let v = normalize(-in.view_pos);
    let key = normalize(globals.light_dir.xyz);
    let fill = normalize(vec3<f32>(0.7, 0.1, 0.5));
    let rim = normalize(vec3<f32>(0.0, 0.4, -1.0));
    let hemi = 0.5 + 0.5 * vn.y;
    var c = in.color * (0.16 + 0.10 * hemi);
    c += in.color * 0.80 * max(dot(vn, key), 0.0);
    c += in.color * 0.25 * max(dot(vn, fill), 0.0);
    c += vec3<f32>(0.25) * pow(max(dot(vn, rim), 0.0), 2.0);
    let h = normalize(key + v);
    c += vec3<f32>(0.12) * pow(max(dot(vn, h), 0.0), 32.0);
    return vec4<f32>(to_display(c), 1.0);
}

struct PointOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) color: vec3<f32>,
    @location(1) corner: vec2<f32>,
};

@vertex
fn vs_point(@builtin(vertex_index) vi: u32, @location(0) pos: vec3<f32>, @location(1) color: vec4<f32>) -> PointOut {
    var corners = array<vec2<f32>, 4>(vec2<f32>(-1.0, -1.0), vec2<f32>(1.0, -1.0), vec2<f32>(-1.0, 1.0), vec2<f32>(1.0, 1.0));
    let corner = corners[vi];
    var clip = globals.view_proj * vec4<f32>(pos, 1.0);
    let size = globals.params.y * color.a;
    clip = vec4<f32>(clip.xy + corner * size / globals.params.zw * clip.w, clip.z, clip.w);
    var out: PointOut;
    out.clip = clip;
    out.color = color.rgb;
    out.corner = corner;
    return out;
}

@fragment
fn fs_point(in: PointOut) -> @location(0) vec4<f32> {
    let r = dot(in.corner, in.corner);
    if (r > 1.0) {
        discard;
    }
    let shade = 1.0 - 0.35 * r;
    return vec4<f32>(to_display(in.color * shade), 1.0);
}

struct LineOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) color: vec3<f32>,
};

@vertex
fn vs_line(@location(0) pos: vec3<f32>, @location(1) color: vec4<f32>) -> LineOut {
    var out: LineOut;
    out.clip = globals.view_proj * vec4<f32>(pos, 1.0);
    out.color = color.rgb;
    return out;
}

@fragment
fn fs_line(in: LineOut) -> @location(0) vec4<f32> {
    return vec4<f32>(to_display(in.color), 1.0);
}

// Copy of the resolved offscreen image into egui's pass (viewport = the callback's rect),
// drawn by fullscreen.wgsl's `vs_fullscreen`.

@group(0) @binding(0) var blit_src: texture_2d<f32>;
@group(0) @binding(1) var blit_sampler: sampler;

@fragment
fn fs_blit(in: FullscreenOut) -> @location(0) vec4<f32> {
    let dims = vec2<f32>(textureDimensions(blit_src));
    let p = vec2<i32>(clamp(in.uv * dims, vec2<f32>(0.0), dims - vec2<f32>(1.0)));
    return textureLoad(blit_src, p, 0);
}

// The scene drawn smaller than the viewport (moving, on a software renderer): stretched
// bilinearly.
@fragment
fn fs_blit_scaled(in: FullscreenOut) -> @location(0) vec4<f32> {
    return textureSample(blit_src, blit_sampler, in.uv);
}

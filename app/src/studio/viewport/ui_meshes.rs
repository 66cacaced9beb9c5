//! While the view moves on a software renderer (playback, the turntable, an orbit), the
//! panels' text and widgets are painted by this module's shader instead of egui-wgpu's.
//!
//! Why: egui-wgpu 0.37's fragment shader branches on a uniform (`predictable_texture_filtering`)
//! and Mesa 22's llvmpipe pays for both sides of it on every pixel (viewport/flat.rs). What
//! `flat` leaves to egui (text, buttons, frames, sliders) was still about a third of a playback
//! frame at 1280 x 800 (docs/studio.md). Here the window's base layer (where the panels paint)
//! is tessellated by egui's own tessellator at the end of the frame and its meshes are drawn
//! with the same vertex data, the same font texture and sampler and egui's premultiplied
//! blending, by a shader without the branch. Paint callbacks (the 3D view, `flat`'s backdrop
//! and images) and meshes with other textures keep their place and stay egui's.
//!
//! The pixels are egui's but for its dithering (at most one level, on gradients). Only while
//! the view moves: a still window, and so every screenshot test, is painted by egui itself.

use eframe::egui;
use eframe::egui::epaint::{ClippedPrimitive, ClippedShape, Mesh, Primitive};
use eframe::egui_wgpu::{self, wgpu};
use std::sync::Arc;

/// The pipeline, the font texture's bind group and the buffers of the last frame's meshes,
/// kept in egui-wgpu's callback resources.
pub struct UiMeshes {
    pipeline: wgpu::RenderPipeline,
    layout: wgpu::BindGroupLayout,
    sampler: wgpu::Sampler,
    screen: wgpu::Buffer,
    /// egui's font texture and our bind group for it.
    font: Option<(wgpu::Texture, wgpu::BindGroup)>,
    /// The font atlas's fill ratio and the pixels per point at the last take-over (a drop, or
    /// a new scale, means the atlas was rebuilt).
    last_fill: f32,
    last_ppp: f32,
    buffers: Option<(wgpu::Buffer, wgpu::Buffer)>,
    /// Which frame's meshes the buffers hold ([`FrameMeshes::generation`]).
    uploaded: u64,
}

/// Create the pipeline (call at start-up on a software renderer).
pub fn install(render_state: &egui_wgpu::RenderState) {
    let device = &render_state.device;
    let shader = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("ui meshes"),
        source: wgpu::ShaderSource::Wgsl(SHADER.into()),
    });
    let uniforms = wgpu::BindGroupLayoutEntry {
        binding: 0,
        visibility: wgpu::ShaderStages::VERTEX,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Uniform,
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    };
    let [texture, sampler] = super::pipelines::texture_and_sampler_entries(1);
    let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("ui meshes"),
        entries: &[uniforms, texture, sampler],
    });
    let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some("ui meshes"),
        bind_group_layouts: &[Some(&layout)],
        immediate_size: 0,
    });
    // A target that encodes sRGB itself wants linear values; egui's usual one takes gamma.
    let entry =
        if render_state.target_format.is_srgb() { "fs_linear_target" } else { "fs_gamma_target" };
    let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some("ui meshes"),
        layout: Some(&pipeline_layout),
        vertex: wgpu::VertexState {
            module: &shader,
            entry_point: Some("vs_main"),
            compilation_options: Default::default(),
            // epaint's vertex: position and uv in points, colour as four sRGB bytes.
            buffers: &[Some(wgpu::VertexBufferLayout {
                array_stride: std::mem::size_of::<egui::epaint::Vertex>() as u64,
                step_mode: wgpu::VertexStepMode::Vertex,
                attributes: &wgpu::vertex_attr_array![0 => Float32x2, 1 => Float32x2, 2 => Unorm8x4],
            })],
        },
        primitive: wgpu::PrimitiveState::default(),
        depth_stencil: None,
        multisample: wgpu::MultisampleState::default(),
        fragment: Some(wgpu::FragmentState {
            module: &shader,
            entry_point: Some(entry),
            compilation_options: Default::default(),
            // egui's blending: premultiplied colour; alpha accumulates under what is there.
            targets: &[Some(wgpu::ColorTargetState {
                format: render_state.target_format,
                blend: Some(wgpu::BlendState {
                    color: wgpu::BlendComponent { src_factor: wgpu::BlendFactor::One, dst_factor: wgpu::BlendFactor::OneMinusSrcAlpha, operation: wgpu::BlendOperation::Add },
                    alpha: wgpu::BlendComponent { src_factor: wgpu::BlendFactor::OneMinusDstAlpha, dst_factor: wgpu::BlendFactor::One, operation: wgpu::BlendOperation::Add },
                }),
                write_mask: wgpu::ColorWrites::ALL,
            })],
        }),
        multiview_mask: None,
        cache: None,
    });
    // egui's sampler for the font atlas (`TextureOptions::LINEAR`).
    let sampler = super::pipelines::linear_clamp_sampler(device, "ui meshes");
    let screen = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("ui meshes screen"),
        size: 16,
        usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let resources = UiMeshes {
        pipeline,
        layout,
        sampler,
        screen,
        font: None,
        last_fill: 0.0,
        last_ppp: 0.0,
        buffers: None,
        uploaded: 0,
    };
    render_state.renderer.write().callback_resources.insert(resources);
}

/// Take over the painting of the window's base layer for this frame (call at the end of the
/// UI, after everything is drawn). Returns false, leaving everything to egui, where egui's font
/// texture may not match this frame's atlas (it grew or was rebuilt: egui uploads it anew
/// only after the UI has run) or the layer is transformed.
pub fn take_over(ctx: &egui::Context, render_state: &egui_wgpu::RenderState) -> bool {
    let layer = egui::LayerId::background();
    if ctx.memory(|m| m.to_global.contains_key(&layer)) {
        return false;
    }
    let (atlas_size, fill) = ctx.fonts(|f| (f.font_image_size(), f.font_atlas_fill_ratio()));
    let ppp = ctx.pixels_per_point();
    let font = render_state
        .renderer
        .read()
        .texture(&egui::TextureId::default())
        .and_then(|t| t.texture.clone());
    {
        let mut renderer = render_state.renderer.write();
        let Some(res) = renderer.callback_resources.get_mut::<UiMeshes>() else {
            return false;
        };
        // egui rebuilds the atlas when it is 80 % full (at the next frame's start) or the scale
        // changes; a fill ratio that dropped means it was rebuilt, perhaps at the same size.
        let rebuilt = fill < res.last_fill || res.last_fill > 0.8 || ppp != res.last_ppp;
        (res.last_fill, res.last_ppp) = (fill, ppp);
        let Some(font) = font.filter(|t| [t.width() as usize, t.height() as usize] == atlas_size)
        else {
            return false;
        };
        if rebuilt {
            return false;
        }
        if res.font.as_ref().is_none_or(|(t, _)| *t != font) {
            let view = font.create_view(&wgpu::TextureViewDescriptor::default());
            let group = render_state.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("ui meshes"),
                layout: &res.layout,
                entries: &[
                    wgpu::BindGroupEntry { binding: 0, resource: res.screen.as_entire_binding() },
                    wgpu::BindGroupEntry {
                        binding: 1,
                        resource: wgpu::BindingResource::TextureView(&view),
                    },
                    wgpu::BindGroupEntry {
                        binding: 2,
                        resource: wgpu::BindingResource::Sampler(&res.sampler),
                    },
                ],
            });
            res.font = Some((font, group));
        }
    }
    let shapes: Vec<ClippedShape> =
        ctx.graphics_mut(|g| std::mem::take(g.entry(layer))).all_entries().cloned().collect();
    let screen = ctx.content_rect().union(ctx.viewport_rect());
    let list = split(ctx.tessellate(shapes, ppp), screen);
    ctx.graphics_mut(|g| *g.entry(layer) = list);
    true
}

/// The layer again, as egui will paint it: runs of font-textured meshes become one callback
/// each (drawn by this module), everything else is handed back in its place.
fn split(primitives: Vec<ClippedPrimitive>, screen: egui::Rect) -> egui::layers::PaintList {
    // A number per frame (an address could be reused by the next frame's meshes).
    static GENERATION: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(1);
    let mut frame_data = FrameMeshes {
        generation: GENERATION.fetch_add(1, std::sync::atomic::Ordering::Relaxed),
        ..Default::default()
    };
    let mut pending: Vec<(usize, egui::Shape, egui::Rect)> = Vec::new(); // (run index or MAX, shape, clip)
    let mut run: Option<usize> = None;
    for ClippedPrimitive { clip_rect, primitive } in primitives {
        match primitive {
            Primitive::Mesh(mesh) if mesh.texture_id == egui::TextureId::default() => {
                let index = *run.get_or_insert_with(|| {
                    frame_data.runs.push(Vec::new());
                    pending.push((frame_data.runs.len() - 1, egui::Shape::Noop, screen));
                    frame_data.runs.len() - 1
                });
                frame_data.add(index, clip_rect, &mesh);
            }
            Primitive::Mesh(mesh) => {
                run = None;
                pending.push((usize::MAX, egui::Shape::mesh(mesh), clip_rect));
            }
            Primitive::Callback(callback) => {
                run = None;
                pending.push((usize::MAX, egui::Shape::Callback(callback), clip_rect));
            }
        }
    }
    let frame = Arc::new(frame_data);
    let mut list = egui::layers::PaintList::default();
    for (index, shape, clip) in pending {
        let shape = if index == usize::MAX {
            shape
        } else {
            egui::Shape::Callback(egui_wgpu::Callback::new_paint_callback(
                screen,
                Run { frame: frame.clone(), index },
            ))
        };
        list.add(clip, shape);
    }
    list
}

/// One frame's meshes: all vertices and indices, and per run its draws.
#[derive(Default)]
struct FrameMeshes {
    generation: u64,
    vertices: Vec<egui::epaint::Vertex>,
    indices: Vec<u32>,
    runs: Vec<Vec<Draw>>,
}

struct Draw {
    clip: egui::Rect,
    indices: std::ops::Range<u32>,
    base_vertex: i32,
}

impl FrameMeshes {
    fn add(&mut self, run: usize, clip: egui::Rect, mesh: &Mesh) {
        let start = self.indices.len() as u32;
        let base_vertex = self.vertices.len() as i32;
        self.vertices.extend_from_slice(&mesh.vertices);
        self.indices.extend_from_slice(&mesh.indices);
        self.runs[run].push(Draw { clip, indices: start..self.indices.len() as u32, base_vertex });
    }
}

struct Run {
    frame: Arc<FrameMeshes>,
    index: usize,
}

impl egui_wgpu::CallbackTrait for Run {
    fn prepare(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        screen: &egui_wgpu::ScreenDescriptor,
        _encoder: &mut wgpu::CommandEncoder,
        resources: &mut egui_wgpu::CallbackResources,
    ) -> Vec<wgpu::CommandBuffer> {
        let Some(res) = resources.get_mut::<UiMeshes>() else {
            return Vec::new();
        };
        // The frame's first run uploads all of its meshes.
        if res.uploaded == self.frame.generation {
            return Vec::new();
        }
        res.uploaded = self.frame.generation;
        let points = [
            screen.size_in_pixels[0] as f32 / screen.pixels_per_point,
            screen.size_in_pixels[1] as f32 / screen.pixels_per_point,
            0.0,
            0.0,
        ];
        queue.write_buffer(&res.screen, 0, bytemuck::cast_slice(&points));
        let vertices: &[u8] = bytemuck::cast_slice(&self.frame.vertices);
        let indices: &[u8] = bytemuck::cast_slice(&self.frame.indices);
        let fits = res.buffers.as_ref().is_some_and(|(v, i)| {
            v.size() >= vertices.len() as u64 && i.size() >= indices.len() as u64
        });
        if !fits {
            // Room for twice as much, so that a growing UI does not reallocate every frame.
            let make = |label, len: usize, usage| {
                device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some(label),
                    size: (2 * len.max(1024)).next_multiple_of(4) as u64,
                    usage: usage | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                })
            };
            res.buffers = Some((
                make("ui meshes vertices", vertices.len(), wgpu::BufferUsages::VERTEX),
                make("ui meshes indices", indices.len(), wgpu::BufferUsages::INDEX),
            ));
        }
        if let Some((v, i)) = &res.buffers {
            queue.write_buffer(v, 0, vertices);
            queue.write_buffer(i, 0, indices);
        }
        Vec::new()
    }

    fn paint(
        &self,
        info: egui::PaintCallbackInfo,
        pass: &mut wgpu::RenderPass<'static>,
        resources: &egui_wgpu::CallbackResources,
    ) {
        let Some(res) = resources.get::<UiMeshes>() else {
            return;
        };
        let (Some((_, group)), Some((v, i))) = (&res.font, &res.buffers) else {
            return;
        };
        // The whole window (egui set the viewport to the callback's rectangle: the screen).
        let [w, h] = info.screen_size_px;
        pass.set_viewport(0.0, 0.0, w as f32, h as f32, 0.0, 1.0);
        pass.set_pipeline(&res.pipeline);
        pass.set_bind_group(0, group, &[]);
        pass.set_vertex_buffer(0, v.slice(..));
        pass.set_index_buffer(i.slice(..), wgpu::IndexFormat::Uint32);
        for draw in &self.frame.runs[self.index] {
            let Some([x, y, sw, sh]) = scissor(draw.clip, info.pixels_per_point, [w, h]) else {
                continue;
            };
            pass.set_scissor_rect(x, y, sw, sh);
            pass.draw_indexed(draw.indices.clone(), draw.base_vertex, 0..1);
        }
    }
}

/// A clip rectangle in points as a scissor rectangle in pixels (rounded as egui-wgpu rounds
/// it); None when empty.
fn scissor(clip: egui::Rect, ppp: f32, size: [u32; 2]) -> Option<[u32; 4]> {
    let px = |v: f32, max: u32| ((v * ppp).round().max(0.0) as u32).min(max);
    let (x0, y0) = (px(clip.min.x, size[0]), px(clip.min.y, size[1]));
    let (x1, y1) = (px(clip.max.x, size[0]).max(x0), px(clip.max.y, size[1]).max(y0));
    (x1 > x0 && y1 > y0).then_some([x0, y0, x1 - x0, y1 - y0])
}

/// egui's vertex colours and font atlas hold gamma-encoded (sRGB) values, premultiplied.
const SHADER: &str = "
struct Screen { size: vec2<f32>, unused: vec2<f32> };
@group(0) @binding(0) var<uniform> screen: Screen;
@group(0) @binding(1) var font: texture_2d<f32>;
@group(0) @binding(2) var font_sampler: sampler;

struct Out {
    @builtin(position) position: vec4<f32>,
    @location(0) uv: vec2<f32>,
    @location(1) color: vec4<f32>,
};

@vertex
fn vs_main(@location(0) pos: vec2<f32>, @location(1) uv: vec2<f32>, @location(2) color: vec4<f32>) -> Out {
    var out: Out;
    out.position = vec4<f32>(2.0 * pos.x / screen.size.x - 1.0, 1.0 - 2.0 * pos.y / screen.size.y, 0.0, 1.0);
    out.uv = uv;
    out.color = color;
    return out;
}

@fragment
fn fs_gamma_target(in: Out) -> @location(0) vec4<f32> {
    return in.color * textureSample(font, font_sampler, in.uv);
}

@fragment
fn fs_linear_target(in: Out) -> @location(0) vec4<f32> {
    let c = in.color * textureSample(font, font_sampler, in.uv);
    let linear = select(pow((c.rgb + 0.055) / 1.055, vec3<f32>(2.4)), c.rgb / 12.92, c.rgb < vec3<f32>(0.04045));
    return vec4<f32>(linear, c.a);
}
";

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scissor_rounds_and_clamps_like_egui() {
        let r = |x0, y0, x1, y1| egui::Rect::from_min_max(egui::pos2(x0, y0), egui::pos2(x1, y1));
        assert_eq!(scissor(r(10.2, 5.6, 20.5, 30.0), 1.0, [100, 100]), Some([10, 6, 11, 24]));
        assert_eq!(scissor(r(-5.0, -5.0, 200.0, 50.0), 2.0, [100, 80]), Some([0, 0, 100, 80]));
        assert_eq!(scissor(r(10.0, 10.0, 10.2, 40.0), 1.0, [100, 100]), None);
        assert_eq!(scissor(r(150.0, 0.0, 160.0, 10.0), 1.0, [100, 100]), None);
    }

    #[test]
    fn runs_keep_callbacks_and_other_textures_in_place() {
        let screen = egui::Rect::from_min_size(egui::Pos2::ZERO, egui::vec2(100.0, 100.0));
        let mesh = |texture| {
            let mut m = Mesh::with_texture(texture);
            let uv = egui::Rect::from_min_max(egui::Pos2::ZERO, egui::pos2(1.0, 1.0));
            m.add_rect_with_uv(
                egui::Rect::from_min_size(egui::pos2(1.0, 1.0), egui::vec2(5.0, 5.0)),
                uv,
                egui::Color32::WHITE,
            );
            Primitive::Mesh(m)
        };
        let other = egui::TextureId::User(7);
        let callback =
            Primitive::Callback(egui::PaintCallback { rect: screen, callback: Arc::new(()) });
        let prims = [
            mesh(Default::default()),
            mesh(Default::default()),
            callback,
            mesh(other),
            mesh(Default::default()),
        ];
        let list = split(
            prims
                .into_iter()
                .map(|primitive| ClippedPrimitive { clip_rect: screen, primitive })
                .collect(),
            screen,
        );
        let kinds: Vec<String> = list
            .all_entries()
            .map(|s| match &s.shape {
                egui::Shape::Callback(c) => {
                    match c.callback.downcast_ref::<egui_wgpu::Callback>() {
                        Some(_) => "run".to_string(),
                        None => "callback".to_string(),
                    }
                }
                egui::Shape::Mesh(m) => format!("mesh {:?}", m.texture_id),
                other => format!("{other:?}"),
            })
            .collect();
        assert_eq!(kinds, ["run", "callback", "mesh User(7)", "run"]);
    }
}

//! The 3D viewport: an egui wgpu paint callback. It takes a [`Scene`] (meshes, points and
//! lines, already in world space), camera matrices and a shading mode, never the app. The
//! scene is rendered offscreen (4x MSAA colour + 32-bit depth; while the view moves on a
//! software renderer one sample a pixel and [`SOFTWARE_MOVING_SCALE`] of the pixels) in
//! `prepare()`, resolved, and copied into egui's render pass in `paint()` (egui's pass has
//! neither depth nor MSAA; a smaller image is stretched bilinearly).

use bytemuck::{Pod, Zeroable};
use eframe::egui;
use eframe::egui_wgpu::{self, wgpu};
use glam::Mat4;
use std::sync::Arc;

pub const MSAA: u32 = 4;
/// The scene's resolution (per axis) while the view moves on a software renderer: a quarter
/// of the pixels took playback in a 1280 x 800 window on lavapipe from 31 to 24 ms of CPU a
/// frame (0.75: 28 ms; docs/studio.md), and the moving image hides the softer, blockier
/// edges. 1 when still (every screenshot) and on a GPU.
pub const SOFTWARE_MOVING_SCALE: f32 = 0.5;
const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;
const COLOR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;
/// The viewport's background (linear RGB).
pub const BACKGROUND: [f64; 3] = [0.018, 0.020, 0.026];

mod callback;
pub mod flat;
mod pipelines;
mod scene;
pub mod ui_meshes;
use pipelines::{
    ScenePipelines, fullscreen_pipeline, linear_clamp_sampler, texture_and_sampler_entries,
};
pub use scene::{ColoredPoint, MeshVertex, Scene};

/// How meshes are shaded.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum Shading {
    Lit,
    Normals,
}

/// The camera as the renderer needs it.
#[derive(Debug, Clone, Copy)]
pub struct CameraMatrices {
    pub view: Mat4,
    pub proj: Mat4,
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct Globals {
    view_proj: [[f32; 4]; 4],
    view: [[f32; 4]; 4],
    params: [f32; 4],
    light: [f32; 4],
}

/// Paint `scene` into `rect` of `ui`. Does nothing visible (but paints the background) when the
/// wgpu renderer is missing. `moving`: the view changes every frame (see
/// [`ViewportResources::samples`]).
#[allow(clippy::too_many_arguments)]
pub fn paint(
    ui: &mut egui::Ui,
    rect: egui::Rect,
    scene: Arc<Scene>,
    camera: CameraMatrices,
    shading: Shading,
    point_size: f32,
    light: [f32; 3],
    moving: bool,
) {
    let ppp = ui.ctx().pixels_per_point();
    let size = [
        (rect.width() * ppp).round().max(1.0) as u32,
        (rect.height() * ppp).round().max(1.0) as u32,
    ];
    let cb = ViewportCallback {
        scene,
        camera,
        shading,
        point_size: point_size * ppp,
        size,
        light,
        moving,
    };
    ui.painter().add(egui_wgpu::Callback::new_paint_callback(rect, cb));
}

struct ViewportCallback {
    scene: Arc<Scene>,
    camera: CameraMatrices,
    shading: Shading,
    point_size: f32,
    size: [u32; 2],
    light: [f32; 3],
    moving: bool,
}

/// GPU objects of the viewport, kept in egui-wgpu's callback resources.
pub struct ViewportResources {
    shader: wgpu::ShaderModule,
    scene_layout: wgpu::PipelineLayout,
    /// One set per sample count drawn with so far (built on first use).
    pipelines: Vec<ScenePipelines>,
    blit_pipeline: wgpu::RenderPipeline,
    /// The same copy, stretched: the scene drawn smaller than the viewport.
    blit_scaled_pipeline: wgpu::RenderPipeline,
    blit_sampler: wgpu::Sampler,
    blit_layout: wgpu::BindGroupLayout,
    globals: wgpu::Buffer,
    globals_group: wgpu::BindGroup,
    targets: Option<Targets>,
    uploaded: Option<Uploaded>,
    software: bool,
}

struct Targets {
    size: [u32; 2],
    samples: u32,
    /// The multisampled colour target (None without MSAA: the scene is drawn into `resolved`).
    msaa: Option<wgpu::TextureView>,
    depth: wgpu::TextureView,
    resolved: wgpu::TextureView,
    blit_group: wgpu::BindGroup,
}

struct Uploaded {
    generation: u64,
    vertices: Option<wgpu::Buffer>,
    indices: Option<wgpu::Buffer>,
    index_count: u32,
    points: Option<wgpu::Buffer>,
    point_count: u32,
    lines: Option<wgpu::Buffer>,
    line_count: u32,
    overlay_points: Option<wgpu::Buffer>,
    overlay_point_count: u32,
    overlay_lines: Option<wgpu::Buffer>,
    overlay_line_count: u32,
}

/// Create the viewport's pipelines once and store them in the renderer (call at start-up).
/// Returns whether the adapter is a software renderer (lavapipe, llvmpipe: wgpu's
/// `DeviceType::Cpu`).
pub fn install(render_state: &egui_wgpu::RenderState) -> bool {
    let software = render_state.adapter.get_info().device_type == wgpu::DeviceType::Cpu;
    let resources =
        ViewportResources::new(&render_state.device, render_state.target_format, software);
    render_state.renderer.write().callback_resources.insert(resources);
    software
}

impl ViewportResources {
    /// `software`: the adapter is a CPU renderer (lavapipe), where 4x MSAA is the frame's cost.
    pub fn new(
        device: &wgpu::Device,
        target_format: wgpu::TextureFormat,
        software: bool,
    ) -> ViewportResources {
        let shader = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("viewport"),
            source: wgpu::ShaderSource::Wgsl(
                concat!(include_str!("fullscreen.wgsl"), include_str!("shaders.wgsl")).into(),
            ),
        });
        let globals_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("viewport globals"),
            entries: &[wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::VERTEX_FRAGMENT,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Uniform,
                    has_dynamic_offset: false,
                    min_binding_size: None,
                },
                count: None,
            }],
        });
        let blit_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("viewport blit"),
            entries: &texture_and_sampler_entries(0),
        });
        let scene_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("viewport scene"),
            bind_group_layouts: &[Some(&globals_layout)],
            immediate_size: 0,
        });
        let blit_pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("viewport blit"),
            bind_group_layouts: &[Some(&blit_layout)],
            immediate_size: 0,
        });
        let globals = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("viewport globals"),
            size: std::mem::size_of::<Globals>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let globals_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("viewport globals"),
            layout: &globals_layout,
            entries: &[wgpu::BindGroupEntry { binding: 0, resource: globals.as_entire_binding() }],
        });
        let blit = |fragment: &str| {
            fullscreen_pipeline(
                device,
                "viewport blit",
                &blit_pipeline_layout,
                &shader,
                fragment,
                &[],
                target_format,
                None,
            )
        };
        let (blit_pipeline, blit_scaled_pipeline) = (blit("fs_blit"), blit("fs_blit_scaled"));
        let blit_sampler = linear_clamp_sampler(device, "viewport blit");
        let pipelines = vec![ScenePipelines::new(device, &shader, &scene_layout, MSAA)];
        ViewportResources {
            shader,
            scene_layout,
            pipelines,
            blit_pipeline,
            blit_scaled_pipeline,
            blit_sampler,
            blit_layout,
            globals,
            globals_group,
            targets: None,
            uploaded: None,
            software,
        }
    }

    /// Samples a pixel for a view that is `moving` (playback, the turntable, an orbit): 4x MSAA,
    /// except on a software renderer while the view moves, where MSAA at 1280 x 800 costs about
    /// two thirds of a frame (docs/studio.md) and the moving image hides the jagged edges.
    pub fn samples(&self, moving: bool) -> u32 {
        if moving && self.software { 1 } else { MSAA }
    }

    /// The size to draw the scene at for a viewport of `size` pixels (see [`render_scale`]).
    pub fn render_size(&self, size: [u32; 2], moving: bool) -> [u32; 2] {
        scaled_size(size, render_scale(self.software, moving))
    }

    /// Draw the scene offscreen with `samples` per pixel (resolved into `resolved` when above
    /// 1), which `paint` blits into egui's pass. Used by the paint callback and by the headless
    /// benchmark.
    #[allow(clippy::too_many_arguments)]
    pub fn render(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        scene: &Scene,
        camera: &CameraMatrices,
        shading: Shading,
        point_size: f32,
        size: [u32; 2],
        light: [f32; 3],
        samples: u32,
    ) {
        self.ensure_targets(device, size, samples);
        if !self.pipelines.iter().any(|p| p.samples == samples) {
            self.pipelines.push(ScenePipelines::new(
                device,
                &self.shader,
                &self.scene_layout,
                samples,
            ));
        }
        self.upload(device, queue, scene);
        let mode = match shading {
            Shading::Lit => 0.0,
            Shading::Normals => 1.0,
        };
        let globals = Globals {
            view_proj: (camera.proj * camera.view).to_cols_array_2d(),
            view: camera.view.to_cols_array_2d(),
            params: [mode, point_size, size[0] as f32, size[1] as f32],
            light: [light[0], light[1], light[2], 0.0],
        };
        queue.write_buffer(&self.globals, 0, bytemuck::bytes_of(&globals));
        let (Some(targets), Some(up), Some(pipelines)) =
            (&self.targets, &self.uploaded, self.pipelines.iter().find(|p| p.samples == samples))
        else {
            return;
        };
        let [r, g, b] = BACKGROUND;
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("viewport scene"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: targets.msaa.as_ref().unwrap_or(&targets.resolved),
                depth_slice: None,
                resolve_target: targets.msaa.as_ref().map(|_| &targets.resolved),
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(wgpu::Color { r, g, b, a: 1.0 }),
                    store: if targets.msaa.is_some() {
                        wgpu::StoreOp::Discard
                    } else {
                        wgpu::StoreOp::Store
                    },
                },
            })],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &targets.depth,
                depth_ops: Some(wgpu::Operations {
                    load: wgpu::LoadOp::Clear(1.0),
                    store: wgpu::StoreOp::Discard,
                }),
                stencil_ops: None,
            }),
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_bind_group(0, &self.globals_group, &[]);
        if let (Some(v), Some(i)) = (&up.vertices, &up.indices) {
            pass.set_pipeline(&pipelines.mesh);
            pass.set_vertex_buffer(0, v.slice(..));
            pass.set_index_buffer(i.slice(..), wgpu::IndexFormat::Uint32);
            pass.draw_indexed(0..up.index_count, 0, 0..1);
        }
        if let Some(l) = &up.lines {
            pass.set_pipeline(&pipelines.lines);
            pass.set_vertex_buffer(0, l.slice(..));
            pass.draw(0..up.line_count, 0..1);
        }
        if let Some(p) = &up.points {
            pass.set_pipeline(&pipelines.points);
            pass.set_vertex_buffer(0, p.slice(..));
            pass.draw(0..4, 0..up.point_count);
        }
        if let Some(l) = &up.overlay_lines {
            pass.set_pipeline(&pipelines.overlay_lines);
            pass.set_vertex_buffer(0, l.slice(..));
            pass.draw(0..up.overlay_line_count, 0..1);
        }
        if let Some(p) = &up.overlay_points {
            pass.set_pipeline(&pipelines.overlay_points);
            pass.set_vertex_buffer(0, p.slice(..));
            pass.draw(0..4, 0..up.overlay_point_count);
        }
    }

    fn ensure_targets(&mut self, device: &wgpu::Device, size: [u32; 2], samples: u32) {
        if self.targets.as_ref().is_some_and(|t| t.size == size && t.samples == samples) {
            return;
        }
        let extent = wgpu::Extent3d { width: size[0], height: size[1], depth_or_array_layers: 1 };
        let make = |label: &str, format, samples, usage| {
            device
                .create_texture(&wgpu::TextureDescriptor {
                    label: Some(label),
                    size: extent,
                    mip_level_count: 1,
                    sample_count: samples,
                    dimension: wgpu::TextureDimension::D2,
                    format,
                    usage,
                    view_formats: &[],
                })
                .create_view(&wgpu::TextureViewDescriptor::default())
        };
        let msaa = (samples > 1).then(|| {
            make("viewport msaa", COLOR_FORMAT, samples, wgpu::TextureUsages::RENDER_ATTACHMENT)
        });
        let depth =
            make("viewport depth", DEPTH_FORMAT, samples, wgpu::TextureUsages::RENDER_ATTACHMENT);
        let resolved = make(
            "viewport resolved",
            COLOR_FORMAT,
            1,
            wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
        );
        let blit_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("viewport blit"),
            layout: &self.blit_layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: wgpu::BindingResource::TextureView(&resolved),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::Sampler(&self.blit_sampler),
                },
            ],
        });
        self.targets = Some(Targets { size, samples, msaa, depth, resolved, blit_group });
    }

    fn upload(&mut self, device: &wgpu::Device, queue: &wgpu::Queue, scene: &Scene) {
        if self.uploaded.as_ref().is_some_and(|u| u.generation == scene.generation) {
            return;
        }
        let buffer =
            |label: &str, bytes: &[u8], usage: wgpu::BufferUsages| -> Option<wgpu::Buffer> {
                if bytes.is_empty() {
                    return None;
                }
                let b = device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some(label),
                    size: bytes.len() as u64,
                    usage: usage | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                });
                queue.write_buffer(&b, 0, bytes);
                Some(b)
            };
        self.uploaded = Some(Uploaded {
            generation: scene.generation,
            vertices: buffer(
                "viewport vertices",
                bytemuck::cast_slice(&scene.vertices),
                wgpu::BufferUsages::VERTEX,
            ),
            indices: buffer(
                "viewport indices",
                bytemuck::cast_slice(&scene.indices),
                wgpu::BufferUsages::INDEX,
            ),
            index_count: scene.indices.len() as u32,
            points: buffer(
                "viewport points",
                bytemuck::cast_slice(&scene.points),
                wgpu::BufferUsages::VERTEX,
            ),
            point_count: scene.points.len() as u32,
            lines: buffer(
                "viewport lines",
                bytemuck::cast_slice(&scene.lines),
                wgpu::BufferUsages::VERTEX,
            ),
            line_count: scene.lines.len() as u32,
            overlay_points: buffer(
                "viewport overlay points",
                bytemuck::cast_slice(&scene.overlay_points),
                wgpu::BufferUsages::VERTEX,
            ),
            overlay_point_count: scene.overlay_points.len() as u32,
            overlay_lines: buffer(
                "viewport overlay lines",
                bytemuck::cast_slice(&scene.overlay_lines),
                wgpu::BufferUsages::VERTEX,
            ),
            overlay_line_count: scene.overlay_lines.len() as u32,
        });
    }
}

/// The scene's resolution per axis, relative to the viewport's pixels: all of them, except
/// while the view moves on a software renderer ([`SOFTWARE_MOVING_SCALE`]).
pub fn render_scale(software: bool, moving: bool) -> f32 {
    if moving && software { SOFTWARE_MOVING_SCALE } else { 1.0 }
}

/// `size` scaled by `scale` per axis, rounded, at least one pixel.
pub fn scaled_size(size: [u32; 2], scale: f32) -> [u32; 2] {
    size.map(|s| ((s as f32 * scale).round() as u32).max(1))
}

#[cfg(test)]
mod tests;

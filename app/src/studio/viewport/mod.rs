//! The 3D viewport: an egui wgpu paint callback. It takes a [`Scene`] (meshes, points and
//! lines, already in world space), camera matrices and a shading mode, never the app. The
//! scene is rendered offscreen (4x MSAA colour + 32-bit depth) in `prepare()`, resolved, and
//! copied into egui's render pass in `paint()` (egui's pass has neither depth nor MSAA).

use bytemuck::{Pod, Zeroable};
use eframe::egui;
use eframe::egui_wgpu::{self, wgpu};
use glam::{Mat4, Vec3};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

pub const MSAA: u32 = 4;
const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;
const COLOR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;
/// The viewport's background (linear RGB).
pub const BACKGROUND: [f64; 3] = [0.018, 0.020, 0.026];

#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct MeshVertex {
    pub pos: [f32; 3],
    pub normal: [f32; 3],
    pub color: [f32; 4],
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct ColoredPoint {
    pub pos: [f32; 3],
    pub color: [f32; 4],
}

/// What the viewport draws: triangles with per-vertex normals and colours, points (drawn as
/// round billboards) and line segments. Built once per change; the renderer re-uploads only
/// when the generation changes.
#[derive(Debug, Default)]
pub struct Scene {
    pub generation: u64,
    pub vertices: Vec<MeshVertex>,
    pub indices: Vec<u32>,
    pub points: Vec<ColoredPoint>,
    /// Pairs of endpoints.
    pub lines: Vec<ColoredPoint>,
    /// Drawn over everything else (the skeleton).
    pub overlay_points: Vec<ColoredPoint>,
    pub overlay_lines: Vec<ColoredPoint>,
}

static GENERATION: AtomicU64 = AtomicU64::new(1);

impl Scene {
    pub fn new() -> Scene {
        Scene { generation: GENERATION.fetch_add(1, Ordering::Relaxed), ..Scene::default() }
    }

    /// Add a triangle mesh with smooth vertex normals in one colour (linear RGB).
    pub fn add_mesh(&mut self, positions: &[Vec3], faces: &[[u32; 3]], color: [f32; 3]) {
        self.add_mesh_with_normals(positions, None, faces, color);
    }

    /// Add a triangle mesh with the given unit vertex normals (an SDF's gradient), or normals
    /// from its triangles (area-weighted) when there are none.
    pub fn add_mesh_with_normals(&mut self, positions: &[Vec3], normals: Option<&[Vec3]>, faces: &[[u32; 3]], color: [f32; 3]) {
        let owned;
        let normals = match normals {
            Some(n) if n.len() == positions.len() => n,
            _ => {
                // A vertex on no proper triangle gets "up" rather than no normal at all.
                owned = avatar_core::mesh::vertex_normals(positions, faces).into_iter().map(|n| n.normalize_or(Vec3::Y)).collect::<Vec<_>>();
                &owned[..]
            }
        };
        let base = self.vertices.len() as u32;
        self.vertices.extend(positions.iter().zip(normals).map(|(p, n)| MeshVertex { pos: p.to_array(), normal: n.to_array(), color: [color[0], color[1], color[2], 1.0] }));
        self.indices.extend(faces.iter().flat_map(|f| f.map(|i| i + base)));
    }

    /// Points drawn as discs; `size` scales the viewport's point size.
    pub fn add_points(&mut self, points: &[Vec3], color: [f32; 3], size: f32) {
        self.points.extend(points.iter().map(|p| ColoredPoint { pos: p.to_array(), color: [color[0], color[1], color[2], size] }));
    }

    /// Points with normals, lit by a fixed key light (so that the cloud reads as a surface).
    pub fn add_lit_points(&mut self, points: &[Vec3], normals: &[Vec3], color: [f32; 3], size: f32) {
        let key = Vec3::new(-0.4, 0.6, 0.7).normalize();
        self.points.extend(points.iter().zip(normals.iter().chain(std::iter::repeat(&Vec3::Z))).map(|(p, n)| {
            let l = 0.25 + 0.75 * n.dot(key).abs();
            ColoredPoint { pos: p.to_array(), color: [color[0] * l, color[1] * l, color[2] * l, size] }
        }));
    }

    /// A skeleton drawn over the meshes: bones as lines from each joint to its parent.
    pub fn add_skeleton(&mut self, joints: &[Vec3], parents: &[i32], color: [f32; 3]) {
        for (j, &p) in parents.iter().enumerate() {
            if p >= 0 {
                let c = [color[0], color[1], color[2], 1.0];
                self.overlay_lines.push(ColoredPoint { pos: joints[p as usize].to_array(), color: c });
                self.overlay_lines.push(ColoredPoint { pos: joints[j].to_array(), color: c });
            }
        }
        self.overlay_points.extend(joints.iter().map(|p| ColoredPoint { pos: p.to_array(), color: [1.0, 0.85, 0.35, 2.6] }));
    }

    pub fn add_line(&mut self, a: Vec3, b: Vec3, color: [f32; 3]) {
        let c = [color[0], color[1], color[2], 1.0];
        self.lines.push(ColoredPoint { pos: a.to_array(), color: c });
        self.lines.push(ColoredPoint { pos: b.to_array(), color: c });
    }

    /// A ground grid on the plane y = `y`.
    pub fn add_grid(&mut self, center: Vec3, y: f32, half: f32, step: f32) {
        let n = (half / step).round() as i32;
        for i in -n..=n {
            let t = i as f32 * step;
            let c = if i == 0 { [0.16, 0.17, 0.20] } else { [0.07, 0.075, 0.09] };
            self.add_line(Vec3::new(center.x + t, y, center.z - half), Vec3::new(center.x + t, y, center.z + half), c);
            self.add_line(Vec3::new(center.x - half, y, center.z + t), Vec3::new(center.x + half, y, center.z + t), c);
        }
    }

    /// Bounds of everything but the lines (the grid must not change framing).
    pub fn bounds(&self) -> Option<(Vec3, Vec3)> {
        let pts = self.vertices.iter().map(|v| Vec3::from(v.pos)).chain(self.points.iter().map(|p| Vec3::from(p.pos)));
        let mut it = pts.peekable();
        it.peek()?;
        Some(it.fold((Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)), |(lo, hi), p| (lo.min(p), hi.max(p))))
    }

    pub fn is_empty(&self) -> bool {
        self.indices.is_empty() && self.points.is_empty() && self.lines.is_empty() && self.overlay_points.is_empty()
    }
}

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
/// wgpu renderer is missing.
pub fn paint(ui: &mut egui::Ui, rect: egui::Rect, scene: Arc<Scene>, camera: CameraMatrices, shading: Shading, point_size: f32, light: [f32; 3]) {
    let ppp = ui.ctx().pixels_per_point();
    let size = [(rect.width() * ppp).round().max(1.0) as u32, (rect.height() * ppp).round().max(1.0) as u32];
    let cb = ViewportCallback { scene, camera, shading, point_size: point_size * ppp, size, light };
    ui.painter().add(egui_wgpu::Callback::new_paint_callback(rect, cb));
}

struct ViewportCallback {
    scene: Arc<Scene>,
    camera: CameraMatrices,
    shading: Shading,
    point_size: f32,
    size: [u32; 2],
    light: [f32; 3],
}

/// GPU objects of the viewport, kept in egui-wgpu's callback resources.
pub struct ViewportResources {
    mesh_pipeline: wgpu::RenderPipeline,
    point_pipeline: wgpu::RenderPipeline,
    line_pipeline: wgpu::RenderPipeline,
    overlay_point_pipeline: wgpu::RenderPipeline,
    overlay_line_pipeline: wgpu::RenderPipeline,
    blit_pipeline: wgpu::RenderPipeline,
    blit_layout: wgpu::BindGroupLayout,
    globals: wgpu::Buffer,
    globals_group: wgpu::BindGroup,
    targets: Option<Targets>,
    uploaded: Option<Uploaded>,
}

struct Targets {
    size: [u32; 2],
    msaa: wgpu::TextureView,
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
pub fn install(render_state: &egui_wgpu::RenderState) {
    let resources = ViewportResources::new(&render_state.device, render_state.target_format);
    render_state.renderer.write().callback_resources.insert(resources);
}

impl ViewportResources {
    pub fn new(device: &wgpu::Device, target_format: wgpu::TextureFormat) -> ViewportResources {
        let shader = device.create_shader_module(wgpu::ShaderModuleDescriptor { label: Some("viewport"), source: wgpu::ShaderSource::Wgsl(include_str!("shaders.wgsl").into()) });
        let globals_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("viewport globals"),
            entries: &[wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::VERTEX_FRAGMENT,
                ty: wgpu::BindingType::Buffer { ty: wgpu::BufferBindingType::Uniform, has_dynamic_offset: false, min_binding_size: None },
                count: None,
            }],
        });
        let blit_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("viewport blit"),
            entries: &[wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::FRAGMENT,
                ty: wgpu::BindingType::Texture { sample_type: wgpu::TextureSampleType::Float { filterable: false }, view_dimension: wgpu::TextureViewDimension::D2, multisampled: false },
                count: None,
            }],
        });
        let scene_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor { label: Some("viewport scene"), bind_group_layouts: &[Some(&globals_layout)], immediate_size: 0 });
        let blit_pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor { label: Some("viewport blit"), bind_group_layouts: &[Some(&blit_layout)], immediate_size: 0 });
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
        let depth = Some(wgpu::DepthStencilState {
            format: DEPTH_FORMAT,
            depth_write_enabled: Some(true),
            depth_compare: Some(wgpu::CompareFunction::Less),
            stencil: wgpu::StencilState::default(),
            bias: wgpu::DepthBiasState::default(),
        });
        let msaa = wgpu::MultisampleState { count: MSAA, mask: !0, alpha_to_coverage_enabled: false };
        let color_target = [Some(wgpu::ColorTargetState { format: COLOR_FORMAT, blend: None, write_mask: wgpu::ColorWrites::ALL })];
        let mesh_attrs = wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3, 2 => Float32x4];
        let point_attrs = wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x4];
        let overlay_depth = Some(wgpu::DepthStencilState {
            format: DEPTH_FORMAT,
            depth_write_enabled: Some(false),
            depth_compare: Some(wgpu::CompareFunction::Always),
            stencil: wgpu::StencilState::default(),
            bias: wgpu::DepthBiasState::default(),
        });
        let pipeline = |label: &str, vs: &str, fs: &str, buffers: &[Option<wgpu::VertexBufferLayout>], topology: wgpu::PrimitiveTopology, overlay: bool| {
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some(label),
                layout: Some(&scene_layout),
                vertex: wgpu::VertexState { module: &shader, entry_point: Some(vs), compilation_options: Default::default(), buffers },
                primitive: wgpu::PrimitiveState { topology, cull_mode: None, ..Default::default() },
                depth_stencil: if overlay { overlay_depth.clone() } else { depth.clone() },
                multisample: msaa,
                fragment: Some(wgpu::FragmentState { module: &shader, entry_point: Some(fs), compilation_options: Default::default(), targets: &color_target }),
                multiview_mask: None,
                cache: None,
            })
        };
        let mesh_pipeline = pipeline(
            "viewport mesh",
            "vs_mesh",
            "fs_mesh",
            &[Some(wgpu::VertexBufferLayout { array_stride: std::mem::size_of::<MeshVertex>() as u64, step_mode: wgpu::VertexStepMode::Vertex, attributes: &mesh_attrs })],
            wgpu::PrimitiveTopology::TriangleList,
            false,
        );
        let point_layout = [Some(wgpu::VertexBufferLayout { array_stride: std::mem::size_of::<ColoredPoint>() as u64, step_mode: wgpu::VertexStepMode::Instance, attributes: &point_attrs })];
        let line_layout = [Some(wgpu::VertexBufferLayout { array_stride: std::mem::size_of::<ColoredPoint>() as u64, step_mode: wgpu::VertexStepMode::Vertex, attributes: &point_attrs })];
        let point_pipeline = pipeline("viewport points", "vs_point", "fs_point", &point_layout, wgpu::PrimitiveTopology::TriangleStrip, false);
        let line_pipeline = pipeline("viewport lines", "vs_line", "fs_line", &line_layout, wgpu::PrimitiveTopology::LineList, false);
        let overlay_point_pipeline = pipeline("viewport overlay points", "vs_point", "fs_point", &point_layout, wgpu::PrimitiveTopology::TriangleStrip, true);
        let overlay_line_pipeline = pipeline("viewport overlay lines", "vs_line", "fs_line", &line_layout, wgpu::PrimitiveTopology::LineList, true);
        let blit_pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("viewport blit"),
            layout: Some(&blit_pipeline_layout),
            vertex: wgpu::VertexState { module: &shader, entry_point: Some("vs_blit"), compilation_options: Default::default(), buffers: &[] },
            primitive: wgpu::PrimitiveState::default(),
            depth_stencil: None,
            multisample: wgpu::MultisampleState::default(),
            fragment: Some(wgpu::FragmentState {
                module: &shader,
                entry_point: Some("fs_blit"),
                compilation_options: Default::default(),
                targets: &[Some(wgpu::ColorTargetState { format: target_format, blend: None, write_mask: wgpu::ColorWrites::ALL })],
            }),
            multiview_mask: None,
            cache: None,
        });
        ViewportResources { mesh_pipeline, point_pipeline, line_pipeline, overlay_point_pipeline, overlay_line_pipeline, blit_pipeline, blit_layout, globals, globals_group, targets: None, uploaded: None }
    }

    /// Draw the scene into the offscreen MSAA target (resolved into `resolved`, which `paint`
    /// blits into egui's pass). Used by the paint callback and by the headless benchmark.
    #[allow(clippy::too_many_arguments)]
    pub fn render(&mut self, device: &wgpu::Device, queue: &wgpu::Queue, encoder: &mut wgpu::CommandEncoder, scene: &Scene, camera: &CameraMatrices, shading: Shading, point_size: f32, size: [u32; 2], light: [f32; 3]) {
        self.ensure_targets(device, size);
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
        let (Some(targets), Some(up)) = (&self.targets, &self.uploaded) else {
            return;
        };
        let [r, g, b] = BACKGROUND;
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("viewport scene"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: &targets.msaa,
                depth_slice: None,
                resolve_target: Some(&targets.resolved),
                ops: wgpu::Operations { load: wgpu::LoadOp::Clear(wgpu::Color { r, g, b, a: 1.0 }), store: wgpu::StoreOp::Discard },
            })],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &targets.depth,
                depth_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Clear(1.0), store: wgpu::StoreOp::Discard }),
                stencil_ops: None,
            }),
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_bind_group(0, &self.globals_group, &[]);
        if let (Some(v), Some(i)) = (&up.vertices, &up.indices) {
            pass.set_pipeline(&self.mesh_pipeline);
            pass.set_vertex_buffer(0, v.slice(..));
            pass.set_index_buffer(i.slice(..), wgpu::IndexFormat::Uint32);
            pass.draw_indexed(0..up.index_count, 0, 0..1);
        }
        if let Some(l) = &up.lines {
            pass.set_pipeline(&self.line_pipeline);
            pass.set_vertex_buffer(0, l.slice(..));
            pass.draw(0..up.line_count, 0..1);
        }
        if let Some(p) = &up.points {
            pass.set_pipeline(&self.point_pipeline);
            pass.set_vertex_buffer(0, p.slice(..));
            pass.draw(0..4, 0..up.point_count);
        }
        if let Some(l) = &up.overlay_lines {
            pass.set_pipeline(&self.overlay_line_pipeline);
            pass.set_vertex_buffer(0, l.slice(..));
            pass.draw(0..up.overlay_line_count, 0..1);
        }
        if let Some(p) = &up.overlay_points {
            pass.set_pipeline(&self.overlay_point_pipeline);
            pass.set_vertex_buffer(0, p.slice(..));
            pass.draw(0..4, 0..up.overlay_point_count);
        }
    }

    fn ensure_targets(&mut self, device: &wgpu::Device, size: [u32; 2]) {
        if self.targets.as_ref().is_some_and(|t| t.size == size) {
            return;
        }
        let extent = wgpu::Extent3d { width: size[0], height: size[1], depth_or_array_layers: 1 };
        let make = |label: &str, format, samples, usage| {
            device
                .create_texture(&wgpu::TextureDescriptor { label: Some(label), size: extent, mip_level_count: 1, sample_count: samples, dimension: wgpu::TextureDimension::D2, format, usage, view_formats: &[] })
                .create_view(&wgpu::TextureViewDescriptor::default())
        };
        let msaa = make("viewport msaa", COLOR_FORMAT, MSAA, wgpu::TextureUsages::RENDER_ATTACHMENT);
        let depth = make("viewport depth", DEPTH_FORMAT, MSAA, wgpu::TextureUsages::RENDER_ATTACHMENT);
        let resolved = make("viewport resolved", COLOR_FORMAT, 1, wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING);
        let blit_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("viewport blit"),
            layout: &self.blit_layout,
            entries: &[wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(&resolved) }],
        });
        self.targets = Some(Targets { size, msaa, depth, resolved, blit_group });
    }

    fn upload(&mut self, device: &wgpu::Device, queue: &wgpu::Queue, scene: &Scene) {
        if self.uploaded.as_ref().is_some_and(|u| u.generation == scene.generation) {
            return;
        }
        let buffer = |label: &str, bytes: &[u8], usage: wgpu::BufferUsages| -> Option<wgpu::Buffer> {
            if bytes.is_empty() {
                return None;
            }
            let b = device.create_buffer(&wgpu::BufferDescriptor { label: Some(label), size: bytes.len() as u64, usage: usage | wgpu::BufferUsages::COPY_DST, mapped_at_creation: false });
            queue.write_buffer(&b, 0, bytes);
            Some(b)
        };
        self.uploaded = Some(Uploaded {
            generation: scene.generation,
            vertices: buffer("viewport vertices", bytemuck::cast_slice(&scene.vertices), wgpu::BufferUsages::VERTEX),
            indices: buffer("viewport indices", bytemuck::cast_slice(&scene.indices), wgpu::BufferUsages::INDEX),
            index_count: scene.indices.len() as u32,
            points: buffer("viewport points", bytemuck::cast_slice(&scene.points), wgpu::BufferUsages::VERTEX),
            point_count: scene.points.len() as u32,
            lines: buffer("viewport lines", bytemuck::cast_slice(&scene.lines), wgpu::BufferUsages::VERTEX),
            line_count: scene.lines.len() as u32,
            overlay_points: buffer("viewport overlay points", bytemuck::cast_slice(&scene.overlay_points), wgpu::BufferUsages::VERTEX),
            overlay_point_count: scene.overlay_points.len() as u32,
            overlay_lines: buffer("viewport overlay lines", bytemuck::cast_slice(&scene.overlay_lines), wgpu::BufferUsages::VERTEX),
            overlay_line_count: scene.overlay_lines.len() as u32,
        });
    }
}

impl egui_wgpu::CallbackTrait for ViewportCallback {
    fn prepare(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        _screen: &egui_wgpu::ScreenDescriptor,
        encoder: &mut wgpu::CommandEncoder,
        resources: &mut egui_wgpu::CallbackResources,
    ) -> Vec<wgpu::CommandBuffer> {
        if let Some(res) = resources.get_mut::<ViewportResources>() {
            res.render(device, queue, encoder, &self.scene, &self.camera, self.shading, self.point_size, self.size, self.light);
        }
        Vec::new()
    }

    fn paint(&self, _info: egui::PaintCallbackInfo, pass: &mut wgpu::RenderPass<'static>, resources: &egui_wgpu::CallbackResources) {
        let Some(res) = resources.get::<ViewportResources>() else {
            return;
        };
        let Some(targets) = &res.targets else {
            return;
        };
        pass.set_pipeline(&res.blit_pipeline);
        pass.set_bind_group(0, &targets.blit_group, &[]);
        pass.draw(0..3, 0..1);
    }
}

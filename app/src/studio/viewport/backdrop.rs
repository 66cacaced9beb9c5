//! The window's flat backdrop (the panels' colour) on a software renderer, painted by a
//! one-line shader instead of egui's.
//!
//! Why: egui-wgpu 0.37's fragment shader branches on a uniform (`predictable_texture_filtering`,
//! for egui_kittest) into a manual four-tap filter whose wrap modes use integer division. Mesa
//! 22's llvmpipe (lavapipe) runs both sides of such a branch for every pixel, so each pixel egui
//! paints costs about 47 ns of CPU (a full 1280 x 800 fill: 47 ms), and the panels' fills were
//! about a third of a playback frame (docs/studio.md). Here the panels are left unfilled
//! (`style::apply`) and this backdrop, drawn first, gives them the same colour: the same pixels
//! at a fraction of the cost. On a GPU egui fills the panels as usual.

use eframe::egui;
use eframe::egui_wgpu::{self, wgpu};

/// The backdrop's pipeline, kept in egui-wgpu's callback resources.
pub struct Backdrop {
    pipeline: wgpu::RenderPipeline,
}

/// Create the backdrop's pipeline (call at start-up on a software renderer): `color` is the
/// panels' fill.
pub fn install(render_state: &egui_wgpu::RenderState, color: egui::Color32) {
    let device = &render_state.device;
    let shader = device.create_shader_module(wgpu::ShaderModuleDescriptor { label: Some("backdrop"), source: wgpu::ShaderSource::Wgsl(SHADER.into()) });
    // egui's target holds gamma-encoded 8-bit values (as egui's own shader writes them).
    let [r, g, b, a] = color.to_normalized_gamma_f32();
    let constants = [("r", r as f64), ("g", g as f64), ("b", b as f64), ("a", a as f64)];
    let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor { label: Some("backdrop"), bind_group_layouts: &[], immediate_size: 0 });
    let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some("backdrop"),
        layout: Some(&layout),
        vertex: wgpu::VertexState { module: &shader, entry_point: Some("vs_main"), compilation_options: Default::default(), buffers: &[] },
        primitive: wgpu::PrimitiveState::default(),
        depth_stencil: None,
        multisample: wgpu::MultisampleState::default(),
        fragment: Some(wgpu::FragmentState {
            module: &shader,
            entry_point: Some("fs_main"),
            compilation_options: wgpu::PipelineCompilationOptions { constants: &constants, ..Default::default() },
            targets: &[Some(wgpu::ColorTargetState { format: render_state.target_format, blend: None, write_mask: wgpu::ColorWrites::ALL })],
        }),
        multiview_mask: None,
        cache: None,
    });
    render_state.renderer.write().callback_resources.insert(Backdrop { pipeline });
}

/// Paint the backdrop over `rect` (call before anything else is painted in the layer).
pub fn paint(ui: &egui::Ui, rect: egui::Rect) {
    ui.painter().add(egui_wgpu::Callback::new_paint_callback(rect, BackdropCallback));
}

struct BackdropCallback;

impl egui_wgpu::CallbackTrait for BackdropCallback {
    fn paint(&self, _info: egui::PaintCallbackInfo, pass: &mut wgpu::RenderPass<'static>, resources: &egui_wgpu::CallbackResources) {
        if let Some(b) = resources.get::<Backdrop>() {
            pass.set_pipeline(&b.pipeline);
            pass.draw(0..3, 0..1);
        }
    }
}

/// One triangle over the callback's viewport, one colour.
const SHADER: &str = "
override r: f32;
override g: f32;
override b: f32;
override a: f32;

@vertex
fn vs_main(@builtin(vertex_index) vi: u32) -> @builtin(position) vec4<f32> {
    let x = f32((vi << 1u) & 2u);
    let y = f32(vi & 2u);
    return vec4<f32>(x * 2.0 - 1.0, 1.0 - y * 2.0, 0.0, 1.0);
}

@fragment
fn fs_main() -> @location(0) vec4<f32> {
    return vec4<f32>(r, g, b, a);
}
";

//! The UI's large flat parts on a software renderer, painted by one-line shaders instead of
//! egui's: the window's backdrop (the panels' colour) and images (the capture's thumbnails).
//!
//! Why: egui-wgpu 0.37's fragment shader branches on a uniform (`predictable_texture_filtering`,
//! for egui_kittest) into a manual four-tap filter whose wrap modes use integer division. Mesa
//! 22's llvmpipe (lavapipe) runs both sides of such a branch for every pixel, so each pixel egui
//! paints costs about 47 ns of CPU (a full 1280 x 800 fill: 47 ms; more for a textured one), and
//! the panels' fills and the thumbnails were about half of a playback frame (docs/studio.md).
//! Here the panels are left unfilled (`style::apply`) and the backdrop, drawn first, gives them
//! their colour; a thumbnail is sampled as egui samples it (its texture's bytes, a linear
//! clamping sampler, pixel centres mapped linearly onto the image's rectangle). The same pixels
//! (egui's dithering aside, at most one level) at a fraction of the cost. On a GPU egui paints
//! everything as usual.

use eframe::egui;
use eframe::egui_wgpu::{self, wgpu};
use std::collections::HashMap;
use std::sync::Arc;

/// Uploaded images kept at most (thumbnails of a few captures); beyond that all are dropped
/// and the ones still shown uploaded again.
const MAX_IMAGES: usize = 512;

/// The pipelines and uploaded images, kept in egui-wgpu's callback resources.
pub struct Flat {
    backdrop: wgpu::RenderPipeline,
    image: wgpu::RenderPipeline,
    image_layout: wgpu::BindGroupLayout,
    sampler: wgpu::Sampler,
    images: HashMap<egui::TextureId, wgpu::BindGroup>,
}

/// Create the pipelines (call at start-up on a software renderer): `backdrop` is the panels'
/// fill.
pub fn install(render_state: &egui_wgpu::RenderState, backdrop: egui::Color32) {
    let device = &render_state.device;
    let shader = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("flat"),
        source: wgpu::ShaderSource::Wgsl(SHADER.into()),
    });
    let image_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("flat image"),
        entries: &super::pipelines::texture_and_sampler_entries(0),
    });
    // egui's target holds gamma-encoded 8-bit values (as egui's own shader writes them).
    let [r, g, b, a] = backdrop.to_normalized_gamma_f32();
    let constants = [("r", r as f64), ("g", g as f64), ("b", b as f64), ("a", a as f64)];
    let pipeline = |label: &str,
                    layouts: &[Option<&wgpu::BindGroupLayout>],
                    fs: &str,
                    constants: &[(&str, f64)],
                    blend: Option<wgpu::BlendState>| {
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some(label),
            bind_group_layouts: layouts,
            immediate_size: 0,
        });
        super::pipelines::fullscreen_pipeline(
            device,
            label,
            &layout,
            &shader,
            fs,
            constants,
            render_state.target_format,
            blend,
        )
    };
    let backdrop = pipeline("flat backdrop", &[], "fs_backdrop", &constants, None);
    // egui's blending (premultiplied alpha).
    let image = pipeline(
        "flat image",
        &[Some(&image_layout)],
        "fs_image",
        &[],
        Some(wgpu::BlendState::PREMULTIPLIED_ALPHA_BLENDING),
    );
    // egui's sampler for `TextureOptions::LINEAR`.
    let sampler = super::pipelines::linear_clamp_sampler(device, "flat image");
    render_state.renderer.write().callback_resources.insert(Flat {
        backdrop,
        image,
        image_layout,
        sampler,
        images: HashMap::new(),
    });
}

/// Paint the backdrop over `rect` (before anything else is painted in the layer).
pub fn backdrop(painter: &egui::Painter, rect: egui::Rect) {
    painter.add(egui_wgpu::Callback::new_paint_callback(rect, Backdrop));
}

/// An image to paint over `rect`, as `painter.image(id, rect, (0,0)-(1,1), WHITE)` with
/// `TextureOptions::LINEAR` would: `pixels` as egui holds them (premultiplied), `id` the egui
/// texture made from them (it names the upload).
#[derive(Clone)]
pub struct FlatImage {
    pub rect: egui::Rect,
    pub id: egui::TextureId,
    pub pixels: Arc<egui::ColorImage>,
}

/// One shape that paints `images` in order, clipped to `clip` (one callback for all: each
/// callback costs egui-wgpu a pipeline switch and back).
pub fn images(clip: egui::Rect, mut images: Vec<FlatImage>) -> egui::Shape {
    images.retain(|i| i.rect.intersects(clip));
    let rect = images.iter().fold(egui::Rect::NOTHING, |r, i| r.union(i.rect)).intersect(clip);
    egui::Shape::Callback(egui_wgpu::Callback::new_paint_callback(rect, Images(images)))
}

struct Backdrop;

impl egui_wgpu::CallbackTrait for Backdrop {
    fn paint(
        &self,
        _info: egui::PaintCallbackInfo,
        pass: &mut wgpu::RenderPass<'static>,
        resources: &egui_wgpu::CallbackResources,
    ) {
        if let Some(flat) = resources.get::<Flat>() {
            pass.set_pipeline(&flat.backdrop);
            pass.draw(0..3, 0..1);
        }
    }
}

struct Images(Vec<FlatImage>);

impl egui_wgpu::CallbackTrait for Images {
    fn prepare(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        _screen: &egui_wgpu::ScreenDescriptor,
        _encoder: &mut wgpu::CommandEncoder,
        resources: &mut egui_wgpu::CallbackResources,
    ) -> Vec<wgpu::CommandBuffer> {
        if let Some(flat) = resources.get_mut::<Flat>() {
            for image in &self.0 {
                flat.upload(device, queue, image);
            }
        }
        Vec::new()
    }

    fn paint(
        &self,
        info: egui::PaintCallbackInfo,
        pass: &mut wgpu::RenderPass<'static>,
        resources: &egui_wgpu::CallbackResources,
    ) {
        let Some(flat) = resources.get::<Flat>() else {
            return;
        };
        pass.set_pipeline(&flat.image);
        let ppp = info.pixels_per_point;
        for image in &self.0 {
            let Some(group) = flat.images.get(&image.id) else {
                continue;
            };
            // The image's rectangle in pixels; egui-wgpu's scissor (the clip) stays.
            let r = image.rect;
            pass.set_viewport(
                r.min.x * ppp,
                r.min.y * ppp,
                r.width() * ppp,
                r.height() * ppp,
                0.0,
                1.0,
            );
            pass.set_bind_group(0, group, &[]);
            pass.draw(0..3, 0..1);
        }
    }
}

impl Flat {
    fn upload(&mut self, device: &wgpu::Device, queue: &wgpu::Queue, image: &FlatImage) {
        if self.images.contains_key(&image.id) {
            return;
        }
        if self.images.len() >= MAX_IMAGES {
            self.images.clear();
        }
        let [w, h] = image.pixels.size.map(|s| s.max(1) as u32);
        let size = wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 };
        let texture = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("flat image"),
            size,
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: wgpu::TextureFormat::Rgba8Unorm,
            usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        });
        let bytes: &[u8] = bytemuck::cast_slice(&image.pixels.pixels);
        if bytes.len() == (w * h * 4) as usize {
            queue.write_texture(
                texture.as_image_copy(),
                bytes,
                wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(4 * w),
                    rows_per_image: Some(h),
                },
                size,
            );
        }
        let view = texture.create_view(&wgpu::TextureViewDescriptor::default());
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("flat image"),
            layout: &self.image_layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: wgpu::BindingResource::TextureView(&view),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::Sampler(&self.sampler),
                },
            ],
        });
        self.images.insert(image.id, group);
    }
}

/// Fills and images over the callback's viewport (fullscreen.wgsl's triangle).
const SHADER: &str = concat!(
    include_str!("fullscreen.wgsl"),
    "
override r: f32 = 0.0;
override g: f32 = 0.0;
override b: f32 = 0.0;
override a: f32 = 1.0;

@fragment
fn fs_backdrop() -> @location(0) vec4<f32> {
    return vec4<f32>(r, g, b, a);
}

@group(0) @binding(0) var image: texture_2d<f32>;
@group(0) @binding(1) var image_sampler: sampler;

@fragment
fn fs_image(in: FullscreenOut) -> @location(0) vec4<f32> {
    return textureSample(image, image_sampler, in.uv);
}
"
);

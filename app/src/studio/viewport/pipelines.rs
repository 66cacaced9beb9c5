//! The viewport's scene pipelines for one sample count: shaded meshes, points and lines, and
//! the overlay (skeleton) drawn over everything. The renderer keeps one set per sample count it
//! has drawn with (4x MSAA when still; 1 sample while the view moves on a software renderer).

use super::{COLOR_FORMAT, ColoredPoint, DEPTH_FORMAT, MeshVertex};
use eframe::egui_wgpu::wgpu;

pub(super) struct ScenePipelines {
    pub samples: u32,
    pub mesh: wgpu::RenderPipeline,
    pub points: wgpu::RenderPipeline,
    pub lines: wgpu::RenderPipeline,
    pub overlay_points: wgpu::RenderPipeline,
    pub overlay_lines: wgpu::RenderPipeline,
}

impl ScenePipelines {
    pub fn new(
        device: &wgpu::Device,
        shader: &wgpu::ShaderModule,
        layout: &wgpu::PipelineLayout,
        samples: u32,
    ) -> ScenePipelines {
        let depth = |overlay: bool| {
            Some(wgpu::DepthStencilState {
                format: DEPTH_FORMAT,
                depth_write_enabled: Some(!overlay),
                depth_compare: Some(if overlay {
                    wgpu::CompareFunction::Always
                } else {
                    wgpu::CompareFunction::Less
                }),
                stencil: wgpu::StencilState::default(),
                bias: wgpu::DepthBiasState::default(),
            })
        };
        let multisample =
            wgpu::MultisampleState { count: samples, mask: !0, alpha_to_coverage_enabled: false };
        let color_target = [Some(wgpu::ColorTargetState {
            format: COLOR_FORMAT,
            blend: None,
            write_mask: wgpu::ColorWrites::ALL,
        })];
        let mesh_attrs = wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3, 2 => Float32x4];
        let point_attrs = wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x4];
        let pipeline = |label: &str,
                        vs: &str,
                        fs: &str,
                        buffers: &[Option<wgpu::VertexBufferLayout>],
                        topology: wgpu::PrimitiveTopology,
                        overlay: bool| {
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some(label),
                layout: Some(layout),
                vertex: wgpu::VertexState {
                    module: shader,
                    entry_point: Some(vs),
                    compilation_options: Default::default(),
                    buffers,
                },
                primitive: wgpu::PrimitiveState { topology, cull_mode: None, ..Default::default() },
                depth_stencil: depth(overlay),
                multisample,
                fragment: Some(wgpu::FragmentState {
                    module: shader,
                    entry_point: Some(fs),
                    compilation_options: Default::default(),
                    targets: &color_target,
                }),
                multiview_mask: None,
                cache: None,
            })
        };
        let mesh_layout = [Some(wgpu::VertexBufferLayout {
            array_stride: std::mem::size_of::<MeshVertex>() as u64,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes: &mesh_attrs,
        })];
        let point_layout = [Some(wgpu::VertexBufferLayout {
            array_stride: std::mem::size_of::<ColoredPoint>() as u64,
            step_mode: wgpu::VertexStepMode::Instance,
            attributes: &point_attrs,
        })];
        let line_layout = [Some(wgpu::VertexBufferLayout {
            array_stride: std::mem::size_of::<ColoredPoint>() as u64,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes: &point_attrs,
        })];
        use wgpu::PrimitiveTopology::{LineList, TriangleList, TriangleStrip};
        ScenePipelines {
            samples,
            mesh: pipeline(
                "viewport mesh",
                "vs_mesh",
                "fs_mesh",
                &mesh_layout,
                TriangleList,
                false,
            ),
            points: pipeline(
                "viewport points",
                "vs_point",
                "fs_point",
                &point_layout,
                TriangleStrip,
                false,
            ),
            lines: pipeline("viewport lines", "vs_line", "fs_line", &line_layout, LineList, false),
            overlay_points: pipeline(
                "viewport overlay points",
                "vs_point",
                "fs_point",
                &point_layout,
                TriangleStrip,
                true,
            ),
            overlay_lines: pipeline(
                "viewport overlay lines",
                "vs_line",
                "fs_line",
                &line_layout,
                LineList,
                true,
            ),
        }
    }
}

/// A pipeline that draws one full-viewport triangle (`fullscreen.wgsl`'s `vs_fullscreen`, which
/// `shader` must include) with `shader`'s fragment entry point `fragment` into `format`: the
/// blit's and flat.rs's fills.
#[allow(clippy::too_many_arguments)]
pub(super) fn fullscreen_pipeline(
    device: &wgpu::Device,
    label: &str,
    layout: &wgpu::PipelineLayout,
    shader: &wgpu::ShaderModule,
    fragment: &str,
    constants: &[(&str, f64)],
    format: wgpu::TextureFormat,
    blend: Option<wgpu::BlendState>,
) -> wgpu::RenderPipeline {
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some(label),
        layout: Some(layout),
        vertex: wgpu::VertexState {
            module: shader,
            entry_point: Some("vs_fullscreen"),
            compilation_options: Default::default(),
            buffers: &[],
        },
        primitive: wgpu::PrimitiveState::default(),
        depth_stencil: None,
        multisample: wgpu::MultisampleState::default(),
        fragment: Some(wgpu::FragmentState {
            module: shader,
            entry_point: Some(fragment),
            compilation_options: wgpu::PipelineCompilationOptions {
                constants,
                ..Default::default()
            },
            targets: &[Some(wgpu::ColorTargetState {
                format,
                blend,
                write_mask: wgpu::ColorWrites::ALL,
            })],
        }),
        multiview_mask: None,
        cache: None,
    })
}

/// Bilinear filtering clamped at the edges (egui's `TextureOptions::LINEAR` too).
pub(super) fn linear_clamp_sampler(device: &wgpu::Device, label: &str) -> wgpu::Sampler {
    device.create_sampler(&wgpu::SamplerDescriptor {
        label: Some(label),
        mag_filter: wgpu::FilterMode::Linear,
        min_filter: wgpu::FilterMode::Linear,
        address_mode_u: wgpu::AddressMode::ClampToEdge,
        address_mode_v: wgpu::AddressMode::ClampToEdge,
        ..Default::default()
    })
}

/// A filterable 2D texture at `binding` and its sampler at `binding + 1`, both for the fragment
/// stage: what every copy of an image into egui's pass binds.
pub(super) fn texture_and_sampler_entries(binding: u32) -> [wgpu::BindGroupLayoutEntry; 2] {
    [
        wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::FRAGMENT,
            ty: wgpu::BindingType::Texture {
                sample_type: wgpu::TextureSampleType::Float { filterable: true },
                view_dimension: wgpu::TextureViewDimension::D2,
                multisampled: false,
            },
            count: None,
        },
        wgpu::BindGroupLayoutEntry {
            binding: binding + 1,
            visibility: wgpu::ShaderStages::FRAGMENT,
            ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
            count: None,
        },
    ]
}

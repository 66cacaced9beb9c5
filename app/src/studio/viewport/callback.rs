//! The paint callback egui runs for the viewport: the scene rendered into the viewport's
//! targets before egui's pass (`prepare`), then blitted into it (`paint`).

use super::{ViewportCallback, ViewportResources};
use eframe::egui;
use eframe::egui_wgpu::{self, wgpu};

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
            let samples = res.samples(self.moving);
            let size = res.render_size(self.size, self.moving);
            // Points keep their size on screen.
            let point_size = self.point_size * size[0] as f32 / self.size[0].max(1) as f32;
            res.render(
                device,
                queue,
                encoder,
                &self.scene,
                &self.camera,
                self.shading,
                point_size,
                size,
                self.light,
                samples,
            );
        }
        Vec::new()
    }

    fn paint(
        &self,
        _info: egui::PaintCallbackInfo,
        pass: &mut wgpu::RenderPass<'static>,
        resources: &egui_wgpu::CallbackResources,
    ) {
        let Some(res) = resources.get::<ViewportResources>() else {
            return;
        };
        let Some(targets) = &res.targets else {
            return;
        };
        // Pixel for pixel when the scene has the viewport's size (the still look), else stretched.
        pass.set_pipeline(if targets.size == self.size {
            &res.blit_pipeline
        } else {
            &res.blit_scaled_pipeline
        });
        pass.set_bind_group(0, &targets.blit_group, &[]);
        pass.draw(0..3, 0..1);
    }
}

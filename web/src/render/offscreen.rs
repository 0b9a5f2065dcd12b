//! Native headless rendering (tests, CLI): a device of its own, the same [`SceneRenderer`]
//! as the app, and a readback of the target into an [`image::RgbaImage`].
//!
//! The device is created under WebGL2's downlevel limits (raised to the adapter's texture
//! size and alignment) so native tests catch a renderer that would not fit WebGL2.

use super::readback::readback_buffer;
use image::RgbaImage;
use kloub_core::Instance;
use kloub_core::asset::Asset;

use super::camera::Camera;
use super::scene::{SceneRenderer, msaa_samples};

/// A headless wgpu device (the adapter `WGPU_ADAPTER_NAME`/`WGPU_BACKEND` select, else the
/// default one: lavapipe on a machine without a GPU).
pub struct Offscreen {
    device: wgpu::Device,
    queue: wgpu::Queue,
    sample_count: u32,
    adapter: wgpu::AdapterInfo,
}

impl Offscreen {
    /// Opens the adapter and device.
    pub fn new() -> Result<Self, String> {
        Self::with_limits(wgpu::Limits::downlevel_webgl2_defaults())
    }

    /// A device with WebGPU's default limits (storage buffers and compute shaders, as the
    /// browser's WebGPU backend has) instead of WebGL2's.
    pub fn webgpu() -> Result<Self, String> {
        Self::with_limits(wgpu::Limits::default())
    }

    fn with_limits(base: wgpu::Limits) -> Result<Self, String> {
        let instance = wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
        let adapter = pollster::block_on(wgpu::util::initialize_adapter_from_env_or_default(&instance, None))
            .map_err(|e| format!("no wgpu adapter: {e}"))?;
        let limits = base.using_resolution(adapter.limits()).using_alignment(adapter.limits());
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("kloub offscreen"),
            required_limits: limits,
            ..Default::default()
        }))
        .map_err(|e| format!("no wgpu device: {e}"))?;
        Ok(Self { sample_count: msaa_samples(&adapter), adapter: adapter.get_info(), device, queue })
    }

    /// The device.
    pub fn device(&self) -> &wgpu::Device {
        &self.device
    }

    /// The queue.
    pub fn queue(&self) -> &wgpu::Queue {
        &self.queue
    }

    /// Name and backend of the adapter, for logs.
    pub fn adapter_info(&self) -> &wgpu::AdapterInfo {
        &self.adapter
    }

    /// A renderer on this device with `asset` uploaded.
    pub fn scene_renderer(&self, asset: &Asset) -> Result<SceneRenderer, String> {
        let mut renderer = SceneRenderer::new(&self.device, &self.queue, self.sample_count);
        renderer.set_asset(&self.device, &self.queue, asset)?;
        Ok(renderer)
    }

    /// Renders a frame with `renderer` and reads it back.
    pub fn render(
        &self,
        renderer: &mut SceneRenderer,
        asset: &Asset,
        instance: &mut Instance,
        camera: &Camera,
        width: u32,
        height: u32,
    ) -> Result<RgbaImage, String> {
        renderer.render(&self.device, &self.queue, asset, instance, camera, [width, height])?;
        let texture = renderer.target_texture().ok_or("nothing rendered")?;
        self.read_texture(texture)
    }

    /// Copies an `Rgba8Unorm(Srgb)` texture into an image (bytes as stored: sRGB-encoded).
    pub fn read_texture(&self, texture: &wgpu::Texture) -> Result<RgbaImage, String> {
        let pixels = read_texture_bytes(&self.device, &self.queue, texture, 4)?;
        RgbaImage::from_raw(texture.width(), texture.height(), pixels)
            .ok_or_else(|| "readback size mismatch".to_string())
    }
}

/// The texels of `texture` (`bytes_per_texel` each, `COPY_SRC`), rows packed tightly. Blocks
/// until the GPU is done.
pub fn read_texture_bytes(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    texture: &wgpu::Texture,
    bytes_per_texel: u32,
) -> Result<Vec<u8>, String> {
    let pending = super::readback::PendingReadback::start(device, queue, texture, bytes_per_texel);
    device.poll(wgpu::PollType::wait_indefinitely()).map_err(|e| format!("device poll: {e}"))?;
    pending.poll(device).ok_or("readback: the GPU finished without mapping the buffer")?
}

/// The contents of `buffer` (`COPY_SRC`). Blocks until the GPU is done.
pub fn read_buffer_bytes(device: &wgpu::Device, queue: &wgpu::Queue, buffer: &wgpu::Buffer) -> Result<Vec<u8>, String> {
    let readback = readback_buffer(device, buffer.size());
    let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("kloub readback") });
    encoder.copy_buffer_to_buffer(buffer, 0, &readback, 0, buffer.size());
    queue.submit([encoder.finish()]);
    map_read(device, &readback)
}

/// Maps `buffer` for reading, waits, and copies it out.
fn map_read(device: &wgpu::Device, buffer: &wgpu::Buffer) -> Result<Vec<u8>, String> {
    let (sender, receiver) = std::sync::mpsc::channel();
    buffer.map_async(wgpu::MapMode::Read, .., move |result| {
        // The receiver waits below; a send error only means it is gone.
        let _ = sender.send(result);
    });
    device.poll(wgpu::PollType::wait_indefinitely()).map_err(|e| format!("device poll: {e}"))?;
    receiver.recv().map_err(|e| format!("readback: {e}"))?.map_err(|e| format!("readback map: {e}"))?;
    let bytes = buffer.get_mapped_range(..).map_err(|e| format!("readback range: {e}"))?.to_vec();
    buffer.unmap();
    Ok(bytes)
}

/// One-shot: opens a device, uploads `asset`, renders `instance` (already evaluated) from
/// `camera` at `width`×`height` and returns the pixels (sRGB-encoded RGBA8).
pub fn render_to_image(
    asset: &Asset,
    instance: &mut Instance,
    camera: &Camera,
    width: u32,
    height: u32,
) -> Result<RgbaImage, String> {
    let offscreen = Offscreen::new()?;
    let mut renderer = offscreen.scene_renderer(asset)?;
    offscreen.render(&mut renderer, asset, instance, camera, width, height)
}

//! Copying a GPU texture to the CPU without blocking (the browser cannot wait for the GPU):
//! the viewer's screenshot. The blocking helpers for tests live in `offscreen` (native only).

/// A `COPY_DST | MAP_READ` buffer of `size` bytes.
pub(crate) fn readback_buffer(device: &wgpu::Device, size: u64) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("kloub readback"),
        size,
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
        mapped_at_creation: false,
    })
}

/// A texture being copied to the CPU without blocking (the browser cannot wait for the GPU):
/// [`PendingReadback::poll`] it once per frame until it yields the pixels.
pub struct PendingReadback {
    buffer: wgpu::Buffer,
    width: u32,
    height: u32,
    row: u32,
    padded: u32,
    state: std::sync::Arc<std::sync::Mutex<Option<Result<(), String>>>>,
}

impl PendingReadback {
    /// Starts copying `texture` (`bytes_per_texel` each, `COPY_SRC`).
    pub fn start(device: &wgpu::Device, queue: &wgpu::Queue, texture: &wgpu::Texture, bytes_per_texel: u32) -> Self {
        let (width, height) = (texture.width(), texture.height());
        let row = width * bytes_per_texel;
        let padded = row.div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT) * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
        let buffer = readback_buffer(device, u64::from(padded) * u64::from(height));
        let mut encoder =
            device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("kloub screenshot") });
        encoder.copy_texture_to_buffer(
            texture.as_image_copy(),
            wgpu::TexelCopyBufferInfo {
                buffer: &buffer,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(padded),
                    rows_per_image: Some(height),
                },
            },
            texture.size(),
        );
        queue.submit([encoder.finish()]);
        let state = std::sync::Arc::new(std::sync::Mutex::new(None));
        let slot = state.clone();
        buffer.map_async(wgpu::MapMode::Read, .., move |result| {
            if let Ok(mut slot) = slot.lock() {
                *slot = Some(result.map_err(|e| format!("readback map: {e}")));
            }
        });
        Self { buffer, width, height, row, padded, state }
    }

    /// Size of the texture being read, in texels.
    pub fn size(&self) -> (u32, u32) {
        (self.width, self.height)
    }

    /// The texels, rows packed tightly, once the GPU is done; `None` while it is not.
    pub fn poll(&self, device: &wgpu::Device) -> Option<Result<Vec<u8>, String>> {
        // Natively this drives the callback; in the browser the callback comes on its own.
        let _ = device.poll(wgpu::PollType::Poll);
        let mapped = self.state.lock().ok()?.take()?;
        Some(mapped.and_then(|()| {
            let mut out = Vec::with_capacity((self.row * self.height) as usize);
            {
                // Rows are copied straight out of the mapping, dropping the row padding.
                let mapped = self.buffer.get_mapped_range(..).map_err(|e| format!("readback range: {e}"))?;
                for chunk in mapped.chunks_exact(self.padded as usize).take(self.height as usize) {
                    out.extend_from_slice(&chunk[..self.row as usize]);
                }
            }
            self.buffer.unmap();
            Ok(out)
        }))
    }
}

/// Turns premultiplied RGBA8 pixels (what the scene leaves where its background is
/// transparent) into the straight alpha an image file holds. Opaque pixels are unchanged.
pub fn unpremultiply(pixels: &mut [u8]) {
    for px in pixels.chunks_exact_mut(4) {
        let a = u32::from(px[3]);
        if a == 255 {
            continue;
        }
        for c in &mut px[..3] {
            *c = (u32::from(*c) * 255 + a / 2).checked_div(a).map_or(0, |v| v.min(255) as u8);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::unpremultiply;

    #[test]
    fn unpremultiply_restores_straight_alpha_and_keeps_opaque_pixels() {
        let mut pixels = [10, 20, 30, 255, 64, 32, 0, 128, 9, 9, 9, 0, 200, 100, 50, 100];
        unpremultiply(&mut pixels);
        assert_eq!(pixels, [10, 20, 30, 255, 128, 64, 0, 128, 0, 0, 0, 0, 255, 255, 128, 100]);
    }
}

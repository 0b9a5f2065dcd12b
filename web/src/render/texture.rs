//! Material textures: mip chains, sRGB-correct for colour (base colour, emissive) and plain
//! for data (metallic-roughness, normal, occlusion), built on the CPU for images the importer
//! decoded and on the GPU ([`MipMaker`]) for those the browser decoded (copied in as they are,
//! never through the wasm heap), and sampler creation from glTF sampler settings.

use kloub_core::asset::{Image, MinFilter, TextureRef};

/// The sRGB texture format every colour image is uploaded as.
pub const COLOR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8UnormSrgb;
/// The format of data images (metallic-roughness, normal, occlusion): bytes read as they are.
pub const DATA_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;

/// The texture format of an image holding colour (`srgb`) or data.
pub fn image_format(srgb: bool) -> wgpu::TextureFormat {
    if srgb { COLOR_FORMAT } else { DATA_FORMAT }
}

/// One level of a mip chain: RGBA8 sRGB bytes, row-major.
#[derive(Clone, Debug, PartialEq)]
pub struct MipLevel {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `width * height * 4` bytes.
    pub rgba8: Vec<u8>,
}

fn srgb_to_linear(c: u8) -> f32 {
    let c = f32::from(c) / 255.0;
    if c <= 0.04045 { c / 12.92 } else { ((c + 0.055) / 1.055).powf(2.4) }
}

fn linear_to_srgb(c: f32) -> u8 {
    let c = c.clamp(0.0, 1.0);
    let s = if c <= 0.003_130_8 { c * 12.92 } else { 1.055 * c.powf(1.0 / 2.4) - 0.055 };
    // In 0..=255 after the clamp above, so the cast cannot truncate.
    (s * 255.0 + 0.5) as u8
}

/// The linear values at which [`linear_to_srgb`]'s byte steps up: `thresholds[k - 1]` is the
/// smallest `c` it encodes as `k` or more, so the byte of `c` is the number of thresholds ≤ `c`
/// ([`encode`]) — the same bytes as the formula, by 8 comparisons instead of a `powf`.
fn srgb_thresholds() -> [f32; 255] {
    let mut thresholds = [0.0f32; 255];
    for (k, t) in (1u8..=255).zip(thresholds.iter_mut()) {
        // The inverse of the encoding at the rounding boundary, then moved by ulps until it is
        // exactly where the forward formula steps (a handful of steps at most).
        let s = (f32::from(k) - 0.5) / 255.0;
        let mut c = if s <= 0.04045 { s / 12.92 } else { ((s + 0.055) / 1.055).powf(2.4) };
        for _ in 0..1 << 16 {
            if c > 0.0 && linear_to_srgb(c.next_down()) >= k {
                c = c.next_down();
            } else if linear_to_srgb(c) < k {
                c = c.next_up();
            } else {
                break;
            }
        }
        *t = c;
    }
    thresholds
}

/// [`linear_to_srgb`] through its thresholds.
fn encode(c: f32, thresholds: &[f32; 255]) -> u8 {
    // At most 255 thresholds are at or below `c`.
    thresholds.partition_point(|&t| t <= c) as u8
}

/// Halves a level (box filter in linear light for RGB, plain average for alpha; with
/// `to_linear` `None`, a plain average of every channel's bytes, for data). Odd sizes fold the
/// last row/column in by clamping.
fn downsample(level: &MipLevel, to_linear: Option<&[f32; 256]>, thresholds: &[f32; 255]) -> MipLevel {
    let (w, h) = (level.width as usize, level.height as usize);
    let (nw, nh) = ((w / 2).max(1), (h / 2).max(1));
    let mut rgba8 = vec![0u8; nw * nh * 4];
    for y in 0..nh {
        for x in 0..nw {
            let mut sum = [0.0f32; 4];
            for (sx, sy) in [(2 * x, 2 * y), (2 * x + 1, 2 * y), (2 * x, 2 * y + 1), (2 * x + 1, 2 * y + 1)] {
                let i = (sy.min(h - 1) * w + sx.min(w - 1)) * 4;
                for (total, &byte) in sum.iter_mut().zip(&level.rgba8[i..i + 3]) {
                    *total += to_linear.map_or(f32::from(byte), |t| t[usize::from(byte)]);
                }
                sum[3] += f32::from(level.rgba8[i + 3]);
            }
            let o = (y * nw + x) * 4;
            for c in 0..3 {
                rgba8[o + c] = match to_linear {
                    Some(_) => encode(sum[c] * 0.25, thresholds),
                    // Average of four bytes: at most 255.
                    None => (sum[c] * 0.25 + 0.5) as u8,
                };
            }
            // Average of four bytes: at most 255.
            rgba8[o + 3] = (sum[3] * 0.25 + 0.5) as u8;
        }
    }
    MipLevel { width: nw as u32, height: nh as u32, rgba8 }
}

/// The full mip chain of `image` down to 1×1, skipping the levels larger than `max_size`
/// on either side (so oversized images still load on WebGL2's 2048 limit); filtered in
/// linear light for a colour image (`srgb`), on the bytes for data.
/// Returns an error when the image's byte count does not match its size.
pub fn mip_chain(image: &Image, max_size: u32, srgb: bool) -> Result<Vec<MipLevel>, String> {
    let expected = u64::from(image.width) * u64::from(image.height) * 4;
    if image.width == 0 || image.height == 0 || image.rgba8.len() as u64 != expected {
        return Err(format!(
            "image {}x{} has {} bytes, expected {expected}",
            image.width,
            image.height,
            image.rgba8.len()
        ));
    }
    let mut to_linear = [0.0f32; 256];
    for (i, v) in to_linear.iter_mut().enumerate() {
        *v = srgb_to_linear(i as u8);
    }
    let thresholds = srgb_thresholds();
    let mut levels = Vec::new();
    let mut level = MipLevel { width: image.width, height: image.height, rgba8: image.rgba8.clone() };
    loop {
        let next =
            (level.width > 1 || level.height > 1).then(|| downsample(&level, srgb.then_some(&to_linear), &thresholds));
        if level.width <= max_size && level.height <= max_size {
            levels.push(level);
        }
        match next {
            Some(n) => level = n,
            None => break,
        }
    }
    Ok(levels)
}

/// Creates the texture of `image` with all its mips and uploads them: sRGB for colour
/// (`srgb`), plain for data.
pub fn upload_image(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    image: &Image,
    label: &str,
    srgb: bool,
) -> Result<wgpu::Texture, String> {
    let max = device.limits().max_texture_dimension_2d;
    let levels = mip_chain(image, max, srgb)?;
    let first = levels.first().ok_or("image has no level that fits the device")?;
    let texture = device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d { width: first.width, height: first.height, depth_or_array_layers: 1 },
        mip_level_count: levels.len() as u32,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: image_format(srgb),
        usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
        view_formats: &[],
    });
    for (mip, level) in levels.iter().enumerate() {
        write_level(queue, &texture, mip as u32, level);
    }
    Ok(texture)
}

/// Mip levels of a `width` × `height` image down to 1×1.
pub fn mip_count(width: u32, height: u32) -> u32 {
    u32::BITS - width.max(height).max(1).leading_zeros()
}

/// Makes a texture's mip levels 1.. from its level 0 on the GPU, one render pass per level:
/// each pixel the box filter of its 2×2 block above (`shaders/mip.wgsl`), in linear light for
/// an sRGB texture (the sampler decodes, the target encodes), on the values for data. The
/// texture needs [`GPU_MIPPED`] usage and the maker's format. Made once per pipeline kit and
/// format, on first use.
pub struct MipMaker {
    pipeline: wgpu::RenderPipeline,
    layout: wgpu::BindGroupLayout,
    sampler: wgpu::Sampler,
    format: wgpu::TextureFormat,
}

/// The usages of a texture whose mips [`MipMaker`] makes (and that the browser's decoded image
/// is copied into).
pub const GPU_MIPPED: wgpu::TextureUsages = wgpu::TextureUsages::TEXTURE_BINDING
    .union(wgpu::TextureUsages::COPY_DST)
    .union(wgpu::TextureUsages::COPY_SRC)
    .union(wgpu::TextureUsages::RENDER_ATTACHMENT);

/// A texture of `format` and `width` × `height` with its whole mip chain, for [`MipMaker`].
pub fn gpu_mipped_texture(
    device: &wgpu::Device,
    label: &str,
    width: u32,
    height: u32,
    format: wgpu::TextureFormat,
) -> wgpu::Texture {
    device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d { width, height, depth_or_array_layers: 1 },
        mip_level_count: mip_count(width, height),
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage: GPU_MIPPED,
        view_formats: &[],
    })
}

impl MipMaker {
    /// The pipeline for textures of `format` ([`COLOR_FORMAT`] or [`DATA_FORMAT`]).
    pub fn new(device: &wgpu::Device, format: wgpu::TextureFormat) -> Self {
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("kloub mip"),
            source: super::pipelines::shader_source!(super::pipelines::MIP_WGSL),
        });
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("kloub mip"),
            entries: &[
                super::pipelines::texture_entry(
                    0,
                    wgpu::ShaderStages::FRAGMENT,
                    wgpu::TextureSampleType::Float { filterable: true },
                ),
                super::pipelines::sampler_entry(1, wgpu::ShaderStages::FRAGMENT, wgpu::SamplerBindingType::Filtering),
            ],
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("kloub mip"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let pipeline = super::pipelines::fill_pipeline(
            device,
            "kloub mip",
            &pipeline_layout,
            &module,
            ("vs_mip", "fs_mip"),
            format,
        );
        let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("kloub mip"),
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            ..Default::default()
        });
        Self { pipeline, layout, sampler, format }
    }

    /// The format of the textures it fills.
    pub fn format(&self) -> wgpu::TextureFormat {
        self.format
    }

    /// Fills levels 1.. of `texture` from level 0 and submits the work.
    pub fn generate(&self, device: &wgpu::Device, queue: &wgpu::Queue, texture: &wgpu::Texture) {
        let level = |mip: u32| {
            texture.create_view(&wgpu::TextureViewDescriptor {
                label: Some("kloub mip level"),
                base_mip_level: mip,
                mip_level_count: Some(1),
                ..Default::default()
            })
        };
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("kloub mips") });
        for mip in 1..texture.mip_level_count() {
            let source = level(mip - 1);
            let target = level(mip);
            let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("kloub mip"),
                layout: &self.layout,
                entries: &[
                    wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(&source) },
                    wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::Sampler(&self.sampler) },
                ],
            });
            let mut pass = super::pipelines::fill_pass(&mut encoder, "kloub mip", &target);
            pass.set_pipeline(&self.pipeline);
            pass.set_bind_group(0, &bind_group, &[]);
            pass.draw(0..3, 0..1);
        }
        queue.submit([encoder.finish()]);
    }
}

/// The texture of an image the browser decoded: `bitmap` copied into level 0 as it is (not
/// premultiplied, no colour conversion), the other levels made by `mips`.
///
/// # Errors
/// When the bitmap is larger than the device allows.
#[cfg(target_arch = "wasm32")]
pub fn upload_bitmap(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    mips: &MipMaker,
    bitmap: &web_sys::ImageBitmap,
    label: &str,
) -> Result<wgpu::Texture, String> {
    let (width, height) = (bitmap.width(), bitmap.height());
    let max = device.limits().max_texture_dimension_2d;
    if width == 0 || height == 0 || width > max || height > max {
        return Err(format!("{width}×{height} pixels; this device takes at most {max}×{max}"));
    }
    let size = wgpu::Extent3d { width, height, depth_or_array_layers: 1 };
    let texture = gpu_mipped_texture(device, label, width, height, mips.format());
    queue.copy_external_image_to_texture(
        &wgpu::CopyExternalImageSourceInfo {
            source: wgpu::ExternalImageSource::ImageBitmap(bitmap.clone()),
            origin: wgpu::Origin2d::ZERO,
            flip_y: false,
        },
        wgpu::CopyExternalImageDestInfo {
            texture: &texture,
            mip_level: 0,
            origin: wgpu::Origin3d::ZERO,
            aspect: wgpu::TextureAspect::All,
            color_space: wgpu::PredefinedColorSpace::Srgb,
            premultiplied_alpha: false,
        },
        size,
    );
    mips.generate(device, queue, &texture);
    Ok(texture)
}

/// The texture of image `index` of `asset`, which the browser decoded ([`crate::decode`]), its
/// mips made by the kit's mip maker for colour (`srgb`) or data
/// ([`super::pipelines::Pipelines::mip_maker`]). `None` (the material draws white) when the
/// browser could not decode it or the device cannot hold it — and natively, where the importer
/// decodes every image.
pub fn upload_decoded(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    pipelines: &super::pipelines::Pipelines,
    asset: &kloub_core::Asset,
    index: usize,
    label: &str,
    srgb: bool,
) -> Option<wgpu::Texture> {
    #[cfg(target_arch = "wasm32")]
    {
        let bitmap = crate::decode::bitmap(asset, index)?;
        upload_bitmap(device, queue, pipelines.mip_maker(device, srgb), &bitmap, label)
            .map_err(|e| log::warn!("kloub: image {index}: {e}; drawn white"))
            .ok()
    }
    #[cfg(not(target_arch = "wasm32"))]
    {
        let _ = (device, queue, pipelines, asset, label, srgb);
        log::warn!("kloub: image {index} was not decoded; drawn white");
        None
    }
}

/// Writes one mip level.
pub fn write_level(queue: &wgpu::Queue, texture: &wgpu::Texture, mip: u32, level: &MipLevel) {
    queue.write_texture(
        wgpu::TexelCopyTextureInfo {
            texture,
            mip_level: mip,
            origin: wgpu::Origin3d::ZERO,
            aspect: wgpu::TextureAspect::All,
        },
        &level.rgba8,
        wgpu::TexelCopyBufferLayout {
            offset: 0,
            bytes_per_row: Some(level.width * 4),
            rows_per_image: Some(level.height),
        },
        wgpu::Extent3d { width: level.width, height: level.height, depth_or_array_layers: 1 },
    );
}

/// A 1×1 white texture, bound where a material has no base colour texture.
pub fn white_texture(device: &wgpu::Device, queue: &wgpu::Queue) -> wgpu::Texture {
    let texture = device.create_texture(&wgpu::TextureDescriptor {
        label: Some("kloub white"),
        size: wgpu::Extent3d { width: 1, height: 1, depth_or_array_layers: 1 },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: COLOR_FORMAT,
        usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
        view_formats: &[],
    });
    write_level(queue, &texture, 0, &MipLevel { width: 1, height: 1, rgba8: vec![255; 4] });
    texture
}

/// Sampler settings of a texture reference: (repeat u, repeat v, nearest magnification).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct SamplerKey {
    /// Repeat (true) or clamp (false) along u and v.
    pub repeat: [bool; 2],
    /// Nearest magnification.
    pub nearest: bool,
    /// Minification.
    pub min_filter: MinFilter,
}

impl SamplerKey {
    /// The key of a material's texture reference; trilinear repeat when there is none.
    pub fn of(texture: Option<&TextureRef>) -> Self {
        texture.map_or(Self { repeat: [true; 2], nearest: false, min_filter: MinFilter::default() }, |t| Self {
            repeat: t.repeat,
            nearest: t.nearest,
            min_filter: t.min_filter,
        })
    }

    /// Creates the sampler (a filter without mipmaps samples level 0 only).
    pub fn create(&self, device: &wgpu::Device) -> wgpu::Sampler {
        let mode = |repeat: bool| {
            if repeat { wgpu::AddressMode::Repeat } else { wgpu::AddressMode::ClampToEdge }
        };
        device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("kloub material texture"),
            address_mode_u: mode(self.repeat[0]),
            address_mode_v: mode(self.repeat[1]),
            mag_filter: if self.nearest { wgpu::FilterMode::Nearest } else { wgpu::FilterMode::Linear },
            min_filter: if self.min_filter.linear() { wgpu::FilterMode::Linear } else { wgpu::FilterMode::Nearest },
            mipmap_filter: if self.min_filter.mipmap() == Some(true) {
                wgpu::MipmapFilterMode::Linear
            } else {
                wgpu::MipmapFilterMode::Nearest
            },
            lod_max_clamp: if self.min_filter.mipmap().is_some() { 32.0 } else { 0.0 },
            ..Default::default()
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn thresholds_encode_as_the_formula_does() {
        let thresholds = srgb_thresholds();
        // Every value a box filter of four bytes can give, and a fine sweep with the edges.
        let mut values: Vec<f32> = (0..=4 * 255 * 64).map(|i| i as f32 / (4.0 * 255.0 * 64.0)).collect();
        values.extend([-1.0, 0.0, 1e-9, 0.003_130_8, 0.5, 1.0, 2.0, f32::NAN]);
        values.extend(thresholds.iter().flat_map(|&t| [t, t.next_down(), t.next_up()]));
        for c in values {
            assert_eq!(encode(c, &thresholds), linear_to_srgb(c), "at {c}");
        }
    }

    #[test]
    fn mip_chain_goes_to_one_pixel_and_averages_in_linear_light() {
        // 3x2: black and white columns; odd width exercises the clamped edge.
        let mut rgba8 = Vec::new();
        for _ in 0..2 {
            for v in [0u8, 255, 0] {
                rgba8.extend_from_slice(&[v, v, v, 255]);
            }
        }
        let image = Image { name: None, width: 3, height: 2, rgba8, encoded: None };
        let chain = mip_chain(&image, 4096, true).expect("valid image");
        let sizes: Vec<(u32, u32)> = chain.iter().map(|l| (l.width, l.height)).collect();
        assert_eq!(sizes, vec![(3, 2), (1, 1)]);
        // Half black, half white in linear light is sRGB ~188, not 128.
        let v = chain[1].rgba8[0];
        assert!((186..=190).contains(&v), "got {v}");
        assert_eq!(chain[1].rgba8[3], 255);
        // Data (a normal or metallic-roughness map) averages its bytes.
        let data = mip_chain(&image, 4096, false).expect("valid image");
        assert_eq!(data[1].rgba8, [128, 128, 128, 255]);
    }

    #[test]
    fn oversized_levels_are_skipped_and_bad_sizes_refused() {
        let image = Image { name: None, width: 8, height: 2, rgba8: vec![128; 8 * 2 * 4], encoded: None };
        let chain = mip_chain(&image, 4, true).expect("valid image");
        assert_eq!((chain[0].width, chain[0].height), (4, 1));
        let bad = Image { name: None, width: 8, height: 2, rgba8: vec![0; 3], encoded: None };
        assert!(mip_chain(&bad, 4096, true).is_err());
    }

    #[test]
    fn srgb_round_trip() {
        for i in 0..=255u8 {
            assert_eq!(linear_to_srgb(srgb_to_linear(i)), i);
        }
    }
}

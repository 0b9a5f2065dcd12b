//! Images (decoded to RGBA8), textures, samplers and materials.

use super::Cx;
use super::container::{Budget, load_uri};
use super::json::{
    Obj, child, extension, member_error, objects, opt_bool, opt_f32, opt_f32_array, opt_index, opt_object, opt_str,
    opt_u64, req_index,
};
use crate::asset::{AlphaMode, EncodedImage, Image, ImageFormat, Material, TextureRef, TextureTransform};
use crate::error::ImportError;
use std::borrow::Cow;
#[cfg(feature = "images")]
use std::io::Cursor;

/// Images by glTF index, decoded or (`decode` false, or without the `images` feature) kept
/// encoded; an image that cannot be loaded or decoded (or, kept encoded, whose header cannot
/// be read) is replaced by a 1×1 white pixel (with a warning) and marked unusable (`false`).
pub(crate) fn images(cx: &mut Cx<'_>, decode: bool) -> Result<(Vec<Image>, Vec<bool>), ImportError> {
    let mut images = Vec::new();
    let mut usable = Vec::new();
    for (image, ptr) in objects(cx.root, "images", "")? {
        let uri = opt_str(image, "uri", &ptr)?;
        let name = super::json::name(image).or_else(|| uri.filter(|u| !u.starts_with("data:")).map(str::to_owned));
        let view = opt_index(image, "bufferView", &ptr, cx.accessors.view_count(), "bufferView")?;
        let bytes: Result<Cow<'_, [u8]>, ImportError> = match (uri, view) {
            (Some(uri), _) => load_uri(uri, &child(&ptr, "uri"), cx.resolver, &mut cx.budget),
            (None, Some(v)) => cx.accessors.view_bytes(v as usize).map(Cow::Borrowed),
            (None, None) => Err(ImportError::new(&ptr, "image has neither uri nor bufferView")),
        };
        let loaded = bytes.and_then(|b| {
            #[cfg(feature = "images")]
            if decode {
                return decode_rgba8(&b, &ptr, &mut cx.budget).map(|(width, height, rgba8)| Image {
                    name: name.clone(),
                    width,
                    height,
                    rgba8,
                    encoded: None,
                });
            }
            #[cfg(not(feature = "images"))]
            let _ = decode;
            keep_encoded(b.into_owned(), &ptr, &mut cx.budget).map(|(width, height, encoded)| Image {
                name: name.clone(),
                width,
                height,
                rgba8: Vec::new(),
                encoded: Some(encoded),
            })
        });
        match loaded {
            Ok(image) => {
                images.push(image);
                usable.push(true);
            }
            Err(e) => {
                cx.warn(e.pointer, format!("{}; image skipped (replaced by a white pixel)", e.message));
                images.push(Image { name, width: 1, height: 1, rgba8: vec![255; 4], encoded: None });
                usable.push(false);
            }
        }
    }
    Ok((images, usable))
}

/// Checks an image file's header (format and size, against the budget) and keeps its bytes.
fn keep_encoded(bytes: Vec<u8>, ptr: &str, budget: &mut Budget) -> Result<(u32, u32, EncodedImage), ImportError> {
    let (format, width, height) = header(&bytes)
        .ok_or_else(|| ImportError::new(ptr, "cannot decode image: not a PNG or JPEG file, or its header is cut"))?;
    if width == 0 || height == 0 {
        return Err(ImportError::new(ptr, format!("image is {width}×{height} pixels")));
    }
    budget.take_items(u64::from(width) * u64::from(height), 4, ptr, &format!("image of {width}×{height} pixels"))?;
    Ok((width, height, EncodedImage { format, bytes }))
}

/// The format and size of a PNG, JPEG or WebP file from its header: PNG's IHDR, JPEG's first
/// start-of-frame segment, WebP's first chunk (`VP8 `, `VP8L` or `VP8X`). `None` for anything
/// else or a header cut short.
pub(crate) fn header(bytes: &[u8]) -> Option<(ImageFormat, u32, u32)> {
    let be32 = |at: usize| bytes.get(at..at + 4).map(|b| u32::from_be_bytes([b[0], b[1], b[2], b[3]]));
    let be16 = |at: usize| bytes.get(at..at + 2).map(|b| u32::from(u16::from_be_bytes([b[0], b[1]])));
    let le = |at: usize, n: usize| {
        bytes.get(at..at + n).map(|b| b.iter().rev().fold(0u32, |v, &byte| (v << 8) | u32::from(byte)))
    };
    if bytes.get(0..4) == Some(b"RIFF") && bytes.get(8..12) == Some(b"WEBP") {
        let size = match bytes.get(12..16)? {
            // Lossy: a key frame's start code, then 14-bit width and height (2 bits of scale above).
            b"VP8 " => {
                (bytes.get(23..26)? == [0x9D, 0x01, 0x2A]).then(|| Some((le(26, 2)? & 0x3FFF, le(28, 2)? & 0x3FFF)))
            }
            // Lossless: a signature byte, then width − 1 and height − 1 in 14 bits each.
            b"VP8L" => (*bytes.get(20)? == 0x2F).then(|| {
                let bits = le(21, 4)?;
                Some(((bits & 0x3FFF) + 1, ((bits >> 14) & 0x3FFF) + 1))
            }),
            // Extended: flags, then the canvas's width − 1 and height − 1 in 24 bits each.
            b"VP8X" => Some(Some((le(24, 3)? + 1, le(27, 3)? + 1))),
            _ => None,
        };
        return size.flatten().map(|(width, height)| (ImageFormat::Webp, width, height));
    }
    if bytes.starts_with(b"\x89PNG\r\n\x1a\n") {
        return (bytes.get(12..16) == Some(b"IHDR")).then(|| Some((ImageFormat::Png, be32(16)?, be32(20)?))).flatten();
    }
    if !bytes.starts_with(&[0xFF, 0xD8]) {
        return None;
    }
    let mut at = 2;
    loop {
        // Fill bytes before a marker are 0xFF too.
        while bytes.get(at) == Some(&0xFF) && bytes.get(at + 1) == Some(&0xFF) {
            at += 1;
        }
        if bytes.get(at) != Some(&0xFF) {
            return None;
        }
        let marker = *bytes.get(at + 1)?;
        match marker {
            // Markers without a length: TEM, RSTn, SOI.
            0x01 | 0xD0..=0xD8 => at += 2,
            // Start of scan or end of image before any frame header.
            0xD9 | 0xDA => return None,
            // Start of frame (not DHT 0xC4, JPG 0xC8, DAC 0xCC): precision, height, width.
            0xC0..=0xCF if !matches!(marker, 0xC4 | 0xC8 | 0xCC) => {
                return Some((ImageFormat::Jpeg, be16(at + 7)?, be16(at + 5)?));
            }
            _ => at = at.checked_add(2 + usize::try_from(be16(at + 2)?).ok()?)?,
        }
    }
}

/// Decodes PNG or JPEG bytes to RGBA8, checking the header's dimensions against the budget first.
#[cfg(feature = "images")]
fn decode_rgba8(bytes: &[u8], ptr: &str, budget: &mut Budget) -> Result<(u32, u32, Vec<u8>), ImportError> {
    let fail = |e: &dyn std::fmt::Display| ImportError::new(ptr, format!("cannot decode image: {e}"));
    let reader = || image::ImageReader::new(Cursor::new(bytes)).with_guessed_format().map_err(|e| fail(&e));
    let (width, height) = reader()?.into_dimensions().map_err(|e| fail(&e))?;
    if width == 0 || height == 0 {
        return Err(ImportError::new(ptr, format!("image is {width}×{height} pixels")));
    }
    let left = budget.left();
    budget.take_items(u64::from(width) * u64::from(height), 4, ptr, &format!("image of {width}×{height} pixels"))?;
    let mut reader = reader()?;
    let mut limits = image::Limits::default();
    limits.max_image_width = Some(width);
    limits.max_image_height = Some(height);
    limits.max_alloc = Some(left);
    reader.limits(limits);
    let rgba = reader.decode().map_err(|e| fail(&e))?.into_rgba8();
    Ok((rgba.width(), rgba.height(), rgba.into_raw()))
}

/// Materials, with base-colour textures resolved through textures and samplers.
pub(crate) fn materials(cx: &mut Cx<'_>, usable_images: &[bool]) -> Result<Vec<Material>, ImportError> {
    let textures = objects(cx.root, "textures", "")?;
    let samplers = objects(cx.root, "samplers", "")?;
    let mut out = Vec::new();
    for (m, ptr) in objects(cx.root, "materials", "")? {
        let mut material = Material { name: super::json::name(m), ..Material::default() };
        if let Some(pbr) = opt_object(m, "pbrMetallicRoughness", &ptr)? {
            let pptr = child(&ptr, "pbrMetallicRoughness");
            material.base_color = opt_f32_array::<4>(pbr, "baseColorFactor", &pptr)?.unwrap_or([1.0; 4]);
            material.metallic = opt_f32(pbr, "metallicFactor", &pptr)?.unwrap_or(1.0);
            material.roughness = opt_f32(pbr, "roughnessFactor", &pptr)?.unwrap_or(1.0);
            if let Some(info) = opt_object(pbr, "baseColorTexture", &pptr)? {
                let iptr = child(&pptr, "baseColorTexture");
                material.base_color_texture = texture_ref(cx, info, &iptr, &textures, &samplers, usable_images)?;
            }
        }
        material.emissive = opt_f32_array::<3>(m, "emissiveFactor", &ptr)?.unwrap_or([0.0; 3]);
        let cutoff = opt_f32(m, "alphaCutoff", &ptr)?.unwrap_or(0.5);
        material.alpha = match opt_str(m, "alphaMode", &ptr)?.unwrap_or("OPAQUE") {
            "OPAQUE" => AlphaMode::Opaque,
            "MASK" => AlphaMode::Mask(cutoff),
            "BLEND" => AlphaMode::Blend,
            other => {
                cx.warn(child(&ptr, "alphaMode"), format!("unknown alphaMode '{other}'; OPAQUE is used"));
                AlphaMode::Opaque
            }
        };
        material.double_sided = opt_bool(m, "doubleSided", &ptr)?.unwrap_or(false);
        material.unlit = extension(m, "KHR_materials_unlit", &ptr)?.is_some();
        out.push(material);
    }
    Ok(out)
}

/// A texture reference from a `textureInfo`; `None` when the texture has no usable image.
fn texture_ref(
    cx: &mut Cx<'_>,
    info: &Obj,
    ptr: &str,
    textures: &[(&Obj, String)],
    samplers: &[(&Obj, String)],
    usable_images: &[bool],
) -> Result<Option<TextureRef>, ImportError> {
    let t = req_index(info, "index", ptr, textures.len(), "texture")? as usize;
    let (texture, tptr) = &textures[t];
    // A WebP image (EXT_texture_webp) is preferred; `source`, when present, is its fallback (also
    // when the WebP cannot be read).
    let webp = match extension(texture, "EXT_texture_webp", tptr)? {
        Some(x) => {
            opt_index(x, "source", &format!("{tptr}/extensions/EXT_texture_webp"), usable_images.len(), "image")?
        }
        None => None,
    };
    let fallback = opt_index(texture, "source", tptr, usable_images.len(), "image")?;
    let usable = |i: Option<_>| i.filter(|&i| usable_images[i as usize]);
    let Some(image) = usable(webp).or(usable(fallback)).or(webp).or(fallback) else {
        cx.warn(tptr.as_str(), "texture has no source image in a supported format; not drawn");
        return Ok(None);
    };
    if !usable_images[image as usize] {
        return Ok(None);
    }
    let mut repeat = [true, true];
    let mut nearest = false;
    if let Some(s) = opt_index(texture, "sampler", tptr, samplers.len(), "sampler")? {
        let (sampler, sptr) = &samplers[s as usize];
        repeat = [
            opt_u64(sampler, "wrapS", sptr)?.unwrap_or(10497) != 33071,
            opt_u64(sampler, "wrapT", sptr)?.unwrap_or(10497) != 33071,
        ];
        nearest = opt_u64(sampler, "magFilter", sptr)? == Some(9728);
    }
    let mut tex_coord = opt_u64(info, "texCoord", ptr)?.unwrap_or(0);
    let mut transform = TextureTransform::default();
    if let Some(x) = extension(info, "KHR_texture_transform", ptr)? {
        let xptr = format!("{ptr}/extensions/KHR_texture_transform");
        transform.offset = opt_f32_array::<2>(x, "offset", &xptr)?.unwrap_or([0.0; 2]);
        transform.rotation = opt_f32(x, "rotation", &xptr)?.unwrap_or(0.0);
        transform.scale = opt_f32_array::<2>(x, "scale", &xptr)?.unwrap_or([1.0; 2]);
        tex_coord = opt_u64(x, "texCoord", &xptr)?.unwrap_or(tex_coord);
    }
    let tex_coord = u32::try_from(tex_coord).map_err(|_| member_error(ptr, "texCoord", "texCoord is too large"))?;
    Ok(Some(TextureRef { image, tex_coord, transform, repeat, nearest }))
}

//! Images (decoded to RGBA8), textures, samplers and materials.

use super::Cx;
use super::container::{Budget, load_uri};
use super::json::{
    Obj, child, extension, member_error, objects, opt_bool, opt_f32, opt_f32_array, opt_index, opt_object, opt_str,
    opt_u64,
};
use crate::asset::{AlphaMode, EncodedImage, Image, ImageFormat, Material, MinFilter, TextureRef, TextureTransform};
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
    let (format, width, height) = header(&bytes).ok_or_else(|| {
        ImportError::new(ptr, "cannot decode image: not a PNG, JPEG or WebP file, or its header is cut")
    })?;
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
    // Every texture's image and sampler, once: a reference that resolves to nothing is reported
    // (and not drawn) whether or not a material uses the texture.
    let mut resolved = Vec::with_capacity(textures.len());
    // Textures that name no image at all: reported once, when a material uses one.
    let mut sourceless = Vec::with_capacity(textures.len());
    for (texture, tptr) in &textures {
        let (texture, named) = resolve_texture(cx, texture, tptr, &samplers, usable_images)?;
        sourceless.push(!named);
        resolved.push(texture);
    }
    let mut out = Vec::new();
    for (m, ptr) in objects(cx.root, "materials", "")? {
        let mut material = Material { name: super::json::name(m), ..Material::default() };
        // Each texture reference: which slot it fills, its info and pointer.
        let mut infos = Vec::with_capacity(5);
        if let Some(pbr) = opt_object(m, "pbrMetallicRoughness", &ptr)? {
            let pptr = child(&ptr, "pbrMetallicRoughness");
            material.base_color = opt_f32_array::<4>(pbr, "baseColorFactor", &pptr)?.unwrap_or([1.0; 4]);
            material.metallic = opt_f32(pbr, "metallicFactor", &pptr)?.unwrap_or(1.0);
            material.roughness = opt_f32(pbr, "roughnessFactor", &pptr)?.unwrap_or(1.0);
            for (slot, key) in
                [(Slot::BaseColor, "baseColorTexture"), (Slot::MetallicRoughness, "metallicRoughnessTexture")]
            {
                if let Some(info) = texture_info(cx, pbr, key, &pptr, textures.len())? {
                    infos.push((slot, info));
                }
            }
        }
        for (slot, key) in [
            (Slot::Normal, "normalTexture"),
            (Slot::Occlusion, "occlusionTexture"),
            (Slot::Emissive, "emissiveTexture"),
        ] {
            if let Some(info) = texture_info(cx, m, key, &ptr, textures.len())? {
                infos.push((slot, info));
            }
        }
        for (slot, (t, info, iptr)) in infos {
            let reference = match &resolved[t] {
                Some(texture) => texture_ref(cx, texture, info, &iptr)?,
                None => {
                    if sourceless[t] {
                        sourceless[t] = false;
                        cx.warn(textures[t].1.as_str(), "texture has no source image in a supported format; not drawn");
                    }
                    continue;
                }
            };
            match slot {
                Slot::BaseColor => material.base_color_texture = Some(reference),
                Slot::MetallicRoughness => material.metallic_roughness_texture = Some(reference),
                Slot::Normal => {
                    material.normal_scale = opt_f32(info, "scale", &iptr)?.unwrap_or(1.0);
                    material.normal_texture = Some(reference);
                }
                Slot::Occlusion => {
                    let strength = opt_f32(info, "strength", &iptr)?.unwrap_or(1.0);
                    if !(0.0..=1.0).contains(&strength) {
                        cx.warn(
                            child(&iptr, "strength"),
                            format!("occlusion strength {strength} is outside 0..1; clamped"),
                        );
                    }
                    material.occlusion_strength = strength.clamp(0.0, 1.0);
                    material.occlusion_texture = Some(reference);
                }
                Slot::Emissive => material.emissive_texture = Some(reference),
            }
        }
        material.emissive = opt_f32_array::<3>(m, "emissiveFactor", &ptr)?.unwrap_or([0.0; 3]);
        if let Some(x) = extension(m, "KHR_materials_emissive_strength", &ptr)? {
            let xptr = format!("{ptr}/extensions/KHR_materials_emissive_strength");
            let strength = opt_f32(x, "emissiveStrength", &xptr)?.unwrap_or(1.0);
            if strength < 0.0 {
                cx.warn(
                    child(&xptr, "emissiveStrength"),
                    format!("emissive strength {strength} is negative; 0 is used"),
                );
            }
            material.emissive_strength = strength.max(0.0);
        }
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

/// The `textureInfo` `obj[key]`, if any: the texture it names, the info and its pointer; a
/// texture index that resolves to nothing is reported and the reference left out.
fn texture_info<'a>(
    cx: &mut Cx<'_>,
    obj: &'a Obj<'a>,
    key: &str,
    ptr: &str,
    textures: usize,
) -> Result<Option<(usize, &'a Obj<'a>, String)>, ImportError> {
    let Some(info) = opt_object(obj, key, ptr)? else {
        return Ok(None);
    };
    let iptr = child(ptr, key);
    if !info.contains_key("index") {
        return Err(member_error(&iptr, "index", "missing"));
    }
    let t = lenient_index(cx, info, "index", &iptr, textures, "texture", "the texture is not drawn")?;
    Ok(t.map(|t| (t as usize, info, iptr)))
}

/// `obj[key]` as an index into `len` `what`s; one out of range is reported with `consequence`
/// and read as absent.
fn lenient_index(
    cx: &mut Cx<'_>,
    obj: &Obj,
    key: &str,
    ptr: &str,
    len: usize,
    what: &str,
    consequence: &str,
) -> Result<Option<u32>, ImportError> {
    let Some(i) = opt_u64(obj, key, ptr)? else {
        return Ok(None);
    };
    match super::json::check_index(i, len, what, &child(ptr, key)) {
        Ok(i) => Ok(Some(i)),
        Err(e) => {
            cx.warn(e.pointer, format!("{}; {consequence}", e.message));
            Ok(None)
        }
    }
}

/// The texture slots of a material.
#[derive(Clone, Copy)]
enum Slot {
    BaseColor,
    MetallicRoughness,
    Normal,
    Occlusion,
    Emissive,
}

/// A texture's image and sampler settings.
struct Resolved {
    image: u32,
    repeat: [bool; 2],
    nearest: bool,
    min_filter: MinFilter,
}

/// What a texture draws: its image (a WebP of `EXT_texture_webp` preferred, `source` its
/// fallback, also when the WebP cannot be read) and sampler, `None` when it has no usable
/// image; and whether it names an image at all. A `source` or `sampler` that resolves to
/// nothing is reported.
fn resolve_texture(
    cx: &mut Cx<'_>,
    texture: &Obj,
    tptr: &str,
    samplers: &[(&Obj, String)],
    usable_images: &[bool],
) -> Result<(Option<Resolved>, bool), ImportError> {
    let images = usable_images.len();
    let not_drawn = "the texture is not drawn from it";
    let webp = match extension(texture, "EXT_texture_webp", tptr)? {
        Some(x) => {
            let xptr = format!("{tptr}/extensions/EXT_texture_webp");
            lenient_index(cx, x, "source", &xptr, images, "image", not_drawn)?
        }
        None => None,
    };
    let fallback = lenient_index(cx, texture, "source", tptr, images, "image", not_drawn)?;
    let sampler =
        lenient_index(cx, texture, "sampler", tptr, samplers.len(), "sampler", "the default sampler is used")?;
    let named = texture.contains_key("source") || webp.is_some();
    // An image that cannot be read was reported with the images.
    let usable = |i: Option<u32>| i.filter(|&i| usable_images[i as usize]);
    let Some(image) = usable(webp).or(usable(fallback)) else {
        return Ok((None, named));
    };
    let mut repeat = [true, true];
    let mut nearest = false;
    let mut min_filter = MinFilter::default();
    if let Some(s) = sampler {
        let (sampler, sptr) = &samplers[s as usize];
        repeat = [
            opt_u64(sampler, "wrapS", sptr)?.unwrap_or(10497) != 33071,
            opt_u64(sampler, "wrapT", sptr)?.unwrap_or(10497) != 33071,
        ];
        nearest = opt_u64(sampler, "magFilter", sptr)? == Some(9728);
        if let Some(code) = opt_u64(sampler, "minFilter", sptr)? {
            match MinFilter::from_gl(code) {
                Some(filter) => min_filter = filter,
                None => cx.warn(
                    child(sptr, "minFilter"),
                    format!("minFilter {code} is not a glTF filter; trilinear is used"),
                ),
            }
        }
    }
    Ok((Some(Resolved { image, repeat, nearest, min_filter }), named))
}

/// A texture reference from a `textureInfo` (at `ptr`) to a resolved texture. A `texCoord`
/// above 1 is reported: the viewer draws with TEXCOORD_0 and TEXCOORD_1.
fn texture_ref(cx: &mut Cx<'_>, texture: &Resolved, info: &Obj, ptr: &str) -> Result<TextureRef, ImportError> {
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
    let tex_coord = if tex_coord > 1 {
        cx.warn(
            child(ptr, "texCoord"),
            format!("texture coordinate set {tex_coord} is not drawn (sets 0 and 1 are); TEXCOORD_0 is used"),
        );
        0
    } else {
        tex_coord
    };
    let Resolved { image, repeat, nearest, min_filter } = *texture;
    Ok(TextureRef { image, tex_coord, transform, repeat, nearest, min_filter })
}

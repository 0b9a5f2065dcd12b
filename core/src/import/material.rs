//! Images (decoded to RGBA8), textures, samplers and materials.

use super::Cx;
use super::container::{Budget, load_uri};
use super::json::{
    Obj, child, extension, member_error, objects, opt_bool, opt_f32, opt_f32_array, opt_index, opt_object, opt_str,
    opt_u64, req_index,
};
use crate::asset::{AlphaMode, Image, Material, TextureRef, TextureTransform};
use crate::error::ImportError;
use std::borrow::Cow;
use std::io::Cursor;

/// Decoded images by glTF index; an image that cannot be loaded or decoded is replaced
/// by a 1×1 white pixel (with a warning) and marked unusable (`false`).
pub(crate) fn images(cx: &mut Cx<'_>) -> Result<(Vec<Image>, Vec<bool>), ImportError> {
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
        let decoded = bytes.and_then(|b| decode(&b, &ptr, &mut cx.budget));
        match decoded {
            Ok((width, height, rgba8)) => {
                images.push(Image { name, width, height, rgba8 });
                usable.push(true);
            }
            Err(e) => {
                cx.warn(e.pointer, format!("{}; image skipped (replaced by a white pixel)", e.message));
                images.push(Image { name, width: 1, height: 1, rgba8: vec![255; 4] });
                usable.push(false);
            }
        }
    }
    Ok((images, usable))
}

/// Decodes PNG or JPEG bytes to RGBA8, checking the header's dimensions against the budget first.
fn decode(bytes: &[u8], ptr: &str, budget: &mut Budget) -> Result<(u32, u32, Vec<u8>), ImportError> {
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
    let Some(image) = opt_index(texture, "source", tptr, usable_images.len(), "image")? else {
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

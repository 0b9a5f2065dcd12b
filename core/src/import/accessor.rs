//! Buffer views and accessors: layouts validated with checked 64-bit arithmetic before
//! anything is read, then decoded element by element (strides, matrix column padding,
//! normalized integers, sparse substitution).

use super::container::Budget;
use super::json::{Obj, Ptr, child, items, member_error, opt_bool, opt_object, opt_u64, req_index, req_u64};
use crate::error::ImportError;
use crate::math::Vec4;
use std::borrow::Cow;
use std::fmt::Display;

/// An accessor component type.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Component {
    I8,
    U8,
    I16,
    U16,
    U32,
    F32,
}

impl Component {
    fn from_gl(code: u64) -> Option<Self> {
        Some(match code {
            5120 => Self::I8,
            5121 => Self::U8,
            5122 => Self::I16,
            5123 => Self::U16,
            5125 => Self::U32,
            5126 => Self::F32,
            _ => return None,
        })
    }

    /// Bytes per component.
    pub(crate) fn size(self) -> u64 {
        match self {
            Self::I8 | Self::U8 => 1,
            Self::I16 | Self::U16 => 2,
            Self::U32 | Self::F32 => 4,
        }
    }

    /// What a normalized integer of this type is divided by, its largest value; `None` for the
    /// types glTF never normalizes.
    pub(crate) fn normalized_scale(self) -> Option<f32> {
        match self {
            Self::I8 => Some(I8_SCALE),
            Self::U8 => Some(U8_SCALE),
            Self::I16 => Some(I16_SCALE),
            Self::U16 => Some(U16_SCALE),
            Self::U32 | Self::F32 => None,
        }
    }

    /// Whether this is an unsigned integer type (indices, joints).
    fn is_unsigned_int(self) -> bool {
        matches!(self, Self::U8 | Self::U16 | Self::U32)
    }

    /// One component as `f32` (normalized integers mapped to [0, 1] or [-1, 1]).
    #[inline]
    fn to_f32(self, b: &[u8], normalized: bool) -> f32 {
        match self {
            Self::F32 => f32::from_le_bytes([b[0], b[1], b[2], b[3]]),
            Self::U32 => u32_f32([b[0], b[1], b[2], b[3]]),
            Self::I8 => i8_f32([b[0]], normalized),
            Self::U8 => u8_f32([b[0]], normalized),
            Self::I16 => i16_f32([b[0], b[1]], normalized),
            Self::U16 => u16_f32([b[0], b[1]], normalized),
        }
    }

    /// One unsigned component as `u32` (0 for signed or float types, which callers refuse).
    #[inline]
    fn to_u32(self, b: &[u8]) -> u32 {
        match self {
            Self::U8 => u32::from(b[0]),
            Self::U16 => u32::from(u16::from_le_bytes([b[0], b[1]])),
            Self::U32 => u32::from_le_bytes([b[0], b[1], b[2], b[3]]),
            _ => 0,
        }
    }
}

/// An integer component's value as `f32`; normalized, divided by its type's largest value
/// (`scale`) and kept at or above -1. A comparison, not `f32::max`: the quotient is never NaN,
/// and wasm's `f32.max` treats NaN unlike Rust's, so `max` there is a call to `fmaxf` (for a
/// quantized file, a call for every component: 8 % of its import).
#[inline]
fn scaled(v: f32, scale: f32, normalized: bool) -> f32 {
    if !normalized {
        return v;
    }
    let x = v / scale;
    if x < -1.0 { -1.0 } else { x }
}

/// [`scaled`] of every value of `values` (integers as floats), normalized: four at a time, each
/// lane's division and comparison the same as one value's (a wasm build of the importer at
/// opt-level "s" does not vectorize the loop itself; a value at a time was 7 % of a quantized
/// file's import).
fn normalize_run(values: &mut [f32], scale: f32) {
    let (fours, rest) = values.as_chunks_mut::<4>();
    let scale4 = Vec4::splat(scale);
    for four in fours {
        let v = Vec4::from_array(*four) / scale4;
        *four = Vec4::select(v.cmplt(Vec4::NEG_ONE), Vec4::NEG_ONE, v).to_array();
    }
    for x in rest {
        *x = scaled(*x, scale, true);
    }
}

// Each integer type's largest value, what a normalized one is divided by.
const I8_SCALE: f32 = i8::MAX as f32;
const U8_SCALE: f32 = u8::MAX as f32;
const I16_SCALE: f32 = i16::MAX as f32;
const U16_SCALE: f32 = u16::MAX as f32;

// Each integer component type's bytes as `f32` ([`Component::to_f32`] and the whole-run reads).
#[inline]
fn i8_f32([b]: [u8; 1], normalized: bool) -> f32 {
    scaled(f32::from(b as i8), I8_SCALE, normalized)
}
#[inline]
fn u8_f32([b]: [u8; 1], normalized: bool) -> f32 {
    scaled(f32::from(b), U8_SCALE, normalized)
}
#[inline]
fn i16_f32(b: [u8; 2], normalized: bool) -> f32 {
    scaled(f32::from(i16::from_le_bytes(b)), I16_SCALE, normalized)
}
#[inline]
fn u16_f32(b: [u8; 2], normalized: bool) -> f32 {
    scaled(f32::from(u16::from_le_bytes(b)), U16_SCALE, normalized)
}
#[inline]
fn u32_f32(b: [u8; 4]) -> f32 {
    u32::from_le_bytes(b) as f32
}

/// A dense `VEC4` accessor's elements as one run of bytes ([`Accessors::dense_vec4`]).
pub(crate) struct DenseRun<'a> {
    pub component: Component,
    pub normalized: bool,
    /// From the first element to the end of the last: `count` chunks of `stride` bytes, the
    /// last possibly just one element long.
    pub bytes: &'a [u8],
    /// Whether the elements lie side by side (the stride is an element's size).
    pub packed: bool,
}

/// A validated buffer view.
#[derive(Clone, Copy, Debug)]
struct View {
    buffer: usize,
    offset: u64,
    length: u64,
    stride: Option<u64>,
}

/// A validated sparse substitution.
#[derive(Clone, Copy, Debug)]
struct Sparse {
    count: u64,
    indices_view: usize,
    indices_offset: u64,
    indices_component: Component,
    values_view: usize,
    values_offset: u64,
}

/// A validated accessor layout.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Accessor {
    view: Option<usize>,
    offset: u64,
    /// Number of elements.
    pub count: u64,
    component: Component,
    normalized: bool,
    /// `"SCALAR"`, `"VEC3"`, `"MAT4"`…
    pub type_name: &'static str,
    rows: usize,
    cols: usize,
    column_stride: u64,
    element_size: u64,
    /// The bytes an element's components span: `element_size` without the last column's
    /// padding (a matrix's last element in its view needs no padding after it).
    extent: u64,
    stride: u64,
    sparse: Option<Sparse>,
}

impl Accessor {
    /// Components per element.
    pub fn components(&self) -> usize {
        self.rows * self.cols
    }

    /// The component type.
    pub(crate) fn component(&self) -> Component {
        self.component
    }
}

/// `(rows, cols)` of an accessor type.
fn shape(type_name: &str) -> Option<(&'static str, usize, usize)> {
    Some(match type_name {
        "SCALAR" => ("SCALAR", 1, 1),
        "VEC2" => ("VEC2", 2, 1),
        "VEC3" => ("VEC3", 3, 1),
        "VEC4" => ("VEC4", 4, 1),
        "MAT2" => ("MAT2", 2, 2),
        "MAT3" => ("MAT3", 3, 3),
        "MAT4" => ("MAT4", 4, 4),
        _ => return None,
    })
}

/// All buffers, views and accessors of a document.
#[derive(Debug)]
pub(crate) struct Accessors<'a> {
    /// `None`: a buffer without data (refused where a view of it is read).
    buffers: Vec<Option<Cow<'a, [u8]>>>,
    views: Vec<View>,
    /// Each accessor, or why it cannot be read: an accessor is refused only where it is read.
    list: Vec<Result<Accessor, ImportError>>,
    /// The views that were stored compressed.
    pub compressed: Vec<crate::asset::CompressedView>,
}

/// `offset + stride * (count - 1) + element` (count ≥ 1) in u64, None on overflow.
fn span(offset: u64, stride: u64, count: u64, element: u64) -> Option<u64> {
    offset.checked_add(stride.checked_mul(count.checked_sub(1)?)?)?.checked_add(element)
}

/// The bytes of the view `v` (at `ptr`, `length` bytes) when it is stored compressed with
/// `EXT_meshopt_compression` or `KHR_meshopt_compression`: the compressed range is read from
/// its buffer, checked, charged to the budget and decoded, with what it cost (its `view` set by the caller). `None` for a view
/// stored as is.
fn decompress(
    v: &Obj,
    ptr: &Ptr<'_>,
    length: u64,
    buffers: &[Option<Cow<'_, [u8]>>],
    budget: &mut Budget,
) -> Result<Option<(Vec<u8>, crate::asset::CompressedView)>, ImportError> {
    let mut found = None;
    for name in super::meshopt::EXTENSIONS {
        if let Some(x) = super::json::extension(v, name, ptr)? {
            found = Some((name, x));
            break;
        }
    }
    let Some((name, x)) = found else {
        return Ok(None);
    };
    let khr = name == super::meshopt::EXTENSIONS[0];
    // Written out only for a message.
    let extensions = Ptr::member(ptr, "extensions");
    let xptr = Ptr::member(&extensions, name);
    let buffer = req_index(x, "buffer", &xptr, buffers.len(), "buffer")? as usize;
    let offset = opt_u64(x, "byteOffset", &xptr)?.unwrap_or(0);
    let size = req_u64(x, "byteLength", &xptr)?;
    let stride = req_u64(x, "byteStride", &xptr)?;
    let count = req_u64(x, "count", &xptr)?;
    let mode_name = super::json::opt_str(x, "mode", &xptr)?.ok_or_else(|| member_error(&xptr, "mode", "missing"))?;
    let mode = super::meshopt::Mode::parse(mode_name)
        .ok_or_else(|| member_error(&xptr, "mode", format!("unknown mode '{mode_name}'")))?;
    let filter_name = super::json::opt_str(x, "filter", &xptr)?.unwrap_or("NONE");
    let filter = super::meshopt::Filter::parse(filter_name)
        .ok_or_else(|| member_error(&xptr, "filter", format!("unknown filter '{filter_name}'")))?;
    super::meshopt::check(mode, filter, count, stride, khr).map_err(|e| ImportError::new(xptr, e))?;
    if count.checked_mul(stride) != Some(length) {
        return Err(ImportError::new(
            xptr,
            format!("count {count} × byteStride {stride} is not the view's byteLength {length}"),
        ));
    }
    let data = buffers[buffer].as_deref().ok_or_else(|| {
        ImportError::new(child(&xptr, "buffer"), format!("buffer {buffer} has no data for the compressed view"))
    })?;
    let src = offset
        .checked_add(size)
        .and_then(|end| data.get(usize::try_from(offset).ok()?..usize::try_from(end).ok()?))
        .ok_or_else(|| {
            ImportError::new(
                xptr,
                format!("byteOffset {offset} + byteLength {size} does not fit buffer {buffer} ({} bytes)", data.len()),
            )
        })?;
    budget.take(Some(length), &xptr, &format_args!("decompressed view of {length} bytes"))?;
    let length = usize::try_from(length).map_err(|_| ImportError::new(xptr, "the view is too large"))?;
    let mut out = vec![0u8; length];
    // `check` and the length test above hold, so the sizes fit a usize.
    super::meshopt::decode(mode, filter, count as usize, stride as usize, src, &mut out, khr)
        .map_err(|e| ImportError::new(xptr, e))?;
    let cost = crate::asset::CompressedView {
        view: 0,
        extension: name.to_owned(),
        mode: mode_name.to_owned(),
        filter: filter_name.to_owned(),
        compressed_bytes: size,
        decoded_bytes: length as u64,
    };
    Ok(Some((out, cost)))
}

impl<'a> Accessors<'a> {
    /// Validates every buffer view and accessor of `root` against `buffers`.
    /// A view compressed with a meshopt extension is decoded here (into a buffer of its own,
    /// charged to the budget first).
    pub fn new(root: &Obj, mut buffers: Vec<Option<Cow<'a, [u8]>>>, budget: &mut Budget) -> Result<Self, ImportError> {
        let view_objects = items(root, "bufferViews", &"")?;
        budget.take_items(view_objects.len() as u64, size_of::<View>() as u64, "/bufferViews", "buffer views")?;
        let mut views = Vec::with_capacity(view_objects.len());
        let mut compressed = Vec::new();
        for (index, (v, ptr)) in view_objects.iter().enumerate() {
            let buffer = req_index(v, "buffer", ptr, buffers.len(), "buffer")? as usize;
            let offset = opt_u64(v, "byteOffset", ptr)?.unwrap_or(0);
            let length = req_u64(v, "byteLength", ptr)?;
            if length == 0 {
                return Err(member_error(ptr, "byteLength", "byteLength must be at least 1"));
            }
            if let Some((decoded, mut cost)) = decompress(v, ptr, length, &buffers, budget)? {
                cost.view = index as u32;
                compressed.push(cost);
                let stride = opt_u64(v, "byteStride", ptr)?;
                views.push(View { buffer: buffers.len(), offset: 0, length, stride });
                buffers.push(Some(Cow::Owned(decoded)));
                continue;
            }
            let stride = opt_u64(v, "byteStride", ptr)?;
            if let Some(s) = stride
                && (!(4..=252).contains(&s) || s % 4 != 0)
            {
                return Err(member_error(
                    ptr,
                    "byteStride",
                    format!("byteStride {s} is not a multiple of 4 in 4..=252"),
                ));
            }
            // A buffer without data: its views are checked where they are read.
            let buffer_len = buffers[buffer].as_ref().map_or(u64::MAX, |b| b.len() as u64);
            if offset.checked_add(length).is_none_or(|end| end > buffer_len) {
                return Err(ImportError::new(
                    *ptr,
                    format!(
                        "byteOffset {offset} + byteLength {length} does not fit buffer {buffer} ({buffer_len} bytes)"
                    ),
                ));
            }
            views.push(View { buffer, offset, length, stride });
        }
        let accessor_objects = items(root, "accessors", &"")?;
        budget.take_items(accessor_objects.len() as u64, size_of::<Accessor>() as u64, "/accessors", "accessors")?;
        let mut list = Vec::with_capacity(accessor_objects.len());
        for (a, ptr) in &accessor_objects {
            list.push(Self::accessor(a, ptr, &views));
        }
        Ok(Self { buffers, views, list, compressed })
    }

    fn accessor(a: &Obj, ptr: &Ptr<'_>, views: &[View]) -> Result<Accessor, ImportError> {
        let code = req_u64(a, "componentType", ptr)?;
        let component = Component::from_gl(code)
            .ok_or_else(|| member_error(ptr, "componentType", format!("{code} is not a valid component type")))?;
        let type_value = a.get("type").and_then(|t| t.as_str()).unwrap_or("");
        let (type_name, rows, cols) = shape(type_value)
            .ok_or_else(|| member_error(ptr, "type", format!("'{type_value}' is not a valid accessor type")))?;
        let count = req_u64(a, "count", ptr)?;
        if count == 0 {
            return Err(member_error(ptr, "count", "count must be at least 1, got 0"));
        }
        let normalized = opt_bool(a, "normalized", ptr)?.unwrap_or(false);
        if normalized && matches!(component, Component::F32 | Component::U32) {
            return Err(member_error(ptr, "normalized", "FLOAT and UNSIGNED_INT accessors cannot be normalized"));
        }
        let csize = component.size();
        let column = rows as u64 * csize;
        let column_stride = if cols > 1 { column.next_multiple_of(4) } else { column };
        let element_size = column_stride * cols as u64;
        let extent = column_stride * (cols as u64 - 1) + column;
        let offset = opt_u64(a, "byteOffset", ptr)?.unwrap_or(0);
        let view = super::json::opt_index(a, "bufferView", ptr, views.len(), "bufferView")?.map(|v| v as usize);
        let mut stride = element_size;
        if let Some(v) = view {
            let vw = &views[v];
            stride = vw.stride.unwrap_or(element_size);
            if stride < element_size {
                return Err(ImportError::new(
                    *ptr,
                    format!("byteStride {stride} of bufferView {v} is smaller than its {element_size}-byte elements"),
                ));
            }
            if span(offset, stride, count, extent).is_none_or(|end| end > vw.length) {
                return Err(ImportError::new(
                    *ptr,
                    format!(
                        "count {count} does not fit bufferView {v} ({count} elements of {element_size} bytes, stride {stride}, from byteOffset {offset}; the view has {} bytes)",
                        vw.length
                    ),
                ));
            }
        }
        let sparse = match opt_object(a, "sparse", ptr)? {
            Some(s) => Some(Self::sparse(s, &child(ptr, "sparse"), count, element_size, views)?),
            None => None,
        };
        Ok(Accessor {
            view,
            offset,
            count,
            component,
            normalized,
            type_name,
            rows,
            cols,
            column_stride,
            element_size,
            extent,
            stride,
            sparse,
        })
    }

    fn sparse(s: &Obj, ptr: &str, count: u64, element_size: u64, views: &[View]) -> Result<Sparse, ImportError> {
        let sparse_count = req_u64(s, "count", ptr)?;
        if sparse_count == 0 || sparse_count > count {
            return Err(member_error(ptr, "count", format!("sparse count {sparse_count} must be in 1..={count}")));
        }
        let fits = |o: &Obj, p: &str, element: u64| -> Result<(usize, u64), ImportError> {
            let v = req_index(o, "bufferView", p, views.len(), "bufferView")? as usize;
            let offset = opt_u64(o, "byteOffset", p)?.unwrap_or(0);
            if span(offset, element, sparse_count, element).is_none_or(|end| end > views[v].length) {
                return Err(ImportError::new(
                    p,
                    format!(
                        "{sparse_count} sparse elements of {element} bytes from byteOffset {offset} do not fit bufferView {v}"
                    ),
                ));
            }
            Ok((v, offset))
        };
        let ip = child(ptr, "indices");
        let indices = opt_object(s, "indices", ptr)?.ok_or_else(|| ImportError::new(&ip, "missing"))?;
        let code = req_u64(indices, "componentType", &ip)?;
        let indices_component = Component::from_gl(code)
            .filter(|c| c.is_unsigned_int())
            .ok_or_else(|| member_error(&ip, "componentType", format!("{code} is not a valid sparse index type")))?;
        let (indices_view, indices_offset) = fits(indices, &ip, indices_component.size())?;
        let vp = child(ptr, "values");
        let values = opt_object(s, "values", ptr)?.ok_or_else(|| ImportError::new(&vp, "missing"))?;
        let (values_view, values_offset) = fits(values, &vp, element_size)?;
        Ok(Sparse { count: sparse_count, indices_view, indices_offset, indices_component, values_view, values_offset })
    }

    /// Points accessor `index` at `data`, decoded elsewhere (a Draco stream): `count` tightly
    /// packed elements of its type in `component`. Its view, offset and sparse part are
    /// replaced; the caller checked `index` and charged `data` to the budget.
    pub fn replace(&mut self, index: u32, data: Vec<u8>, count: u64, component: Component) {
        let Some(Ok(a)) = self.list.get_mut(index as usize) else { return };
        let column = a.rows as u64 * component.size();
        a.column_stride = if a.cols > 1 { column.next_multiple_of(4) } else { column };
        a.element_size = a.column_stride * a.cols as u64;
        a.extent = a.column_stride * (a.cols as u64 - 1) + column;
        a.stride = a.element_size;
        a.component = component;
        a.count = count;
        a.offset = 0;
        a.sparse = None;
        a.view = Some(self.views.len());
        self.views.push(View { buffer: self.buffers.len(), offset: 0, length: data.len() as u64, stride: None });
        self.buffers.push(Some(Cow::Owned(data)));
    }

    /// Number of buffer views.
    pub fn view_count(&self) -> usize {
        self.views.len()
    }

    /// Number of accessors.
    pub fn len(&self) -> usize {
        self.list.len()
    }

    /// The accessor at `index` (validated by the caller against [`Accessors::len`]).
    pub fn get(&self, index: u32) -> Result<&Accessor, ImportError> {
        match self.list.get(index as usize) {
            Some(Ok(accessor)) => Ok(accessor),
            Some(Err(e)) => Err(e.clone()),
            None => Err(ImportError::new(format!("/accessors/{index}"), "accessor does not exist")),
        }
    }

    /// Bytes of a buffer view.
    pub fn view_bytes(&self, view: usize) -> Result<&[u8], ImportError> {
        let v =
            self.views.get(view).ok_or_else(|| ImportError::new(format!("/bufferViews/{view}"), "does not exist"))?;
        if let Some(None) = self.buffers.get(v.buffer) {
            return Err(ImportError::new(
                format!("/buffers/{}", v.buffer),
                format!("buffer has no uri and the file has no GLB BIN chunk for it (bufferView {view} is read)"),
            ));
        }
        let start = usize::try_from(v.offset).ok();
        let end = v.offset.checked_add(v.length).and_then(|e| usize::try_from(e).ok());
        start
            .zip(end)
            .and_then(|(s, e)| self.buffers.get(v.buffer)?.as_ref()?.get(s..e))
            .ok_or_else(|| ImportError::new(format!("/bufferViews/{view}"), "does not fit its buffer"))
    }

    /// Refuses (at `use_ptr`) an accessor whose type is not one of `types`.
    pub fn expect_type(
        &self,
        index: u32,
        use_ptr: &(impl Display + ?Sized),
        types: &[&str],
    ) -> Result<&Accessor, ImportError> {
        let a = self.get(index)?;
        if types.contains(&a.type_name) {
            Ok(a)
        } else {
            Err(ImportError::new(
                use_ptr.to_string(),
                format!("accessor {index} is {}, expected {}", a.type_name, types.join(" or ")),
            ))
        }
    }

    /// Calls `f(element_index, components)` for every element, dense data or zeros with
    /// sparse substitutions, decoding each component with `decode`.
    fn visit<T: Copy + Default>(
        &self,
        index: u32,
        decode: impl Fn(Component, &[u8]) -> T,
        mut f: impl FnMut(u64, &[T]) -> Result<(), ImportError>,
    ) -> Result<(), ImportError> {
        let a = self.get(index)?;
        let ptr = || format!("/accessors/{index}");
        let out_of_bounds = || ImportError::new(ptr(), "element outside its buffer view");
        let dense = a.view.map(|v| self.view_bytes(v)).transpose()?;
        let sparse = match &a.sparse {
            Some(s) => Some((s, self.view_bytes(s.indices_view)?, self.view_bytes(s.values_view)?)),
            None => None,
        };
        let sparse_index = |k: u64| -> Result<u64, ImportError> {
            let (s, indices, _) = sparse.as_ref().ok_or_else(out_of_bounds)?;
            let size = s.indices_component.size();
            let at = s.indices_offset + k * size;
            let bytes = slice(indices, at, size).ok_or_else(out_of_bounds)?;
            Ok(u64::from(s.indices_component.to_u32(bytes)))
        };
        let mut next_sparse = 0u64;
        let mut next_index = match &sparse {
            Some(_) => Some(sparse_index(0)?),
            None => None,
        };
        let mut values = [T::default(); 16];
        let n = a.components();
        let csize = a.component.size();
        // The common case first: dense data, each element's components side by side (no matrix
        // column padding), read with the component size as a constant.
        if let (Some(d), None, 1) = (dense, &sparse, a.cols) {
            let read = |bytes: &[u8]| decode(a.component, bytes);
            return match a.component.size() {
                1 => dense_run::<1, T>(index, a, d, read, f),
                2 => dense_run::<2, T>(index, a, d, read, f),
                _ => dense_run::<4, T>(index, a, d, read, f),
            };
        }
        // Each component's byte offset in its element (matrix columns padded to 4 bytes).
        let mut offsets = [0u64; 16];
        for (j, at) in offsets[..n].iter_mut().enumerate() {
            *at = (j / a.rows) as u64 * a.column_stride + (j % a.rows) as u64 * csize;
        }
        for i in 0..a.count {
            let element = match (next_index, &sparse) {
                (Some(si), Some((s, _, sparse_values))) if si == i => {
                    let bytes = slice(sparse_values, s.values_offset + next_sparse * a.element_size, a.element_size);
                    next_sparse += 1;
                    next_index = None;
                    if next_sparse < s.count {
                        let following = sparse_index(next_sparse)?;
                        if following <= i {
                            return Err(ImportError::new(
                                format!("{}/sparse/indices", ptr()),
                                format!("sparse indices must be strictly increasing: {following} follows {i}"),
                            ));
                        }
                        next_index = Some(following);
                    }
                    Some(bytes.ok_or_else(out_of_bounds)?)
                }
                _ => match dense {
                    Some(d) => Some(slice(d, a.offset + i * a.stride, a.extent).ok_or_else(out_of_bounds)?),
                    None => None,
                },
            };
            match element {
                Some(bytes) => {
                    for (v, &at) in values[..n].iter_mut().zip(&offsets[..n]) {
                        *v = decode(a.component, slice(bytes, at, csize).ok_or_else(out_of_bounds)?);
                    }
                }
                None => values[..n].fill(T::default()),
            }
            f(i, &values[..n])?;
        }
        if let Some(si) = next_index {
            return Err(ImportError::new(
                format!("{}/sparse/indices", ptr()),
                format!("sparse index {si} is out of range (count {})", a.count),
            ));
        }
        Ok(())
    }

    /// Takes `count × N × 4` bytes from the budget and returns an empty vector with that capacity.
    fn allocate<T>(&self, index: u32, count: u64, budget: &mut Budget) -> Result<Vec<T>, ImportError> {
        let ptr = format_args!("/accessors/{index}");
        budget.take_items(count, size_of::<T>() as u64, &ptr, &format_args!("accessor {index} ({count} elements)"))?;
        let n = usize::try_from(count)
            .map_err(|_| ImportError::new(format!("/accessors/{index}"), format!("count {count} is too large")))?;
        Ok(Vec::with_capacity(n))
    }

    /// Reads an accessor of `N` components per element as floats. When `finite` is set,
    /// a NaN or infinite component is refused.
    pub fn read_f32<const N: usize>(
        &self,
        index: u32,
        use_ptr: &(impl Display + ?Sized),
        types: &[&str],
        finite: bool,
        budget: &mut Budget,
    ) -> Result<Vec<[f32; N]>, ImportError> {
        let a = self.expect_type(index, use_ptr, types)?;
        if a.components() != N {
            return Err(ImportError::new(
                use_ptr.to_string(),
                format!("accessor {index} has {} components, expected {N}", a.components()),
            ));
        }
        let normalized = a.normalized;
        let mut out = self.allocate::<[f32; N]>(index, a.count, budget)?;
        if a.component == Component::F32 && self.dense_elements::<N, 4, _>(a, f32::from_le_bytes, &mut out)? {
            // One pass without a branch a value; the element is looked for only to name it.
            if finite
                && !crate::math::all_finite(out.as_flattened())
                && let Some((i, e)) = out.iter().enumerate().find(|(_, e)| !e.iter().all(|x| x.is_finite()))
            {
                return Err(ImportError::new(
                    format!("/accessors/{index}"),
                    format!("element {i} is not finite: {e:?}"),
                ));
            }
            return Ok(out);
        }
        // Quantized (integer) attributes, finite whatever they hold: filled as one flat run
        // (code for each component type, not for each type and element width); `out` already
        // has room for every element (charged to the budget above).
        if a.component != Component::F32 {
            out.resize(usize::try_from(a.count).unwrap_or(0), [0.0; N]);
            if self.dense_components(a, normalized, out.as_flattened_mut())? {
                return Ok(out);
            }
            out.clear();
        }
        self.visit(
            index,
            |c, b| c.to_f32(b, normalized),
            |i, v| {
                let mut e = [0.0; N];
                e.copy_from_slice(v);
                if finite && !e.iter().all(|x| x.is_finite()) {
                    return Err(ImportError::new(
                        format!("/accessors/{index}"),
                        format!("element {i} is not finite: {e:?}"),
                    ));
                }
                out.push(e);
                Ok(())
            },
        )?;
        Ok(out)
    }

    /// The common case of [`Accessors::read_f32`] and [`Accessors::read_u32`] in one go: data in
    /// a buffer view, not sparse, every element inside the view (checked once, for the last), so
    /// `out` is filled without a bounds check or a closure call per element (positions, normals,
    /// UVs, keyframes, indices, joints: the same values [`Accessors::visit`] reads element by
    /// element). `S`: the component's bytes, which `read` converts. `false`, `out` untouched,
    /// for anything else (that path then gives the right error where there is one).
    fn dense_elements<const N: usize, const S: usize, T: Copy + Default>(
        &self,
        a: &Accessor,
        read: impl Fn([u8; S]) -> T,
        out: &mut Vec<[T; N]>,
    ) -> Result<bool, ImportError> {
        if a.components() != N {
            return Ok(false);
        }
        let Some((region, stride)) = self.dense_region(a, S * N)? else {
            return Ok(false);
        };
        // The region holds `count` elements, `stride` bytes apart, the last one ending it.
        if stride == S * N {
            // Packed: extended by an iterator of known length (room made once, no check per
            // element; pushing element by element cost wasm a capacity check and a store per
            // element, and writing over zeros a pass to zero them first).
            out.extend(region.as_chunks::<S>().0.as_chunks::<N>().0.iter().map(|e| e.map(&read)));
            return Ok(true);
        }
        let start = out.len();
        out.resize(start + (region.len() - S * N) / stride + 1, [T::default(); N]);
        // Interleaved: each chunk starts an element (the last may stop at its end).
        for (e, c) in out[start..].iter_mut().zip(region.chunks(stride)) {
            for (v, &b) in e.iter_mut().zip(c.as_chunks::<S>().0) {
                *v = read(b);
            }
        }
        Ok(true)
    }

    /// [`Accessors::dense_elements`] for any number of components: every component of every
    /// element, one after the other, into `out` (`count × components` values; `false`, `out`
    /// untouched, for any other length).
    fn dense_flat<const S: usize>(
        &self,
        a: &Accessor,
        read: impl Fn([u8; S]) -> f32,
        out: &mut [f32],
    ) -> Result<bool, ImportError> {
        let n = a.components();
        let element = S * n;
        if u64::try_from(out.len()).ok() != a.count.checked_mul(n as u64) {
            return Ok(false);
        }
        let Some((region, stride)) = self.dense_region(a, element)? else {
            return Ok(false);
        };
        if stride == element {
            for (v, &b) in out.iter_mut().zip(region.as_chunks::<S>().0) {
                *v = read(b);
            }
        } else {
            let elements = region.chunks(stride).filter_map(|c| c.get(..element));
            for (values, e) in out.chunks_exact_mut(n).zip(elements) {
                for (v, &b) in values.iter_mut().zip(e.as_chunks::<S>().0) {
                    *v = read(b);
                }
            }
        }
        Ok(true)
    }

    /// Whether accessor `index` is read as one run ([`Accessors::dense_region`]) rather than
    /// element by element.
    #[cfg(test)]
    pub(crate) fn reads_as_one_run(&self, index: u32) -> bool {
        self.get(index)
            .is_ok_and(|a| matches!(self.dense_region(a, a.component.size() as usize * a.components()), Ok(Some(_))))
    }

    /// [`Accessors::dense_flat`] for any component type (`normalized`: integers mapped to
    /// [0, 1] or [-1, 1]).
    fn dense_components(&self, a: &Accessor, normalized: bool, out: &mut [f32]) -> Result<bool, ImportError> {
        // One loop per component type (its decoder known in the loop), the integers as they
        // are; normalized ones then divided four at a time.
        let read = match a.component {
            Component::F32 => self.dense_flat::<4>(a, f32::from_le_bytes, out),
            Component::U32 => self.dense_flat::<4>(a, u32_f32, out),
            Component::I16 => self.dense_flat::<2>(a, |b| i16_f32(b, false), out),
            Component::U16 => self.dense_flat::<2>(a, |b| u16_f32(b, false), out),
            Component::I8 => self.dense_flat::<1>(a, |b| i8_f32(b, false), out),
            Component::U8 => self.dense_flat::<1>(a, |b| u8_f32(b, false), out),
        }?;
        if let Some(scale) = a.component.normalized_scale()
            && read
            && normalized
        {
            normalize_run(out, scale);
        }
        Ok(read)
    }

    /// The bytes from a dense accessor's first element to the end of its last (`element`
    /// bytes each) and its stride, where the accessor is in a buffer view, not sparse, not a
    /// matrix (whose columns may be padded), not empty, and every element lies in the view (checked once,
    /// for the last); `None` for anything else (the element-by-element path then gives the
    /// right error where there is one).
    fn dense_region(&self, a: &Accessor, element: usize) -> Result<Option<(&[u8], usize)>, ImportError> {
        let (Some(view), None, 1) = (a.view, &a.sparse, a.cols) else {
            return Ok(None);
        };
        if a.count == 0 || element == 0 {
            return Ok(None);
        }
        let data = self.view_bytes(view)?;
        let span = (a.count - 1).checked_mul(a.stride).and_then(|s| s.checked_add(element as u64));
        let region = span
            .and_then(|span| a.offset.checked_add(span).map(|end| (a.offset, end)))
            .and_then(|(start, end)| Some((usize::try_from(start).ok()?, usize::try_from(end).ok()?)))
            .and_then(|(start, end)| data.get(start..end));
        match (region, usize::try_from(a.stride)) {
            (Some(region), Ok(stride)) if stride >= element => Ok(Some((region, stride))),
            _ => Ok(None),
        }
    }

    /// Reads any accessor as a flat float array (`count × components`), non-finite values included.
    pub fn read_flat(&self, index: u32, budget: &mut Budget) -> Result<(Vec<f32>, usize), ImportError> {
        let a = self.get(index)?;
        let n = a.components();
        let normalized = a.normalized;
        let total = a.count.checked_mul(n as u64);
        let mut out = self.allocate::<f32>(index, total.unwrap_or(u64::MAX), budget)?;
        // Packed floats (most animation outputs): extended straight from the bytes, without
        // zeroing room for them first.
        if a.component == Component::F32
            && let Some((region, stride)) = self.dense_region(a, 4 * n)?
            && stride == 4 * n
        {
            out.extend(region.as_chunks::<4>().0.iter().map(|&b| f32::from_le_bytes(b)));
            return Ok((out, n));
        }
        out.resize(total.and_then(|t| usize::try_from(t).ok()).unwrap_or(0), 0.0);
        if self.dense_components(a, normalized, &mut out)? {
            return Ok((out, n));
        }
        out.clear();
        self.visit(
            index,
            |c, b| c.to_f32(b, normalized),
            |_, v| {
                out.extend_from_slice(v);
                Ok(())
            },
        )?;
        Ok((out, n))
    }

    /// Reads an accessor of unsigned integers (indices, joints) with `N` components.
    pub fn read_u32<const N: usize>(
        &self,
        index: u32,
        use_ptr: &(impl Display + ?Sized),
        types: &[&str],
        budget: &mut Budget,
    ) -> Result<Vec<[u32; N]>, ImportError> {
        let a = self.expect_type(index, use_ptr, types)?;
        if !a.component.is_unsigned_int() || a.normalized || a.components() != N {
            return Err(ImportError::new(
                use_ptr.to_string(),
                format!("accessor {index} must hold {N} unnormalized unsigned integers per element"),
            ));
        }
        let mut out = self.allocate::<[u32; N]>(index, a.count, budget)?;
        let dense = match a.component {
            Component::U8 => self.dense_elements::<N, 1, _>(a, |[b]| u32::from(b), &mut out)?,
            Component::U16 => self.dense_elements::<N, 2, _>(a, |b| u32::from(u16::from_le_bytes(b)), &mut out)?,
            Component::U32 => self.dense_elements::<N, 4, _>(a, u32::from_le_bytes, &mut out)?,
            _ => false,
        };
        if dense {
            return Ok(out);
        }
        self.visit(
            index,
            |c, b| c.to_u32(b),
            |_, v| {
                let mut e = [0; N];
                e.copy_from_slice(v);
                out.push(e);
                Ok(())
            },
        )?;
        Ok(out)
    }

    /// Accessor `index`'s elements as one run of bytes where it is a dense `VEC4`
    /// ([`Accessors::dense_region`]); `None` for anything else.
    pub(crate) fn dense_vec4(&self, index: u32) -> Result<Option<DenseRun<'_>>, ImportError> {
        let a = self.get(index)?;
        if a.type_name != "VEC4" {
            return Ok(None);
        }
        let element = 4 * a.component.size() as usize;
        Ok(self.dense_region(a, element)?.map(|(bytes, stride)| DenseRun {
            component: a.component,
            normalized: a.normalized,
            bytes,
            packed: stride == element,
        }))
    }

    /// Whether the accessor holds 8- or 16-bit unsigned integers (JOINTS_n).
    pub fn is_small_uint(&self, index: u32) -> bool {
        self.get(index).is_ok_and(|a| matches!(a.component, Component::U8 | Component::U16))
    }
}

/// Calls `f(element_index, components)` for every element of dense accessor `index` (`a`)
/// whose components of `S` bytes lie side by side, decoding each with `read`.
fn dense_run<const S: usize, T: Copy + Default>(
    index: u32,
    a: &Accessor,
    data: &[u8],
    read: impl Fn(&[u8]) -> T,
    mut f: impl FnMut(u64, &[T]) -> Result<(), ImportError>,
) -> Result<(), ImportError> {
    let n = a.components();
    let mut values = [T::default(); 16];
    for i in 0..a.count {
        let element = usize::try_from(a.offset + i * a.stride)
            .ok()
            .and_then(|at| data.get(at..))
            .and_then(|e| e.get(..n * S))
            .ok_or_else(|| ImportError::new(format!("/accessors/{index}"), "element outside its buffer view"))?;
        for (v, bytes) in values[..n].iter_mut().zip(element.chunks_exact(S)) {
            *v = read(bytes);
        }
        f(i, &values[..n])?;
    }
    Ok(())
}

/// `bytes[at..at + len]` with checked arithmetic.
fn slice(bytes: &[u8], at: u64, len: u64) -> Option<&[u8]> {
    let start = usize::try_from(at).ok()?;
    let end = usize::try_from(at.checked_add(len)?).ok()?;
    bytes.get(start..end)
}

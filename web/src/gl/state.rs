//! The WebGL2 contexts of the page and the GL objects behind the backend's handles.
//!
//! wgpu's interface objects must be `Send + Sync` (the workspace builds wgpu with
//! `fragile-send-sync-non-atomic-wasm`), which no JavaScript object is. So every handle the
//! backend gives wgpu is plain data — a context number and an object number — and the JS
//! objects live here, in a thread-local table per context (the page has one thread). A handle
//! dropped deletes its GL object; a lost context's table goes with its last handle.

use std::cell::RefCell;
use std::collections::HashMap;

use web_sys::{
    WebGl2RenderingContext as Gl, WebGlBuffer, WebGlFramebuffer, WebGlProgram, WebGlRenderbuffer, WebGlSampler,
    WebGlShader, WebGlTexture, WebGlUniformLocation,
};

pub(super) use super::table::Binding;
use super::table::GlStage;

/// A slab of GL objects: handles are indices, freed ones reused.
pub(super) struct Slab<T> {
    items: Vec<Option<T>>,
    free: Vec<u32>,
}

impl<T> Default for Slab<T> {
    fn default() -> Self {
        Self { items: Vec::new(), free: Vec::new() }
    }
}

impl<T> Slab<T> {
    pub fn insert(&mut self, item: T) -> u32 {
        if let Some(id) = self.free.pop()
            && let Some(slot) = self.items.get_mut(id as usize)
        {
            *slot = Some(item);
            return id;
        }
        self.items.push(Some(item));
        (self.items.len() - 1) as u32
    }

    pub fn get(&self, id: u32) -> Option<&T> {
        self.items.get(id as usize).and_then(Option::as_ref)
    }

    pub fn get_mut(&mut self, id: u32) -> Option<&mut T> {
        self.items.get_mut(id as usize).and_then(Option::as_mut)
    }

    pub fn remove(&mut self, id: u32) -> Option<T> {
        let item = self.items.get_mut(id as usize)?.take();
        if item.is_some() {
            self.free.push(id);
        }
        item
    }
}

/// The GL side of a texture: a texture, or a renderbuffer for a multisampled one (WebGL2
/// samples no multisampled texture; they are only drawn into and resolved).
pub(super) enum Image {
    Texture {
        texture: WebGlTexture,
        /// The mip range the texture's sampling was last limited to (`TEXTURE_BASE_LEVEL`,
        /// `TEXTURE_MAX_LEVEL`), to set it only when a view of another range is bound.
        levels: (u32, u32),
    },
    Renderbuffer(WebGlRenderbuffer),
}

/// A linked program and where its resources go (see `shaders`).
pub(super) struct Program {
    pub program: WebGlProgram,
    /// Until checked (`shaders::check`): its shaders and stages.
    #[allow(clippy::type_complexity, reason = "held for one check")]
    pub pending: Option<(WebGlShader, WebGlShader, &'static GlStage, Option<&'static GlStage>)>,
    /// `_kloub_flip`, the clip-space Y flip (−1 into textures, +1 into the canvas).
    pub flip: Option<WebGlUniformLocation>,
    /// The flip it was last drawn with (0: not yet).
    pub flipped: f32,
    /// It did not compile or link (reported once): it draws nothing.
    pub failed: bool,
    /// Uniform blocks: (group, binding) → the block's binding point (its index here).
    pub uniforms: Vec<Binding>,
    /// Texture units: the texture's (group, binding), its sampler's (`None`: `texelFetch` only).
    pub textures: Vec<(Binding, Option<Binding>)>,
}

/// What a framebuffer object is made of: colour attachments and depth, each an image and a mip
/// level.
#[derive(Clone, PartialEq, Eq, Hash, Debug)]
pub(super) struct FramebufferKey {
    pub colors: Vec<(u32, u32)>,
    pub depth: Option<(u32, u32)>,
}

/// One WebGL2 context and everything made on it.
pub(super) struct Context {
    pub gl: Gl,
    pub canvas: web_sys::HtmlCanvasElement,
    pub buffers: Slab<WebGlBuffer>,
    pub images: Slab<Image>,
    pub samplers: Slab<WebGlSampler>,
    pub programs: Slab<Program>,
    /// Framebuffer objects by what they are made of (made on first use; those of a deleted image
    /// go with it).
    pub framebuffers: HashMap<FramebufferKey, WebGlFramebuffer>,
    /// A sampler for textures read with `texelFetch` only (nearest, one level: always complete).
    pub nearest: Option<WebGlSampler>,
    /// Vertex attributes enabled in [`Self::vertex_array`], by location.
    pub enabled_attributes: u32,
    /// The GL state the running submit has set (see [`Known`]).
    pub known: Known,
    /// Whether `EXT_color_buffer_float` is on (rendering to 16- and 32-bit float textures).
    pub float_render: bool,
    /// Whether `OES_texture_float_linear` is on (filtering 32-bit float textures).
    pub float_linear: bool,
    /// The largest 2D texture.
    pub max_texture: u32,
    /// The renderer's name (`WEBGL_debug_renderer_info` where the browser tells it).
    pub renderer: String,
    /// Live handles of this context (its table goes when the last one does).
    pub handles: usize,
}

/// Binding points, texture units and attribute locations whose state [`Known`] tracks (the
/// renderer's programs use fewer; one beyond is set at every draw).
pub(super) const KNOWN_SLOTS: usize = 16;

/// A vertex attribute's source as last pointed at: buffer, byte offset, stride, format, per
/// instance.
pub(super) type Attribute = (u32, i64, i32, wgpu::VertexFormat, bool);

/// The GL state the running submit has set, so that a draw makes only the calls that change
/// something (a WebGL call costs the page and the GPU process a few microseconds: at 50 copies,
/// two passes re-binding every texture, uniform block and attribute were thousands a frame).
///
/// `None` is "not known": everything is forgotten when a submit starts
/// ([`super::commands::execute`]), as uploads between submits bind buffers and textures behind
/// it; within a submit only the commands' runner makes GL calls, and it keeps this up to date
/// (or forgets what it changed otherwise: the program after a program's first check).
#[derive(Default)]
pub(super) struct Known {
    /// The program in use (by number).
    pub program: Option<u32>,
    /// Face culling: off, or the face culled.
    pub cull: Option<Option<u32>>,
    pub front_face: Option<u32>,
    /// The depth test: off, or its function.
    pub depth_test: Option<Option<u32>>,
    pub depth_mask: Option<bool>,
    /// Polygon offset: off, or its factor and units (as bits).
    pub polygon_offset: Option<Option<(u32, u32)>>,
    /// Blending: off, or its four factors and two equations.
    pub blend: Option<Option<[u32; 6]>>,
    pub color_mask: Option<[bool; 4]>,
    /// Each uniform binding point's buffer, offset and size.
    pub uniforms: [Option<(u32, u64, u64)>; KNOWN_SLOTS],
    /// The active texture unit.
    pub active_unit: Option<u32>,
    /// Each unit's texture (by image).
    pub textures: [Option<u32>; KNOWN_SLOTS],
    /// Each unit's sampler (`u32::MAX`: the backend's nearest one).
    pub samplers: [Option<u32>; KNOWN_SLOTS],
    pub array_buffer: Option<u32>,
    /// The vertex array's index buffer.
    pub element_buffer: Option<u32>,
    /// Each attribute location's source.
    pub attributes: [Option<Attribute>; KNOWN_SLOTS],
}

/// Whether `value` differs from what `known` holds (always, for an untracked slot), noting it.
pub(super) fn changes<T: PartialEq>(known: Option<&mut Option<T>>, value: T) -> bool {
    match known {
        Some(k) if k.as_ref() == Some(&value) => false,
        Some(k) => {
            *k = Some(value);
            true
        }
        None => true,
    }
}

/// Work on a context that a handle's drop asked for while the table was in use (a recorded
/// command list dropped as it runs): done when the table is free again.
type Deferred = (u32, Box<dyn FnOnce(&mut Context)>);

thread_local! {
    static CONTEXTS: RefCell<Vec<Option<Context>>> = const { RefCell::new(Vec::new()) };
    static DEFERRED: RefCell<Vec<Deferred>> = const { RefCell::new(Vec::new()) };
}

/// Registers a new context; its number.
pub(super) fn register(context: Context) -> u32 {
    CONTEXTS.with(|c| {
        let mut c = c.borrow_mut();
        if let Some(i) = c.iter().position(Option::is_none) {
            c[i] = Some(context);
            i as u32
        } else {
            c.push(Some(context));
            (c.len() - 1) as u32
        }
    })
}

/// Runs `f` on context `ctx`; `None` when it is gone. What handles dropped meanwhile asked for
/// is done after.
pub(super) fn with<R>(ctx: u32, f: impl FnOnce(&mut Context) -> R) -> Option<R> {
    let result = CONTEXTS.with(|c| {
        let mut c = c.try_borrow_mut().ok()?;
        c.get_mut(ctx as usize).and_then(Option::as_mut).map(f)
    });
    run_deferred();
    result
}

/// Runs `f` on context `ctx` now, or once the table is free if it is in use (a drop).
pub(super) fn with_or_later(ctx: u32, f: impl FnOnce(&mut Context) + 'static) {
    let busy = CONTEXTS.with(|c| c.try_borrow_mut().is_err());
    if busy {
        DEFERRED.with(|d| d.borrow_mut().push((ctx, Box::new(f))));
    } else {
        with(ctx, f);
    }
}

fn run_deferred() {
    loop {
        // In use (a drop inside `with`): the outer `with` runs the queue when it ends.
        if CONTEXTS.with(|c| c.try_borrow_mut().is_err()) {
            return;
        }
        let next = DEFERRED.with(|d| d.try_borrow_mut().ok().and_then(|mut d| (!d.is_empty()).then(|| d.remove(0))));
        let Some((ctx, f)) = next else { return };
        CONTEXTS.with(|c| {
            if let Ok(mut c) = c.try_borrow_mut()
                && let Some(context) = c.get_mut(ctx as usize).and_then(Option::as_mut)
            {
                f(context);
            }
        });
        drop_unused(ctx);
    }
}

/// A handle of `ctx` was made.
pub(super) fn retain(ctx: u32) {
    with_or_later(ctx, |c| c.handles += 1);
}

/// A handle of `ctx` went; the context's table goes with its last one.
pub(super) fn release(ctx: u32) {
    with_or_later(ctx, |c| c.handles = c.handles.saturating_sub(1));
    drop_unused(ctx);
}

/// Drops the table of `ctx` if no handle is left.
fn drop_unused(ctx: u32) {
    CONTEXTS.with(|c| {
        if let Ok(mut c) = c.try_borrow_mut()
            && let Some(slot) = c.get_mut(ctx as usize)
            && slot.as_ref().is_some_and(|context| context.handles == 0)
        {
            *slot = None;
        }
    });
}

impl Context {
    /// Deletes image `id` and the framebuffers made with it.
    pub fn delete_image(&mut self, id: u32) {
        let gl = &self.gl;
        self.framebuffers.retain(|key, fb| {
            let uses = key.colors.iter().any(|c| c.0 == id) || key.depth.is_some_and(|d| d.0 == id);
            if uses {
                gl.delete_framebuffer(Some(fb));
            }
            !uses
        });
        match self.images.remove(id) {
            Some(Image::Texture { texture, .. }) => gl.delete_texture(Some(&texture)),
            Some(Image::Renderbuffer(rb)) => gl.delete_renderbuffer(Some(&rb)),
            None => {}
        }
    }
}

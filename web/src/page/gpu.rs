//! The page's GPU: one device for every viewer of a backend, created once (the first viewer
//! to mount asks, the others wait for the same answer), and replaced after a loss.
//!
//! - **WebGPU**: one `GPUDevice`; each viewer configures its own canvas with it.
//! - **WebGL2**: one WebGL2 context on a canvas of the page's own (not in the document);
//!   each viewer is drawn into its top-left corner and copied to the viewer's canvas with
//!   `drawImage`, as model-viewer does: the browser's limit of active contexts (16 in
//!   Chromium) no longer limits the number of viewers.
//!
//! A loss (`device.lost`, `webglcontextlost`) marks the device lost and tells every viewer
//! that used it (`kloub:lost`); each then asks [`shared`] again, which makes a new device.

use std::cell::{Cell, RefCell};
use std::rc::Rc;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use wasm_bindgen::JsCast;
use wasm_bindgen::prelude::*;

use crate::backend::BackendChoice;

/// Which kind of device.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GpuKind {
    /// A `GPUDevice`.
    WebGpu,
    /// A WebGL2 context on the page's own canvas.
    Gl,
}

/// The WebGL2 canvas every viewer is drawn through, and its surface.
pub struct GlCanvas {
    /// The canvas holding the page's one WebGL2 context.
    pub canvas: web_sys::HtmlCanvasElement,
    /// Its surface, configured as large as the largest viewer drawn so far.
    pub surface: wgpu::Surface<'static>,
    /// The surface's configuration.
    pub config: RefCell<wgpu::SurfaceConfiguration>,
    /// The MSAA and depth attachments every viewer draws with into the surface, one after
    /// another: one set for the page, not one of the largest viewer's size per viewer.
    pub attachments: RefCell<Option<crate::render::scene::Attachments>>,
    _lost: Closure<dyn FnMut(web_sys::Event)>,
}

/// One device shared by the page's viewers of one backend.
pub struct Gpu {
    /// WebGPU or WebGL2.
    pub kind: GpuKind,
    /// The instance (surfaces of WebGPU canvases are made from it).
    pub instance: wgpu::Instance,
    /// The adapter.
    pub adapter: wgpu::Adapter,
    /// The device every viewer draws with.
    pub device: wgpu::Device,
    /// Its queue.
    pub queue: wgpu::Queue,
    /// The colour format of every surface (and of egui's output).
    pub format: wgpu::TextureFormat,
    /// WebGL2 only: the page's canvas.
    pub gl: Option<GlCanvas>,
    lost: Arc<AtomicBool>,
    /// Numbered in creation order (a viewer knows whether it was moved to a new one).
    pub generation: u32,
    /// The render state every viewer's app is made with (its egui renderer is used only
    /// off the page, where the app draws the scene into an egui texture; on the page each
    /// viewer paints egui with a renderer of its own, made when it first has something to paint).
    #[cfg(feature = "full")]
    pub render: egui_wgpu::RenderState,
}

impl Gpu {
    /// The adapter, device and queue a viewer's stage draws with.
    pub fn graphics(&self) -> crate::stage::Graphics {
        crate::stage::Graphics { adapter: self.adapter.clone(), device: self.device.clone(), queue: self.queue.clone() }
    }

    /// Whether the device was lost (every viewer must move to a new one).
    pub fn is_lost(&self) -> bool {
        self.lost.load(Ordering::Relaxed)
    }

    /// Marks the device lost and tells every viewer of its kind.
    fn mark_lost(lost: &AtomicBool, kind: GpuKind, why: &str) {
        if !lost.swap(true, Ordering::Relaxed) {
            log::warn!("kloub: the {kind:?} device was lost ({why}); every viewer moves to a new one");
            notify_lost(kind, why);
        }
    }

    /// For tests: loses the device as a GPU reset would (WebGPU: `device.destroy()`;
    /// WebGL2: `WEBGL_lose_context.loseContext()`).
    pub fn lose_for_test(&self) {
        match &self.gl {
            None => self.device.destroy(),
            Some(gl) => {
                let lose = || -> Option<()> {
                    let context = gl.canvas.get_context("webgl2").ok()??;
                    let ext = js_sys::Reflect::get(&context, &"getExtension".into()).ok()?;
                    let ext =
                        ext.dyn_into::<js_sys::Function>().ok()?.call1(&context, &"WEBGL_lose_context".into()).ok()?;
                    let lose = js_sys::Reflect::get(&ext, &"loseContext".into()).ok()?;
                    lose.dyn_into::<js_sys::Function>().ok()?.call0(&ext).ok()?;
                    Some(())
                };
                if lose().is_none() {
                    log::warn!("kloub: WEBGL_lose_context is not available");
                }
            }
        }
    }
}

thread_local! {
    /// The live device of each kind.
    static DEVICES: RefCell<Vec<Rc<Gpu>>> = const { RefCell::new(Vec::new()) };
    /// A device being made, per kind: the promise the other viewers wait on.
    static MAKING: RefCell<Vec<(GpuKind, js_sys::Promise)>> = const { RefCell::new(Vec::new()) };
    /// The last failure per kind (what the waiting viewers report).
    static FAILED: RefCell<Vec<(GpuKind, String)>> = const { RefCell::new(Vec::new()) };
    /// Whom to tell when a device is lost: each mounted viewer's `emit`.
    static LISTENERS: RefCell<Vec<(u32, js_sys::Function)>> = const { RefCell::new(Vec::new()) };
    static GENERATION: Cell<u32> = const { Cell::new(0) };
    /// Whether the browser has no WebGPU adapter (known after the first try).
    static NO_WEBGPU: Cell<bool> = const { Cell::new(false) };
    /// How many viewers draw through the page's WebGL2 canvas.
    static GL_VIEWS: Cell<u32> = const { Cell::new(0) };
}

/// How many viewers draw through the page's WebGL2 canvas. With one, that canvas is shown in
/// the viewer itself (no copy); with more, each frame is copied into its viewer's canvas.
pub fn gl_views() -> u32 {
    GL_VIEWS.with(Cell::get)
}

/// A viewer starts (`true`) or stops drawing through the WebGL2 canvas. Every viewer is asked
/// for a frame, since the ones on WebGL2 switch between showing that canvas and copying it.
pub fn count_gl_view(added: bool) {
    GL_VIEWS.with(|n| n.set(if added { n.get().saturating_add(1) } else { n.get().saturating_sub(1) }));
    let listeners: Vec<js_sys::Function> = LISTENERS.with(|l| l.borrow().iter().map(|(_, f)| f.clone()).collect());
    for emit in listeners {
        let _ = emit.call2(&JsValue::NULL, &"kloub:wake".into(), &0.into());
    }
}

/// Registers `emit` to hear `kloub:lost` (with the lost kind's name) under `id`.
pub fn listen(id: u32, emit: js_sys::Function) {
    LISTENERS.with(|l| l.borrow_mut().push((id, emit)));
}

/// Forgets the listener `id`.
pub fn unlisten(id: u32) {
    LISTENERS.with(|l| l.borrow_mut().retain(|(i, _)| *i != id));
}

fn notify_lost(kind: GpuKind, why: &str) {
    DEVICES.with(|d| d.borrow_mut().retain(|g| g.kind != kind));
    let listeners: Vec<js_sys::Function> = LISTENERS.with(|l| l.borrow().iter().map(|(_, f)| f.clone()).collect());
    let name = match kind {
        GpuKind::WebGpu => "webgpu",
        GpuKind::Gl => "webgl2",
    };
    for emit in listeners {
        let _ = emit.call2(&JsValue::NULL, &"kloub:lost".into(), &format!("{name}: {why}").into());
    }
}

/// Every live device (for tests that lose them).
pub fn live() -> Vec<Rc<Gpu>> {
    DEVICES.with(|d| d.borrow().clone())
}

/// The page's device for `choice`, made on first use. `Auto` is WebGPU where the browser has
/// an adapter, else WebGL2.
///
/// # Errors
/// When no device of the asked kind can be made (the message says why).
pub async fn shared(choice: BackendChoice) -> Result<Rc<Gpu>, String> {
    match choice {
        BackendChoice::WebGpu => shared_kind(GpuKind::WebGpu).await,
        BackendChoice::WebGl2 => shared_kind(GpuKind::Gl).await,
        BackendChoice::Auto => {
            if !NO_WEBGPU.with(Cell::get) {
                match shared_kind(GpuKind::WebGpu).await {
                    Ok(gpu) => return Ok(gpu),
                    Err(e) => {
                        log::info!("kloub: no WebGPU ({e}); using WebGL2");
                        NO_WEBGPU.with(|n| n.set(true));
                    }
                }
            }
            shared_kind(GpuKind::Gl).await
        }
    }
}

async fn shared_kind(kind: GpuKind) -> Result<Rc<Gpu>, String> {
    for _ in 0..2 {
        if let Some(gpu) = DEVICES.with(|d| d.borrow().iter().find(|g| g.kind == kind && !g.is_lost()).cloned()) {
            return Ok(gpu);
        }
        let making = MAKING.with(|m| m.borrow().iter().find(|(k, _)| *k == kind).map(|(_, p)| p.clone()));
        let Some(promise) = making else { break };
        // Another viewer is making it: wait for its answer, then look again.
        let _ = wasm_bindgen_futures::JsFuture::from(promise).await;
        if let Some(error) = FAILED.with(|f| f.borrow().iter().find(|(k, _)| *k == kind).map(|(_, e)| e.clone()))
            && DEVICES.with(|d| d.borrow().iter().all(|g| g.kind != kind))
        {
            return Err(error);
        }
    }
    let mut resolve = None;
    let promise = js_sys::Promise::new(&mut |ok, _| resolve = Some(ok));
    MAKING.with(|m| m.borrow_mut().push((kind, promise)));
    let made = make(kind).await;
    MAKING.with(|m| m.borrow_mut().retain(|(k, _)| *k != kind));
    FAILED.with(|f| f.borrow_mut().retain(|(k, _)| *k != kind));
    let result = match made {
        Ok(gpu) => {
            let gpu = Rc::new(gpu);
            DEVICES.with(|d| {
                let mut d = d.borrow_mut();
                // The device this one replaces was lost: what was built and uploaded on it goes.
                for old in d.iter().filter(|g| g.kind == kind) {
                    crate::render::pipelines::forget_device(old.generation);
                    crate::render::scene::release_unused_uploads(Some(old.generation));
                }
                d.retain(|g| g.kind != kind);
                d.push(gpu.clone());
            });
            Ok(gpu)
        }
        Err(e) => {
            FAILED.with(|f| f.borrow_mut().push((kind, e.clone())));
            Err(e)
        }
    };
    if let Some(resolve) = resolve {
        let _ = resolve.call0(&JsValue::NULL);
    }
    result
}

fn device_descriptor(adapter: &wgpu::Adapter) -> wgpu::DeviceDescriptor<'static> {
    let base = if adapter.get_info().backend == wgpu::Backend::Gl {
        wgpu::Limits::downlevel_webgl2_defaults()
    } else {
        wgpu::Limits::default()
    };
    let max_texture = adapter.limits().max_texture_dimension_2d.min(8192);
    wgpu::DeviceDescriptor {
        label: Some("kloub page device"),
        required_limits: wgpu::Limits { max_texture_dimension_2d: max_texture, ..base },
        ..Default::default()
    }
}

async fn make(kind: GpuKind) -> Result<Gpu, String> {
    #[cfg(not(feature = "webgpu"))]
    if kind == GpuKind::WebGpu {
        return Err("this build of Kloub has no WebGPU (the element loads the one that has)".into());
    }
    let generation = GENERATION.with(|g| {
        g.set(g.get() + 1);
        g.get()
    });
    let lost = Arc::new(AtomicBool::new(false));
    let (instance, adapter, gl) = match kind {
        GpuKind::WebGpu => {
            let mut descriptor = wgpu::InstanceDescriptor::new_without_display_handle();
            descriptor.backends = wgpu::Backends::BROWSER_WEBGPU;
            let instance = wgpu::Instance::new(descriptor);
            let has_gpu = web_sys::window()
                .and_then(|w| js_sys::Reflect::get(&w.navigator(), &"gpu".into()).ok())
                .is_some_and(|gpu| !gpu.is_undefined());
            if !has_gpu {
                return Err("this browser has no WebGPU (navigator.gpu)".into());
            }
            let adapter = instance
                .request_adapter(&wgpu::RequestAdapterOptions::default())
                .await
                .map_err(|e| format!("no WebGPU adapter: {e}"))?;
            (instance, adapter, None)
        }
        GpuKind::Gl => make_gl(&lost).await?,
    };
    let (device, queue) =
        adapter.request_device(&device_descriptor(&adapter)).await.map_err(|e| format!("no device: {e}"))?;
    let flag = lost.clone();
    device.set_device_lost_callback(move |reason, message| {
        if reason != wgpu::DeviceLostReason::Unknown || !message.is_empty() {
            Gpu::mark_lost(&flag, kind, &format!("{reason:?} {message}"));
        }
    });
    let format = match &gl {
        Some(gl) => gl.config.borrow().format,
        // Every browser's canvas takes rgba8unorm, with an sRGB view for the scene (the
        // scene's pipelines are built for one format, also used natively and for screenshots).
        None => wgpu::TextureFormat::Rgba8Unorm,
    };
    if let Some(gl) = &gl {
        gl.surface.configure(&device, &gl.config.borrow());
    }
    log::info!("kloub: page device {generation} ({kind:?}, {:?})", adapter.get_info().name);
    #[cfg(feature = "full")]
    let renderer = egui_wgpu::Renderer::new(&device, format, egui_wgpu::RendererOptions::default());
    #[cfg(feature = "full")]
    let render = egui_wgpu::RenderState {
        adapter: adapter.clone(),
        instance: instance.clone(),
        device: device.clone(),
        queue: queue.clone(),
        target_format: format,
        renderer: Arc::new(egui::mutex::RwLock::new(renderer)),
    };
    Ok(Gpu {
        kind,
        instance,
        adapter,
        device,
        queue,
        format,
        gl,
        lost,
        generation,
        #[cfg(feature = "full")]
        render,
    })
}

/// The page's WebGL2 canvas (not in the document), a context on it through Kloub's own WebGL2
/// backend (`crate::gl`), and its surface and adapter.
#[cfg(feature = "gl")]
async fn make_gl(lost: &Arc<AtomicBool>) -> Result<(wgpu::Instance, wgpu::Adapter, Option<GlCanvas>), String> {
    let document = web_sys::window().and_then(|w| w.document()).ok_or("no document")?;
    let canvas: web_sys::HtmlCanvasElement = document
        .create_element("canvas")
        .map_err(|_| "cannot create a canvas")?
        .dyn_into()
        .map_err(|_| "cannot create a canvas")?;
    canvas.set_width(1);
    canvas.set_height(1);
    // Shown inside a viewer while it is the page's only WebGL2 viewer: over its own canvas,
    // which keeps receiving the input.
    let _ = canvas.style().set_property("position", "absolute");
    let _ = canvas.style().set_property("inset", "0");
    let _ = canvas.style().set_property("pointer-events", "none");
    // No stencil and no antialiasing (the scene multisamples into attachments of its own);
    // a depth buffer, which Kloub's backend (`crate::gl`) draws the scene into where it is
    // not multisampled (a framebuffer is the canvas's or a texture's, never colour of one
    // and depth of the other).
    let attributes = js_sys::Object::new();
    for (key, value) in [("antialias", false), ("depth", true), ("stencil", false)] {
        let _ = js_sys::Reflect::set(&attributes, &key.into(), &value.into());
    }
    let instance = crate::gl::instance(&canvas, &attributes)?;
    let flag = lost.clone();
    let on_lost = Closure::<dyn FnMut(web_sys::Event)>::new(move |event: web_sys::Event| {
        event.prevent_default();
        Gpu::mark_lost(&flag, GpuKind::Gl, "webglcontextlost");
    });
    canvas
        .add_event_listener_with_callback("webglcontextlost", on_lost.as_ref().unchecked_ref())
        .map_err(|_| "cannot listen for context loss")?;
    let surface = instance
        .create_surface(wgpu::SurfaceTarget::Canvas(canvas.clone()))
        .map_err(|e| format!("no WebGL2 context: {e}"))?;
    let adapter = instance
        .request_adapter(&wgpu::RequestAdapterOptions { compatible_surface: Some(&surface), ..Default::default() })
        .await
        .map_err(|e| format!("no WebGL2 adapter: {e}"))?;
    let format = pick_format(&surface, &adapter)?;
    let config = wgpu::SurfaceConfiguration {
        usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
        format,
        width: 1,
        height: 1,
        present_mode: wgpu::PresentMode::Fifo,
        desired_maximum_frame_latency: 2,
        alpha_mode: wgpu::CompositeAlphaMode::Auto,
        view_formats: vec![],
        color_space: wgpu::SurfaceColorSpace::Auto,
    };
    Ok((
        instance,
        adapter,
        Some(GlCanvas {
            canvas,
            surface,
            config: RefCell::new(config),
            attachments: RefCell::new(None),
            _lost: on_lost,
        }),
    ))
}

#[cfg(not(feature = "gl"))]
async fn make_gl(_lost: &Arc<AtomicBool>) -> Result<(wgpu::Instance, wgpu::Adapter, Option<GlCanvas>), String> {
    Err("this build of Kloub has no WebGL2 (the element loads the one that has)".into())
}

/// The WebGL2 surface's format: plain `Rgba8Unorm`, which the scene draws into straight with
/// its shaders encoding sRGB (`render::scene_format`). wgpu presents that with a blit, where an
/// sRGB surface takes a full-screen shader pass more per frame; WebGL2 has no sRGB views of a
/// plain texture. egui, like the browser, blends in gamma space on such a target.
#[cfg(feature = "gl")]
fn pick_format(surface: &wgpu::Surface<'_>, adapter: &wgpu::Adapter) -> Result<wgpu::TextureFormat, String> {
    let format = crate::render::scene_format(wgpu::Backend::Gl);
    if surface.get_capabilities(adapter).formats.contains(&format) {
        Ok(format)
    } else {
        Err(format!("the WebGL2 canvas takes no {format:?} surface"))
    }
}

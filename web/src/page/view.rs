//! One viewer on the page: its app, egui context and renderer, its canvas and how frames get
//! there (a WebGPU surface of its own, or a copy from the page's WebGL2 canvas).

use std::rc::Rc;

use wasm_bindgen::JsCast;

#[cfg(not(feature = "full"))]
pub use super::gesture::Input;
use super::gpu::{Gpu, GpuKind};
#[cfg(feature = "full")]
pub use super::input::Input;
#[cfg(feature = "full")]
use crate::app::App;
use crate::stage::Stage;

/// Where a viewer's frames end up.
enum Output {
    /// Its canvas's own WebGPU surface.
    Surface { surface: wgpu::Surface<'static>, config: wgpu::SurfaceConfiguration },
    /// Its canvas's 2D context, which the page's WebGL2 canvas is copied into.
    Copy { context: web_sys::CanvasRenderingContext2d },
}

/// What a frame asks of the page.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Next {
    /// Draw again after this many milliseconds (0: at the next animation frame).
    In(f64),
    /// Nothing to draw until something changes (input, a command, a load).
    Idle,
    /// The device is lost: move to a new one ([`View::reattach`]).
    Lost,
}

/// A mounted viewer.
pub struct View {
    /// The viewer's state, panels and 3D view.
    #[cfg(feature = "full")]
    pub app: App,
    /// The viewer (the widget build: no panels).
    #[cfg(not(feature = "full"))]
    stage: Stage,
    /// Its egui context.
    #[cfg(feature = "full")]
    pub ctx: egui::Context,
    /// Input since the last frame.
    pub input: Input,
    gpu: Rc<Gpu>,
    /// Paints egui's output; made when there first is some (an embedded viewer without panels
    /// or notes never needs one: no pipeline of its own in the GPU process).
    #[cfg(feature = "full")]
    painter: Option<egui_wgpu::Renderer>,
    /// egui's texture changes (its font atlas) while there is no painter yet.
    #[cfg(feature = "full")]
    pending_textures: egui::TexturesDelta,
    canvas: web_sys::HtmlCanvasElement,
    output: Output,
    /// The time origin (ms, `performance.now()`).
    #[cfg(feature = "full")]
    start: f64,
    /// Counted in [`super::gpu::gl_views`].
    counted_gl: bool,
    #[cfg(feature = "full")]
    cursor: egui::CursorIcon,
    /// The panels' accessibility tree as the element mirrors it (`None`: not mirrored).
    #[cfg(feature = "full")]
    a11y: Option<super::a11y::Mirror>,
    /// The mirror's changes from the last frame, until the element takes them.
    #[cfg(feature = "full")]
    a11y_out: Option<String>,
    /// Reduced motion asked for by the page (`prefers-reduced-motion`): no UI animations.
    #[cfg(feature = "full")]
    reduced_motion: bool,
    /// The keyboard moved to the 3D view: egui's focused widget lets go before the next frame.
    #[cfg(feature = "full")]
    release_focus: bool,
    /// The widget build's clock: the last frame's time (ms) and whether it asked for the next
    /// at once (its interval is then the step; otherwise a 60 Hz step, as egui does).
    #[cfg(not(feature = "full"))]
    last_frame: Option<(f64, bool)>,
}

fn output(gpu: &Gpu, canvas: &web_sys::HtmlCanvasElement) -> Result<Output, String> {
    match gpu.kind {
        GpuKind::WebGpu => {
            let surface = gpu
                .instance
                .create_surface(wgpu::SurfaceTarget::Canvas(canvas.clone()))
                .map_err(|e| format!("the canvas takes no WebGPU context: {e}"))?;
            let config = wgpu::SurfaceConfiguration {
                usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
                format: gpu.format,
                width: canvas.width().max(1),
                height: canvas.height().max(1),
                present_mode: wgpu::PresentMode::Fifo,
                desired_maximum_frame_latency: 2,
                // For the transparent background: every browser's WebGPU canvas takes premultiplied
                // alpha (wgpu lists only `Opaque` in its capabilities there, yet maps this one).
                alpha_mode: wgpu::CompositeAlphaMode::PreMultiplied,
                // The scene draws through an sRGB view of the same texture; egui draws through
                // the plain one (it blends in gamma space, as the browser composites).
                view_formats: vec![crate::render::texture::COLOR_FORMAT],
                color_space: wgpu::SurfaceColorSpace::Auto,
            };
            surface.configure(&gpu.device, &config);
            Ok(Output::Surface { surface, config })
        }
        GpuKind::Gl => {
            let context = canvas
                .get_context("2d")
                .ok()
                .flatten()
                .and_then(|c| c.dyn_into::<web_sys::CanvasRenderingContext2d>().ok())
                .ok_or("the canvas takes no 2D context (it was used with another backend)")?;
            Ok(Output::Copy { context })
        }
    }
}

/// What the full app paints over the scene: egui's primitives and screen.
#[cfg(feature = "full")]
type EguiOutput<'a> = (&'a [egui::ClippedPrimitive], &'a egui_wgpu::ScreenDescriptor);
/// The widget build paints nothing over the scene.
#[cfg(not(feature = "full"))]
type EguiOutput<'a> = &'a std::convert::Infallible;

/// The widget's canvas before a model arrives (as the full app's dark panels' background).
#[cfg(not(feature = "full"))]
const EMPTY_BACKGROUND: [f32; 4] = [10.0 / 255.0, 10.0 / 255.0, 10.0 / 255.0, 1.0];

/// `performance.now()` in milliseconds.
pub fn now_ms() -> f64 {
    web_sys::window().and_then(|w| w.performance()).map_or(0.0, |p| p.now())
}

impl View {
    /// A viewer on `canvas` drawing with `gpu`; `make` creates its stage on the device.
    ///
    /// # Errors
    /// When the canvas cannot show frames of `gpu`'s kind.
    #[cfg(not(feature = "full"))]
    pub fn new(
        gpu: Rc<Gpu>,
        canvas: web_sys::HtmlCanvasElement,
        make: impl FnOnce(crate::stage::Graphics) -> Stage,
    ) -> Result<View, String> {
        let output = output(&gpu, &canvas)?;
        let mut stage = make(gpu.graphics());
        stage.set_direct(true);
        let counted_gl = gpu.kind == GpuKind::Gl;
        if counted_gl {
            super::gpu::count_gl_view(true);
        }
        Ok(View { counted_gl, stage, input: Input::default(), gpu, canvas, output, last_frame: None })
    }

    /// The viewer without its panels.
    pub fn stage(&self) -> &Stage {
        #[cfg(feature = "full")]
        return self.app.stage();
        #[cfg(not(feature = "full"))]
        &self.stage
    }

    /// The viewer without its panels, to change.
    pub fn stage_mut(&mut self) -> &mut Stage {
        #[cfg(feature = "full")]
        return self.app.stage_mut();
        #[cfg(not(feature = "full"))]
        &mut self.stage
    }

    /// A viewer on `canvas` drawing with `gpu`; `make` creates its app on the given egui
    /// context and render state.
    ///
    /// # Errors
    /// When the canvas cannot show frames of `gpu`'s kind.
    #[cfg(feature = "full")]
    pub fn new(
        gpu: Rc<Gpu>,
        canvas: web_sys::HtmlCanvasElement,
        make: impl FnOnce(&egui::Context, egui_wgpu::RenderState) -> App,
    ) -> Result<View, String> {
        let output = output(&gpu, &canvas)?;
        let ctx = egui::Context::default();
        let mut app = make(&ctx, gpu.render.clone());
        app.stage_mut().set_direct(true);
        let counted_gl = gpu.kind == GpuKind::Gl;
        if counted_gl {
            super::gpu::count_gl_view(true);
        }
        Ok(View {
            counted_gl,
            app,
            ctx,
            input: Input::default(),
            gpu,
            painter: None,
            pending_textures: egui::TexturesDelta::default(),
            canvas,
            output,
            start: now_ms(),
            cursor: egui::CursorIcon::Default,
            a11y: None,
            a11y_out: None,
            reduced_motion: false,
            release_focus: false,
        })
    }

    /// The device this viewer draws with.
    pub fn gpu(&self) -> &Rc<Gpu> {
        &self.gpu
    }

    /// Moves the viewer to `gpu` (after a loss) on a fresh `canvas`: a new egui context and
    /// renderer (egui re-sends its fonts), the app's renderer rebuilt and its model uploaded
    /// again; the model, clocks, camera and settings stay.
    ///
    /// # Errors
    /// When the canvas takes no context of the new kind, or the model cannot be uploaded.
    pub fn reattach(&mut self, gpu: Rc<Gpu>, canvas: web_sys::HtmlCanvasElement) -> Result<(), String> {
        self.output = output(&gpu, &canvas)?;
        self.release_gl();
        if gpu.kind == GpuKind::Gl {
            self.counted_gl = true;
            super::gpu::count_gl_view(true);
        }
        self.canvas = canvas;
        #[cfg(not(feature = "full"))]
        {
            self.stage.replace_gpu(gpu.graphics(), Some(gpu.generation))?;
            self.gpu = gpu;
            self.last_frame = None;
            Ok(())
        }
        #[cfg(feature = "full")]
        self.reattach_ui(gpu)
    }

    /// The full app's part of [`View::reattach`]: a new egui context and painter.
    #[cfg(feature = "full")]
    fn reattach_ui(&mut self, gpu: Rc<Gpu>) -> Result<(), String> {
        let ctx = egui::Context::default();
        crate::app::install_fonts(&ctx);
        crate::app::style_panels(&ctx);
        self.app.replace_gpu(gpu.render.clone(), Some(gpu.generation))?;
        self.app.set_context(&ctx);
        self.ctx = ctx;
        // The new context sends its textures again, to a painter for the new device.
        self.painter = None;
        self.pending_textures.clear();
        self.gpu = gpu;
        let mirrored = self.a11y.is_some();
        self.set_accessibility(mirrored);
        self.set_reduced_motion(self.reduced_motion);
        Ok(())
    }

    #[cfg(feature = "full")]
    /// Mirrors the panels' accessibility tree for the element (on), or stops (off). Turning it
    /// on sends the whole tree with the next frame.
    pub fn set_accessibility(&mut self, on: bool) {
        if on {
            self.ctx.enable_accesskit();
            self.a11y = Some(super::a11y::Mirror::default());
        } else {
            self.ctx.disable_accesskit();
            self.a11y = None;
        }
        self.a11y_out = None;
    }

    #[cfg(feature = "full")]
    /// The mirror's changes since the element last took them (JSON, see [`super::a11y`]).
    pub fn take_accessibility(&mut self) -> Option<String> {
        self.a11y_out.take()
    }

    #[cfg(feature = "full")]
    /// Every control of the mirrored tree as `[[role, name], …]` (empty when not mirrored).
    pub fn accessibility_controls(&self) -> String {
        self.a11y.as_ref().map_or_else(|| "[]".to_owned(), super::a11y::Mirror::controls_json)
    }

    #[cfg(feature = "full")]
    /// No UI animations (collapsing sections, scrolling) when the page prefers reduced motion.
    pub fn set_reduced_motion(&mut self, on: bool) {
        self.reduced_motion = on;
        let default = egui::Style::default();
        self.ctx.all_styles_mut(|style| {
            style.animation_time = if on { 0.0 } else { default.animation_time };
            style.scroll_animation = if on { egui::style::ScrollAnimation::none() } else { default.scroll_animation };
        });
    }

    #[cfg(feature = "full")]
    /// The keyboard focus moved to the 3D view: no panel widget keeps egui's focus (keys go to
    /// the view's shortcuts).
    pub fn release_focus(&mut self) {
        self.release_focus = true;
    }

    /// Draws a frame at `now` (ms) on a canvas of `width` × `height` pixels, `ppp` pixels
    /// per CSS pixel; says when the next is wanted.
    pub fn frame(&mut self, now: f64, width: u32, height: u32, ppp: f32) -> Next {
        if self.gpu.is_lost() {
            return Next::Lost;
        }
        let max = self.gpu.device.limits().max_texture_dimension_2d;
        let (width, height) = (width.clamp(1, max), height.clamp(1, max));
        let ppp = if ppp.is_finite() && ppp > 0.05 { ppp } else { 1.0 };
        if self.canvas.width() != width {
            self.canvas.set_width(width);
        }
        if self.canvas.height() != height {
            self.canvas.set_height(height);
        }
        self.fit_gl_canvas([width, height]);
        self.frame_at(now, [width, height], ppp)
    }

    /// The widget build's frame: commands and clocks, the camera's input, the scene.
    #[cfg(not(feature = "full"))]
    fn frame_at(&mut self, now: f64, size: [u32; 2], ppp: f32) -> Next {
        let unstable = self.last_frame.map_or(1.0 / 60.0, |(t, _)| ((now - t) / 1000.0) as f32);
        let stable = match self.last_frame {
            Some((_, true)) => unstable,
            _ => 1.0 / 60.0,
        };
        let stage = &mut self.stage;
        let points = emath::vec2(size[0] as f32, size[1] as f32) / ppp;
        let rect = emath::Rect::from_min_size(emath::Pos2::ZERO, points);
        // Set first: a model arriving in this frame is framed for this view.
        stage.set_view_rect(rect);
        stage.receive();
        stage.tick(stable, unstable);
        self.input.apply(stage, points.y);
        stage.evaluate();
        stage.render_view(rect, ppp);
        stage.frames += 1;
        stage.finish_screenshot();
        stage.sync_dataset();
        let busy = stage.busy();
        self.last_frame = Some((now, busy));
        self.present(size, None);
        if busy { Next::In(0.0) } else { Next::Idle }
    }

    /// The full app's frame: egui's pass over the app, then its output over the scene.
    #[cfg(feature = "full")]
    fn frame_at(&mut self, now: f64, [width, height]: [u32; 2], ppp: f32) -> Next {
        let size = egui::vec2(width as f32, height as f32) / ppp;
        let raw = self.input.take(size, ppp, (now - self.start) / 1000.0);
        if std::mem::take(&mut self.release_focus) {
            self.ctx.memory_mut(|m| {
                if let Some(id) = m.focused() {
                    m.surrender_focus(id);
                }
            });
        }
        let app = &mut self.app;
        let output = self.ctx.run_ui(raw, |ui| app.frame(ui));
        self.platform(&output.platform_output);
        if let (Some(mirror), Some(update)) = (self.a11y.as_mut(), output.platform_output.accesskit_update.as_ref()) {
            if self.a11y_out.is_some() {
                // The element did not take the last changes: start over with the whole tree.
                mirror.reset();
            }
            self.a11y_out = mirror.update(update);
        }
        let next = output.viewport_output.get(&egui::ViewportId::ROOT).map_or(Next::Idle, |v| {
            if v.repaint_delay == std::time::Duration::MAX {
                Next::Idle
            } else {
                Next::In(v.repaint_delay.as_secs_f64() * 1000.0)
            }
        });
        let primitives = self.ctx.tessellate(output.shapes, output.pixels_per_point);
        let screen =
            egui_wgpu::ScreenDescriptor { size_in_pixels: [width, height], pixels_per_point: output.pixels_per_point };
        let painted = self.prepare_egui(&primitives, output.textures_delta);
        self.present([width, height], painted.as_ref().map(|_| (primitives.as_slice(), &screen)));
        if let (Some(renderer), Some(mut textures)) = (&mut self.painter, painted) {
            for id in &textures.free {
                renderer.free_texture(id);
            }
            textures.clear();
        }
        next
    }

    /// Uploads egui's texture changes and buffers for this frame: `None` when there is nothing
    /// of egui's to paint and no painter yet (its texture changes then wait for one).
    #[cfg(feature = "full")]
    fn prepare_egui(
        &mut self,
        primitives: &[egui::ClippedPrimitive],
        mut textures: egui::TexturesDelta,
    ) -> Option<egui::TexturesDelta> {
        let gpu = &self.gpu;
        if primitives.is_empty() && self.painter.is_none() {
            self.pending_textures.append(textures);
            return None;
        }
        let painter = self.painter.get_or_insert_with(|| {
            egui_wgpu::Renderer::new(&gpu.device, gpu.format, egui_wgpu::RendererOptions::default())
        });
        let mut waiting = std::mem::take(&mut self.pending_textures);
        waiting.append(std::mem::take(&mut textures));
        for (id, deltas) in waiting.set.drain() {
            for delta in deltas {
                painter.update_texture(&gpu.device, &gpu.queue, id, &delta);
            }
        }
        Some(waiting)
    }

    /// Draws the prepared scene into the canvas and, in the full app, egui's output over it
    /// (`egui`: its primitives and screen).
    fn present(&mut self, size: [u32; 2], egui: Option<EguiOutput<'_>>) {
        let gpu = self.gpu.clone();
        let mut encoder =
            gpu.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("kloub frame") });
        #[cfg(feature = "full")]
        let commands = match (&egui, &mut self.painter) {
            (Some((primitives, screen)), Some(renderer)) => {
                renderer.update_buffers(&gpu.device, &gpu.queue, &mut encoder, primitives, screen)
            }
            _ => Vec::new(),
        };
        #[cfg(not(feature = "full"))]
        let commands: Vec<wgpu::CommandBuffer> = Vec::new();
        let frame = match &mut self.output {
            Output::Surface { surface, config } => {
                if config.width != size[0] || config.height != size[1] {
                    config.width = size[0];
                    config.height = size[1];
                    surface.configure(&gpu.device, config);
                }
                match surface.get_current_texture() {
                    wgpu::CurrentSurfaceTexture::Success(f) | wgpu::CurrentSurfaceTexture::Suboptimal(f) => Some(f),
                    other => {
                        log::warn!("kloub: no surface texture this frame ({other:?}); configuring again");
                        surface.configure(&gpu.device, config);
                        None
                    }
                }
            }
            // The page's WebGL2 canvas was placed and sized for this frame (`fit_gl_canvas`).
            Output::Copy { .. } => gpu.gl.as_ref().and_then(|gl| match gl.surface.get_current_texture() {
                wgpu::CurrentSurfaceTexture::Success(f) | wgpu::CurrentSurfaceTexture::Suboptimal(f) => Some(f),
                other => {
                    log::warn!("kloub: no WebGL2 surface texture this frame ({other:?})");
                    None
                }
            }),
        };
        if let Some(frame) = frame {
            let view = frame.texture.create_view(&wgpu::TextureViewDescriptor::default());
            // The scene straight into the canvas (WebGPU: an sRGB view of it; WebGL2: the
            // canvas's own format, the shaders encoding sRGB), then egui over it.
            let scene_format = self.stage().scene_format();
            let scene_view = if frame.texture.format() == scene_format {
                view.clone()
            } else {
                frame
                    .texture
                    .create_view(&wgpu::TextureViewDescriptor { format: Some(scene_format), ..Default::default() })
            };
            let surface_size = [frame.texture.width(), frame.texture.height()];
            // On WebGL2 every viewer draws into the page's one surface: one set of attachments.
            let mut shared = gpu.gl.as_ref().map(|gl| gl.attachments.borrow_mut());
            let drew_scene =
                self.stage_mut().draw_scene(&mut encoder, &scene_view, surface_size, shared.as_deref_mut());
            drop(shared);
            #[cfg(feature = "full")]
            let clear = self.ctx.global_style().visuals.extreme_bg_color.to_normalized_gamma_f32();
            #[cfg(not(feature = "full"))]
            let clear = EMPTY_BACKGROUND;
            let load = if drew_scene {
                wgpu::LoadOp::Load
            } else if self.stage().transparent() {
                // No model yet on a transparent viewer: the page shows through from the start.
                wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT)
            } else {
                wgpu::LoadOp::Clear(wgpu::Color {
                    r: f64::from(clear[0]),
                    g: f64::from(clear[1]),
                    b: f64::from(clear[2]),
                    a: 1.0,
                })
            };
            // Nothing of egui's over the scene (an embedded viewer without panels or notes): no
            // second pass over the canvas.
            #[cfg(feature = "full")]
            let over = egui.filter(|(primitives, _)| !primitives.is_empty());
            #[cfg(not(feature = "full"))]
            let over = egui;
            if !drew_scene || over.is_some() {
                #[cfg_attr(not(feature = "full"), expect(unused_variables, reason = "egui's pass"))]
                let pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                    label: Some("kloub egui"),
                    color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                        view: &view,
                        resolve_target: None,
                        ops: wgpu::Operations { load, store: wgpu::StoreOp::Store },
                        depth_slice: None,
                    })],
                    depth_stencil_attachment: None,
                    timestamp_writes: None,
                    occlusion_query_set: None,
                    multiview_mask: None,
                });
                #[cfg(feature = "full")]
                if let (Some(renderer), Some((primitives, screen))) = (&self.painter, over) {
                    renderer.render(&mut pass.forget_lifetime(), primitives, screen);
                }
            }
            gpu.queue.submit(commands.into_iter().chain(std::iter::once(encoder.finish())));
            gpu.queue.present(frame);
            if let (Output::Copy { context }, Some(gl)) = (&self.output, &gpu.gl)
                && super::gpu::gl_views() != 1
            {
                let (w, h) = (f64::from(size[0]), f64::from(size[1]));
                context.set_global_composite_operation("copy").ok();
                let _ = context.draw_image_with_html_canvas_element_and_sw_and_sh_and_dx_and_dy_and_dw_and_dh(
                    &gl.canvas, 0.0, 0.0, w, h, 0.0, 0.0, w, h,
                );
            }
        } else {
            gpu.queue.submit(commands.into_iter().chain(std::iter::once(encoder.finish())));
        }
    }

    /// What egui asks of the page: the cursor, copied text, links to open.
    #[cfg(feature = "full")]
    fn platform(&mut self, output: &egui::PlatformOutput) {
        if output.cursor_icon != self.cursor {
            self.cursor = output.cursor_icon;
            let _ = self.canvas.style().set_property("cursor", css_cursor(output.cursor_icon));
        }
        for command in &output.commands {
            match command {
                egui::OutputCommand::CopyText(text) => {
                    if let Some(window) = web_sys::window() {
                        let _ = window.navigator().clipboard().write_text(text);
                    }
                }
                egui::OutputCommand::OpenUrl(open) => {
                    if let Some(window) = web_sys::window() {
                        let target = if open.new_tab { "_blank" } else { "_self" };
                        let _ = window.open_with_url_and_target_and_features(&open.url, target, "noopener");
                    }
                }
                _ => {}
            }
        }
    }
}

impl View {
    /// Places and sizes the page's WebGL2 canvas for this viewer's frame of `size`: the only
    /// WebGL2 viewer shows that canvas itself, sized to it; several share it, grown to the
    /// largest, each copied out of its top-left corner. Done before the frame's GPU work: a
    /// WebGL2 canvas resized after it waits for that work to finish.
    fn fit_gl_canvas(&self, size: [u32; 2]) {
        let (Output::Copy { .. }, Some(gl)) = (&self.output, &self.gpu.gl) else { return };
        let alone = super::gpu::gl_views() == 1;
        let shown_here = gl.canvas.parent_node().is_some_and(|p| Some(p) == self.canvas.parent_node());
        if alone && !shown_here {
            let _ = self.canvas.after_with_node_1(&gl.canvas);
        } else if !alone && shown_here {
            gl.canvas.remove();
        }
        let mut config = gl.config.borrow_mut();
        let fits = if alone {
            config.width == size[0] && config.height == size[1]
        } else {
            config.width >= size[0] && config.height >= size[1]
        };
        if !fits {
            config.width = if alone { size[0] } else { config.width.max(size[0]) };
            config.height = if alone { size[1] } else { config.height.max(size[1]) };
            gl.surface.configure(&self.gpu.device, &config);
        }
    }

    /// Stops drawing through the page's WebGL2 canvas (the viewer goes away or moves to a new
    /// device): takes that canvas out of this viewer if it is shown here, and uncounts it.
    fn release_gl(&mut self) {
        // Shown here, or anywhere once its device is lost (the canvas of a lost context is of no use).
        if let Some(gl) = &self.gpu.gl
            && gl.canvas.parent_node().is_some_and(|p| self.gpu.is_lost() || Some(p) == self.canvas.parent_node())
        {
            gl.canvas.remove();
        }
        if self.counted_gl {
            self.counted_gl = false;
            super::gpu::count_gl_view(false);
        }
    }
}

impl Drop for View {
    fn drop(&mut self) {
        // Changes never painted go with the viewer.
        #[cfg(feature = "full")]
        self.pending_textures.clear();
        self.release_gl();
    }
}

/// The CSS `cursor` for egui's cursor.
#[cfg(feature = "full")]
fn css_cursor(icon: egui::CursorIcon) -> &'static str {
    use egui::CursorIcon as C;
    match icon {
        C::None => "none",
        C::ContextMenu => "context-menu",
        C::Help => "help",
        C::PointingHand => "pointer",
        C::Progress => "progress",
        C::Wait => "wait",
        C::Cell => "cell",
        C::Crosshair => "crosshair",
        C::Text => "text",
        C::VerticalText => "vertical-text",
        C::Alias => "alias",
        C::Copy => "copy",
        C::Move => "move",
        C::NoDrop => "no-drop",
        C::NotAllowed => "not-allowed",
        C::Grab => "grab",
        C::Grabbing => "grabbing",
        C::AllScroll => "all-scroll",
        C::ResizeHorizontal | C::ResizeEast | C::ResizeWest => "ew-resize",
        C::ResizeVertical | C::ResizeNorth | C::ResizeSouth => "ns-resize",
        C::ResizeNeSw | C::ResizeNorthEast | C::ResizeSouthWest => "nesw-resize",
        C::ResizeNwSe | C::ResizeNorthWest | C::ResizeSouthEast => "nwse-resize",
        C::ResizeColumn => "col-resize",
        C::ResizeRow => "row-resize",
        C::ZoomIn => "zoom-in",
        C::ZoomOut => "zoom-out",
        _ => "default",
    }
}

//! The GLSL the build translated (`web/build.rs`), found by module, entry point and override
//! constants, and linked into programs whose resources are bound where the backend binds them.
//!
//! Orientation: the build keeps the clip-space Y flip of naga's `ADJUST_COORDINATE_SPACE` as a
//! uniform, `_kloub_flip`. Into textures it is −1, so that whatever is drawn lies in memory as
//! WebGPU lays it out (row 0 at the top) and reads back and samples the same; into the canvas's
//! own framebuffer, whose row 0 is at the bottom of the screen, it is +1, so that nothing has to
//! be copied over with a flip to present it. One program serves both.
//!
//! Programs are linked when their pipeline is made and checked when first drawn with: the
//! browser compiles them meanwhile (each question about a program waits for it).

use web_sys::WebGl2RenderingContext as Gl;

use super::state::{Binding, Context, Program};
use super::table::{GlStage, text};

/// Starts compiling `source` (its status is asked only if the program does not link).
fn compile(gl: &Gl, kind: u32, source: &str) -> Option<web_sys::WebGlShader> {
    let shader = gl.create_shader(kind)?;
    gl.shader_source(&shader, source);
    gl.compile_shader(&shader);
    Some(shader)
}

/// What went wrong with `shader`, if it did not compile.
fn compile_log(gl: &Gl, shader: &web_sys::WebGlShader) -> Option<String> {
    (gl.get_shader_parameter(shader, Gl::COMPILE_STATUS).as_bool() != Some(true))
        .then(|| gl.get_shader_info_log(shader).unwrap_or_default())
}

/// Starts linking `vertex` and `fragment` (a fragment shader that writes nothing without one)
/// into a program of `c`: its number, checked by [`check`] before its first draw. `None` when
/// the context is lost.
pub(super) fn link(c: &mut Context, vertex: &'static GlStage, fragment: Option<&'static GlStage>) -> Option<u32> {
    let gl = &c.gl;
    let vs = compile(gl, Gl::VERTEX_SHADER, &text(vertex))?;
    let fs_text = match fragment {
        Some(f) => text(f),
        None => "#version 300 es\nvoid main() {}\n".to_owned(),
    };
    let fs = compile(gl, Gl::FRAGMENT_SHADER, &fs_text)?;
    let program = gl.create_program()?;
    gl.attach_shader(&program, &vs);
    gl.attach_shader(&program, &fs);
    for &(name, location) in vertex.varyings {
        gl.bind_attrib_location(&program, location, name);
    }
    gl.link_program(&program);
    Some(c.programs.insert(Program {
        program,
        pending: Some((vs, fs, vertex, fragment)),
        flip: None,
        flipped: 0.0,
        failed: false,
        uniforms: Vec::new(),
        textures: Vec::new(),
    }))
}

/// Checks program `id` once linked and binds its uniform blocks and samplers to the points its
/// [`Program`] then lists (at its first draw: each question waits for the link).
///
/// # Errors
/// The compiler's or linker's message.
pub(super) fn check(c: &mut Context, id: u32) -> Result<(), String> {
    let gl = &c.gl;
    let Some(p) = c.programs.get_mut(id) else { return Err("the context is lost".into()) };
    let Some((vs, fs, vertex, fragment)) = p.pending.take() else { return Ok(()) };
    let program = &p.program;
    let linked = gl.get_program_parameter(program, Gl::LINK_STATUS).as_bool() == Some(true) || gl.is_context_lost();
    let failure = (!linked).then(|| {
        let stage = |name, shader| compile_log(gl, shader).map(|log| format!("{name} shader: {log}"));
        stage("vertex", &vs)
            .or_else(|| stage("fragment", &fs))
            .unwrap_or_else(|| format!("link: {}", gl.get_program_info_log(program).unwrap_or_default()))
    });
    gl.delete_shader(Some(&vs));
    gl.delete_shader(Some(&fs));
    if let Some(failure) = failure {
        p.failed = true;
        return Err(failure);
    }
    let mut uniforms: Vec<Binding> = Vec::new();
    let mut textures: Vec<(Binding, Option<Binding>)> = Vec::new();
    gl.use_program(Some(program));
    for stage in std::iter::once(vertex).chain(fragment) {
        for &(name, group, binding) in stage.uniforms {
            let slot = slot_of(&mut uniforms, (group, binding));
            let index = gl.get_uniform_block_index(program, name);
            if index != Gl::INVALID_INDEX {
                gl.uniform_block_binding(program, index, slot as u32);
            }
        }
        for &(name, texture, sampler) in stage.textures {
            let unit = slot_of(&mut textures, (texture, sampler));
            if let Some(location) = gl.get_uniform_location(program, name) {
                gl.uniform1i(Some(&location), unit as i32);
            }
        }
    }
    p.flip = gl.get_uniform_location(program, "_kloub_flip");
    p.uniforms = uniforms;
    p.textures = textures;
    Ok(())
}

/// The index of `item` in `slots`, added at the end if new: a resource both stages read gets one
/// binding point (one uniform block binding, one texture unit).
fn slot_of<T: PartialEq>(slots: &mut Vec<T>, item: T) -> usize {
    match slots.iter().position(|s| *s == item) {
        Some(i) => i,
        None => {
            slots.push(item);
            slots.len() - 1
        }
    }
}

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

/// Whether a stage is a vertex or fragment shader.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum GlStageKind {
    Vertex,
    Fragment,
}

/// A WGSL module the renderer compiles: its source's hash and override constants (name,
/// default, number of values), and its entry points.
pub(super) struct GlModule {
    pub name: &'static str,
    pub hash: u64,
    pub overrides: &'static [(&'static str, u32, u32)],
    pub entries: &'static [GlEntry],
}

/// An entry point: its stage for every combination of the module's override constants (the
/// first constant varies fastest).
pub(super) struct GlEntry {
    pub name: &'static str,
    pub stage: GlStageKind,
    pub variants: &'static [usize],
}

/// One translated stage: its text (an index into `GL_TEXTS`) and its resources by GLSL name.
#[derive(Debug)]
pub(super) struct GlStage {
    pub text: usize,
    /// Uniform blocks: name, group, binding.
    pub uniforms: &'static [(&'static str, u32, u32)],
    /// Samplers: name, the texture's (group, binding), the sampler's.
    pub textures: &'static [(&'static str, Binding, Option<Binding>)],
    /// Vertex inputs or fragment outputs: name, location.
    pub varyings: &'static [(&'static str, u32)],
}

include!(concat!(env!("OUT_DIR"), "/gl_shaders.rs"));

/// Every distinct line of the translated GLSL, one after the other (`GL_LINE_ENDS`).
static GL_LINES: &str = include_str!(concat!(env!("OUT_DIR"), "/gl_lines.txt"));

/// The module whose WGSL is `source`, if the build translated it.
pub(super) fn module_for(source: &str) -> Option<usize> {
    let hash = super::hash::source_hash(source);
    GL_MODULES.iter().position(|m| m.hash == hash)
}

/// The stage of `entry` in module `module` specialised with `constants` (the others at their
/// defaults).
pub(super) fn stage(
    module: usize,
    entry: Option<&str>,
    kind: GlStageKind,
    constants: &[(&str, f64)],
) -> Result<&'static GlStage, String> {
    let m = GL_MODULES.get(module).ok_or("no such shader module")?;
    let entry = match entry {
        Some(name) => m.entries.iter().find(|e| e.name == name && e.stage == kind),
        None => {
            let mut of_kind = m.entries.iter().filter(|e| e.stage == kind);
            match (of_kind.next(), of_kind.next()) {
                (Some(only), None) => Some(only),
                _ => None,
            }
        }
    }
    .ok_or_else(|| format!("{}: no {kind:?} entry point {entry:?}", m.name))?;
    for (name, _) in constants {
        if !m.overrides.iter().any(|(o, _, _)| o == name) {
            return Err(format!("{}: no override constant {name}", m.name));
        }
    }
    let mut index = 0usize;
    let mut scale = 1usize;
    for &(name, default, count) in m.overrides {
        let value = match constants.iter().find(|(n, _)| *n == name) {
            Some(&(_, v)) if v >= 0.0 && v < f64::from(count) && v.fract() == 0.0 => v as usize,
            Some(&(_, v)) => return Err(format!("{}: {name} = {v} was not translated (0 to {})", m.name, count - 1)),
            None => default as usize,
        };
        index += value * scale;
        scale *= count as usize;
    }
    entry.variants.get(index).and_then(|&s| GL_STAGES.get(s)).ok_or_else(|| format!("{}: no variant {index}", m.name))
}

/// The GLSL text of `stage`.
fn text(stage: &GlStage) -> String {
    let mut out = String::new();
    let Some(&(start, end)) = GL_TEXTS.get(stage.text) else { return out };
    for &line in GL_TEXT_LINES.get(start as usize..end as usize).unwrap_or(&[]) {
        let line = usize::from(line);
        let from = if line == 0 { 0 } else { GL_LINE_ENDS.get(line - 1).copied().unwrap_or(0) as usize };
        let to = GL_LINE_ENDS.get(line).copied().unwrap_or(0) as usize;
        out.push_str(GL_LINES.get(from..to).unwrap_or(""));
        out.push('\n');
    }
    out
}

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
            let slot = match uniforms.iter().position(|&u| u == (group, binding)) {
                Some(i) => i,
                None => {
                    uniforms.push((group, binding));
                    uniforms.len() - 1
                }
            };
            let index = gl.get_uniform_block_index(program, name);
            if index != Gl::INVALID_INDEX {
                gl.uniform_block_binding(program, index, slot as u32);
            }
        }
        for &(name, texture, sampler) in stage.textures {
            let unit = match textures.iter().position(|&t| t == (texture, sampler)) {
                Some(i) => i,
                None => {
                    textures.push((texture, sampler));
                    textures.len() - 1
                }
            };
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

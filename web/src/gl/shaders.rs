//! The GLSL the build translated (`web/build.rs`), found by module, entry point and override
//! constants, and linked into programs whose resources are bound where the backend binds them.
//!
//! Each program exists in two orientations. The translation flips clip-space Y (naga's
//! `ADJUST_COORDINATE_SPACE`), so that whatever is drawn into a texture lies in memory as
//! WebGPU lays it out (row 0 at the top) and reads back and samples the same; what is drawn
//! for the canvas's own framebuffer, whose row 0 is at the bottom of the screen, is drawn
//! unflipped instead (the same text without the sign), so that nothing has to be copied over
//! with a flip to present it.

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

/// The GLSL text of `stage`; unflipped (see the module's doc) when `flip` is false.
fn text(stage: &GlStage, flip: bool) -> String {
    let mut out = String::new();
    let Some(&(start, end)) = GL_TEXTS.get(stage.text) else { return out };
    for &line in GL_TEXT_LINES.get(start as usize..end as usize).unwrap_or(&[]) {
        let line = usize::from(line);
        let from = if line == 0 { 0 } else { GL_LINE_ENDS.get(line - 1).copied().unwrap_or(0) as usize };
        let to = GL_LINE_ENDS.get(line).copied().unwrap_or(0) as usize;
        out.push_str(GL_LINES.get(from..to).unwrap_or(""));
        out.push('\n');
    }
    if !flip {
        // naga's only use of the sign: `gl_Position.yz = vec2(-gl_Position.y, …)`.
        out = out.replace("vec2(-gl_Position.y,", "vec2(gl_Position.y,");
    }
    out
}

fn compile(gl: &Gl, kind: u32, source: &str) -> Result<web_sys::WebGlShader, String> {
    let shader = gl.create_shader(kind).ok_or("the context is lost")?;
    gl.shader_source(&shader, source);
    gl.compile_shader(&shader);
    if gl.get_shader_parameter(&shader, Gl::COMPILE_STATUS).as_bool() == Some(true) || gl.is_context_lost() {
        Ok(shader)
    } else {
        let log = gl.get_shader_info_log(&shader).unwrap_or_default();
        gl.delete_shader(Some(&shader));
        Err(log)
    }
}

/// Links `vertex` and `fragment` (a fragment shader that writes nothing without one) into a
/// program of `c`, its uniform blocks and samplers bound to the points the returned
/// [`Program`] lists.
pub(super) fn link(c: &mut Context, vertex: &GlStage, fragment: Option<&GlStage>, flip: bool) -> Result<u32, String> {
    let gl = &c.gl;
    let vs = compile(gl, Gl::VERTEX_SHADER, &text(vertex, flip)).map_err(|e| format!("vertex shader: {e}"))?;
    let fs_text = match fragment {
        Some(f) => text(f, flip),
        None => "#version 300 es\nvoid main() {}\n".to_owned(),
    };
    let fs = match compile(gl, Gl::FRAGMENT_SHADER, &fs_text) {
        Ok(fs) => fs,
        Err(e) => {
            gl.delete_shader(Some(&vs));
            return Err(format!("fragment shader: {e}"));
        }
    };
    let program = gl.create_program().ok_or("the context is lost")?;
    gl.attach_shader(&program, &vs);
    gl.attach_shader(&program, &fs);
    for &(name, location) in vertex.varyings {
        gl.bind_attrib_location(&program, location, name);
    }
    gl.link_program(&program);
    gl.delete_shader(Some(&vs));
    gl.delete_shader(Some(&fs));
    if gl.get_program_parameter(&program, Gl::LINK_STATUS).as_bool() != Some(true) && !gl.is_context_lost() {
        let log = gl.get_program_info_log(&program).unwrap_or_default();
        gl.delete_program(Some(&program));
        return Err(format!("link: {log}"));
    }
    let mut uniforms: Vec<Binding> = Vec::new();
    let mut textures: Vec<(Binding, Option<Binding>)> = Vec::new();
    gl.use_program(Some(&program));
    for stage in std::iter::once(vertex).chain(fragment) {
        for &(name, group, binding) in stage.uniforms {
            let slot = match uniforms.iter().position(|&u| u == (group, binding)) {
                Some(i) => i,
                None => {
                    uniforms.push((group, binding));
                    uniforms.len() - 1
                }
            };
            let index = gl.get_uniform_block_index(&program, name);
            if index != Gl::INVALID_INDEX {
                gl.uniform_block_binding(&program, index, slot as u32);
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
            if let Some(location) = gl.get_uniform_location(&program, name) {
                gl.uniform1i(Some(&location), unit as i32);
            }
        }
    }
    Ok(c.programs.insert(Program { program, uniforms, textures }))
}

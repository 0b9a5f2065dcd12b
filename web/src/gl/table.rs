//! The GLSL that `web/build.rs` translated, found by module, entry point and override
//! constants (platform-free: a native test checks that every pipeline the renderer can ask for
//! on WebGL2 is here).

/// A resource's group and binding.
pub(super) type Binding = (u32, u32);

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

/// An entry point: the module's override constants it depends on (indices into
/// [`GlModule::overrides`]; the others leave its GLSL unchanged), and its stage for every
/// combination of them (the first varies fastest).
pub(super) struct GlEntry {
    pub name: &'static str,
    pub stage: GlStageKind,
    pub overrides: &'static [usize],
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

/// The module whose WGSL is `source`, or whose key `source` gives ([`super::KEYED`] and the key in
/// hex: the WebGL2 widget hands over no WGSL), if the build translated it.
pub(super) fn module_for(source: &str) -> Option<usize> {
    let hash = match source.strip_prefix(super::KEYED) {
        Some(hex) => u64::from_str_radix(hex, 16).ok()?,
        None => super::hash::source_hash(source),
    };
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
    // Every constant given must be one the module declares, with a value the build translated
    // (also those this entry point does not depend on).
    for &(name, v) in constants {
        let Some(&(_, _, count)) = m.overrides.iter().find(|(o, _, _)| *o == name) else {
            return Err(format!("{}: no override constant {name}", m.name));
        };
        if !(v >= 0.0 && v < f64::from(count) && v.fract() == 0.0) {
            return Err(format!("{}: {name} = {v} was not translated (0 to {})", m.name, count - 1));
        }
    }
    let mut index = 0usize;
    let mut scale = 1usize;
    for &o in entry.overrides {
        let &(name, default, count) = m.overrides.get(o).ok_or("no such override constant")?;
        let value = match constants.iter().find(|(n, _)| *n == name) {
            Some(&(_, v)) => v as usize,
            None => default as usize,
        };
        index += value * scale;
        scale *= count as usize;
    }
    entry.variants.get(index).and_then(|&s| GL_STAGES.get(s)).ok_or_else(|| format!("{}: no variant {index}", m.name))
}

/// The GLSL text of `stage`.
pub(super) fn text(stage: &GlStage) -> String {
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::pipelines::{SHADER_MODULES, SKIN_FROM_DRAW};

    /// The values the renderer gives each override constant (`render::pipelines`): a skinning
    /// method up to "read it from the draw", and flags.
    fn values(name: &str) -> Vec<f64> {
        match name {
            "SKIN_METHOD" => (0..=SKIN_FROM_DRAW).map(f64::from).collect(),
            "HEATMAP" | "TANGENTS" | "SRGB_ENCODE" | "ENVIRONMENT" => vec![0.0, 1.0],
            "TEXTURES" => (0..16).map(f64::from).collect(),
            other => panic!("override {other}: the renderer's values are not known to this test (nor to web/build.rs)"),
        }
    }

    #[test]
    fn a_module_handed_over_by_its_key_is_the_one_its_wgsl_names() {
        for (name, source, webgl) in SHADER_MODULES {
            let by_source = module_for(source);
            assert_eq!(by_source.is_some(), webgl, "{name}");
            let keyed = format!("{}{:016x}", super::super::KEYED, super::super::hash::source_hash(source));
            assert_eq!(module_for(&keyed), by_source, "{name}: {keyed}");
        }
        assert_eq!(module_for(&format!("{}zz", super::super::KEYED)), None);
        assert_eq!(module_for(&format!("{}{:016x}", super::super::KEYED, 1_u64)), None);
    }

    #[test]
    fn every_pipeline_the_renderer_builds_on_webgl2_was_translated() {
        for (name, source, webgl) in SHADER_MODULES {
            if !webgl {
                continue;
            }
            let index = module_for(source).unwrap_or_else(|| panic!("{name}: not translated by web/build.rs"));
            let module = naga::front::wgsl::parse_str(source).expect("the renderer's WGSL parses");
            let overrides: Vec<String> = module.overrides.iter().filter_map(|(_, o)| o.name.clone()).collect();
            for ep in &module.entry_points {
                let kind = match ep.stage {
                    naga::ShaderStage::Vertex => GlStageKind::Vertex,
                    naga::ShaderStage::Fragment => GlStageKind::Fragment,
                    _ => continue,
                };
                // Every combination of the values the renderer may set, each constant also left out.
                let mut combos: Vec<Vec<(&str, f64)>> = vec![Vec::new()];
                for o in &overrides {
                    let mut next = Vec::new();
                    for c in &combos {
                        next.push(c.clone());
                        for v in values(o) {
                            let mut c = c.clone();
                            c.push((o.as_str(), v));
                            next.push(c);
                        }
                    }
                    combos = next;
                }
                let mut checked = std::collections::HashSet::new();
                for constants in &combos {
                    let stage = stage(index, Some(&ep.name), kind, constants)
                        .unwrap_or_else(|e| panic!("{name} {} {constants:?}: {e}", ep.name));
                    if !checked.insert(stage.text) {
                        continue;
                    }
                    let glsl = text(stage);
                    assert!(glsl.starts_with("#version 300 es\n"), "{name} {}", ep.name);
                    if kind == GlStageKind::Vertex {
                        assert!(glsl.contains("uniform float _kloub_flip;"), "{name} {}: no flip uniform", ep.name);
                        assert!(glsl.contains("vec2(_kloub_flip * gl_Position.y,"), "{name} {}", ep.name);
                    }
                }
            }
        }
    }

    /// egui-wgpu's shader as the full app's panels hand it to the device: the copy web/build.rs
    /// translated (web/vendor/egui-wgpu) is byte for byte the one in the egui-wgpu crate built.
    #[cfg(feature = "full")]
    #[test]
    fn egui_wgpus_shader_is_translated_from_the_crate_in_use() {
        let vendored = include_str!("../../vendor/egui-wgpu/egui.wgsl");
        let egui = module_for(vendored).expect("web/build.rs translated web/vendor/egui-wgpu/egui.wgsl");
        for (entry, kind) in [
            ("vs_main", GlStageKind::Vertex),
            ("fs_main_linear_framebuffer", GlStageKind::Fragment),
            ("fs_main_gamma_framebuffer", GlStageKind::Fragment),
        ] {
            let glsl = text(stage(egui, Some(entry), kind, &[]).expect("egui's entry points"));
            assert!(glsl.starts_with("#version 300 es\n"), "{entry}");
            assert!(kind == GlStageKind::Fragment || glsl.contains("uniform float _kloub_flip;"), "{entry}: no flip");
        }
        // The egui-wgpu crate cargo resolved for this workspace, found through `cargo metadata`.
        let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
        let output = std::process::Command::new(cargo)
            .args(["metadata", "--format-version", "1", "--offline", "--filter-platform", env!("KLOUB_BUILD_TARGET")])
            .current_dir(env!("CARGO_MANIFEST_DIR"))
            .output()
            .expect("cargo metadata runs");
        assert!(output.status.success(), "cargo metadata: {}", String::from_utf8_lossy(&output.stderr));
        let metadata: serde_json::Value = serde_json::from_slice(&output.stdout).expect("cargo metadata's JSON");
        let manifest = metadata["packages"]
            .as_array()
            .and_then(|p| p.iter().find(|p| p["name"] == "egui-wgpu"))
            .and_then(|p| p["manifest_path"].as_str())
            .expect("egui-wgpu among the packages");
        let crate_source = std::path::Path::new(manifest).with_file_name("src/egui.wgsl");
        let original = std::fs::read_to_string(&crate_source).expect("egui-wgpu's src/egui.wgsl");
        assert!(
            original == vendored,
            "web/vendor/egui-wgpu/egui.wgsl differs from {}: copy it again",
            crate_source.display()
        );
    }

    #[test]
    fn a_stage_outside_the_translations_is_an_error() {
        let mesh = GL_MODULES.iter().position(|m| m.name == "mesh").expect("the mesh module");
        assert!(stage(mesh, Some("vs_skinned"), GlStageKind::Vertex, &[("SKIN_METHOD", 9.0)]).is_err());
        assert!(stage(mesh, Some("vs_skinned"), GlStageKind::Vertex, &[("SKIN_METHOD", 0.5)]).is_err());
        assert!(stage(mesh, Some("vs_skinned"), GlStageKind::Vertex, &[("NO_SUCH", 0.0)]).is_err());
        assert!(stage(mesh, Some("no_such_entry"), GlStageKind::Vertex, &[]).is_err());
        assert!(stage(mesh, Some("fs_main"), GlStageKind::Vertex, &[]).is_err());
        assert!(stage(GL_MODULES.len(), None, GlStageKind::Vertex, &[]).is_err());
        assert!(module_for("fn nothing() {}").is_none());
        // A module with one entry point of a kind takes `None` for it.
        let mip = GL_MODULES.iter().position(|m| m.name == "mip").expect("the mip module");
        assert!(stage(mip, None, GlStageKind::Fragment, &[]).is_ok());
    }
}

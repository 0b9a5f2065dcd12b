//! Every shader module the renderer compiles ([`SHADER_MODULES`]: `shaders/*.wgsl` files, the
//! skinning library prepended where it is used) must parse and validate with naga, and the
//! WebGL2 ones translate to GLSL ES 3.00 (what wgpu's WebGL2 backend feeds the browser) for
//! every entry point. Every `shaders/*.wgsl` file must be part of a module. Structs with the
//! same name in different modules (the shared `Frame` uniform) must have the same layout.

use std::collections::BTreeMap;
use std::path::PathBuf;

use kloub_web::render::pipelines::SHADER_MODULES;
use naga::back::glsl;
use naga::valid::{Capabilities, ModuleInfo, ValidationFlags, Validator};

/// The WGSL files, sorted.
fn shader_files() -> Vec<PathBuf> {
    let dir = kloub_tests::repo_root().join("shaders");
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("reading {}: {e}", dir.display()))
        .filter_map(|entry| entry.ok().map(|e| e.path()))
        .filter(|path| path.extension().is_some_and(|ext| ext == "wgsl"))
        .collect();
    files.sort();
    files
}

/// Parses and validates with no optional capabilities (WebGL2 has none of them).
fn validate(source: &str) -> Result<(naga::Module, ModuleInfo), String> {
    let module = naga::front::wgsl::parse_str(source).map_err(|e| e.emit_to_string(source))?;
    let info = Validator::new(ValidationFlags::all(), Capabilities::empty())
        .validate(&module)
        .map_err(|e| e.emit_to_string(source))?;
    Ok((module, info))
}

/// Writes GLSL ES 3.00 for WebGL2 for every entry point.
fn translate_for_webgl2(module: &naga::Module, info: &ModuleInfo) -> Result<(), String> {
    let options = glsl::Options {
        version: glsl::Version::Embedded { version: 300, is_webgl: true },
        writer_flags: glsl::WriterFlags::ADJUST_COORDINATE_SPACE,
        ..Default::default()
    };
    // Every specialisation the renderer builds: the overrides' defaults, each skinning method
    // with and without the heatmap and the tangent stream (`PipelineKey` in
    // web/src/render/pipelines.rs), the
    // fragment shaders encoding sRGB themselves (`SRGB_ENCODE`, the WebGL2 canvas), and the mesh
    // fragment shader for each set of optional textures and each kind of ambient light
    // (`TEXTURES`, `ENVIRONMENT`).
    let has = |name: &str| module.overrides.iter().any(|(_, o)| o.name.as_deref() == Some(name));
    let specialised = has("SKIN_METHOD");
    let mut variants = vec![naga::back::PipelineConstants::default()];
    if has("SRGB_ENCODE") {
        let mut constants = naga::back::PipelineConstants::default();
        constants.insert("SRGB_ENCODE".to_owned(), 1.0);
        variants.push(constants);
    }
    if has("TEXTURES") {
        for textures in 0..16 {
            for environment in 0..2 {
                let mut constants = naga::back::PipelineConstants::default();
                constants.insert("TEXTURES".to_owned(), f64::from(textures));
                constants.insert("ENVIRONMENT".to_owned(), f64::from(environment));
                constants.insert("HEATMAP".to_owned(), 0.0);
                variants.push(constants);
            }
        }
    }
    if specialised {
        for method in 0..5 {
            for heatmap in 0..2 {
                for tangents in 0..2 {
                    let mut constants = naga::back::PipelineConstants::default();
                    constants.insert("SKIN_METHOD".to_owned(), f64::from(method));
                    constants.insert("HEATMAP".to_owned(), f64::from(heatmap));
                    constants.insert("TANGENTS".to_owned(), f64::from(tangents));
                    variants.push(constants);
                }
            }
        }
    }
    for entry in &module.entry_points {
        for constants in &variants {
            let (module, info) = naga::back::pipeline_constants::process_overrides(
                module,
                info,
                Some((entry.stage, entry.name.as_str())),
                constants,
            )
            .map_err(|e| format!("entry point {}: overrides {constants:?}: {e}", entry.name))?;
            let pipeline =
                glsl::PipelineOptions { shader_stage: entry.stage, entry_point: entry.name.clone(), multiview: None };
            let mut out = String::new();
            glsl::Writer::new(
                &mut out,
                &module,
                &info,
                &options,
                &pipeline,
                naga::proc::BoundsCheckPolicies::default(),
            )
            .and_then(|mut writer| writer.write())
            .map_err(|e| format!("entry point {}: GLSL ES 3.00 with {constants:?}: {e}", entry.name))?;
        }
    }
    Ok(())
}

/// A struct's members (name, offset) and its size.
type Layout = (Vec<(String, u32)>, u32);

/// Named structs of a module by name.
fn struct_layouts(module: &naga::Module) -> BTreeMap<String, Layout> {
    let mut out = BTreeMap::new();
    for (_, ty) in module.types.iter() {
        if let (Some(name), naga::TypeInner::Struct { members, span }) = (&ty.name, &ty.inner) {
            let members = members.iter().map(|m| (m.name.clone().unwrap_or_default(), m.offset)).collect();
            out.insert(name.clone(), (members, *span));
        }
    }
    out
}

#[test]
fn every_shader_module_validates_for_webgpu_and_webgl2() {
    let mut failures = Vec::new();
    for (name, source, webgl2) in SHADER_MODULES {
        let result = validate(source).and_then(|(module, info)| {
            if webgl2 { translate_for_webgl2(&module, &info).map(|()| module) } else { Ok(module) }
        });
        match result {
            Ok(module) => assert!(!module.entry_points.is_empty(), "{name}: no entry points"),
            Err(e) => failures.push(format!("{name}:\n{e}")),
        }
    }
    assert!(failures.is_empty(), "{} shader module(s) failed:\n\n{}", failures.len(), failures.join("\n\n"));
}

#[test]
fn every_wgsl_file_is_compiled() {
    let files = shader_files();
    assert!(files.len() >= 4, "expected the mesh, skinning, compute and environment shaders, found {files:?}");
    for path in files {
        let source = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        // As web/build.rs embeds it: each line without its comment and indentation, blank lines dropped.
        let code: String = source
            .lines()
            .map(|l| l.split("//").next().unwrap_or("").trim())
            .filter(|l| !l.is_empty())
            .map(|l| format!("{l}\n"))
            .collect();
        assert!(!code.is_empty() && code.len() < source.len(), "{}", path.display());
        assert!(
            SHADER_MODULES.iter().any(|(_, module, _)| module.contains(&code)),
            "{} is in no shader module the renderer compiles",
            path.display()
        );
    }
}

#[test]
fn shared_structs_have_one_layout() {
    let mut seen: BTreeMap<String, (&str, Layout)> = BTreeMap::new();
    let mut failures = Vec::new();
    for (name, source, _) in SHADER_MODULES {
        let Ok((module, _)) = validate(source) else {
            continue;
        }; // reported by the test above
        for (struct_name, layout) in struct_layouts(&module) {
            match seen.get(&struct_name) {
                Some((first, known)) if *known != layout => {
                    failures.push(format!("struct {struct_name}: {first} has {known:?}, {name} has {layout:?}"))
                }
                Some(_) => {}
                None => {
                    seen.insert(struct_name, (name, layout));
                }
            }
        }
    }
    assert!(seen.contains_key("Frame"), "the shared Frame uniform struct was not found");
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn validation_catches_a_broken_shader() {
    // Guards the test itself: a type error and a storage buffer in a vertex shader
    // (not available on WebGL2) must both be reported.
    assert!(validate("@vertex fn main() -> @builtin(position) vec4<f32> { return 1.0; }").is_err());
    let storage = "@group(0) @binding(0) var<storage, read> data: array<vec4<f32>>;\n\
                   @vertex fn main(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> { return data[i]; }";
    let (module, info) = validate(storage).expect("valid WGSL");
    assert!(translate_for_webgl2(&module, &info).is_err(), "storage buffers must not pass for WebGL2");
}

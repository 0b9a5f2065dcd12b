//! The WGSL shaders (`shaders/*.wgsl`) as the renderer embeds them: without their comments,
//! indentation and blank lines (they are a fifth of the widget's download otherwise). Each line
//! keeps its place in a statement; WGSL has no string literals, and the shaders use no block
//! comments, so a `//` always starts a comment. `render::pipelines` includes the copies from
//! `OUT_DIR`; `tests/shaders.rs` validates those same strings with naga.
//!
//! With the `gl` feature (Kloub's own WebGL2 backend, `crate::gl`) the build also translates
//! every module the renderer compiles on WebGL2 into GLSL ES 3.00, once per entry point and
//! combination of its override constants, with what the backend needs to bind each program's
//! resources (`gl_shaders.rs` in `OUT_DIR`): the page then carries no shader compiler.

use std::fmt::Write as _;

include!("src/gl/hash.rs");

fn main() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../shaders");
    let out = std::path::PathBuf::from(std::env::var("OUT_DIR").expect("cargo sets OUT_DIR"));
    println!("cargo:rerun-if-changed={}", root.display());
    println!("cargo:rerun-if-changed=src/gl/hash.rs");
    let mut names: Vec<_> = std::fs::read_dir(&root)
        .expect("shaders/")
        .map(|e| e.expect("a shaders/ entry").path())
        .filter(|p| p.extension().is_some_and(|e| e == "wgsl"))
        .collect();
    names.sort();
    let mut stripped_files = std::collections::HashMap::new();
    for path in names {
        println!("cargo:rerun-if-changed={}", path.display());
        let source = std::fs::read_to_string(&path).expect("a WGSL file");
        assert!(!source.contains("/*"), "{}: a block comment (the build strips line comments only)", path.display());
        let mut stripped = String::with_capacity(source.len() / 2);
        for line in source.lines() {
            let code = line.split("//").next().unwrap_or("").trim();
            if !code.is_empty() {
                let _ = writeln!(stripped, "{code}");
            }
        }
        let name = path.file_name().expect("a file name").to_string_lossy().into_owned();
        std::fs::write(out.join(&name), &stripped).expect("writing the stripped shader");
        stripped_files.insert(name, stripped);
    }
    #[cfg(feature = "gl")]
    {
        // For `gl::table`'s test, which asks `cargo metadata` for the egui-wgpu in use on this target.
        println!("cargo:rustc-env=KLOUB_BUILD_TARGET={}", std::env::var("TARGET").unwrap_or_default());
        // egui-wgpu's own shader, which the full app's panels are drawn with (web/vendor/egui-wgpu);
        // the widget has no panels.
        let egui = cfg!(feature = "full").then(|| {
            let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("vendor/egui-wgpu/egui.wgsl");
            println!("cargo:rerun-if-changed={}", path.display());
            std::fs::read_to_string(&path).expect("web/vendor/egui-wgpu/egui.wgsl")
        });
        glsl::write_table(&stripped_files, egui.as_deref(), &out.join("gl_shaders.rs"));
    }
    #[cfg(not(feature = "gl"))]
    let _ = stripped_files;
}

#[cfg(feature = "gl")]
mod glsl {
    //! WGSL → GLSL ES 3.00 at build time (see the crate's build script doc).

    use std::collections::HashMap;

    use super::source_hash;
    use std::fmt::Write as _;

    /// The modules the renderer compiles on WebGL2, each as `render::pipelines` composes it
    /// (the files' stripped texts, concatenated in this order).
    const MODULES: [(&str, &[&str]); 4] = [
        ("mesh", &["skinning.wgsl", "output.wgsl", "equirect.wgsl", "mesh.wgsl"]),
        ("ibl", &["equirect.wgsl", "ibl.wgsl"]),
        ("environment", &["output.wgsl", "environment.wgsl"]),
        ("mip", &["mip.wgsl"]),
    ];

    /// Every override constant the shaders declare and how many values it takes (0 to n − 1):
    /// the renderer specialises its pipelines with these (`render::pipelines`).
    const OVERRIDES: [(&str, u32); 6] =
        [("SRGB_ENCODE", 2), ("SKIN_METHOD", 5), ("HEATMAP", 2), ("TANGENTS", 2), ("TEXTURES", 16), ("ENVIRONMENT", 3)];

    /// A group and binding.
    type Binding = (u32, u32);

    /// One translated stage: its GLSL (an index into the texts) and its resources.
    #[derive(PartialEq, Eq, Hash, Clone)]
    struct Stage {
        text: usize,
        /// Uniform blocks: GLSL name, group, binding.
        uniforms: Vec<(String, u32, u32)>,
        /// Combined samplers: GLSL name, the texture's group and binding, the sampler's.
        textures: Vec<(String, Binding, Option<Binding>)>,
        /// Vertex inputs or fragment outputs: GLSL name, location.
        varyings: Vec<(String, u32)>,
    }

    /// Writes the table of every module in [`MODULES`] (from `files`, the stripped shaders) and
    /// of egui-wgpu's shader (`egui`, as egui-wgpu hands it to the device; the full app only).
    pub fn write_table(files: &HashMap<String, String>, egui: Option<&str>, path: &std::path::Path) {
        let mut texts: Vec<String> = Vec::new();
        let mut stages: Vec<Stage> = Vec::new();
        let mut rust = String::from("// Generated by web/build.rs: GLSL ES 3.00 of the WebGL2 shaders.\n");
        let mut modules = String::new();
        let sources = MODULES
            .iter()
            .map(|(name, parts)| (*name, parts.iter().map(|p| files[*p].as_str()).collect::<String>()))
            .chain(egui.map(|egui| ("egui", egui.to_owned())));
        let count = MODULES.len() + usize::from(egui.is_some());
        for (name, source) in sources {
            let module = naga::front::wgsl::parse_str(&source).unwrap_or_else(|e| panic!("{name}: {e}"));
            let info =
                naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::all())
                    .validate(&module)
                    .unwrap_or_else(|e| panic!("{name}: {e:?}"));
            let overrides: Vec<(String, u32, u32)> = module
                .overrides
                .iter()
                .map(|(_, o)| {
                    let oname = o.name.clone().expect("named overrides");
                    let count = OVERRIDES
                        .iter()
                        .find(|(n, _)| *n == oname)
                        .unwrap_or_else(|| panic!("{name}: override {oname} has no domain in build.rs"))
                        .1;
                    let default = match o.init.map(|h| &module.global_expressions[h]) {
                        Some(naga::Expression::Literal(naga::Literal::U32(v))) => *v,
                        other => panic!("{name}: override {oname}: a u32 literal default, not {other:?}"),
                    };
                    (oname, default, count)
                })
                .collect();
            let _ =
                write!(modules, "    GlModule {{ name: {name:?}, hash: 0x{:016x}, overrides: &[", source_hash(&source));
            for (oname, default, count) in &overrides {
                let _ = write!(modules, "({oname:?}, {default}, {count}), ");
            }
            modules.push_str("], entries: &[\n");
            for ep in &module.entry_points {
                let stage = match ep.stage {
                    naga::ShaderStage::Vertex => "Vertex",
                    naga::ShaderStage::Fragment => "Fragment",
                    _ => continue,
                };
                // The constants this entry point depends on: those its code, or a function it calls,
                // refers to (an entry is translated for every combination of its own constants only:
                // fs_main's material textures do not multiply the vertex shaders).
                let at = |values: &[u32]| {
                    let mut constants = naga::back::PipelineConstants::default();
                    for ((oname, _, _), value) in overrides.iter().zip(values) {
                        constants.insert(oname.clone(), f64::from(*value));
                    }
                    translate(&module, &info, ep.stage, &ep.name, &constants)
                        .unwrap_or_else(|e| panic!("{name} {}: {e}", ep.name))
                };
                let defaults: Vec<u32> = overrides.iter().map(|o| o.1).collect();
                let read = overrides_read(&module, ep);
                let used: Vec<usize> = module
                    .overrides
                    .iter()
                    .enumerate()
                    .filter(|(_, (handle, _))| read.contains(handle))
                    .map(|(i, _)| i)
                    .collect();
                let combos: u32 = used.iter().map(|&i| overrides[i].2).product();
                let mut variants = Vec::new();
                for combo in 0..combos {
                    let mut values = defaults.clone();
                    let mut rest = combo;
                    for &i in &used {
                        values[i] = rest % overrides[i].2;
                        rest /= overrides[i].2;
                    }
                    let stage_entry = intern(at(&values), &mut texts);
                    let index = match stages.iter().position(|s| *s == stage_entry) {
                        Some(i) => i,
                        None => {
                            stages.push(stage_entry);
                            stages.len() - 1
                        }
                    };
                    variants.push(index);
                }
                let _ = writeln!(
                    modules,
                    "        GlEntry {{ name: {:?}, stage: GlStageKind::{stage}, overrides: &{used:?}, variants: &{variants:?} }},",
                    ep.name
                );
            }
            modules.push_str("    ] },\n");
        }
        // The texts as lists of lines, each distinct line stored once (the variants of a module
        // share most of their lines: 812 KB of GLSL is 1,203 distinct lines): `gl_lines.txt`
        // holds the lines, `GL_LINE_ENDS` where each ends in it, `GL_TEXTS` each text's range of
        // `GL_TEXT_LINES`.
        let mut lines: Vec<&str> = Vec::new();
        let mut line_index: HashMap<&str, u16> = HashMap::new();
        let mut text_lines: Vec<u16> = Vec::new();
        let _ = writeln!(rust, "pub static GL_TEXTS: [(u32, u32); {}] = [", texts.len());
        for text in &texts {
            let start = text_lines.len();
            for line in text.split('\n') {
                let next = u16::try_from(lines.len()).expect("fewer than 65,536 distinct GLSL lines");
                let index = *line_index.entry(line).or_insert_with(|| {
                    lines.push(line);
                    next
                });
                text_lines.push(index);
            }
            let _ = writeln!(rust, "    ({start}, {}),", text_lines.len());
        }
        rust.push_str("];\n");
        let _ = writeln!(rust, "pub static GL_TEXT_LINES: [u16; {}] = {text_lines:?};", text_lines.len());
        let mut ends = Vec::with_capacity(lines.len());
        let mut all = String::new();
        for line in &lines {
            all.push_str(line);
            ends.push(all.len());
        }
        let _ = writeln!(rust, "pub static GL_LINE_ENDS: [u32; {}] = {ends:?};", ends.len());
        std::fs::write(path.with_file_name("gl_lines.txt"), all).expect("writing gl_lines.txt");
        let _ = writeln!(rust, "pub static GL_STAGES: [GlStage; {}] = [", stages.len());
        for s in &stages {
            let _ = writeln!(
                rust,
                "    GlStage {{ text: {}, uniforms: &{:?}, textures: &{:?}, varyings: &{:?} }},",
                s.text, s.uniforms, s.textures, s.varyings
            );
        }
        rust.push_str("];\n");
        let _ = writeln!(rust, "pub static GL_MODULES: [GlModule; {count}] = [\n{modules}];");
        std::fs::write(path, rust).expect("writing gl_shaders.rs");
    }

    /// The override constants entry point `ep` refers to, in its own code or in a function it
    /// calls (directly or not). Only these can change its GLSL.
    fn overrides_read(
        module: &naga::Module,
        ep: &naga::EntryPoint,
    ) -> std::collections::HashSet<naga::Handle<naga::Override>> {
        let mut read = std::collections::HashSet::new();
        let mut seen = std::collections::HashSet::new();
        let mut stack = vec![&ep.function];
        while let Some(function) = stack.pop() {
            let mut calls = Vec::new();
            for (_, expression) in function.expressions.iter() {
                match *expression {
                    naga::Expression::Override(o) => {
                        read.insert(o);
                    }
                    naga::Expression::CallResult(f) => calls.push(f),
                    _ => {}
                }
            }
            calls_in(&function.body, &mut calls);
            for f in calls {
                if seen.insert(f) {
                    stack.push(&module.functions[f]);
                }
            }
        }
        read
    }

    /// Every function `block` calls (nested blocks included).
    fn calls_in(block: &naga::Block, calls: &mut Vec<naga::Handle<naga::Function>>) {
        for statement in block.iter() {
            match statement {
                naga::Statement::Block(b) => calls_in(b, calls),
                naga::Statement::If { accept, reject, .. } => {
                    calls_in(accept, calls);
                    calls_in(reject, calls);
                }
                naga::Statement::Switch { cases, .. } => cases.iter().for_each(|c| calls_in(&c.body, calls)),
                naga::Statement::Loop { body, continuing, .. } => {
                    calls_in(body, calls);
                    calls_in(continuing, calls);
                }
                naga::Statement::Call { function, .. } => calls.push(*function),
                _ => {}
            }
        }
    }

    /// A stage as translated: its GLSL and resources.
    struct Translated {
        glsl: String,
        uniforms: Vec<(String, u32, u32)>,
        textures: Vec<(String, Binding, Option<Binding>)>,
        varyings: Vec<(String, u32)>,
    }

    /// `translated` with its text stored once in `texts`.
    fn intern(translated: Translated, texts: &mut Vec<String>) -> Stage {
        let Translated { glsl, uniforms, textures, varyings } = translated;
        let text = match texts.iter().position(|t| *t == glsl) {
            Some(i) => i,
            None => {
                texts.push(glsl);
                texts.len() - 1
            }
        };
        Stage { text, uniforms, textures, varyings }
    }

    fn translate(
        module: &naga::Module,
        info: &naga::valid::ModuleInfo,
        stage: naga::ShaderStage,
        entry: &str,
        constants: &naga::back::PipelineConstants,
    ) -> Result<Translated, String> {
        let (module, info) =
            naga::back::pipeline_constants::process_overrides(module, info, Some((stage, entry)), constants)
                .map_err(|e| format!("{e:?}"))?;
        let options = naga::back::glsl::Options {
            version: naga::back::glsl::Version::Embedded { version: 300, is_webgl: true },
            writer_flags: naga::back::glsl::WriterFlags::ADJUST_COORDINATE_SPACE
                | naga::back::glsl::WriterFlags::FORCE_POINT_SIZE,
            binding_map: Default::default(),
            zero_initialize_workgroup_memory: false,
        };
        let pipeline =
            naga::back::glsl::PipelineOptions { shader_stage: stage, entry_point: entry.into(), multiview: None };
        let mut glsl = String::new();
        let mut writer =
            naga::back::glsl::Writer::new(&mut glsl, &module, &info, &options, &pipeline, Default::default())
                .map_err(|e| format!("{e}"))?;
        let reflection = writer.write().map_err(|e| format!("{e}"))?;
        drop(writer);
        // The clip-space flip (naga's `ADJUST_COORDINATE_SPACE`) by a uniform the backend sets per
        // pass: -1 into textures (their rows as WebGPU's), +1 into the canvas (`crate::gl`).
        if stage == naga::ShaderStage::Vertex {
            const FLIP: &str = "gl_Position.yz = vec2(-gl_Position.y,";
            const PRECISION: &str = "precision highp int;\n";
            if !glsl.contains(FLIP) || !glsl.contains(PRECISION) {
                return Err("naga's clip-space flip or precision lines are not where the build expects them".into());
            }
            glsl = glsl.replace(FLIP, "gl_Position.yz = vec2(_kloub_flip * gl_Position.y,").replacen(
                PRECISION,
                "precision highp int;\nuniform float _kloub_flip;\n",
                1,
            );
        }
        let binding = |h: naga::Handle<naga::GlobalVariable>| {
            let b = module.global_variables[h].binding.as_ref().expect("a bound resource");
            (b.group, b.binding)
        };
        let mut uniforms: Vec<_> = reflection
            .uniforms
            .iter()
            .map(|(h, n)| {
                let (g, b) = binding(*h);
                (n.clone(), g, b)
            })
            .collect();
        uniforms.sort();
        let mut textures: Vec<_> = reflection
            .texture_mapping
            .iter()
            .map(|(n, m)| (n.clone(), binding(m.texture), m.sampler.map(binding)))
            .collect();
        textures.sort();
        let mut varyings: Vec<_> = reflection.varying.iter().map(|(n, l)| (n.clone(), l.location)).collect();
        varyings.sort();
        Ok(Translated { glsl, uniforms, textures, varyings })
    }
}

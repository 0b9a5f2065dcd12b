//! Kloub's decoders as a module of their own: what `<kloub-viewer>`'s light widget build leaves
//! out of its first download (draco-core, the zip reader and its inflater) and fetches when a
//! file needs it (`web/kloub-viewer.js` loads `kloub_codecs.js`; the widget calls it through
//! `kloub_web::codecs`, an implementation of [`kloub_core::codecs::Codecs`]). Each call takes
//! bytes and gives bytes in the layouts of [`kloub_core::codecs`]; errors are messages.

use kloub_core::archive::ArchiveLimits;
use kloub_core::codecs::{Builtin, Codecs, archive_to_bytes};

/// Decodes a Draco stream: [`Codecs::draco`], as [`kloub_core::codecs::DracoMesh::to_bytes`].
///
/// # Errors
/// Why the stream does not decode.
pub fn decode_draco(stream: &[u8], wanted: &[u32], max_bytes: u64) -> Result<Vec<u8>, String> {
    Builtin.draco(stream, wanted, max_bytes)?.to_bytes()
}

/// Reads a zip archive: [`Codecs::unzip`], as [`kloub_core::codecs::archive_to_bytes`].
///
/// # Errors
/// What [`kloub_core::archive::read_zip`] refuses.
pub fn decode_zip(bytes: &[u8], max_entries: u32, max_bytes: u64) -> Result<Vec<u8>, String> {
    let limits = ArchiveLimits { max_entries: max_entries as usize, max_bytes };
    archive_to_bytes(&Builtin.unzip(bytes, &limits)?)
}

#[cfg(target_arch = "wasm32")]
mod wasm {
    use wasm_bindgen::prelude::*;

    /// `draco(stream, wanted ids, max bytes)` → the decoded mesh's bytes; throws the message.
    #[wasm_bindgen]
    pub fn draco(stream: &[u8], wanted: &[u32], max_bytes: f64) -> Result<Vec<u8>, JsError> {
        super::decode_draco(stream, wanted, max_bytes as u64).map_err(|e| JsError::new(&e))
    }

    /// `unzip(bytes, max entries, max bytes)` → the archive's bytes; throws the message.
    #[wasm_bindgen]
    pub fn unzip(bytes: &[u8], max_entries: u32, max_bytes: f64) -> Result<Vec<u8>, JsError> {
        super::decode_zip(bytes, max_entries, max_bytes as u64).map_err(|e| JsError::new(&e))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use kloub_core::codecs::{DracoMesh, archive_from_bytes};

    /// The decoders as the widget reaches them: every result crosses as bytes and is read back.
    struct Crossing;

    impl Codecs for Crossing {
        fn draco(&self, stream: &[u8], wanted: &[u32], max_bytes: u64) -> Result<DracoMesh, String> {
            DracoMesh::from_bytes(&decode_draco(stream, wanted, max_bytes)?)
        }

        fn unzip(&self, bytes: &[u8], limits: &ArchiveLimits) -> Result<kloub_core::archive::Archive, String> {
            archive_from_bytes(&decode_zip(bytes, limits.max_entries as u32, limits.max_bytes)?)
        }
    }

    /// The module given half of each stream.
    struct Halves;

    impl Codecs for Halves {
        fn draco(&self, stream: &[u8], wanted: &[u32], max_bytes: u64) -> Result<DracoMesh, String> {
            DracoMesh::from_bytes(&decode_draco(&stream[..stream.len() / 2], wanted, max_bytes)?)
        }

        fn unzip(&self, bytes: &[u8], limits: &ArchiveLimits) -> Result<kloub_core::archive::Archive, String> {
            Crossing.unzip(bytes, limits)
        }
    }

    fn optimized(name: &str) -> Vec<u8> {
        let path = format!("{}/../../tests/optimized/{name}", env!("CARGO_MANIFEST_DIR"));
        std::fs::read(&path).unwrap_or_else(|e| panic!("{path}: {e}"))
    }

    #[test]
    fn draco_files_import_the_same_through_the_module() {
        for name in ["Fox.draco.glb", "CesiumMan.draco.glb", "AnimatedMorphCube.draco.glb"] {
            let bytes = optimized(name);
            let options = kloub_core::ImportOptions::default();
            let builtin = kloub_core::import(&bytes, &kloub_core::NoResolver, &options).expect("imports");
            let crossed =
                kloub_core::import_with(&bytes, &kloub_core::NoResolver, &Crossing, &options).expect("imports");
            assert!(!builtin.asset.extensions.compressed_primitives.is_empty(), "{name}");
            assert_eq!(format!("{:?}", builtin.asset), format!("{:?}", crossed.asset), "{name}");
            // What the module refuses (here half of each stream) reaches the importer's message and pointer.
            let err = kloub_core::import_with(&bytes, &kloub_core::NoResolver, &Halves, &options).expect_err("cut");
            assert!(err.to_string().contains("KHR_draco_mesh_compression/bufferView"), "{name}: {err}");
            assert!(err.to_string().contains("does not decode"), "{name}: {err}");
        }
        let err = decode_draco(b"not draco", &[0], 1 << 20).expect_err("garbage");
        assert!(!err.is_empty());
    }

    #[test]
    fn archives_open_the_same_through_the_module() {
        use std::io::Write;
        let mut zip = zip::ZipWriter::new(std::io::Cursor::new(Vec::new()));
        let options = zip::write::SimpleFileOptions::default();
        for (name, bytes) in [("Man/Man.gltf", &b"{}"[..]), ("Man/data.bin", &[7u8; 3000][..]), ("../out.bin", b"x")] {
            zip.start_file(name, options).expect("start");
            zip.write_all(bytes).expect("write");
        }
        let bytes = zip.finish().expect("finish").into_inner();
        let limits = ArchiveLimits::default();
        let crossed = Crossing.unzip(&bytes, &limits).expect("opens");
        assert_eq!(crossed, Builtin.unzip(&bytes, &limits).expect("opens"));
        assert_eq!(crossed.entries.len(), 2);
        assert_eq!(crossed.skipped.len(), 1);
        let small = ArchiveLimits { max_entries: 10, max_bytes: 100 };
        assert!(Crossing.unzip(&bytes, &small).expect_err("over").contains("budget"));
        let empty = [b"PK\x05\x06".as_slice(), &[0u8; 18]].concat();
        assert_eq!(
            archive_from_bytes(&decode_zip(&empty, 10, 1 << 20).expect("empty")).expect("reads").entries.len(),
            0
        );
        let err = decode_zip(b"PK\x03\x04junk", 10, 1 << 20).expect_err("junk");
        assert!(err.contains("zip"), "{err}");
    }
}

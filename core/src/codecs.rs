//! The decoders few files need: Draco mesh streams (`KHR_draco_mesh_compression`) and zip
//! archives. The importer reaches them through [`Codecs`], so a host can leave them out of its
//! first download and bring them in when a file needs them: the web widget fetches them as a
//! module of their own (`web/codecs`) and calls it through [`Codecs`], with the data crossing as
//! the byte layouts below ([`DracoMesh::to_bytes`], [`archive_to_bytes`]). With the `codecs`
//! feature (the default) [`Builtin`] decodes in-process.
//!
//! Reading either byte layout back checks every length against the bytes there are: what comes
//! from another module is treated like any input.

use crate::archive::{Archive, ArchiveEntry, ArchiveLimits};

/// One decoded Draco stream: its points, triangles and the attributes asked for.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DracoMesh {
    /// Points (vertices) the stream decoded to.
    pub points: u32,
    /// Three point indices per triangle.
    pub indices: Vec<u32>,
    /// The attributes asked for that the stream has, by unique id.
    pub attributes: Vec<DracoAttribute>,
}

/// One attribute of a [`DracoMesh`].
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DracoAttribute {
    /// The attribute's unique id in the stream (what the glTF extension names).
    pub id: u32,
    /// Components per point (1–4 for glTF's attributes).
    pub components: u8,
    /// Whether the stream stores floats (else integers, handed out as whole f32 values).
    pub float: bool,
    /// `points × components` values.
    pub values: Vec<f32>,
}

/// The decoders the importer and the archive reader call.
pub trait Codecs {
    /// Decodes the Draco mesh stream `stream`, converting the attributes with unique ids in
    /// `wanted` to f32 values (ids the stream lacks are left out). Nothing larger than
    /// `max_bytes` (what is left of the import budget) is decoded or converted.
    ///
    /// # Errors
    /// Why the stream does not decode, or that it is over `max_bytes`.
    fn draco(&self, stream: &[u8], wanted: &[u32], max_bytes: u64) -> Result<DracoMesh, String>;

    /// Reads every file of the zip archive `bytes` (see [`crate::archive`] for what is refused).
    ///
    /// # Errors
    /// A message a user can act on (see [`crate::archive::read_zip`]).
    fn unzip(&self, bytes: &[u8], limits: &ArchiveLimits) -> Result<Archive, String>;
}

/// No decoders: every call says which one a file needs (a host that leaves them out checks
/// [`needed`] first and brings them in).
#[derive(Clone, Copy, Debug, Default)]
pub struct Unavailable;

impl Codecs for Unavailable {
    fn draco(&self, _stream: &[u8], _wanted: &[u32], _max_bytes: u64) -> Result<DracoMesh, String> {
        Err("this build has no Draco decoder".to_owned())
    }

    fn unzip(&self, _bytes: &[u8], _limits: &ArchiveLimits) -> Result<Archive, String> {
        Err("this build cannot open zip archives".to_owned())
    }
}

/// The decoders in this build: draco-core and the zip crate (the `codecs` feature).
#[cfg(feature = "codecs")]
#[derive(Clone, Copy, Debug, Default)]
pub struct Builtin;

#[cfg(feature = "codecs")]
impl Codecs for Builtin {
    fn draco(&self, stream: &[u8], wanted: &[u32], max_bytes: u64) -> Result<DracoMesh, String> {
        use draco_core::{DecodeLimits, DecoderBuffer, Mesh, MeshDecoder, draco_types::DataType};
        let limits = DecodeLimits::default().with_max_decoded_bytes(max_bytes).with_max_points(u64::from(u32::MAX));
        let mut buffer = DecoderBuffer::new(stream).with_limits(limits);
        let mut mesh = Mesh::new();
        MeshDecoder::new().decode(&mut buffer, &mut mesh).map_err(|e| e.to_string())?;
        let points = u32::try_from(mesh.num_points()).map_err(|_| "more than 2³² points".to_owned())?;
        let mut left = max_bytes;
        let mut take = |n: u64| {
            left = left.checked_sub(n).ok_or_else(|| "the decoded stream exceeds the import budget".to_owned())?;
            Ok::<_, String>(())
        };
        let mut indices = Vec::with_capacity(mesh.num_faces() * 3);
        for face in mesh.faces() {
            indices.extend(face.iter().map(|corner| corner.0));
        }
        let mut attributes = Vec::with_capacity(wanted.len());
        for &id in wanted {
            let Some(attribute) = mesh.attribute_by_unique_id(id) else { continue };
            let components = attribute.num_components();
            take(u64::from(points) * u64::from(components) * 4)?;
            attributes.push(DracoAttribute {
                id,
                components,
                float: matches!(attribute.data_type(), DataType::Float32 | DataType::Float64),
                values: attribute.read_f32s(points as usize, usize::from(components)),
            });
        }
        Ok(DracoMesh { points, indices, attributes })
    }

    fn unzip(&self, bytes: &[u8], limits: &ArchiveLimits) -> Result<Archive, String> {
        crate::archive::read_zip(bytes, limits)
    }
}

/// The decoders of this build: [`Builtin`] with the `codecs` feature, else [`Unavailable`].
pub fn builtin() -> &'static dyn Codecs {
    #[cfg(feature = "codecs")]
    return &Builtin;
    #[cfg(not(feature = "codecs"))]
    return &Unavailable;
}

/// Which decoders a file needs, by a look at its bytes (no parsing): a zip archive; a glTF
/// (GLB or JSON) that names `KHR_draco_mesh_compression`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Needs {
    /// A zip archive (by name or, for a name without an extension, by content).
    pub zip: bool,
    /// A glTF that uses Draco.
    pub draco: bool,
}

impl Needs {
    /// Whether any decoder is needed.
    pub fn any(self) -> bool {
        self.zip || self.draco
    }
}

/// What the file `name` with `bytes` needs: see [`Needs`]. A GLB's JSON chunk, or the whole of a
/// `.gltf` (or of a file named without an extension), is searched for the extension's name (false
/// positives only cost a download); other files (`.bin`, images) are not read.
pub fn needed(name: &str, bytes: &[u8]) -> Needs {
    let base = name.rsplit(['/', '\\']).next().unwrap_or(name);
    let lower = base.to_ascii_lowercase();
    let zip = lower.ends_with(".zip") || (!base.contains('.') && crate::archive::is_zip(bytes));
    let json = if bytes.starts_with(b"glTF") {
        let length = bytes.get(12..16).map_or(0, |b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as usize);
        bytes.get(20..20usize.saturating_add(length)).unwrap_or(&[])
    } else if lower.ends_with(".gltf") || !base.contains('.') {
        bytes
    } else {
        &[]
    };
    let draco = !zip && json.windows(DRACO.len()).any(|w| w == DRACO.as_bytes());
    Needs { zip, draco }
}

const DRACO: &str = "KHR_draco_mesh_compression";

/// Little-endian reads that fail instead of panicking.
struct Reader<'a> {
    bytes: &'a [u8],
}

impl<'a> Reader<'a> {
    fn take(&mut self, n: usize) -> Result<&'a [u8], String> {
        if n > self.bytes.len() {
            return Err("the decoder's output is truncated".to_owned());
        }
        let (head, tail) = self.bytes.split_at(n);
        self.bytes = tail;
        Ok(head)
    }

    fn u32(&mut self) -> Result<u32, String> {
        let b = self.take(4)?;
        Ok(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    }

    fn len(&mut self, element: usize) -> Result<usize, String> {
        let n = self.u32()? as usize;
        // A count must fit the bytes left: no allocation bigger than the input.
        if n.checked_mul(element).is_none_or(|total| total > self.bytes.len()) {
            return Err("the decoder's output is truncated".to_owned());
        }
        Ok(n)
    }

    fn string(&mut self) -> Result<String, String> {
        let n = self.len(1)?;
        String::from_utf8(self.take(n)?.to_vec())
            .map_err(|_| "the decoder's output has a name that is not UTF-8".to_owned())
    }
}

fn put_u32(out: &mut Vec<u8>, v: usize) -> Result<(), String> {
    let v = u32::try_from(v).map_err(|_| "more than 2³² items or bytes".to_owned())?;
    out.extend_from_slice(&v.to_le_bytes());
    Ok(())
}

impl DracoMesh {
    /// The mesh as bytes: points, index count, indices, attribute count, then per attribute its
    /// id, components, float flag and value count and values (all u32 / f32, little-endian).
    ///
    /// # Errors
    /// A count past u32.
    pub fn to_bytes(&self) -> Result<Vec<u8>, String> {
        let values: usize = self.attributes.iter().map(|a| a.values.len()).sum();
        let mut out = Vec::with_capacity(12 + 4 * self.indices.len() + 16 * self.attributes.len() + 4 * values);
        put_u32(&mut out, self.points as usize)?;
        put_u32(&mut out, self.indices.len())?;
        out.extend(self.indices.iter().flat_map(|i| i.to_le_bytes()));
        put_u32(&mut out, self.attributes.len())?;
        for a in &self.attributes {
            put_u32(&mut out, a.id as usize)?;
            put_u32(&mut out, usize::from(a.components))?;
            put_u32(&mut out, usize::from(a.float))?;
            put_u32(&mut out, a.values.len())?;
            out.extend(a.values.iter().flat_map(|v| v.to_le_bytes()));
        }
        Ok(out)
    }

    /// Reads [`DracoMesh::to_bytes`]'s layout.
    ///
    /// # Errors
    /// Bytes that do not hold one (truncated, a count past the bytes, trailing bytes).
    pub fn from_bytes(bytes: &[u8]) -> Result<Self, String> {
        let mut r = Reader { bytes };
        let points = r.u32()?;
        let count = r.len(4)?;
        let indices =
            r.take(count * 4)?.chunks_exact(4).map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]])).collect();
        let n = r.len(16)?;
        let mut attributes = Vec::with_capacity(n);
        for _ in 0..n {
            let id = r.u32()?;
            let components = u8::try_from(r.u32()?).map_err(|_| "an attribute has too many components".to_owned())?;
            let float = r.u32()? != 0;
            let count = r.len(4)?;
            let values =
                r.take(count * 4)?.chunks_exact(4).map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]])).collect();
            attributes.push(DracoAttribute { id, components, float, values });
        }
        if !r.bytes.is_empty() {
            return Err("the decoder's output has trailing bytes".to_owned());
        }
        Ok(Self { points, indices, attributes })
    }
}

/// `archive` as bytes: entry count, per entry its path and contents (each a u32 length and the
/// bytes), then the count of notes and each note the same way.
///
/// # Errors
/// A length past u32.
pub fn archive_to_bytes(archive: &Archive) -> Result<Vec<u8>, String> {
    let size: usize = archive.entries.iter().map(|e| 8 + e.path.len() + e.bytes.len()).sum::<usize>()
        + archive.skipped.iter().map(|s| 4 + s.len()).sum::<usize>();
    let mut out = Vec::with_capacity(8 + size);
    put_u32(&mut out, archive.entries.len())?;
    for e in &archive.entries {
        put_u32(&mut out, e.path.len())?;
        out.extend_from_slice(e.path.as_bytes());
        put_u32(&mut out, e.bytes.len())?;
        out.extend_from_slice(&e.bytes);
    }
    put_u32(&mut out, archive.skipped.len())?;
    for s in &archive.skipped {
        put_u32(&mut out, s.len())?;
        out.extend_from_slice(s.as_bytes());
    }
    Ok(out)
}

/// Reads [`archive_to_bytes`]'s layout.
///
/// # Errors
/// Bytes that do not hold one.
pub fn archive_from_bytes(bytes: &[u8]) -> Result<Archive, String> {
    let mut r = Reader { bytes };
    let n = r.len(8)?;
    let mut archive = Archive { entries: Vec::with_capacity(n), skipped: Vec::new() };
    for _ in 0..n {
        let path = r.string()?;
        let count = r.len(1)?;
        archive.entries.push(ArchiveEntry { path, bytes: r.take(count)?.to_vec() });
    }
    let n = r.len(4)?;
    for _ in 0..n {
        archive.skipped.push(r.string()?);
    }
    if !r.bytes.is_empty() {
        return Err("the decoder's output has trailing bytes".to_owned());
    }
    Ok(archive)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn mesh() -> DracoMesh {
        DracoMesh {
            points: 3,
            indices: vec![0, 1, 2],
            attributes: vec![
                DracoAttribute {
                    id: 0,
                    components: 3,
                    float: true,
                    values: vec![0.0, 1.0, 2.0, 3.0, 4.5, 5.0, 6.0, 7.0, -8.0],
                },
                DracoAttribute { id: 4, components: 1, float: false, values: vec![1.0, 2.0, 3.0] },
            ],
        }
    }

    #[test]
    fn meshes_and_archives_cross_as_bytes_unchanged() {
        let m = mesh();
        assert_eq!(DracoMesh::from_bytes(&m.to_bytes().expect("fits")).expect("reads"), m);
        let a = Archive {
            entries: vec![
                ArchiveEntry { path: "a/b.gltf".into(), bytes: b"{}".to_vec() },
                ArchiveEntry { path: "a/é.bin".into(), bytes: vec![] },
            ],
            skipped: vec!["../x: left out".into()],
        };
        assert_eq!(archive_from_bytes(&archive_to_bytes(&a).expect("fits")).expect("reads"), a);
    }

    #[test]
    fn damaged_bytes_are_errors_never_panics_or_huge_allocations() {
        let m = mesh().to_bytes().expect("fits");
        for cut in 0..m.len() {
            assert!(DracoMesh::from_bytes(&m[..cut]).is_err(), "cut at {cut}");
        }
        let mut long = m.clone();
        long.push(0);
        assert!(DracoMesh::from_bytes(&long).is_err());
        // A count of 2³² − 1 indices in 16 bytes: refused before anything is allocated.
        let mut huge = m.clone();
        huge[4..8].copy_from_slice(&u32::MAX.to_le_bytes());
        assert!(DracoMesh::from_bytes(&huge).is_err());
        let a = archive_to_bytes(&Archive {
            entries: vec![ArchiveEntry { path: "x".into(), bytes: vec![1, 2, 3] }],
            skipped: vec![],
        })
        .expect("fits");
        for cut in 0..a.len() {
            assert!(archive_from_bytes(&a[..cut]).is_err(), "cut at {cut}");
        }
        for i in 0..a.len() {
            let mut flipped = a.clone();
            flipped[i] ^= 0xff;
            let _ = archive_from_bytes(&flipped);
        }
    }

    #[test]
    fn needs_are_read_from_names_and_the_json() {
        assert_eq!(needed("models/Fox.zip", b"anything"), Needs { zip: true, draco: false });
        assert_eq!(needed("download", b"PK\x03\x04...."), Needs { zip: true, draco: false });
        assert_eq!(needed("data.bin", b"PK\x03\x04...."), Needs::default());
        let json = br#"{"extensionsUsed":["KHR_draco_mesh_compression"]}"#;
        assert!(needed("a.gltf", json).draco);
        let mut glb = b"glTF\x02\0\0\0\0\0\0\0".to_vec();
        glb.extend_from_slice(&(json.len() as u32).to_le_bytes());
        glb.extend_from_slice(b"JSON");
        glb.extend_from_slice(json);
        assert!(needed("a.glb", &glb).draco);
        // The name in the binary chunk only (after the JSON) does not count.
        let mut plain = b"glTF\x02\0\0\0\0\0\0\0\x02\0\0\0JSON{}".to_vec();
        plain.extend_from_slice(json);
        assert!(!needed("a.glb", &plain).any());
        assert!(!needed("a.glb", b"glTF").any());
        // Buffers and images are not searched.
        assert!(!needed("a.bin", json).any());
        assert!(needed("download", json).draco);
    }

    #[cfg(not(feature = "codecs"))]
    #[test]
    fn without_the_feature_the_decoders_say_what_is_missing() {
        let err = builtin().draco(&[], &[], 0).expect_err("no decoder");
        assert!(err.contains("Draco"), "{err}");
    }
}

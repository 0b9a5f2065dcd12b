//! `EXT_meshopt_compression` and its successor `KHR_meshopt_compression`: buffer views stored
//! compressed by meshoptimizer's codecs, decoded here into the bytes the view would hold. The
//! bitstream is the extensions' Appendix A (modes ATTRIBUTES, TRIANGLES, INDICES; the KHR one
//! adds version 1 of the attribute codec) and Appendix B (filters OCTAHEDRAL, QUATERNION,
//! EXPONENTIAL, and KHR's COLOR). Every read is bounds-checked: a malformed stream is an error,
//! never a panic, and the output is allocated by the caller after the budget allowed it.
//!
//! kloub-core's importer calls it for each compressed view (`import/accessor.rs`). A crate of its
//! own so that the web bundle builds it at opt-level 3 while the rest of the widget is built for
//! size (`Cargo.toml`, `[profile.wasm-release.package.kloub-meshopt]`; BENCHMARKS.md "Import and
//! decoding").

mod filters;
mod lanes;
pub use lanes::sqrt4;
mod vertex;

/// How a view's bytes were compressed (the extension's `mode`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    /// Mode 0: elements of `byteStride` bytes, delta-coded byte by byte.
    Attributes,
    /// Mode 1: a triangle list's indices.
    Triangles,
    /// Mode 2: any index sequence.
    Indices,
}

/// What is applied to the decoded elements (the extension's `filter`, ATTRIBUTES only).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Filter {
    None,
    Octahedral,
    Quaternion,
    Exponential,
    /// `KHR_meshopt_compression` only: YCoCg colours.
    Color,
}

impl Mode {
    /// The extension's name for it (`None`: not one the extension defines).
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "ATTRIBUTES" => Some(Self::Attributes),
            "TRIANGLES" => Some(Self::Triangles),
            "INDICES" => Some(Self::Indices),
            _ => None,
        }
    }
}

impl Filter {
    /// The extension's name for it (`None`: not one the extension defines).
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "NONE" => Some(Self::None),
            "OCTAHEDRAL" => Some(Self::Octahedral),
            "QUATERNION" => Some(Self::Quaternion),
            "EXPONENTIAL" => Some(Self::Exponential),
            "COLOR" => Some(Self::Color),
            _ => None,
        }
    }
}

/// Checks the extension's rules on `mode`, `filter`, `count` and `stride` (before anything is
/// allocated); `khr`: the view is `KHR_meshopt_compression`'s.
pub fn check(mode: Mode, filter: Filter, count: u64, stride: u64, khr: bool) -> Result<(), String> {
    match mode {
        Mode::Attributes if stride == 0 || !stride.is_multiple_of(4) || stride > 256 => {
            return Err(format!("ATTRIBUTES needs a byteStride that is a multiple of 4 up to 256, not {stride}"));
        }
        Mode::Triangles | Mode::Indices if stride != 2 && stride != 4 => {
            return Err(format!("index data needs a byteStride of 2 or 4, not {stride}"));
        }
        Mode::Triangles if !count.is_multiple_of(3) => {
            return Err(format!("TRIANGLES needs a count divisible by 3, not {count}"));
        }
        Mode::Triangles | Mode::Indices if filter != Filter::None => {
            return Err("index data takes no filter".to_owned());
        }
        _ => {}
    }
    match filter {
        Filter::Octahedral if stride != 4 && stride != 8 => {
            Err(format!("the OCTAHEDRAL filter needs a byteStride of 4 or 8, not {stride}"))
        }
        Filter::Quaternion if stride != 8 => {
            Err(format!("the QUATERNION filter needs a byteStride of 8, not {stride}"))
        }
        Filter::Exponential if !stride.is_multiple_of(4) => {
            Err(format!("the EXPONENTIAL filter needs a byteStride that is a multiple of 4, not {stride}"))
        }
        Filter::Color if !khr => Err("the COLOR filter is KHR_meshopt_compression's".to_owned()),
        Filter::Color if stride != 4 && stride != 8 => {
            Err(format!("the COLOR filter needs a byteStride of 4 or 8, not {stride}"))
        }
        _ => Ok(()),
    }
}

/// Decodes `src` into `out` (`count` elements of `stride` bytes: `out.len() == count * stride`),
/// then applies `filter`. The arguments must have passed [`check`]; `khr` allows version 1 of
/// the attribute codec.
pub fn decode(
    mode: Mode,
    filter: Filter,
    count: usize,
    stride: usize,
    src: &[u8],
    out: &mut [u8],
    khr: bool,
) -> Result<(), String> {
    if count.checked_mul(stride) != Some(out.len()) {
        return Err("the output does not hold count × byteStride bytes".to_owned());
    }
    match mode {
        Mode::Attributes => vertex::decode_vertices(out, count, stride, src, khr, vertex::Steps::BEST)?,
        Mode::Triangles => decode_triangles(out, count, stride, src)?,
        Mode::Indices => decode_indices(out, stride, src)?,
    }
    filters::apply(filter, stride, out);
    Ok(())
}

/// A cursor over the compressed bytes.
struct Reader<'a> {
    data: &'a [u8],
    at: usize,
}

impl<'a> Reader<'a> {
    fn take(&mut self, n: usize) -> Result<&'a [u8], String> {
        let end = self.at.checked_add(n).filter(|&e| e <= self.data.len()).ok_or("the compressed data ends early")?;
        let bytes = &self.data[self.at..end];
        self.at = end;
        Ok(bytes)
    }

    fn byte(&mut self) -> Result<u8, String> {
        Ok(self.take(1)?[0])
    }

    /// An unsigned LEB128 value of at most 32 bits.
    fn varint(&mut self) -> Result<u32, String> {
        let mut value = 0u32;
        for shift in (0..35).step_by(7) {
            let b = self.byte()?;
            value |= u32::from(b & 0x7f).checked_shl(shift).unwrap_or(0);
            if b & 0x80 == 0 {
                return Ok(value);
            }
        }
        Err("an index value is longer than 5 bytes".to_owned())
    }

    fn finished(&self) -> bool {
        self.at == self.data.len()
    }
}

fn unzigzag8(v: u8) -> u8 {
    if v & 1 != 0 { !(v >> 1) } else { v >> 1 }
}

fn unzigzag32(v: u32) -> u32 {
    if v & 1 != 0 { !(v >> 1) } else { v >> 1 }
}

/// `value`'s lowest `N` bytes (2 or 4), little-endian.
#[inline(always)]
fn index_bytes<const N: usize>(value: u32) -> [u8; N] {
    let bytes = value.to_le_bytes();
    std::array::from_fn(|i| bytes[i])
}

/// Mode 1 (header 0xe1): a code byte per triangle, extra data, a 16-byte table.
fn decode_triangles(out: &mut [u8], count: usize, stride: usize, src: &[u8]) -> Result<(), String> {
    if src.first() != Some(&0xe1) {
        return Err("the TRIANGLES data does not start with 0xe1".to_owned());
    }
    let triangles = count / 3;
    if src.len() < 1 + triangles + 16 {
        return Err("the TRIANGLES data is shorter than its codes and table".to_owned());
    }
    let codes = &src[1..1 + triangles];
    let aux = &src[src.len() - 16..];
    let mut data = Reader { data: &src[1 + triangles..src.len() - 16], at: 0 };
    if stride == 2 {
        triangles_into::<2>(out, codes, aux, &mut data)?;
    } else {
        triangles_into::<4>(out, codes, aux, &mut data)?;
    }
    if !data.finished() {
        return Err("bytes are left over after the TRIANGLES data".to_owned());
    }
    Ok(())
}

/// [`decode_triangles`] into indices of `N` bytes (`out` holds one per code's corner).
fn triangles_into<const N: usize>(
    out: &mut [u8],
    codes: &[u8],
    aux: &[u8],
    data: &mut Reader<'_>,
) -> Result<(), String> {
    let mut s = Fifos { edges: [[0; 2]; 16], edge_at: 0, vertices: [0; 16], vertex_at: 0, next: 0, last: 0 };
    let (indices, _) = out.as_chunks_mut::<N>();
    let (triangles, _) = indices.as_chunks_mut::<3>();
    for (&code, triangle) in codes.iter().zip(triangles) {
        let (hi, lo) = (usize::from(code >> 4), usize::from(code & 15));
        let (a, b, c);
        if hi < 15 {
            // A recent edge and a third vertex.
            [a, b] = s.edge(hi);
            if lo < 13 {
                // The most common case, without a branch on `lo` (they are not predictable): a
                // new vertex (0, then pushed) or a recent one (1..=12).
                let new = lo == 0;
                c = if new { s.next } else { s.vertex(lo) };
                s.next = s.next.wrapping_add(u32::from(new));
                s.vertices[s.vertex_at & 15] = c;
                s.vertex_at = (s.vertex_at + usize::from(new)) & 15;
            } else {
                c = match lo {
                    13 => s.last.wrapping_sub(1),
                    14 => s.last.wrapping_add(1),
                    _ => s.explicit(data)?,
                };
                s.last = c;
                s.push_vertex(c);
            }
            s.push_edge(c, b);
            s.push_edge(a, c);
        } else {
            // Three vertices: by the table (0xf0..0xfd) or the data (0xfe, 0xff).
            let explicit = lo >= 14;
            let zw = if explicit { data.byte()? } else { aux[lo] };
            if explicit && zw == 0 {
                s.next = 0;
            }
            let (z, w) = (usize::from(zw >> 4), usize::from(zw & 15));
            a = if lo == 15 { s.explicit(data)? } else { s.take_next() };
            b = s.third(z, explicit, data)?;
            c = s.third(w, explicit, data)?;
            s.push_edge(b, a);
            s.push_edge(c, b);
            s.push_edge(a, c);
            s.push_vertex(a);
            if z == 0 || (explicit && z == 15) {
                s.push_vertex(b);
            }
            if w == 0 || (explicit && w == 15) {
                s.push_vertex(c);
            }
        }
        *triangle = [index_bytes(a), index_bytes(b), index_bytes(c)];
    }
    Ok(())
}

/// The triangle decoder's state: recent edges and vertices, the next new vertex, the last
/// explicit one.
struct Fifos {
    edges: [[u32; 2]; 16],
    edge_at: usize,
    vertices: [u32; 16],
    vertex_at: usize,
    next: u32,
    last: u32,
}

impl Fifos {
    /// The edge `i` pushes ago (0: the last).
    fn edge(&self, i: usize) -> [u32; 2] {
        self.edges[self.edge_at.wrapping_sub(1 + i) & 15]
    }

    /// The vertex `i` pushes ago (0: the last).
    fn vertex(&self, i: usize) -> u32 {
        self.vertices[self.vertex_at.wrapping_sub(1 + i) & 15]
    }

    fn push_edge(&mut self, a: u32, b: u32) {
        self.edges[self.edge_at & 15] = [a, b];
        self.edge_at = (self.edge_at + 1) & 15;
    }

    fn push_vertex(&mut self, v: u32) {
        self.vertices[self.vertex_at & 15] = v;
        self.vertex_at = (self.vertex_at + 1) & 15;
    }

    fn take_next(&mut self) -> u32 {
        self.next = self.next.wrapping_add(1);
        self.next.wrapping_sub(1)
    }

    /// An index coded in the data as a zigzag delta from the last explicit one.
    fn explicit(&mut self, data: &mut Reader<'_>) -> Result<u32, String> {
        self.last = self.last.wrapping_add(unzigzag32(data.varint()?));
        Ok(self.last)
    }

    /// The second or third vertex of a 0xfY/0xfe/0xff triangle from its nibble `k`: new (0), a
    /// recent vertex (`k - 1` pushes ago), or explicit (15, in the data's case).
    fn third(&mut self, k: usize, explicit: bool, data: &mut Reader<'_>) -> Result<u32, String> {
        if k == 0 {
            Ok(self.take_next())
        } else if k == 15 && explicit {
            self.explicit(data)
        } else {
            Ok(self.vertex(k - 1))
        }
    }
}

/// Mode 2 (header 0xd1): a varint per index, a delta from one of two baselines; a 4-byte tail.
fn decode_indices(out: &mut [u8], stride: usize, src: &[u8]) -> Result<(), String> {
    if src.first() != Some(&0xd1) {
        return Err("the INDICES data does not start with 0xd1".to_owned());
    }
    if src.len() < 1 + 4 {
        return Err("the INDICES data is shorter than its tail".to_owned());
    }
    let mut data = Reader { data: &src[1..src.len() - 4], at: 0 };
    if stride == 2 {
        indices_into::<2>(out, &mut data)?;
    } else {
        indices_into::<4>(out, &mut data)?;
    }
    if !data.finished() {
        return Err("bytes are left over after the INDICES data".to_owned());
    }
    Ok(())
}

/// [`decode_indices`] into indices of `N` bytes (`out` holds the view's count of them).
fn indices_into<const N: usize>(out: &mut [u8], data: &mut Reader<'_>) -> Result<(), String> {
    let mut last = [0u32; 2];
    for index in out.as_chunks_mut::<N>().0 {
        let v = data.varint()?;
        let baseline = (v & 1) as usize;
        let delta = if v & 2 != 0 { !(v >> 2) } else { v >> 2 };
        last[baseline] = last[baseline].wrapping_add(delta);
        *index = index_bytes(last[baseline]);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[cfg_attr(not(target_arch = "wasm32"), test)]
    #[cfg_attr(target_arch = "wasm32", wasm_bindgen_test::wasm_bindgen_test)]
    fn a_4_bit_group_with_sentinels_decodes_as_the_specification_shows() {
        let bytes = [0x17, 0x5f, 0xf0, 0xbc, 0x77, 0xa9, 0x21, 0x00, 0x34, 0xb5];
        let mut reader = Reader { data: &bytes, at: 0 };
        let mut deltas = [0u8; 16];
        vertex::decode_group(&mut reader, 4, &mut deltas).expect("decodes");
        assert!(reader.finished());
        let signed: Vec<i8> = deltas.iter().map(|&d| unzigzag8(d) as i8).collect();
        assert_eq!(signed, [-1, -4, -3, 26, -91, 0, -6, 6, -4, -4, 5, -5, 1, -1, 0, 0]);
    }

    #[cfg_attr(not(target_arch = "wasm32"), test)]
    #[cfg_attr(target_arch = "wasm32", wasm_bindgen_test::wasm_bindgen_test)]
    fn varints_are_unsigned_leb128() {
        // The specification's first two examples; its third (0xff 0xa0 0x05) reads its groups
        // the other way round, while LEB128 and meshoptimizer's decoder put the first lowest.
        let bytes = [0x7f, 0x81, 0x04, 0xff, 0xa0, 0x05];
        let mut reader = Reader { data: &bytes, at: 0 };
        assert_eq!(reader.varint(), Ok(0x7f));
        assert_eq!(reader.varint(), Ok(0x201));
        assert_eq!(reader.varint(), Ok(0x7f | 0x20 << 7 | 0x05 << 14));
        assert!(Reader { data: &[0x80; 6], at: 0 }.varint().is_err());
        assert!(Reader { data: &[0x80], at: 0 }.varint().is_err());
    }

    /// Encodes `values` (4-byte elements) as mode 0 with every group stored as whole bytes.
    fn encode_raw(values: &[[u8; 4]]) -> Vec<u8> {
        let mut out = vec![0xa0];
        let mut last = [0u8; 4];
        for block in values.chunks(256) {
            let groups = block.len().div_ceil(16);
            for byte in 0..4 {
                out.extend(std::iter::repeat_n(0xff, groups.div_ceil(4)));
                let mut deltas: Vec<u8> = block
                    .iter()
                    .map(|v| {
                        let d = v[byte].wrapping_sub(last[byte]);
                        last[byte] = v[byte];
                        if d & 0x80 != 0 { !(d << 1) } else { d << 1 }
                    })
                    .collect();
                deltas.resize(groups * 16, 0);
                out.extend(deltas);
            }
        }
        out.extend([0u8; 32]);
        out
    }

    #[cfg_attr(not(target_arch = "wasm32"), test)]
    #[cfg_attr(target_arch = "wasm32", wasm_bindgen_test::wasm_bindgen_test)]
    fn attributes_round_trip_through_whole_byte_groups() {
        let values: Vec<[u8; 4]> = (0..300u32).map(|i| i.wrapping_mul(2654435761).to_le_bytes()).collect();
        let src = encode_raw(&values);
        let mut out = vec![0u8; values.len() * 4];
        decode(Mode::Attributes, Filter::None, values.len(), 4, &src, &mut out, false).expect("decodes");
        assert_eq!(out, values.concat());
        // Cut short, a byte too many, or another version: errors, never a panic.
        for bad in [&src[..src.len() - 40], &[&src[..], &[0]].concat()[..], &[&[0xa1][..], &src[1..]].concat()[..]] {
            assert!(decode(Mode::Attributes, Filter::None, values.len(), 4, bad, &mut out, false).is_err());
        }
    }

    #[cfg_attr(not(target_arch = "wasm32"), test)]
    #[cfg_attr(target_arch = "wasm32", wasm_bindgen_test::wasm_bindgen_test)]
    fn indices_decode_deltas_from_two_baselines() {
        // 5, then 3 on the second baseline, then 6 on the first (+1), then 3 again (+0).
        let zig = |d: i32, baseline: u32| (((d << 1) ^ (d >> 31)) as u32) << 1 | baseline;
        let mut src = vec![0xd1];
        for v in [zig(5, 0), zig(3, 1), zig(1, 0), zig(0, 1)] {
            assert!(v < 128);
            src.push(v as u8);
        }
        src.extend([0; 4]);
        let mut out = vec![0u8; 8];
        decode(Mode::Indices, Filter::None, 4, 2, &src, &mut out, false).expect("decodes");
        let got: Vec<u16> = out.chunks(2).map(|c| u16::from_le_bytes([c[0], c[1]])).collect();
        assert_eq!(got, [5, 3, 6, 3]);
        // The same as 32-bit indices; a view cut short is an error.
        let mut out = vec![0u8; 16];
        decode(Mode::Indices, Filter::None, 4, 4, &src, &mut out, false).expect("decodes");
        let got: Vec<u32> = out.chunks(4).map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect();
        assert_eq!(got, [5, 3, 6, 3]);
        let mut out = vec![0u8; 10];
        assert!(decode(Mode::Indices, Filter::None, 5, 2, &src, &mut out, false).is_err());
    }

    #[cfg_attr(not(target_arch = "wasm32"), test)]
    #[cfg_attr(target_arch = "wasm32", wasm_bindgen_test::wasm_bindgen_test)]
    fn triangles_decode_new_vertices_and_shared_edges() {
        // 0xfe with 0x00: three new vertices (0, 1, 2) and `next` reset; then 0x00: edge 0 — the
        // last pushed, (a, c) = (0, 2) — and the next vertex 3.
        let mut src = vec![0xe1, 0xfe, 0x00, 0x00];
        src.extend([0u8; 16]);
        let mut out = vec![0u8; 12];
        decode(Mode::Triangles, Filter::None, 6, 2, &src, &mut out, false).expect("decodes");
        let got: Vec<u16> = out.chunks(2).map(|c| u16::from_le_bytes([c[0], c[1]])).collect();
        assert_eq!(got, [0, 1, 2, 0, 2, 3]);
        assert!(decode(Mode::Triangles, Filter::None, 6, 2, &src[..10], &mut out, false).is_err());
    }

    /// Every 8-bit octahedral input (1.0 = 127) and a spread of 16-bit quaternions against the
    /// formulas in f64: within one unit in the last place (the rounding of f32 arithmetic).
    #[cfg_attr(not(target_arch = "wasm32"), test)]
    #[cfg_attr(target_arch = "wasm32", wasm_bindgen_test::wasm_bindgen_test)]
    fn filters_agree_with_the_formulas_in_double_precision() {
        let mut bytes = Vec::new();
        for x in -128i32..128 {
            for y in -128i32..128 {
                bytes.extend([x as u8, y as u8, 127, 7]);
            }
        }
        let mut out = bytes.clone();
        filters::apply(Filter::Octahedral, 4, &mut out);
        for (e, o) in bytes.chunks_exact(4).zip(out.chunks_exact(4)) {
            let (x, y) = (f64::from(e[0] as i8) / 127.0, f64::from(e[1] as i8) / 127.0);
            let z = 1.0 - x.abs() - y.abs();
            let t = z.min(0.0);
            let (x, y) = (x - t.copysign(x), y - t.copysign(y));
            let len = (x * x + y * y + z * z).sqrt();
            for (got, want) in o[..3].iter().zip([x, y, z]) {
                let want = (want / len * 127.0).round();
                assert!((f64::from(*got as i8) - want).abs() <= 1.0, "{e:?} → {o:?}");
            }
            assert_eq!(o[3], 7);
        }
        let mut bytes = Vec::new();
        let mut r = 0x2545_f491_4f6c_dd1du64;
        for i in 0..20000u32 {
            r ^= r << 13;
            r ^= r >> 7;
            r ^= r << 17;
            // 1.0 in K = 4..=16 bits, as the encoder writes it (2^(K-1) - 1: at most 32767; a
            // larger one does not fit the 16-bit component and decodes to garbage).
            let one = (1i32 << (3 + i % 13)) - 1;
            let c = |s: u32| ((r >> s) as i32 % (one + 1)) as i16;
            let w = (one as i16 & !3) | (i % 4) as i16;
            for v in [c(0), c(16), c(32), w] {
                bytes.extend(v.to_le_bytes());
            }
        }
        let mut out = bytes.clone();
        filters::apply(Filter::Quaternion, 8, &mut out);
        let read = |b: &[u8], i: usize| i16::from_le_bytes([b[2 * i], b[2 * i + 1]]);
        for (e, o) in bytes.chunks_exact(8).zip(out.chunks_exact(8)) {
            let one = f64::from(read(e, 3) | 3);
            let [x, y, z] = [0, 1, 2].map(|i| f64::from(read(e, i)) / one * std::f64::consts::FRAC_1_SQRT_2);
            let w = (1.0 - x * x - y * y - z * z).max(0.0).sqrt();
            let max = (read(e, 3) & 3) as usize;
            for (k, want) in [x, y, z, w].into_iter().enumerate() {
                let want = (want * 32767.0).round().clamp(-32768.0, 32767.0);
                let got = f64::from(read(o, (max + 1 + k) % 4));
                assert!((got - want).abs() <= 1.0, "{e:?} → {o:?}: component {k} {got} against {want}");
            }
        }
    }

    #[cfg_attr(not(target_arch = "wasm32"), test)]
    #[cfg_attr(target_arch = "wasm32", wasm_bindgen_test::wasm_bindgen_test)]
    fn filters_decode_unit_vectors_quaternions_and_floats() {
        // Octahedral (0, 0) with 1.0 = 127: +Z.
        let mut e = [0u8, 0, 127, 9];
        filters::apply(Filter::Octahedral, 4, &mut e);
        assert_eq!(e, [0, 0, 127, 9]);
        // Quaternion: largest component w (index 3), the others 0, 1.0 = 32767 → identity.
        let mut q = [0u8; 8];
        q[6..8].copy_from_slice(&(32767i16 & !3 | 3).to_le_bytes());
        filters::apply(Filter::Quaternion, 8, &mut q);
        let got: Vec<i16> = q.chunks(2).map(|c| i16::from_le_bytes([c[0], c[1]])).collect();
        assert_eq!(got, [0, 0, 0, 32767]);
        // Exponential: 3 × 2^-1.
        let mut f = ((-1i32 << 24) | 3).to_le_bytes();
        filters::apply(Filter::Exponential, 4, &mut f);
        assert_eq!(f32::from_le_bytes(f), 1.5);
        assert!(check(Mode::Attributes, Filter::Quaternion, 4, 4, false).is_err());
        assert!(check(Mode::Triangles, Filter::None, 4, 2, false).is_err());
        assert!(check(Mode::Attributes, Filter::Color, 4, 4, false).is_err());
        assert!(check(Mode::Attributes, Filter::Color, 4, 4, true).is_ok());
        assert!(check(Mode::Attributes, Filter::Octahedral, 4, 8, false).is_ok());
        // Colour: grey Y = 128 without chroma, alpha 127 in 7 bits with bit 8 set (K = 8) → 255.
        let mut c = [128u8, 0, 0, 0xff];
        filters::apply(Filter::Color, 4, &mut c);
        assert_eq!(c, [128, 128, 128, 255]);
        // Co = 10, Cg = -5: r = y + co - cg, g = y + cg, b = y - co - cg.
        let mut c = [100u8, 10, (-5i8) as u8, 0xff];
        filters::apply(Filter::Color, 4, &mut c);
        assert_eq!(c, [115, 95, 95, 255]);
    }
}

//! `EXT_meshopt_compression` and its successor `KHR_meshopt_compression`: buffer views stored
//! compressed by meshoptimizer's codecs, decoded here into the bytes the view would hold. The
//! bitstream is the extensions' Appendix A (modes ATTRIBUTES, TRIANGLES, INDICES; the KHR one
//! adds version 1 of the attribute codec) and Appendix B (filters OCTAHEDRAL, QUATERNION,
//! EXPONENTIAL, and KHR's COLOR). Every read is bounds-checked: a malformed stream is an error,
//! never a panic, and the output is allocated by the caller after the budget allowed it.

/// The extensions' names: the KHR successor first (a view naming both is read by it).
pub(crate) const EXTENSIONS: [&str; 2] = ["KHR_meshopt_compression", "EXT_meshopt_compression"];

/// How a view's bytes were compressed (the extension's `mode`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Mode {
    /// Mode 0: elements of `byteStride` bytes, delta-coded byte by byte.
    Attributes,
    /// Mode 1: a triangle list's indices.
    Triangles,
    /// Mode 2: any index sequence.
    Indices,
}

/// What is applied to the decoded elements (the extension's `filter`, ATTRIBUTES only).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Filter {
    None,
    Octahedral,
    Quaternion,
    Exponential,
    /// `KHR_meshopt_compression` only: YCoCg colours.
    Color,
}

impl Mode {
    pub(crate) fn parse(s: &str) -> Option<Self> {
        match s {
            "ATTRIBUTES" => Some(Self::Attributes),
            "TRIANGLES" => Some(Self::Triangles),
            "INDICES" => Some(Self::Indices),
            _ => None,
        }
    }
}

impl Filter {
    pub(crate) fn parse(s: &str) -> Option<Self> {
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
pub(crate) fn check(mode: Mode, filter: Filter, count: u64, stride: u64, khr: bool) -> Result<(), String> {
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
pub(crate) fn decode(
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
        Mode::Attributes => decode_vertices(out, count, stride, src, khr)?,
        Mode::Triangles => decode_triangles(out, count, stride, src)?,
        Mode::Indices => decode_indices(out, count, stride, src)?,
    }
    match filter {
        Filter::None => {}
        Filter::Octahedral if stride == 4 => out.chunks_exact_mut(4).for_each(octahedral8),
        Filter::Octahedral => out.chunks_exact_mut(8).for_each(octahedral16),
        Filter::Quaternion => out.chunks_exact_mut(8).for_each(quaternion),
        Filter::Exponential => out.chunks_exact_mut(4).for_each(exponential),
        Filter::Color if stride == 4 => out.chunks_exact_mut(4).for_each(color8),
        Filter::Color => out.chunks_exact_mut(8).for_each(color16),
    }
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

/// Mode 0: per block of elements, per byte of the element, groups of 16 deltas. Version 0
/// (header 0xa0, `EXT_meshopt_compression`) codes byte deltas only; version 1 (0xa1,
/// `KHR_meshopt_compression`) adds a control mode per byte position (which bit widths its
/// groups use, or all zero, or literal) and a channel mode per 4 bytes (byte deltas, 16-bit
/// deltas, or a rotated 32-bit XOR), read from the tail.
fn decode_vertices(out: &mut [u8], count: usize, stride: usize, src: &[u8], allow_v1: bool) -> Result<(), String> {
    let v1 = match src.first() {
        Some(0xa0) => false,
        Some(0xa1) if allow_v1 => true,
        Some(&h) if h & 0xf0 == 0xa0 => {
            return Err(format!("attribute codec version {} is not supported by this extension", h & 0x0f));
        }
        _ => return Err("the ATTRIBUTES data does not start with 0xa0 or 0xa1".to_owned()),
    };
    // The tail: padding, the baseline element, and (version 1) a channel mode per 4 bytes.
    let tail_block = if v1 { stride + stride / 4 } else { stride };
    let tail = tail_block.max(if v1 { 24 } else { 32 });
    if src.len() < 1 + tail {
        return Err("the ATTRIBUTES data is shorter than its tail".to_owned());
    }
    let tail_start = src.len() - tail_block;
    let mut last = [0u8; 256];
    last[..stride].copy_from_slice(&src[tail_start..tail_start + stride]);
    let channels = &src[tail_start + stride..];
    for &mode in channels {
        if mode & 15 > 2 || (mode & 15 < 2 && mode >> 4 != 0) {
            return Err(format!("channel mode {mode:#04x} is not valid"));
        }
    }
    let mut reader = Reader { data: &src[1..src.len() - tail], at: 0 };
    let block_max = ((8192 / stride) & !15).min(256);
    // The block's deltas, byte position by byte position.
    let mut deltas = vec![0u8; stride * block_max.div_ceil(16) * 16];
    let mut first = 0;
    while first < count {
        let block = block_max.min(count - first);
        let groups = block.div_ceil(16);
        let span = groups * 16;
        let control = if v1 { reader.take(stride / 4)? } else { &[][..] };
        for byte in 0..stride {
            let stream = &mut deltas[byte * span..(byte + 1) * span];
            let mode = control.get(byte / 4).map_or(0, |c| (c >> ((byte % 4) * 2)) & 3);
            match (v1, mode) {
                (true, 2) => stream.fill(0),
                // Literal: the block's deltas as they are (not rounded up to whole groups).
                (true, 3) => stream[..block].copy_from_slice(reader.take(block)?),
                _ => {
                    let header = reader.take(groups.div_ceil(4))?;
                    for group in 0..groups {
                        let bits = (header[group / 4] >> ((group % 4) * 2)) & 3;
                        let width = match (v1, mode, bits) {
                            (false, _, 0) | (true, 0, 0) => 0,
                            (true, 0, 1) | (true, _, 0) => 1,
                            (false, _, 1) | (true, 0, 2) | (true, _, 1) => 2,
                            (false, _, 2) | (true, 0, 3) | (true, _, 2) => 4,
                            _ => 8,
                        };
                        decode_group(&mut reader, width, &mut stream[group * 16..group * 16 + 16])?;
                    }
                }
            }
        }
        // Each channel's running value, byte position by byte position (a prefix sum per
        // position, written straight into the elements).
        let elements = &mut out[first * stride..(first + block) * stride];
        for channel in 0..stride.div_ceil(4) {
            let at = channel * 4;
            let mode = channels.get(channel).copied().unwrap_or(0);
            match mode & 15 {
                1 => {
                    for half in [at, at + 2] {
                        let (low, high) = (&deltas[half * span..][..block], &deltas[(half + 1) * span..][..block]);
                        let mut value = u16::from_le_bytes([last[half], last[half + 1]]);
                        for ((element, &l), &h) in elements.chunks_exact_mut(stride).zip(low).zip(high) {
                            let d = u16::from_le_bytes([l, h]);
                            value = value.wrapping_add(if d & 1 != 0 { !(d >> 1) } else { d >> 1 });
                            element[half..half + 2].copy_from_slice(&value.to_le_bytes());
                        }
                        last[half..half + 2].copy_from_slice(&value.to_le_bytes());
                    }
                }
                2 => {
                    let rotate = u32::from(mode >> 4);
                    let bytes: [&[u8]; 4] = std::array::from_fn(|k| &deltas[(at + k) * span..][..block]);
                    let mut value = u32::from_le_bytes([last[at], last[at + 1], last[at + 2], last[at + 3]]);
                    for (i, element) in elements.chunks_exact_mut(stride).enumerate() {
                        let d = u32::from_le_bytes([bytes[0][i], bytes[1][i], bytes[2][i], bytes[3][i]]);
                        value ^= d.rotate_right(rotate);
                        element[at..at + 4].copy_from_slice(&value.to_le_bytes());
                    }
                    last[at..at + 4].copy_from_slice(&value.to_le_bytes());
                }
                _ => {
                    for k in at..(at + 4).min(stride) {
                        let mut value = last[k];
                        for (element, &d) in elements.chunks_exact_mut(stride).zip(&deltas[k * span..][..block]) {
                            value = value.wrapping_add(unzigzag8(d));
                            element[k] = value;
                        }
                        last[k] = value;
                    }
                }
            }
        }
        first += block;
    }
    if !reader.finished() {
        return Err("bytes are left over after the ATTRIBUTES data".to_owned());
    }
    Ok(())
}

/// One group of 16 zigzag deltas of `width` bits (0: all zero; 8: whole bytes); a delta with
/// every bit set (the sentinel) is a whole byte that follows the packed ones. 1-bit deltas are
/// packed from the lowest bit, 2- and 4-bit ones from the highest.
fn decode_group(reader: &mut Reader<'_>, width: u32, deltas: &mut [u8]) -> Result<(), String> {
    match width {
        0 => deltas.fill(0),
        1 => unpack::<1>(reader, deltas)?,
        2 => unpack::<2>(reader, deltas)?,
        4 => unpack::<4>(reader, deltas)?,
        _ => deltas.copy_from_slice(reader.take(16)?),
    }
    Ok(())
}

/// [`decode_group`] for `W` = 1, 2 or 4 bits.
fn unpack<const W: u32>(reader: &mut Reader<'_>, deltas: &mut [u8]) -> Result<(), String> {
    let per_byte = (8 / W) as usize;
    let sentinel = ((1u32 << W) - 1) as u8;
    let packed = reader.take(16 / per_byte)?;
    for (i, delta) in deltas.iter_mut().enumerate() {
        let slot = (i % per_byte) as u32;
        let shift = if W == 1 { slot } else { 8 - W * (slot + 1) };
        let v = (packed[i / per_byte] >> shift) & sentinel;
        *delta = if v == sentinel { reader.byte()? } else { v };
    }
    Ok(())
}

fn write_index(out: &mut [u8], stride: usize, i: usize, value: u32) {
    let at = i * stride;
    if stride == 2 {
        out[at..at + 2].copy_from_slice(&(value as u16).to_le_bytes());
    } else {
        out[at..at + 4].copy_from_slice(&value.to_le_bytes());
    }
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
    let mut s = Fifos { edges: [[0; 2]; 16], edge_at: 0, vertices: [0; 16], vertex_at: 0, next: 0, last: 0 };
    for (t, &code) in codes.iter().enumerate() {
        let (hi, lo) = (usize::from(code >> 4), usize::from(code & 15));
        let (a, b, c);
        if hi < 15 {
            // A recent edge and a third vertex.
            [a, b] = s.edge(hi);
            c = match lo {
                0 => s.take_next(),
                13 => {
                    s.last = s.last.wrapping_sub(1);
                    s.last
                }
                14 => {
                    s.last = s.last.wrapping_add(1);
                    s.last
                }
                15 => s.explicit(&mut data)?,
                _ => s.vertex(lo),
            };
            s.push_edge(c, b);
            s.push_edge(a, c);
            if lo == 0 || lo >= 13 {
                s.push_vertex(c);
            }
        } else {
            // Three vertices: by the table (0xf0..0xfd) or the data (0xfe, 0xff).
            let explicit = lo >= 14;
            let zw = if explicit { data.byte()? } else { aux[lo] };
            if explicit && zw == 0 {
                s.next = 0;
            }
            let (z, w) = (usize::from(zw >> 4), usize::from(zw & 15));
            a = if lo == 15 { s.explicit(&mut data)? } else { s.take_next() };
            b = s.third(z, explicit, &mut data)?;
            c = s.third(w, explicit, &mut data)?;
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
        write_index(out, stride, t * 3, a);
        write_index(out, stride, t * 3 + 1, b);
        write_index(out, stride, t * 3 + 2, c);
    }
    if !data.finished() {
        return Err("bytes are left over after the TRIANGLES data".to_owned());
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
        self.edges[self.edge_at] = [a, b];
        self.edge_at = (self.edge_at + 1) & 15;
    }

    fn push_vertex(&mut self, v: u32) {
        self.vertices[self.vertex_at] = v;
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
fn decode_indices(out: &mut [u8], count: usize, stride: usize, src: &[u8]) -> Result<(), String> {
    if src.first() != Some(&0xd1) {
        return Err("the INDICES data does not start with 0xd1".to_owned());
    }
    if src.len() < 1 + 4 {
        return Err("the INDICES data is shorter than its tail".to_owned());
    }
    let mut data = Reader { data: &src[1..src.len() - 4], at: 0 };
    let mut last = [0u32; 2];
    for i in 0..count {
        let v = data.varint()?;
        let baseline = (v & 1) as usize;
        let delta = if v & 2 != 0 { !(v >> 2) } else { v >> 2 };
        last[baseline] = last[baseline].wrapping_add(delta);
        write_index(out, stride, i, last[baseline]);
    }
    if !data.finished() {
        return Err("bytes are left over after the INDICES data".to_owned());
    }
    Ok(())
}

/// Rounds to the nearest integer (halves away from zero) and saturates, as the filters' `round`.
fn round_i16(x: f32) -> i16 {
    round(x).clamp(-32768, 32767) as i16
}

/// `x` rounded half away from zero (saturating, NaN → 0), as `f32::round` but without its libm
/// call where the target has no rounding instruction (x86-64's baseline): the `as` cast truncates.
fn round(x: f32) -> i32 {
    (x + 0.5f32.copysign(x)) as i32
}

/// Filter 1 on four signed bytes: octahedral x, y, the K-bit 1.0, and a byte passed through.
fn octahedral8(e: &mut [u8]) {
    let [x, y, z] = octahedral(f32::from(e[0] as i8), f32::from(e[1] as i8), f32::from(e[2] as i8));
    e[0] = round(x * 127.0).clamp(-128, 127) as i8 as u8;
    e[1] = round(y * 127.0).clamp(-128, 127) as i8 as u8;
    e[2] = round(z * 127.0).clamp(-128, 127) as i8 as u8;
}

/// Filter 1 on four signed 16-bit components.
fn octahedral16(e: &mut [u8]) {
    let read = |i: usize| f32::from(i16::from_le_bytes([e[2 * i], e[2 * i + 1]]));
    let [x, y, z] = octahedral(read(0), read(1), read(2));
    for (i, v) in [x, y, z].into_iter().enumerate() {
        e[2 * i..2 * i + 2].copy_from_slice(&round_i16(v * 32767.0).to_le_bytes());
    }
}

/// The unit vector of octahedral coordinates `x`, `y` in units of `one`.
fn octahedral(x: f32, y: f32, one: f32) -> [f32; 3] {
    let (mut x, mut y) = (x / one, y / one);
    let z = 1.0 - x.abs() - y.abs();
    let t = z.min(0.0);
    x -= t.copysign(x);
    y -= t.copysign(y);
    let len = (x * x + y * y + z * z).sqrt();
    [x / len, y / len, z / len]
}

/// Filter 2: three components scaled by √2 and the index of the omitted largest one.
fn quaternion(e: &mut [u8]) {
    let read = |i: usize| i16::from_le_bytes([e[2 * i], e[2 * i + 1]]);
    let range = std::f32::consts::FRAC_1_SQRT_2;
    let one = f32::from(read(3) | 3);
    let x = f32::from(read(0)) / one * range;
    let y = f32::from(read(1)) / one * range;
    let z = f32::from(read(2)) / one * range;
    let w = (1.0 - x * x - y * y - z * z).max(0.0).sqrt();
    let max = u32::from(read(3) as u16 & 3);
    // x, y, z, w as 16-bit lanes 0..3, rotated so that w lands in lane `max` and x, y, z follow it.
    let lane = |v: f32| u64::from(round_i16(v * 32767.0) as u16);
    let q = lane(x) | lane(y) << 16 | lane(z) << 32 | lane(w) << 48;
    e.copy_from_slice(&q.rotate_left((max + 1) * 16).to_le_bytes());
}

/// Filter 3: a signed 8-bit exponent over a signed 24-bit mantissa, to a float.
fn exponential(e: &mut [u8]) {
    let v = i32::from_le_bytes([e[0], e[1], e[2], e[3]]);
    let exponent = v >> 24;
    let mantissa = (v << 8) >> 8;
    // 2^exponent from the bits of powers of two (powi is a libm call on x86-64): exact, as the
    // exponent (-128..=127) splits into two normal ones.
    let power = |e: i32| f32::from_bits(((e + 127) as u32) << 23);
    let scale = if exponent >= -126 { power(exponent) } else { power(-126) * power(exponent + 126) };
    let value = scale * mantissa as f32;
    e.copy_from_slice(&value.to_le_bytes());
}

/// Filter 4 on four 8-bit components: Y, Co, Cg and an alpha whose highest set bit gives K.
fn color8(e: &mut [u8]) {
    let rgba = ycocg(i32::from(e[0]), i32::from(e[1] as i8), i32::from(e[2] as i8), u32::from(e[3]), 255.0);
    for (out, v) in e.iter_mut().zip(rgba) {
        *out = round(v).clamp(0, 255) as u8;
    }
}

/// Filter 4 on four 16-bit components.
fn color16(e: &mut [u8]) {
    let read = |i: usize| [e[2 * i], e[2 * i + 1]];
    let y = i32::from(u16::from_le_bytes(read(0)));
    let co = i32::from(i16::from_le_bytes(read(1)));
    let cg = i32::from(i16::from_le_bytes(read(2)));
    let rgba = ycocg(y, co, cg, u32::from(u16::from_le_bytes(read(3))), 65535.0);
    for (i, v) in rgba.into_iter().enumerate() {
        e[2 * i..2 * i + 2].copy_from_slice(&(round(v).clamp(0, 65535) as u16).to_le_bytes());
    }
}

/// YCoCg with K-bit components (K from the alpha's highest set bit) to RGBA scaled to `max`
/// (rounded and saturated by the caller's cast).
fn ycocg(y: i32, co: i32, cg: i32, alpha: u32, max: f32) -> [f32; 4] {
    let scale = if alpha == 0 { 0 } else { (1u32 << (32 - alpha.leading_zeros())) - 1 };
    let a = alpha & (scale >> 1);
    let a = (a << 1) | (a & 1);
    let ss = if scale == 0 { 0.0 } else { max / scale as f32 };
    [(y + co - cg) as f32 * ss, (y + cg) as f32 * ss, (y - co - cg) as f32 * ss, a as f32 * ss]
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
        decode_group(&mut reader, 4, &mut deltas).expect("decodes");
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

    #[cfg_attr(not(target_arch = "wasm32"), test)]
    #[cfg_attr(target_arch = "wasm32", wasm_bindgen_test::wasm_bindgen_test)]
    fn filters_decode_unit_vectors_quaternions_and_floats() {
        // Octahedral (0, 0) with 1.0 = 127: +Z.
        let mut e = [0u8, 0, 127, 9];
        octahedral8(&mut e);
        assert_eq!(e, [0, 0, 127, 9]);
        // Quaternion: largest component w (index 3), the others 0, 1.0 = 32767 → identity.
        let mut q = [0u8; 8];
        q[6..8].copy_from_slice(&(32767i16 & !3 | 3).to_le_bytes());
        quaternion(&mut q);
        let got: Vec<i16> = q.chunks(2).map(|c| i16::from_le_bytes([c[0], c[1]])).collect();
        assert_eq!(got, [0, 0, 0, 32767]);
        // Exponential: 3 × 2^-1.
        let mut f = ((-1i32 << 24) | 3).to_le_bytes();
        exponential(&mut f);
        assert_eq!(f32::from_le_bytes(f), 1.5);
        assert!(check(Mode::Attributes, Filter::Quaternion, 4, 4, false).is_err());
        assert!(check(Mode::Triangles, Filter::None, 4, 2, false).is_err());
        assert!(check(Mode::Attributes, Filter::Color, 4, 4, false).is_err());
        assert!(check(Mode::Attributes, Filter::Color, 4, 4, true).is_ok());
        assert!(check(Mode::Attributes, Filter::Octahedral, 4, 8, false).is_ok());
        // Colour: grey Y = 128 without chroma, alpha 127 in 7 bits with bit 8 set (K = 8) → 255.
        let mut c = [128u8, 0, 0, 0xff];
        color8(&mut c);
        assert_eq!(c, [128, 128, 128, 255]);
        // Co = 10, Cg = -5: r = y + co - cg, g = y + cg, b = y - co - cg.
        let mut c = [100u8, 10, (-5i8) as u8, 0xff];
        color8(&mut c);
        assert_eq!(c, [115, 95, 95, 255]);
    }
}

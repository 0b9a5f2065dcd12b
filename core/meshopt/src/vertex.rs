//! Mode 0, the attribute codec. Two steps per block of elements: the groups of 16 deltas of
//! each byte position, then each position's running sum written into the elements. Both have a
//! data-parallel form on [`V`] (16 bytes at once: wasm's simd128 in the web builds), used where
//! the input allows it, and a scalar one for the rest (a group whose bytes would run past the
//! data); the two give the same bytes (tested).

use super::Reader;
use super::lanes::V;

/// Mode 0: per block of elements, per byte of the element, groups of 16 deltas. Version 0
/// (header 0xa0, `EXT_meshopt_compression`) codes byte deltas only; version 1 (0xa1,
/// `KHR_meshopt_compression`) adds a control mode per byte position (which bit widths its
/// groups use, or all zero, or literal) and a channel mode per 4 bytes (byte deltas, 16-bit
/// deltas, or a rotated 32-bit XOR), read from the tail. `steps`: which steps run (the tests
/// run each; a build runs [`Steps::BEST`]).
pub(super) fn decode_vertices(
    out: &mut [u8],
    count: usize,
    stride: usize,
    src: &[u8],
    allow_v1: bool,
    steps: Steps,
) -> Result<(), String> {
    let lanes = steps != Steps::Scalar;
    if stride == 0 || !stride.is_multiple_of(4) || stride > 256 {
        return Err(format!("ATTRIBUTES needs a byteStride that is a multiple of 4 up to 256, not {stride}"));
    }
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
    // What the data-parallel group decoding may look at: the data and the tail after it (at
    // least 24 bytes), so that a group near the data's end needs no scalar fallback.
    let window = &src[1..];
    let block_max = ((8192 / stride) & !15).min(256);
    // The block's deltas, byte position by byte position, in groups of 16.
    // (As large as the first block: the largest; small views, such as a short clip's keys,
    // are common.)
    let mut deltas = vec![[0u8; 16]; stride * block_max.min(count).div_ceil(16)];
    let mut first = 0;
    while first < count {
        let block = block_max.min(count - first);
        let groups = block.div_ceil(16);
        let control = if v1 { reader.take(stride / 4)? } else { &[][..] };
        for byte in 0..stride {
            let stream = &mut deltas[byte * groups..(byte + 1) * groups];
            let mode = control.get(byte / 4).map_or(0, |c| (c >> ((byte % 4) * 2)) & 3);
            match (v1, mode) {
                (true, 2) => stream.fill([0; 16]),
                // Literal: the block's deltas as they are (not rounded up to whole groups).
                (true, 3) => {
                    let literal = reader.take(block)?;
                    for (group, bytes) in stream.iter_mut().zip(literal.chunks(16)) {
                        group[..bytes.len()].copy_from_slice(bytes);
                    }
                }
                _ => {
                    let header = reader.take(groups.div_ceil(4))?;
                    let widths = [0, 1, 2, 3].map(|bits| group_width(v1, mode, bits));
                    for (group, deltas) in stream.iter_mut().enumerate() {
                        let width = widths[usize::from((header[group / 4] >> ((group % 4) * 2)) & 3)];
                        if !(lanes && group_lanes(&mut reader, window, width, deltas)) {
                            decode_group(&mut reader, width, deltas)?;
                        }
                    }
                }
            }
        }
        // Each channel's running value, byte position by byte position (a prefix sum per
        // position, written straight into the elements).
        let elements = &mut out[first * stride..(first + block) * stride];
        let row = |k: usize| &deltas[k * groups..(k + 1) * groups];
        let rows_of = |at: usize| -> [&[[u8; 16]]; 4] { std::array::from_fn(|k| row(at + k)) };
        let kind_of = |channel: usize| Channel::of(channels.get(channel).copied().unwrap_or(0));
        let value_of = |last: &[u8; 256], at: usize| [last[at], last[at + 1], last[at + 2], last[at + 3]];
        // Two channels an element (stride 8): both summed at once and written as whole elements.
        let paired = (steps == Steps::Paired && stride == 8).then(|| {
            let mut values = [value_of(&last, 0), value_of(&last, 4)];
            let done = sums_pair([rows_of(0), rows_of(4)], [kind_of(0), kind_of(1)], block, &mut values, elements);
            (done, values)
        });
        for channel in 0..stride / 4 {
            let at = channel * 4;
            let rows = rows_of(at);
            let kind = kind_of(channel);
            let mut value = value_of(&last, at);
            let done = match paired {
                Some((done, values)) => {
                    value = values[channel & 1];
                    done
                }
                None if lanes => sums_lanes(rows, kind, stride, at, block, &mut value, elements),
                None => 0,
            };
            let delta = |i: usize, k: usize| rows[k].as_flattened().get(i).copied().unwrap_or(0);
            for (i, element) in elements.chunks_exact_mut(stride).enumerate().skip(done) {
                match kind {
                    Channel::Bytes => {
                        for (k, v) in value.iter_mut().enumerate() {
                            *v = v.wrapping_add(super::unzigzag8(delta(i, k)));
                        }
                    }
                    Channel::Shorts => {
                        for half in [0, 2] {
                            let d = u16::from_le_bytes([delta(i, half), delta(i, half + 1)]);
                            let v = u16::from_le_bytes([value[half], value[half + 1]]);
                            let v = v.wrapping_add(if d & 1 != 0 { !(d >> 1) } else { d >> 1 });
                            value[half..half + 2].copy_from_slice(&v.to_le_bytes());
                        }
                    }
                    Channel::Xor(rotate) => {
                        let d = u32::from_le_bytes([delta(i, 0), delta(i, 1), delta(i, 2), delta(i, 3)]);
                        value = (u32::from_le_bytes(value) ^ d.rotate_right(rotate)).to_le_bytes();
                    }
                }
                element[at..at + 4].copy_from_slice(&value);
            }
            last[at..at + 4].copy_from_slice(&value);
        }
        first += block;
    }
    if !reader.finished() {
        return Err("bytes are left over after the ATTRIBUTES data".to_owned());
    }
    Ok(())
}

/// Which steps [`decode_vertices`] runs; all three give the same bytes (tested).
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub(super) enum Steps {
    /// Byte by byte, the reference the others are tested against.
    Scalar,
    /// 16 bytes at once through [`V`].
    Lanes,
    /// As `Lanes`, with 8-byte elements' two channels summed and stored together
    /// ([`sums_pair`]): faster with wasm's `v128`, ~10 % slower with the plain array that `V`
    /// is natively.
    Paired,
}

impl Steps {
    /// The fastest steps of this build.
    pub(super) const BEST: Self =
        if cfg!(all(target_arch = "wasm32", target_feature = "simd128")) { Self::Paired } else { Self::Lanes };
}

/// The bit width of a group's deltas from its 2-bit header entry `bits`: version 0 has 0, 2, 4
/// and 8; version 1's control mode 0 has 0, 1, 2 and 4, mode 1 has 1, 2, 4 and 8.
fn group_width(v1: bool, mode: u8, bits: u8) -> u32 {
    match (v1, mode, bits) {
        (false, _, 0) | (true, 0, 0) => 0,
        (true, 0, 1) | (true, _, 0) => 1,
        (false, _, 1) | (true, 0, 2) | (true, _, 1) => 2,
        (false, _, 2) | (true, 0, 3) | (true, _, 2) => 4,
        _ => 8,
    }
}

/// One group of 16 zigzag deltas of `width` bits (0: all zero; 8: whole bytes); a delta with
/// every bit set (the sentinel) is a whole byte that follows the packed ones. 1-bit deltas are
/// packed from the lowest bit, 2- and 4-bit ones from the highest.
pub(super) fn decode_group(reader: &mut Reader<'_>, width: u32, deltas: &mut [u8; 16]) -> Result<(), String> {
    match width {
        0 => *deltas = [0; 16],
        1 => unpack::<1>(reader, deltas)?,
        2 => unpack::<2>(reader, deltas)?,
        4 => unpack::<4>(reader, deltas)?,
        _ => deltas.copy_from_slice(reader.take(16)?),
    }
    Ok(())
}

/// [`decode_group`] for `W` = 1, 2 or 4 bits.
fn unpack<const W: u32>(reader: &mut Reader<'_>, deltas: &mut [u8; 16]) -> Result<(), String> {
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

/// For each mask of 8 lanes, each set lane's rank among the set lanes, a byte per lane.
const RANKS: [u64; 256] = {
    let mut table = [0u64; 256];
    let mut mask = 0;
    while mask < 256 {
        let (mut row, mut rank, mut lane) = (0u64, 0u64, 0);
        while lane < 8 {
            if mask >> lane & 1 != 0 {
                row |= rank << (8 * lane);
                rank += 1;
            }
            lane += 1;
        }
        table[mask] = row;
        mask += 1;
    }
    table
};

/// [`decode_group`] on 16 lanes at once, reading `after` (the reader's data and what follows it)
/// from the reader's position: where 24 bytes are there (the packed deltas and up to 16 whole
/// ones), and the group's bytes end within the reader's data. False (nothing read) otherwise:
/// the scalar path then reads the group or says where the data ends.
#[inline(always)]
fn group_lanes(reader: &mut Reader<'_>, after: &[u8], width: u32, deltas: &mut [u8; 16]) -> bool {
    let Some(window) = after.get(reader.at..reader.at + 24) else { return false };
    let end = reader.data.len();
    let Some(head) = window.first_chunk::<16>() else { return false };
    let head = V::load(head);
    let (selected, sentinel, packed) = match width {
        0 => {
            *deltas = [0; 16];
            return true;
        }
        // Two bytes, lowest bit first: each byte in eight lanes, each lane testing its bit.
        1 => {
            let bits = V::from_u64(0x8040_2010_0804_0201, 0x8040_2010_0804_0201);
            let spread = head.swizzle(V::from_u64(0, 0x0101_0101_0101_0101));
            (spread.and(bits).eq8(bits).and(V::splat(1)), 1, 2)
        }
        // Four bytes, highest pair first: interleaving each byte with itself shifted right by
        // 4 (16-bit shifts: the bits from the next byte land above the ones kept), then by 2.
        2 => {
            let pairs = V::unpack_lo8(head.shr16::<4>(), head);
            (V::unpack_lo8(pairs.shr16::<2>(), pairs).and(V::splat(3)), 3, 4)
        }
        4 => (V::unpack_lo8(head.shr16::<4>(), head).and(V::splat(15)), 15, 8),
        _ => {
            if reader.at + 16 > end {
                return false;
            }
            head.store(deltas);
            reader.at += 16;
            return true;
        }
    };
    let escaped = selected.eq8(V::splat(sentinel));
    let mask = escaped.bitmask();
    if mask == 0 {
        if reader.at + packed > end {
            return false;
        }
        selected.store(deltas);
        reader.at += packed;
        return true;
    }
    // The whole bytes follow the packed ones, in lane order: lane i takes the one whose index
    // is the number of escaped lanes before it.
    let (low, high) = (usize::from(mask as u8), usize::from((mask >> 8) as u8));
    let before_high = u64::from((mask as u8).count_ones()) * 0x0101_0101_0101_0101;
    let index = V::from_u64(RANKS[low], RANKS[high] + before_high);
    let Some(whole) = window.get(packed..packed + 16).and_then(|s| s.first_chunk::<16>()) else { return false };
    let whole = V::load(whole);
    let used = packed + mask.count_ones() as usize;
    if reader.at + used > end {
        return false;
    }
    V::select(whole.swizzle(index), selected, escaped).store(deltas);
    reader.at += used;
    true
}

/// How a 4-byte channel's deltas are coded (version 1's channel mode; version 0 has bytes only).
#[derive(Clone, Copy, PartialEq, Eq)]
enum Channel {
    /// Four zigzag byte deltas, added.
    Bytes,
    /// Two zigzag 16-bit deltas, added.
    Shorts,
    /// One 32-bit value rotated right by the count and XORed in.
    Xor(u32),
}

impl Channel {
    /// The channel mode byte (checked: 0, 1, or 2 with a rotation in its high nibble).
    fn of(mode: u8) -> Self {
        match mode & 15 {
            1 => Self::Shorts,
            2 => Self::Xor(u32::from(mode >> 4)),
            _ => Self::Bytes,
        }
    }
}

/// The 4-byte channel at `at` of 16 elements at once: the four byte rows transposed into
/// elements (a 32-bit lane each), the deltas decoded, and accumulated along the elements (two
/// shifted steps within the four lanes, then the running value). A last partial group is
/// decoded whole (its rows are padded to 16) and only its elements are written. Returns how
/// many elements it wrote (all of the block's unless a row is short, which the caller's
/// sizes rule out); `value` is the running value after them.
#[inline(always)]
fn sums_lanes(
    rows: [&[[u8; 16]]; 4],
    kind: Channel,
    stride: usize,
    at: usize,
    block: usize,
    value: &mut [u8; 4],
    elements: &mut [u8],
) -> usize {
    let mut running = V::splat32(u32::from_le_bytes(*value));
    let mut done = 0;
    // Stops where the rows or the elements end (neither does for a well-formed block): the
    // scalar steps go on from `done` and the running value.
    'groups: for group in 0..block.div_ceil(16) {
        let Some(quads) = quads(rows, group) else { break };
        for quad in quads {
            if done >= block {
                break 'groups;
            }
            let sums = accumulate(quad, kind, running);
            let first = done * stride;
            let n = (block - done).min(4);
            if stride == 4 && n == 4 {
                let Some(out) = elements.get_mut(first..first + 16).and_then(|s| s.first_chunk_mut::<16>()) else {
                    break 'groups;
                };
                sums.store(out);
                running = sums.splat_last32();
            } else {
                let lanes = sums.lanes32();
                for (e, v) in lanes.into_iter().take(n).enumerate() {
                    let Some(out) = elements.get_mut(first + e * stride + at..first + e * stride + at + 4) else {
                        break 'groups;
                    };
                    out.copy_from_slice(&v.to_le_bytes());
                }
                running = if n == 4 { sums.splat_last32() } else { V::splat32(lanes[n - 1]) };
            }
            done += n;
        }
    }
    *value = running.lanes32()[0].to_le_bytes();
    done
}

/// Group `group` of a channel's four byte rows transposed into elements: four vectors of four
/// elements, an element a 32-bit lane. `None` where a row is short.
#[inline(always)]
fn quads(rows: [&[[u8; 16]]; 4], group: usize) -> Option<[V; 4]> {
    let (Some(r0), Some(r1), Some(r2), Some(r3)) =
        (rows[0].get(group), rows[1].get(group), rows[2].get(group), rows[3].get(group))
    else {
        return None;
    };
    let (r0, r1, r2, r3) = (V::load(r0), V::load(r1), V::load(r2), V::load(r3));
    let (t0, t1) = (V::unpack_lo8(r0, r1), V::unpack_hi8(r0, r1));
    let (t2, t3) = (V::unpack_lo8(r2, r3), V::unpack_hi8(r2, r3));
    Some([V::unpack_lo16(t0, t2), V::unpack_hi16(t0, t2), V::unpack_lo16(t1, t3), V::unpack_hi16(t1, t3)])
}

/// Four elements' deltas of a channel (`quad`, an element a 32-bit lane) decoded as `kind` and
/// accumulated along the elements onto `running` (the value before them, in every lane): two
/// shifted steps within the four lanes, then the running value.
#[inline(always)]
fn accumulate(quad: V, kind: Channel, running: V) -> V {
    match kind {
        // Unzigzag: v >> 1, all bits flipped where v is odd; then sums lane by lane.
        Channel::Bytes => {
            let one = V::splat(1);
            let d = quad.shr8::<1>().xor(quad.and(one).eq8(one));
            let d = d.add8(d.shift_up4());
            d.add8(d.shift_up8()).add8(running)
        }
        Channel::Shorts => {
            let one = V::splat16(1);
            let d = quad.shr16::<1>().xor(quad.and(one).eq16(one));
            let d = d.add16(d.shift_up4());
            d.add16(d.shift_up8()).add16(running)
        }
        Channel::Xor(rotate) => {
            let d = quad.rotr32(rotate);
            let d = d.xor(d.shift_up4());
            d.xor(d.shift_up8()).xor(running)
        }
    }
}

/// [`sums_lanes`] of both channels of 8-byte elements at once: four elements' two channels
/// interleaved into 32 bytes and stored whole. Stops before a last partial four (the scalar
/// steps finish it from the returned count and `values`, each channel's running value).
#[inline(always)]
fn sums_pair(
    rows: [[&[[u8; 16]]; 4]; 2],
    kinds: [Channel; 2],
    block: usize,
    values: &mut [[u8; 4]; 2],
    elements: &mut [u8],
) -> usize {
    let mut running = values.map(|v| V::splat32(u32::from_le_bytes(v)));
    let mut done = 0;
    'groups: for group in 0..block.div_ceil(16) {
        let (Some(a), Some(b)) = (quads(rows[0], group), quads(rows[1], group)) else { break };
        for (qa, qb) in a.into_iter().zip(b) {
            let Some(out) = elements.get_mut(done * 8..done * 8 + 32) else { break 'groups };
            let [low, high] = out.as_chunks_mut::<16>().0 else { break 'groups };
            let (sa, sb) = (accumulate(qa, kinds[0], running[0]), accumulate(qb, kinds[1], running[1]));
            V::unpack_lo32(sa, sb).store(low);
            V::unpack_hi32(sa, sb).store(high);
            running = [sa.splat_last32(), sb.splat_last32()];
            done += 4;
        }
    }
    *values = running.map(|r| r.lanes32()[0].to_le_bytes());
    done
}

#[cfg(test)]
mod tests {
    use super::{Steps, decode_vertices};

    /// Every way (byte by byte, 16 lanes at once, and with paired channels): the same result
    /// and the same bytes, whether it decodes or not.
    fn both(src: &[u8], count: usize, stride: usize, khr: bool) -> Result<Vec<u8>, String> {
        let run = |steps| {
            let mut out = vec![0u8; count * stride];
            (decode_vertices(&mut out, count, stride, src, khr, steps), out)
        };
        let (scalar, bytes) = run(Steps::Scalar);
        for steps in [Steps::Lanes, Steps::Paired] {
            let (got, got_bytes) = run(steps);
            assert_eq!(got, scalar, "count {count}, stride {stride}, {steps:?}");
            assert!(got_bytes == bytes, "count {count}, stride {stride}, {steps:?}: the bytes differ");
        }
        scalar.map(|()| bytes)
    }

    /// Every ATTRIBUTES view of gltfpack's meshopt copies of Fox (EXT, version 0; KHR, version 1).
    #[cfg_attr(not(target_arch = "wasm32"), test)]
    #[cfg_attr(target_arch = "wasm32", wasm_bindgen_test::wasm_bindgen_test)]
    fn both_ways_decode_every_attribute_view_of_the_packed_foxes_alike() {
        let files: [&[u8]; 2] = [
            include_bytes!("../../../tests/optimized/Fox.gltfpack-cc.glb"),
            include_bytes!("../../../tests/optimized/Fox.gltfpack-khr.glb"),
        ];
        for (file, khr) in files.into_iter().zip([false, true]) {
            let word = |at: usize| u32::from_le_bytes([file[at], file[at + 1], file[at + 2], file[at + 3]]) as usize;
            let json: serde_json::Value = serde_json::from_slice(&file[20..20 + word(12)]).expect("JSON");
            let bin = &file[20 + word(12) + 8..];
            let mut views = 0;
            for view in json["bufferViews"].as_array().expect("views") {
                let x = &view["extensions"][if khr { "KHR_meshopt_compression" } else { "EXT_meshopt_compression" }];
                if x["mode"] != "ATTRIBUTES" {
                    continue;
                }
                let field = |k: &str| x[k].as_u64().unwrap_or(0) as usize;
                let src = &bin[field("byteOffset")..field("byteOffset") + field("byteLength")];
                both(src, field("count"), field("byteStride"), khr).expect("decodes");
                views += 1;
            }
            assert!(views >= 4, "{views} attribute views");
        }
    }

    /// A little xorshift generator.
    struct Random(u64);

    impl Random {
        fn next(&mut self) -> u64 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            self.0
        }

        fn below(&mut self, n: u64) -> u64 {
            self.next() % n
        }
    }

    /// A well-formed stream of random deltas: random group widths and control modes, sentinels
    /// and their whole bytes, and (version 1) random channel modes.
    fn random_stream(r: &mut Random, count: usize, stride: usize, v1: bool) -> Vec<u8> {
        let mut out = vec![if v1 { 0xa1 } else { 0xa0 }];
        let block_max = ((8192 / stride) & !15).min(256);
        let mut first = 0;
        while first < count {
            let block = block_max.min(count - first);
            let groups = block.div_ceil(16);
            let controls: Vec<u8> = (0..stride / 4).map(|_| r.next() as u8).collect();
            if v1 {
                out.extend(&controls);
            }
            for byte in 0..stride {
                let mode = if v1 { (controls[byte / 4] >> ((byte % 4) * 2)) & 3 } else { 0 };
                match mode {
                    2 => continue,
                    3 => {
                        out.extend((0..block).map(|_| r.next() as u8));
                        continue;
                    }
                    _ => {}
                }
                let bits: Vec<u8> = (0..groups).map(|_| r.below(4) as u8).collect();
                for chunk in bits.chunks(4) {
                    out.push(chunk.iter().enumerate().fold(0, |h, (i, &b)| h | b << (2 * i)));
                }
                for &b in &bits {
                    match super::group_width(v1, mode, b) {
                        0 => {}
                        8 => out.extend((0..16).map(|_| r.next() as u8)),
                        w => {
                            let w = w as usize;
                            let per_byte = 8 / w;
                            let sentinel = (1u8 << w) - 1;
                            // Sentinels often (one lane in four), to exercise the whole bytes.
                            let values: Vec<u8> = (0..16)
                                .map(
                                    |_| if r.below(4) == 0 { sentinel } else { r.below(u64::from(sentinel) + 1) as u8 },
                                )
                                .collect();
                            for chunk in values.chunks(per_byte) {
                                out.push(chunk.iter().enumerate().fold(0, |p, (i, &v)| {
                                    let shift = if w == 1 { i } else { 8 - w * (i + 1) };
                                    p | v << shift
                                }));
                            }
                            out.extend(values.iter().filter(|&&v| v == sentinel).map(|_| r.next() as u8));
                        }
                    }
                }
            }
            first += block;
        }
        // The tail: padding, the baseline element, (version 1) a valid channel mode per 4 bytes.
        let tail_block = if v1 { stride + stride / 4 } else { stride };
        let tail = tail_block.max(if v1 { 24 } else { 32 });
        out.extend(std::iter::repeat_n(0, tail - tail_block));
        out.extend((0..stride).map(|_| r.next() as u8));
        if v1 {
            out.extend((0..stride / 4).map(|_| match r.below(3) {
                0 => 0,
                1 => 1,
                _ => 2 | (r.below(16) as u8) << 4,
            }));
        }
        out
    }

    #[cfg_attr(not(target_arch = "wasm32"), test)]
    #[cfg_attr(target_arch = "wasm32", wasm_bindgen_test::wasm_bindgen_test)]
    fn both_ways_decode_random_streams_alike_and_fail_alike() {
        let mut r = Random(0x9e37_79b9_7f4a_7c15);
        for round in 0..400 {
            let stride = 4 * (1 + r.below(if round % 10 == 0 { 64 } else { 6 }) as usize);
            let count = 1 + r.below(if round % 7 == 0 { 1200 } else { 90 }) as usize;
            let v1 = round % 2 == 1;
            let src = random_stream(&mut r, count, stride, v1);
            both(&src, count, stride, v1).unwrap_or_else(|e| panic!("round {round}: {e}"));
            // Cut short or with a byte flipped: whatever the result, the same both ways.
            let cut = r.below(src.len() as u64) as usize;
            let _ = both(&src[..cut], count, stride, v1);
            let mut flipped = src.clone();
            let at = 1 + r.below(src.len() as u64 - 1) as usize;
            flipped[at] ^= 1 << r.below(8);
            let _ = both(&flipped, count, stride, v1);
        }
    }
}

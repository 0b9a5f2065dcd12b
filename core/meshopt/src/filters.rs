//! The extensions' Appendix B: filters applied to the decoded elements. OCTAHEDRAL,
//! QUATERNION and EXPONENTIAL run four elements (or components) at a time in glam's `Vec4`
//! (simd128 in the web builds, SSE natively); a last partial chunk is padded, run the same way
//! and copied back, so every element goes through the same arithmetic. COLOR (KHR only, rare)
//! is per element.

use super::Filter;
use super::lanes::{V, sqrt4};
use glam::Vec4;

/// Applies `filter` to `out`, elements of `stride` bytes (checked by `super::check`).
pub(super) fn apply(filter: Filter, stride: usize, out: &mut [u8]) {
    match filter {
        Filter::None => {}
        Filter::Octahedral if stride == 4 => by_four::<16>(out, octahedral8),
        Filter::Octahedral => by_four::<32>(out, octahedral16),
        Filter::Quaternion => by_four::<32>(out, quaternion),
        Filter::Exponential => by_four::<16>(out, exponential),
        Filter::Color if stride == 4 => out.chunks_exact_mut(4).for_each(color8),
        Filter::Color => out.chunks_exact_mut(8).for_each(color16),
    }
}

/// Runs `f` on each chunk of `N` bytes (four elements or components), the last one padded with
/// zeros.
fn by_four<const N: usize>(out: &mut [u8], f: impl Fn(&mut [u8; N])) {
    let (chunks, rest) = out.as_chunks_mut::<N>();
    chunks.iter_mut().for_each(&f);
    if !rest.is_empty() {
        let mut padded = [0u8; N];
        padded[..rest.len()].copy_from_slice(rest);
        f(&mut padded);
        let n = rest.len();
        rest.copy_from_slice(&padded[..n]);
    }
}

/// Rounded to the nearest whole number (ties to even), in the low bits of each 32-bit lane:
/// adding 1.5 · 2²³ leaves the sum's mantissa holding `v` in two's complement (exact for
/// |v| < 2²¹: every valid filtered value, at most 32767 in magnitude; anything else is garbage
/// in, garbage out, and never undefined). The filters keep the low 8 or 16 bits; meshoptimizer's
/// SIMD filters round the same way.
#[inline(always)]
fn snap(v: Vec4) -> V {
    V::f32_bits(v + Vec4::splat(12_582_912.0))
}

/// The signed byte of each 32-bit lane that a left shift by `UP` brings to the top, as floats.
#[inline(always)]
fn byte_of<const UP: u32>(v: V) -> Vec4 {
    v.shl32::<UP>().sar32::<24>().to_f32()
}

/// Four elements of four 16-bit components (32 bytes) as their (x | y << 16) and (z | w << 16)
/// words.
#[inline(always)]
fn pairs(b: &[u8; 32]) -> (V, V) {
    let (a, c) = match b.as_chunks::<16>().0 {
        [a, c] => (V::load(a), V::load(c)),
        _ => (V::splat(0), V::splat(0)),
    };
    (V::even32(a, c), V::odd32(a, c))
}

#[inline(always)]
fn unpairs(b: &mut [u8; 32], xy: V, zw: V) {
    let (first, second) = (V::unpack_lo32(xy, zw), V::unpack_hi32(xy, zw));
    if let Some(a) = b.first_chunk_mut::<16>() {
        first.store(a);
    }
    if let Some(c) = b.last_chunk_mut::<16>() {
        second.store(c);
    }
}

/// The low signed 16 bits of each 32-bit lane, as floats.
#[inline(always)]
fn low16(v: V) -> Vec4 {
    v.shl32::<16>().sar32::<16>().to_f32()
}

/// Filter 1 on four elements of four signed bytes: octahedral x, y, the K-bit 1.0, and a byte
/// passed through.
fn octahedral8(b: &mut [u8; 16]) {
    let v = V::load(b);
    let [x, y, z] = octahedral(byte_of::<24>(v), byte_of::<16>(v), byte_of::<8>(v), 127.0);
    let byte = |c: Vec4| snap(c).and(V::splat32(0xff));
    let out = byte(x).or(byte(y).shl32::<8>()).or(byte(z).shl32::<16>()).or(v.and(V::splat32(0xff00_0000)));
    out.store(b);
}

/// Filter 1 on four elements of four signed 16-bit components.
fn octahedral16(b: &mut [u8; 32]) {
    let (xy, zw) = pairs(b);
    let [x, y, z] = octahedral(low16(xy), xy.sar32::<16>().to_f32(), low16(zw), 32767.0);
    let half = |c: Vec4| snap(c).and(V::splat32(0xffff));
    unpairs(b, half(x).or(half(y).shl32::<16>()), half(z).or(zw.and(V::splat32(0xffff_0000))));
}

/// The unit vectors of octahedral coordinates `x`, `y` in units of `one`, scaled to `max`: z
/// from the other two (folded over where it is negative), then the vector scaled to length
/// `max` (meshoptimizer's arithmetic: one division per vector).
#[inline(always)]
fn octahedral(x: Vec4, y: Vec4, one: Vec4, max: f32) -> [Vec4; 3] {
    let z = one - x.abs() - y.abs();
    let t = z.min(Vec4::ZERO);
    let (x, y) = (x - t.copysign(x), y - t.copysign(y));
    let s = Vec4::splat(max) / sqrt4(x * x + y * y + z * z);
    [x * s, y * s, z * s]
}

/// Filter 2 on four elements: three components scaled by √2 and the index of the omitted
/// largest one.
fn quaternion(b: &mut [u8; 32]) {
    let (xy, zw) = pairs(b);
    let w = zw.sar32::<16>();
    // In units of the stored 1.0 (`one`, K bits all set), as meshoptimizer's: with x, y, z
    // scaled by 1 / √2, w = √(2 one² − x² − y² − z²) in the same units, exact for whole numbers
    // of up to 12 bits (1 − x² − y² − z² after scaling loses the small ones).
    let one = w.or(V::splat32(3)).to_f32();
    let (x, y, z) = (low16(xy), xy.sar32::<16>().to_f32(), low16(zw));
    let ww = (one * one + one * one) - (x * x + (y * y + z * z));
    let ww = sqrt4(ww.max(Vec4::ZERO));
    let scale = Vec4::splat(32767.0 * std::f32::consts::FRAC_1_SQRT_2) / one;
    let half = |c: Vec4| snap(c * scale).and(V::splat32(0xffff));
    let (xy, zw) = (half(x).or(half(y).shl32::<16>()), half(z).or(half(ww).shl32::<16>()));
    // Each element's x, y, z, w as the 16-bit lanes 0..3 of a 64-bit lane.
    let [q0, q1] = V::unpack_lo32(xy, zw).lanes64();
    let [q2, q3] = V::unpack_hi32(xy, zw).lanes64();
    let max = w.and(V::splat32(3)).lanes32();
    for (i, (element, q)) in b.chunks_exact_mut(8).zip([q0, q1, q2, q3]).enumerate() {
        // Rotated so that w lands in lane `max` and x, y, z follow it.
        element.copy_from_slice(&q.rotate_left((max[i] + 1) * 16).to_le_bytes());
    }
}

/// Filter 3 on four components: a signed 8-bit exponent over a signed 24-bit mantissa, to a
/// float.
fn exponential(b: &mut [u8; 16]) {
    let v = V::load(b);
    let exponent = v.sar32::<24>();
    let mantissa = v.shl32::<8>().sar32::<8>();
    // 2^exponent from the bits of two powers of two (powi is a libm call on x86-64): exact, as
    // the exponent (-128..=127) splits into two normal ones.
    let high = exponent.max32(V::splat32(-126i32 as u32));
    let power = |e: V| e.add32(V::splat32(127)).shl32::<23>().bits_to_f32();
    let scale = power(high) * power(exponent.sub32(high));
    V::f32_bits(scale * mantissa.to_f32()).store(b);
}

/// Filter 4 on four 8-bit components: Y, Co, Cg and an alpha whose highest set bit gives K.
fn color8(e: &mut [u8]) {
    let rgba = ycocg(i32::from(e[0]), i32::from(e[1] as i8), i32::from(e[2] as i8), u32::from(e[3]), 255.0);
    for (out, v) in e.iter_mut().zip(rgba) {
        *out = round_one(v).clamp(0, 255) as u8;
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
        e[2 * i..2 * i + 2].copy_from_slice(&(round_one(v).clamp(0, 65535) as u16).to_le_bytes());
    }
}

/// `x` rounded half away from zero (saturating, NaN → 0), as `f32::round` but without its libm
/// call where the target has no rounding instruction (x86-64's baseline): the `as` cast truncates.
fn round_one(x: f32) -> i32 {
    (x + 0.5f32.copysign(x)) as i32
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

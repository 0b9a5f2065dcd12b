//! Sixteen bytes as one value, for the attribute codec's data-parallel steps: wasm32's `v128`
//! where the build has simd128 (the web builds), a plain array elsewhere. Both run the same
//! algorithms (`super::vertex`), so native tests and the fuzzer check the wasm build's logic,
//! and `vertex`'s tests compare it with the scalar decoder byte for byte.

#[cfg(all(target_arch = "wasm32", target_feature = "simd128"))]
pub(super) use wasm::V;

#[cfg(not(all(target_arch = "wasm32", target_feature = "simd128")))]
pub(super) use array::V;

/// The square root of each lane, correctly rounded: one `f32x4.sqrt` as wasm with SIMD, where
/// glam's `Vec4::sqrt` takes the lanes one at a time; glam's elsewhere. The filters' roots, and
/// kloub-core's four-lane ones.
#[inline(always)]
pub fn sqrt4(v: glam::Vec4) -> glam::Vec4 {
    #[cfg(all(target_arch = "wasm32", target_feature = "simd128"))]
    let root = glam::Vec4::from(core::arch::wasm32::f32x4_sqrt(v.into()));
    #[cfg(not(all(target_arch = "wasm32", target_feature = "simd128")))]
    let root = v.sqrt();
    root
}

#[cfg(all(target_arch = "wasm32", target_feature = "simd128"))]
#[allow(unsafe_code)]
mod wasm {
    use core::arch::wasm32 as w;

    /// Sixteen byte lanes in a `v128`.
    #[derive(Clone, Copy)]
    pub(in super::super) struct V(w::v128);

    impl V {
        #[inline(always)]
        pub(in super::super) fn load(bytes: &[u8; 16]) -> Self {
            // SAFETY: the reference is 16 readable bytes; wasm's loads need no alignment.
            Self(unsafe { w::v128_load(bytes.as_ptr().cast()) })
        }

        #[inline(always)]
        pub(in super::super) fn store(self, bytes: &mut [u8; 16]) {
            // SAFETY: the reference is 16 writable bytes; wasm's stores need no alignment.
            unsafe { w::v128_store(bytes.as_mut_ptr().cast(), self.0) }
        }

        #[inline(always)]
        pub(in super::super) fn from_u64(low: u64, high: u64) -> Self {
            Self(w::u64x2(low, high))
        }

        #[inline(always)]
        pub(in super::super) fn splat(b: u8) -> Self {
            Self(w::u8x16_splat(b))
        }

        #[inline(always)]
        pub(in super::super) fn splat32(v: u32) -> Self {
            Self(w::u32x4_splat(v))
        }

        #[inline(always)]
        pub(in super::super) fn and(self, o: Self) -> Self {
            Self(w::v128_and(self.0, o.0))
        }

        #[inline(always)]
        pub(in super::super) fn xor(self, o: Self) -> Self {
            Self(w::v128_xor(self.0, o.0))
        }

        #[inline(always)]
        pub(in super::super) fn add8(self, o: Self) -> Self {
            Self(w::u8x16_add(self.0, o.0))
        }

        #[inline(always)]
        pub(in super::super) fn eq8(self, o: Self) -> Self {
            Self(w::u8x16_eq(self.0, o.0))
        }

        #[inline(always)]
        pub(in super::super) fn shr8<const N: u32>(self) -> Self {
            Self(w::u8x16_shr(self.0, N))
        }

        #[inline(always)]
        pub(in super::super) fn shr16<const N: u32>(self) -> Self {
            Self(w::u16x8_shr(self.0, N))
        }

        #[inline(always)]
        pub(in super::super) fn splat16(v: u16) -> Self {
            Self(w::u16x8_splat(v))
        }

        #[inline(always)]
        pub(in super::super) fn add16(self, o: Self) -> Self {
            Self(w::u16x8_add(self.0, o.0))
        }

        #[inline(always)]
        pub(in super::super) fn eq16(self, o: Self) -> Self {
            Self(w::u16x8_eq(self.0, o.0))
        }

        /// Each 32-bit lane rotated right by `n` (below 32).
        #[inline(always)]
        pub(in super::super) fn rotr32(self, n: u32) -> Self {
            Self(w::v128_or(w::u32x4_shr(self.0, n), w::u32x4_shl(self.0, (32 - n) & 31)))
        }

        #[inline(always)]
        pub(in super::super) fn bitmask(self) -> u16 {
            w::u8x16_bitmask(self.0)
        }

        /// Lane `i` of the result is lane `index[i]` of `self` (indices are below 16 here).
        #[inline(always)]
        pub(in super::super) fn swizzle(self, index: Self) -> Self {
            Self(w::u8x16_swizzle(self.0, index.0))
        }

        /// `a` where `mask` is set, `b` elsewhere.
        #[inline(always)]
        pub(in super::super) fn select(a: Self, b: Self, mask: Self) -> Self {
            Self(w::v128_bitselect(a.0, b.0, mask.0))
        }

        #[inline(always)]
        pub(in super::super) fn unpack_lo8(a: Self, b: Self) -> Self {
            Self(w::u8x16_shuffle::<0, 16, 1, 17, 2, 18, 3, 19, 4, 20, 5, 21, 6, 22, 7, 23>(a.0, b.0))
        }

        #[inline(always)]
        pub(in super::super) fn unpack_hi8(a: Self, b: Self) -> Self {
            Self(w::u8x16_shuffle::<8, 24, 9, 25, 10, 26, 11, 27, 12, 28, 13, 29, 14, 30, 15, 31>(a.0, b.0))
        }

        #[inline(always)]
        pub(in super::super) fn unpack_lo16(a: Self, b: Self) -> Self {
            Self(w::u16x8_shuffle::<0, 8, 1, 9, 2, 10, 3, 11>(a.0, b.0))
        }

        #[inline(always)]
        pub(in super::super) fn unpack_hi16(a: Self, b: Self) -> Self {
            Self(w::u16x8_shuffle::<4, 12, 5, 13, 6, 14, 7, 15>(a.0, b.0))
        }

        /// The lanes moved up by 4 (one 32-bit lane), zeros in.
        #[inline(always)]
        pub(in super::super) fn shift_up4(self) -> Self {
            Self(w::u32x4_shuffle::<4, 0, 1, 2>(self.0, w::u32x4_splat(0)))
        }

        /// The lanes moved up by 8 (two 32-bit lanes), zeros in.
        #[inline(always)]
        pub(in super::super) fn shift_up8(self) -> Self {
            Self(w::u64x2_shuffle::<2, 0>(self.0, w::u64x2_splat(0)))
        }

        /// The last 32-bit lane in all four.
        #[inline(always)]
        pub(in super::super) fn splat_last32(self) -> Self {
            Self(w::u32x4_shuffle::<3, 3, 3, 3>(self.0, self.0))
        }

        /// [a0, a2, b0, b2] of 32-bit lanes.
        #[inline(always)]
        pub(in super::super) fn even32(a: Self, b: Self) -> Self {
            Self(w::u32x4_shuffle::<0, 2, 4, 6>(a.0, b.0))
        }

        /// [a1, a3, b1, b3] of 32-bit lanes.
        #[inline(always)]
        pub(in super::super) fn odd32(a: Self, b: Self) -> Self {
            Self(w::u32x4_shuffle::<1, 3, 5, 7>(a.0, b.0))
        }

        /// [a0, b0, a1, b1] of 32-bit lanes.
        #[inline(always)]
        pub(in super::super) fn unpack_lo32(a: Self, b: Self) -> Self {
            Self(w::u32x4_shuffle::<0, 4, 1, 5>(a.0, b.0))
        }

        /// [a2, b2, a3, b3] of 32-bit lanes.
        #[inline(always)]
        pub(in super::super) fn unpack_hi32(a: Self, b: Self) -> Self {
            Self(w::u32x4_shuffle::<2, 6, 3, 7>(a.0, b.0))
        }

        #[inline(always)]
        pub(in super::super) fn or(self, o: Self) -> Self {
            Self(w::v128_or(self.0, o.0))
        }

        #[inline(always)]
        pub(in super::super) fn shl32<const N: u32>(self) -> Self {
            Self(w::i32x4_shl(self.0, N))
        }

        /// Arithmetic (sign-filling) right shift of each 32-bit lane.
        #[inline(always)]
        pub(in super::super) fn sar32<const N: u32>(self) -> Self {
            Self(w::i32x4_shr(self.0, N))
        }

        #[inline(always)]
        pub(in super::super) fn add32(self, o: Self) -> Self {
            Self(w::i32x4_add(self.0, o.0))
        }

        #[inline(always)]
        pub(in super::super) fn max32(self, o: Self) -> Self {
            Self(w::i32x4_max(self.0, o.0))
        }

        #[inline(always)]
        pub(in super::super) fn sub32(self, o: Self) -> Self {
            Self(w::i32x4_sub(self.0, o.0))
        }

        /// The signed 32-bit lanes as floats.
        #[inline(always)]
        pub(in super::super) fn to_f32(self) -> glam::Vec4 {
            glam::Vec4::from(w::f32x4_convert_i32x4(self.0))
        }

        /// The lanes' bits as floats.
        #[inline(always)]
        pub(in super::super) fn bits_to_f32(self) -> glam::Vec4 {
            glam::Vec4::from(self.0)
        }

        /// Floats' bits as lanes.
        #[inline(always)]
        pub(in super::super) fn f32_bits(v: glam::Vec4) -> Self {
            Self(w::v128::from(v))
        }

        #[inline(always)]
        pub(in super::super) fn lanes32(self) -> [u32; 4] {
            [
                w::u32x4_extract_lane::<0>(self.0),
                w::u32x4_extract_lane::<1>(self.0),
                w::u32x4_extract_lane::<2>(self.0),
                w::u32x4_extract_lane::<3>(self.0),
            ]
        }

        /// The two 64-bit lanes.
        #[inline(always)]
        pub(in super::super) fn lanes64(self) -> [u64; 2] {
            [w::u64x2_extract_lane::<0>(self.0), w::u64x2_extract_lane::<1>(self.0)]
        }
    }
}

#[cfg(not(all(target_arch = "wasm32", target_feature = "simd128")))]
mod array {
    /// Sixteen byte lanes in an array.
    #[derive(Clone, Copy)]
    pub(in super::super) struct V([u8; 16]);

    fn map(a: [u8; 16], f: impl Fn(u8) -> u8) -> [u8; 16] {
        a.map(f)
    }

    fn zip(a: [u8; 16], b: [u8; 16], f: impl Fn(u8, u8) -> u8) -> [u8; 16] {
        std::array::from_fn(|i| f(a[i], b[i]))
    }

    impl V {
        #[inline(always)]
        pub(in super::super) fn load(bytes: &[u8; 16]) -> Self {
            Self(*bytes)
        }

        #[inline(always)]
        pub(in super::super) fn store(self, bytes: &mut [u8; 16]) {
            *bytes = self.0;
        }

        #[inline(always)]
        pub(in super::super) fn from_u64(low: u64, high: u64) -> Self {
            Self((u128::from(low) | u128::from(high) << 64).to_le_bytes())
        }

        #[inline(always)]
        pub(in super::super) fn splat(b: u8) -> Self {
            Self([b; 16])
        }

        #[inline(always)]
        pub(in super::super) fn splat32(v: u32) -> Self {
            let b = v.to_le_bytes();
            Self(std::array::from_fn(|i| b[i % 4]))
        }

        #[inline(always)]
        pub(in super::super) fn and(self, o: Self) -> Self {
            Self(zip(self.0, o.0, |a, b| a & b))
        }

        #[inline(always)]
        pub(in super::super) fn xor(self, o: Self) -> Self {
            Self(zip(self.0, o.0, |a, b| a ^ b))
        }

        #[inline(always)]
        pub(in super::super) fn add8(self, o: Self) -> Self {
            Self(zip(self.0, o.0, u8::wrapping_add))
        }

        #[inline(always)]
        pub(in super::super) fn eq8(self, o: Self) -> Self {
            Self(zip(self.0, o.0, |a, b| if a == b { 0xff } else { 0 }))
        }

        #[inline(always)]
        pub(in super::super) fn shr8<const N: u32>(self) -> Self {
            Self(map(self.0, |a| a >> N))
        }

        #[inline(always)]
        pub(in super::super) fn shr16<const N: u32>(self) -> Self {
            let mut out = [0u8; 16];
            for (o, i) in out.chunks_exact_mut(2).zip(self.0.chunks_exact(2)) {
                o.copy_from_slice(&(u16::from_le_bytes([i[0], i[1]]) >> N).to_le_bytes());
            }
            Self(out)
        }

        #[inline(always)]
        pub(in super::super) fn splat16(v: u16) -> Self {
            let b = v.to_le_bytes();
            Self(std::array::from_fn(|i| b[i % 2]))
        }

        fn map16(self, o: Self, f: impl Fn(u16, u16) -> u16) -> Self {
            let mut out = [0u8; 16];
            for ((r, a), b) in out.chunks_exact_mut(2).zip(self.0.chunks_exact(2)).zip(o.0.chunks_exact(2)) {
                r.copy_from_slice(&f(u16::from_le_bytes([a[0], a[1]]), u16::from_le_bytes([b[0], b[1]])).to_le_bytes());
            }
            Self(out)
        }

        #[inline(always)]
        pub(in super::super) fn add16(self, o: Self) -> Self {
            self.map16(o, u16::wrapping_add)
        }

        #[inline(always)]
        pub(in super::super) fn eq16(self, o: Self) -> Self {
            self.map16(o, |a, b| if a == b { 0xffff } else { 0 })
        }

        /// Each 32-bit lane rotated right by `n` (below 32).
        #[inline(always)]
        pub(in super::super) fn rotr32(self, n: u32) -> Self {
            let [a, b, c, d] = self.lanes32().map(|v| v.rotate_right(n).to_le_bytes());
            Self(std::array::from_fn(|i| [a, b, c, d][i / 4][i % 4]))
        }

        #[inline(always)]
        pub(in super::super) fn bitmask(self) -> u16 {
            self.0.iter().enumerate().fold(0, |m, (i, &b)| m | u16::from(b >> 7) << i)
        }

        /// Lane `i` of the result is lane `index[i]` of `self` (indices are below 16 here).
        #[inline(always)]
        pub(in super::super) fn swizzle(self, index: Self) -> Self {
            Self(index.0.map(|i| self.0.get(usize::from(i)).copied().unwrap_or(0)))
        }

        /// `a` where `mask` is set, `b` elsewhere.
        #[inline(always)]
        pub(in super::super) fn select(a: Self, b: Self, mask: Self) -> Self {
            Self(std::array::from_fn(|i| (a.0[i] & mask.0[i]) | (b.0[i] & !mask.0[i])))
        }

        #[inline(always)]
        pub(in super::super) fn unpack_lo8(a: Self, b: Self) -> Self {
            Self(std::array::from_fn(|i| if i % 2 == 0 { a.0[i / 2] } else { b.0[i / 2] }))
        }

        #[inline(always)]
        pub(in super::super) fn unpack_hi8(a: Self, b: Self) -> Self {
            Self(std::array::from_fn(|i| if i % 2 == 0 { a.0[8 + i / 2] } else { b.0[8 + i / 2] }))
        }

        #[inline(always)]
        pub(in super::super) fn unpack_lo16(a: Self, b: Self) -> Self {
            Self(std::array::from_fn(|i| {
                let (pair, byte) = (i / 2, i % 2);
                if pair % 2 == 0 { a.0[pair + byte] } else { b.0[pair - 1 + byte] }
            }))
        }

        #[inline(always)]
        pub(in super::super) fn unpack_hi16(a: Self, b: Self) -> Self {
            Self(std::array::from_fn(|i| {
                let (pair, byte) = (i / 2, i % 2);
                if pair % 2 == 0 { a.0[8 + pair + byte] } else { b.0[8 + pair - 1 + byte] }
            }))
        }

        /// The lanes moved up by 4 (one 32-bit lane), zeros in.
        #[inline(always)]
        pub(in super::super) fn shift_up4(self) -> Self {
            Self(std::array::from_fn(|i| if i < 4 { 0 } else { self.0[i - 4] }))
        }

        /// The lanes moved up by 8 (two 32-bit lanes), zeros in.
        #[inline(always)]
        pub(in super::super) fn shift_up8(self) -> Self {
            Self(std::array::from_fn(|i| if i < 8 { 0 } else { self.0[i - 8] }))
        }

        /// The last 32-bit lane in all four.
        #[inline(always)]
        pub(in super::super) fn splat_last32(self) -> Self {
            Self(std::array::from_fn(|i| self.0[12 + i % 4]))
        }

        fn lanes_i32(self) -> [i32; 4] {
            self.lanes32().map(|v| v as i32)
        }

        fn from_i32(v: [i32; 4]) -> Self {
            Self(std::array::from_fn(|i| v[i / 4].to_le_bytes()[i % 4]))
        }

        /// [a0, a2, b0, b2] of 32-bit lanes.
        #[inline(always)]
        pub(in super::super) fn even32(a: Self, b: Self) -> Self {
            let (a, b) = (a.lanes_i32(), b.lanes_i32());
            Self::from_i32([a[0], a[2], b[0], b[2]])
        }

        /// [a1, a3, b1, b3] of 32-bit lanes.
        #[inline(always)]
        pub(in super::super) fn odd32(a: Self, b: Self) -> Self {
            let (a, b) = (a.lanes_i32(), b.lanes_i32());
            Self::from_i32([a[1], a[3], b[1], b[3]])
        }

        /// [a0, b0, a1, b1] of 32-bit lanes.
        #[inline(always)]
        pub(in super::super) fn unpack_lo32(a: Self, b: Self) -> Self {
            let (a, b) = (a.lanes_i32(), b.lanes_i32());
            Self::from_i32([a[0], b[0], a[1], b[1]])
        }

        /// [a2, b2, a3, b3] of 32-bit lanes.
        #[inline(always)]
        pub(in super::super) fn unpack_hi32(a: Self, b: Self) -> Self {
            let (a, b) = (a.lanes_i32(), b.lanes_i32());
            Self::from_i32([a[2], b[2], a[3], b[3]])
        }

        #[inline(always)]
        pub(in super::super) fn or(self, o: Self) -> Self {
            Self(zip(self.0, o.0, |a, b| a | b))
        }

        #[inline(always)]
        pub(in super::super) fn shl32<const N: u32>(self) -> Self {
            Self::from_i32(self.lanes_i32().map(|v| v << N))
        }

        /// Arithmetic (sign-filling) right shift of each 32-bit lane.
        #[inline(always)]
        pub(in super::super) fn sar32<const N: u32>(self) -> Self {
            Self::from_i32(self.lanes_i32().map(|v| v >> N))
        }

        #[inline(always)]
        pub(in super::super) fn add32(self, o: Self) -> Self {
            let (a, b) = (self.lanes_i32(), o.lanes_i32());
            Self::from_i32(std::array::from_fn(|i| a[i].wrapping_add(b[i])))
        }

        #[inline(always)]
        pub(in super::super) fn max32(self, o: Self) -> Self {
            let (a, b) = (self.lanes_i32(), o.lanes_i32());
            Self::from_i32(std::array::from_fn(|i| a[i].max(b[i])))
        }

        #[inline(always)]
        pub(in super::super) fn sub32(self, o: Self) -> Self {
            let (a, b) = (self.lanes_i32(), o.lanes_i32());
            Self::from_i32(std::array::from_fn(|i| a[i].wrapping_sub(b[i])))
        }

        /// The signed 32-bit lanes as floats.
        #[inline(always)]
        pub(in super::super) fn to_f32(self) -> glam::Vec4 {
            glam::Vec4::from_array(self.lanes_i32().map(|v| v as f32))
        }

        /// The lanes' bits as floats.
        #[inline(always)]
        pub(in super::super) fn bits_to_f32(self) -> glam::Vec4 {
            glam::Vec4::from_array(self.lanes32().map(f32::from_bits))
        }

        /// Floats' bits as lanes.
        #[inline(always)]
        pub(in super::super) fn f32_bits(v: glam::Vec4) -> Self {
            Self::from_i32(v.to_array().map(|f| f.to_bits() as i32))
        }

        #[inline(always)]
        pub(in super::super) fn lanes32(self) -> [u32; 4] {
            std::array::from_fn(|i| {
                u32::from_le_bytes([self.0[4 * i], self.0[4 * i + 1], self.0[4 * i + 2], self.0[4 * i + 3]])
            })
        }

        /// The two 64-bit lanes.
        #[inline(always)]
        pub(in super::super) fn lanes64(self) -> [u64; 2] {
            let (halves, _) = self.0.as_chunks::<8>();
            std::array::from_fn(|i| halves.get(i).copied().map_or(0, u64::from_le_bytes))
        }
    }
}

//! Four-lane (SoA) quaternion interpolation for [`super::sample::SampleJob`]: four channels per
//! instruction, without a call to `acos` or `sin`.
//!
//! Every function is plain lane-wise IEEE arithmetic on [`Vec4`] (no fused multiply-add, a fixed
//! order of operations), so a lane gives the same bits on every CPU, in SSE2, WebAssembly SIMD or
//! scalar code, and the one-quaternion paths ([`super::sample::slerp`]) that run one lane of
//! the same functions agree bit for bit with the four-lane job.

use crate::math::{Mat4, Quat, Vec4};
use glam::BVec4A;

/// Four quaternions, one per lane: `x`, `y`, `z`, `w` each hold one component of all four.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Quat4 {
    pub x: Vec4,
    pub y: Vec4,
    pub z: Vec4,
    pub w: Vec4,
}

impl Quat4 {
    /// The same quaternion in every lane.
    pub fn splat(q: Quat) -> Self {
        Self { x: Vec4::splat(q.x), y: Vec4::splat(q.y), z: Vec4::splat(q.z), w: Vec4::splat(q.w) }
    }

    /// One block of a rotation [`crate::clip::LaneGroup`]: the x, y, z and w of four members
    /// (the identity in every lane if the block is short, which a group's layout never is).
    pub fn from_block(v: &[Vec4]) -> Self {
        match v {
            [x, y, z, w, ..] => Self { x: *x, y: *y, z: *z, w: *w },
            _ => Self::splat(Quat::IDENTITY),
        }
    }

    /// Lane 0 as a quaternion.
    pub fn first(&self) -> Quat {
        Quat::from_xyzw(self.x.x, self.y.x, self.z.x, self.w.x)
    }

    /// The four lanes as quaternions (a 4×4 transpose).
    pub fn to_quats(self) -> [Quat; 4] {
        let m = Mat4::from_cols(self.x, self.y, self.z, self.w).transpose();
        [Quat::from_vec4(m.x_axis), Quat::from_vec4(m.y_axis), Quat::from_vec4(m.z_axis), Quat::from_vec4(m.w_axis)]
    }

    fn dot(&self, o: &Self) -> Vec4 {
        self.x * o.x + self.y * o.y + self.z * o.z + self.w * o.w
    }

    fn scale(&self, s: Vec4) -> Self {
        Self { x: self.x * s, y: self.y * s, z: self.z * s, w: self.w * s }
    }

    fn add(&self, o: &Self) -> Self {
        Self { x: self.x + o.x, y: self.y + o.y, z: self.z + o.z, w: self.w + o.w }
    }

    /// `self + (o − self)·u` per lane.
    fn lerp(&self, o: &Self, u: Vec4) -> Self {
        let l = |a: Vec4, b: Vec4| a + (b - a) * u;
        Self { x: l(self.x, o.x), y: l(self.y, o.y), z: l(self.z, o.z), w: l(self.w, o.w) }
    }

    fn select(mask: BVec4A, t: &Self, f: &Self) -> Self {
        Self {
            x: Vec4::select(mask, t.x, f.x),
            y: Vec4::select(mask, t.y, f.y),
            z: Vec4::select(mask, t.z, f.z),
            w: Vec4::select(mask, t.w, f.w),
        }
    }

    /// `o`, negated in the lanes where it is on the other hemisphere from `self`, and the
    /// (then non-negative) dot products.
    fn same_hemisphere(&self, o: &Self) -> (Self, Vec4) {
        let d = self.dot(o);
        let flip = d.cmplt(Vec4::ZERO);
        let neg = Self { x: -o.x, y: -o.y, z: -o.z, w: -o.w };
        (Self::select(flip, &neg, o), Vec4::select(flip, -d, d))
    }
}

/// `asin(x)` for `x` in `[0, 0.5]`, with `z = x²`: Cephes' minimax polynomial (relative error
/// below 3e-7 there), evaluated in Estrin's scheme (a shorter dependency chain than Horner's).
#[inline]
fn asin_small(x: Vec4, z: Vec4) -> Vec4 {
    let z2 = z * z;
    let low = Vec4::splat(1.666_675_2e-1) + Vec4::splat(7.495_300_3e-2) * z;
    let mid = Vec4::splat(4.547_002_6e-2) + Vec4::splat(2.418_131e-2) * z;
    let p = low + z2 * mid + (z2 * z2) * Vec4::splat(4.216_32e-2);
    x + x * z * p
}

/// `acos(d)` for `d` in `[0, 1]`: `π/2 − asin(d)` below ½, `2·asin(√((1 − d)/2))` above, where
/// `1 − d` is exact, so angles near zero keep their relative precision.
#[inline]
pub(crate) fn acos_unit(d: Vec4) -> Vec4 {
    let big = d.cmpge(Vec4::splat(0.5));
    let half_gap = (Vec4::ONE - d) * Vec4::splat(0.5);
    let x = Vec4::select(big, crate::math::sqrt4(half_gap), d);
    let z = Vec4::select(big, half_gap, d * d);
    let a = asin_small(x, z);
    Vec4::select(big, a + a, Vec4::splat(std::f32::consts::FRAC_PI_2) - a)
}

/// `sin(x)/x` for `x` in `[0, π/2]` (1 at 0): the Taylor polynomial in x² to x¹⁰ (truncation
/// below 4e-8 there), in Estrin's scheme.
#[inline]
pub(crate) fn sinc(x: Vec4) -> Vec4 {
    let y = x * x;
    let y2 = y * y;
    let e0 = Vec4::ONE + Vec4::splat(-1.666_666_7e-1) * y;
    let e1 = Vec4::splat(8.333_333e-3) + Vec4::splat(-1.984_127e-4) * y;
    let e2 = Vec4::splat(2.755_731_9e-6) + Vec4::splat(-2.505_210_8e-8) * y;
    e0 + y2 * e1 + (y2 * y2) * e2
}

/// Unit length per lane; lanes of zero or non-finite length take `fallback`.
fn normalize_or(q: &Quat4, fallback: &Quat4) -> Quat4 {
    let len2 = q.dot(q);
    let inv = Vec4::ONE / crate::math::sqrt4(len2);
    let ok = len2.cmpgt(Vec4::ZERO) & inv.cmplt(Vec4::INFINITY);
    Quat4::select(ok, &q.scale(inv), fallback)
}

/// What [`slerp4`] needs of a pair of keys besides the keys and `u`: the angle θ between `a`
/// and `b` on the shortest arc, and `±1/sinc θ`, negative where `b` must be negated to be on
/// `a`'s hemisphere. A clip computes it once per pair of keys ([`crate::clip::LaneGroup`]).
#[inline]
pub(crate) fn slerp_angle(a: &Quat4, b: &Quat4) -> (Vec4, Vec4) {
    let d = a.dot(b);
    let flip = d.cmplt(Vec4::ZERO);
    let theta = acos_unit((-d).max(d).min(Vec4::ONE));
    let inv = Vec4::ONE / sinc(theta);
    (theta, Vec4::select(flip, -inv, inv))
}

/// [`slerp4`] from [`slerp_angle`]'s `(theta, inv_signed)` for the same `a` and `b`.
#[inline]
pub(crate) fn slerp_finish(a: &Quat4, b: &Quat4, u: Vec4, theta: Vec4, inv_signed: Vec4) -> Quat4 {
    let v = Vec4::ONE - u;
    let wa = v * sinc(v * theta) * inv_signed.abs();
    let wb = u * sinc(u * theta) * inv_signed;
    let out = a.scale(wa).add(&b.scale(wb));
    Quat4::select(u.cmpeq(Vec4::ZERO), a, &out)
}

/// Spherical linear interpolation along the shortest arc, per lane; exactly `a` where `u == 0`.
/// Within 5e-7 of the exact slerp of unit inputs.
///
/// The weights `sin((1 − u)θ)/sin θ` and `sin(uθ)/sin θ` are computed as
/// `(1 − u)·sinc((1 − u)θ)/sinc θ` and `u·sinc(uθ)/sinc θ`: `sinc` is at least 2/π on `[0, π/2]`,
/// so nothing divides by a small number and keys a hair apart (or equal) need no nlerp
/// fallback; and there the weights hardly depend on θ, so the rounding of the dot product
/// (which θ amplifies near zero) does not reach the result.
///
/// Split in two: [`slerp_angle`] depends on the keys only (a clip computes it at load) and
/// [`slerp_finish`] on `u`.
pub(crate) fn slerp4(a: &Quat4, b: &Quat4, u: Vec4) -> Quat4 {
    let (theta, inv_signed) = slerp_angle(a, b);
    slerp_finish(a, b, u, theta, inv_signed)
}

/// Normalized linear interpolation along the shortest arc, per lane; exactly `a` where
/// `u == 0`, and `a` where the lerp has no direction (inputs that were not unit).
pub(crate) fn nlerp4(a: &Quat4, b: &Quat4, u: Vec4) -> Quat4 {
    let (b, _) = a.same_hemisphere(b);
    let out = normalize_or(&a.lerp(&b, u), a);
    Quat4::select(u.cmpeq(Vec4::ZERO), a, &out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lanes(f: impl Fn(f32) -> f32, xs: Vec4) -> Vec4 {
        Vec4::new(f(xs.x), f(xs.y), f(xs.z), f(xs.w))
    }

    #[test]
    fn acos_and_sinc_match_libm_on_their_ranges() {
        let mut worst = (0.0f64, 0.0f64);
        for i in 0..=40_000 {
            let d = i as f32 / 40_000.0;
            let v = Vec4::new(d, (d * 0.7).min(1.0), 1.0 - d * 1e-3, d * d);
            let got = acos_unit(v);
            let want = lanes(|x| (x as f64).acos() as f32, v);
            for k in 0..4 {
                // Relative to the angle where it is small (d near 1), else absolute.
                let err = (got[k] as f64 - want[k] as f64).abs() / (want[k] as f64).max(1e-3);
                worst.0 = worst.0.max(err);
            }
            let x = d * std::f32::consts::FRAC_PI_2;
            let s = sinc(Vec4::splat(x)).x as f64;
            let x = x as f64;
            worst.1 = worst.1.max((s - if x == 0.0 { 1.0 } else { x.sin() / x }).abs());
        }
        assert!(worst.0 < 1e-6, "acos: {}", worst.0);
        assert!(worst.1 < 2e-7, "sinc: {}", worst.1);
        assert_eq!(acos_unit(Vec4::ONE), Vec4::ZERO);
        assert_eq!(sinc(Vec4::ZERO), Vec4::ONE);
    }

    /// Exact slerp in f64 of two unit quaternions, shortest arc.
    fn slerp_f64(a: Quat, b: Quat, u: f64) -> [f64; 4] {
        let (a, mut b) = (a.to_array().map(f64::from), b.to_array().map(f64::from));
        let mut d: f64 = (0..4).map(|i| a[i] * b[i]).sum();
        if d < 0.0 {
            b = b.map(|x| -x);
            d = -d;
        }
        let theta = d.min(1.0).acos();
        if theta < 1e-9 {
            return a;
        }
        let (wa, wb) = (((1.0 - u) * theta).sin() / theta.sin(), (u * theta).sin() / theta.sin());
        std::array::from_fn(|i| a[i] * wa + b[i] * wb)
    }

    fn random_quat(seed: &mut u32) -> Quat {
        let mut next = || {
            *seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (*seed >> 8) as f32 / (1u32 << 24) as f32 * 2.0 - 1.0
        };
        Quat::from_xyzw(next(), next(), next(), next()).normalize()
    }

    #[test]
    fn slerp4_is_within_5e7_of_the_exact_slerp() {
        let mut seed = 7;
        let mut worst = 0.0f64;
        for i in 0..20_000 {
            let a = random_quat(&mut seed);
            // Half the pairs far apart, half within a few degrees (both sides of the nlerp cut-over).
            let b = if i % 2 == 0 {
                random_quat(&mut seed)
            } else {
                let angle = (i % 97) as f32 * 0.002;
                a * Quat::from_axis_angle(glam::Vec3::new(0.3, -0.5, 0.8).normalize(), angle)
            };
            let b = if i % 3 == 0 { -b } else { b };
            let u = Vec4::new(0.0, 0.25, (i % 101) as f32 / 101.0, 1.0);
            let out = slerp4(&Quat4::splat(a), &Quat4::splat(b), u).to_quats();
            for (k, q) in out.iter().enumerate() {
                let want = slerp_f64(a, b, u[k] as f64);
                let err = (0..4).map(|c| (q.to_array()[c] as f64 - want[c]).abs()).fold(0.0, f64::max);
                worst = worst.max(err);
            }
            assert_eq!(out[0], a, "exactly a at u = 0");
        }
        assert!(worst < 5e-7, "worst component error {worst}");
    }

    #[test]
    fn nlerp4_keeps_a_where_there_is_no_direction() {
        let a = Quat4::splat(Quat::from_xyzw(0.0, 0.0, 0.0, 0.0));
        let b = Quat4::splat(Quat::from_xyzw(0.0, 0.0, 0.0, 0.0));
        let out = nlerp4(&a, &b, Vec4::splat(0.5));
        assert_eq!(out, a);
        let half = nlerp4(&Quat4::splat(Quat::IDENTITY), &Quat4::splat(Quat::from_rotation_z(1.0)), Vec4::splat(0.5));
        assert!(half.first().abs_diff_eq(Quat::from_rotation_z(0.5), 1e-6));
    }
}

//! Skinning: the joint palette and linear blend skinning (the CPU reference of the GPU path).

use super::dqs::{DqsJob, JointDq, RigidJob, SkinningMethod};
use super::sjb::{SjbJob, SjbPlan};
use super::sjbbe::{MAX_EXAMPLES, SjbbeJob, SjbbeRig};
use super::world::affine_mul;
use super::{check_eq, check_index, check_len};
use crate::error::JobError;
use crate::math::{Mat3, Mat4, Vec3, Vec4};

/// Computes `palette[j] = worlds[joints[j]] * inverse_bind[j]` for one skin.
#[derive(Debug)]
pub struct PaletteJob<'a> {
    /// Joint nodes of the skin.
    pub joints: &'a [u32],
    /// Inverse bind matrix of each joint.
    pub inverse_bind: &'a [Mat4],
    /// World matrix of each node.
    pub worlds: &'a [Mat4],
    /// Output: one matrix per joint.
    pub palette: &'a mut [Mat4],
}

impl PaletteJob<'_> {
    /// Checks lengths and joint indices.
    pub fn validate(&self) -> Result<(), JobError> {
        check_eq("inverse_bind", self.joints.len(), self.inverse_bind.len())?;
        check_len("palette", self.joints.len(), self.palette.len())?;
        for &j in self.joints {
            check_index("joints", j as usize, self.worlds.len())?;
        }
        Ok(())
    }

    /// Validates, then writes `palette`.
    pub fn run(&mut self) -> Result<(), JobError> {
        self.validate()?;
        for ((out, &joint), ibm) in self.palette.iter_mut().zip(self.joints).zip(self.inverse_bind) {
            let world = &self.worlds[joint as usize];
            // Inverse bind matrices are affine in practice: then the cheaper product is the same.
            let affine = ibm.x_axis.w == 0.0 && ibm.y_axis.w == 0.0 && ibm.z_axis.w == 0.0 && ibm.w_axis.w == 1.0;
            *out = if affine { affine_mul(world, ibm) } else { *world * *ibm };
        }
        Ok(())
    }
}

/// Linear blend skinning of positions and normals with up to 8 influences per vertex:
/// `p' = Σ w_i · palette[j_i] · p`; normals use the inverse transpose of the blended
/// matrix and are renormalized.
#[derive(Debug)]
pub struct LbsJob<'a> {
    /// Bind-pose positions.
    pub positions: &'a [[f32; 3]],
    /// Bind-pose normals; empty to skip normals.
    pub normals: &'a [[f32; 3]],
    /// Joint indices (into `palette`) per vertex.
    pub joints: &'a [[u16; 8]],
    /// Weights per vertex (summing to 1; zero-weight slots are ignored).
    pub weights: &'a [[f32; 8]],
    /// Skinning matrices ([`PaletteJob`]).
    pub palette: &'a [Mat4],
    /// Output positions, at least `positions.len()`.
    pub out_positions: &'a mut [[f32; 3]],
    /// Output normals, at least `normals.len()`.
    pub out_normals: &'a mut [[f32; 3]],
}

impl LbsJob<'_> {
    /// Checks lengths. Joint indices are checked while running.
    pub fn validate(&self) -> Result<(), JobError> {
        check_vertex_streams(
            self.positions,
            self.normals,
            self.joints,
            self.weights,
            self.out_positions.len(),
            self.out_normals.len(),
        )
    }

    /// Validates, then skins every vertex. Stops with `IndexOutOfRange` at the first
    /// weighted joint index outside `palette`.
    ///
    /// The palette is first turned into affine rows (3 × `Vec4` per joint; on the stack for up
    /// to [`ROW_TABLE`] joints). Vertices then go in blocks of [`BLOCK`]: one vectorized scan of
    /// the block's joints and weights checks the joint indices (an exact per-vertex check runs
    /// only when some index is out of range) and whether JOINTS_1 carries weight; the rows are
    /// blended per vertex (four-wide), four vertices at a time are transposed into lanes, and
    /// positions and normals are transformed four vertices per instruction (SSE natively,
    /// SIMD128 on wasm; on x86-64 CPUs with AVX2 the same code is compiled once more
    /// for them and chosen at run time).
    pub fn run(&mut self) -> Result<(), JobError> {
        self.validate()?;
        let n = self.positions.len();
        let streams = Streams {
            positions: self.positions,
            normals: self.normals,
            joints: self.joints,
            weights: self.weights,
            out_positions: &mut self.out_positions[..n],
            out_normals: &mut self.out_normals[..self.normals.len()],
        };
        if self.palette.len() <= ROW_TABLE {
            let table: [Rows; ROW_TABLE] =
                std::array::from_fn(|j| self.palette.get(j).map_or([Vec4::ZERO; 3], affine_rows));
            lbs_dispatch(&RowTable(&table), self.palette.len(), streams)
        } else {
            lbs_dispatch(&RowsOnTheFly(self.palette), self.palette.len(), streams)
        }
    }
}

fn out_of_range(index: usize, len: usize) -> JobError {
    JobError::IndexOutOfRange { what: "joints", index, len }
}

/// Vertices per block of [`LbsJob::run`].
pub const BLOCK: usize = 16;

/// Palettes with at most this many joints are copied into a row table on the stack, indexed
/// without bounds checks (12 KiB); larger ones are read in place.
pub const ROW_TABLE: usize = 256;

/// The affine rows of a skinning matrix: `row[r] = (m[r][0], m[r][1], m[r][2], m[r][3])`.
type Rows = [Vec4; 3];

fn affine_rows(m: &Mat4) -> Rows {
    let t = m.transpose();
    [t.x_axis, t.y_axis, t.z_axis]
}

/// Where the skinning kernel reads a joint's rows.
trait RowSource {
    /// The rows of joint `j`; `j` is in range or carries no weight (checked per block).
    fn rows(&self, j: u16) -> Rows;
}

/// A palette of at most [`ROW_TABLE`] joints, zero-padded: any `u8` index is in bounds.
struct RowTable<'a>(&'a [Rows; ROW_TABLE]);

impl RowSource for RowTable<'_> {
    #[inline(always)]
    fn rows(&self, j: u16) -> Rows {
        // Indices at or past the palette's length carry no weight (checked before); they read
        // zero rows or, past 255, any row: times a zero weight either adds nothing.
        self.0[usize::from(j as u8)]
    }
}

/// A palette of more than [`ROW_TABLE`] joints, transposed as read.
struct RowsOnTheFly<'a>(&'a [Mat4]);

impl RowSource for RowsOnTheFly<'_> {
    #[inline(always)]
    fn rows(&self, j: u16) -> Rows {
        affine_rows(&self.0[usize::from(j).min(self.0.len().saturating_sub(1))])
    }
}

/// The vertex streams of one [`LbsJob::run`], outputs cut to the inputs' lengths.
struct Streams<'a, 'b> {
    positions: &'a [[f32; 3]],
    normals: &'a [[f32; 3]],
    joints: &'a [[u16; 8]],
    weights: &'a [[f32; 8]],
    out_positions: &'b mut [[f32; 3]],
    out_normals: &'b mut [[f32; 3]],
}

/// Runs [`lbs_blocks`] compiled for AVX2 where the CPU has it, else for the baseline.
fn lbs_dispatch<S: RowSource>(source: &S, joints: usize, streams: Streams<'_, '_>) -> Result<(), JobError> {
    #[cfg(target_arch = "x86_64")]
    if simd::has_avx2() {
        return simd::lbs_blocks_avx2(source, joints, streams);
    }
    lbs_blocks(source, joints, streams)
}

/// Skins all vertices, block by block; the remainder goes through a zero-padded block.
#[inline(always)]
fn lbs_blocks<S: RowSource>(source: &S, joints: usize, streams: Streams<'_, '_>) -> Result<(), JobError> {
    let Streams { positions, normals, joints: joint_ids, weights, out_positions, out_normals } = streams;
    let (p, p_rest) = positions.as_chunks::<BLOCK>();
    let (j, j_rest) = joint_ids.as_chunks::<BLOCK>();
    let (w, w_rest) = weights.as_chunks::<BLOCK>();
    let (op, op_rest) = out_positions.as_chunks_mut::<BLOCK>();
    // Without normals both normal streams are empty: no chunks, `get` is `None`.
    let (nrm, nrm_rest) = normals.as_chunks::<BLOCK>();
    let (on, on_rest) = out_normals.as_chunks_mut::<BLOCK>();
    for b in 0..p.len() {
        let block = BlockIn { p: &p[b], n: nrm.get(b).unwrap_or(&p[b]), j: &j[b], w: &w[b] };
        #[cfg(target_arch = "x86_64")]
        simd::prefetch_ahead(&block);
        skin_block(source, joints, &block, &mut op[b], on.get_mut(b))?;
    }
    let rest = p_rest.len();
    if rest > 0 {
        let mut pad = PaddedBlock::default();
        pad.p[..rest].copy_from_slice(p_rest);
        pad.n[..nrm_rest.len()].copy_from_slice(nrm_rest);
        pad.j[..rest].copy_from_slice(j_rest);
        pad.w[..rest].copy_from_slice(w_rest);
        let block = BlockIn { p: &pad.p, n: &pad.n, j: &pad.j, w: &pad.w };
        let (mut out_p, mut out_n) = ([[0.0; 3]; BLOCK], [[0.0; 3]; BLOCK]);
        skin_block(source, joints, &block, &mut out_p, (!normals.is_empty()).then_some(&mut out_n))?;
        op_rest.copy_from_slice(&out_p[..rest]);
        on_rest.copy_from_slice(&out_n[..on_rest.len()]);
    }
    Ok(())
}

/// Checks one block against a palette of `joints` joints, then skins it; normals only into
/// `out_n`.
#[inline(always)]
fn skin_block<S: RowSource>(
    source: &S,
    joints: usize,
    block: &BlockIn<'_>,
    out_p: &mut [[f32; 3]; BLOCK],
    out_n: Option<&mut [[f32; 3]; BLOCK]>,
) -> Result<(), JobError> {
    let upper = check_block(block.j, block.w, joints)?;
    match out_n {
        Some(out_n) => lbs_block::<S, true>(source, block, upper, out_p, out_n),
        None => lbs_block::<S, false>(source, block, upper, out_p, &mut [[0.0; 3]; BLOCK]),
    }
    Ok(())
}

/// One block's inputs (`n` is any stream of the right size when there are no normals).
struct BlockIn<'a> {
    p: &'a [[f32; 3]; BLOCK],
    n: &'a [[f32; 3]; BLOCK],
    j: &'a [[u16; 8]; BLOCK],
    w: &'a [[f32; 8]; BLOCK],
}

/// The last, partial block, padded with weightless vertices.
#[derive(Default)]
struct PaddedBlock {
    p: [[f32; 3]; BLOCK],
    n: [[f32; 3]; BLOCK],
    j: [[u16; 8]; BLOCK],
    w: [[f32; 8]; BLOCK],
}

/// Checks a block's joint indices against a palette of `len` joints (`IndexOutOfRange` for
/// the first weighted one outside) and says whether any vertex weights JOINTS_1.
#[inline(always)]
fn check_block(j: &[[u16; 8]; BLOCK], w: &[[f32; 8]; BLOCK], len: usize) -> Result<bool, JobError> {
    // Lane-wise maxima and ORs: the compiler turns both into a few vector instructions.
    let mut max = [0u16; 8];
    let mut upper = [0u32; 4];
    for v in 0..BLOCK {
        for k in 0..8 {
            max[k] = max[k].max(j[v][k]);
        }
        for k in 0..4 {
            upper[k] |= w[v][4 + k].to_bits();
        }
    }
    if max.into_iter().any(|m| usize::from(m) >= len) {
        // Some index is out of range: an error only where it carries weight.
        for (joints, weights) in j.iter().zip(w) {
            for (&joint, &weight) in joints.iter().zip(weights) {
                if usize::from(joint) >= len && weight != 0.0 {
                    return Err(out_of_range(usize::from(joint), len));
                }
            }
        }
    }
    Ok(upper != [0; 4])
}

/// Blends the rows of one vertex's influences (JOINTS_1 only when `upper`).
#[inline(always)]
fn blend_rows<S: RowSource>(source: &S, j: &[u16; 8], w: &[f32; 8], upper: bool) -> Rows {
    let (m0, m1, m2, m3) = (source.rows(j[0]), source.rows(j[1]), source.rows(j[2]), source.rows(j[3]));
    let mut rows = [Vec4::ZERO; 3];
    // Summed in slot order (no reassociation, no fused multiply-add), so every CPU and the
    // wasm build round the same way: a ragdoll fitted to skinned vertices is the same everywhere.
    for (r, row) in rows.iter_mut().enumerate() {
        *row = m0[r] * w[0] + m1[r] * w[1] + m2[r] * w[2] + m3[r] * w[3];
    }
    if upper {
        for k in 4..8 {
            if w[k] != 0.0 {
                let m = source.rows(j[k]);
                for (r, row) in rows.iter_mut().enumerate() {
                    *row += m[r] * w[k];
                }
            }
        }
    }
    rows
}

/// Four vertices' `[x, y, z]` (12 floats) as lanes `(x₀..x₃), (y₀..y₃), (z₀..z₃)`.
#[inline(always)]
fn to_lanes(f: &[[f32; 3]]) -> [Vec4; 3] {
    let v = |i: usize| f.get(i).copied().unwrap_or_default();
    let (a, b, c, d) = (v(0), v(1), v(2), v(3));
    [Vec4::new(a[0], b[0], c[0], d[0]), Vec4::new(a[1], b[1], c[1], d[1]), Vec4::new(a[2], b[2], c[2], d[2])]
}

/// The inverse of [`to_lanes`].
#[inline(always)]
fn from_lanes([x, y, z]: [Vec4; 3], out: &mut [[f32; 3]]) {
    for (i, o) in out.iter_mut().take(4).enumerate() {
        *o = [x[i], y[i], z[i]];
    }
}

/// Linear blend skinning of one block: blended rows per vertex, then positions and normals
/// (the cofactor of the blended 3×3, signed by its determinant, as the GPU paths do) four
/// vertices per lane.
#[inline(always)]
fn lbs_block<S: RowSource, const NORMALS: bool>(
    source: &S,
    block: &BlockIn<'_>,
    upper: bool,
    out_p: &mut [[f32; 3]; BLOCK],
    out_n: &mut [[f32; 3]; BLOCK],
) {
    for g in (0..BLOCK).step_by(4) {
        let blend = |v: usize| blend_rows::<S>(source, &block.j[g + v], &block.w[g + v], upper);
        let (a, b, c, d) = (blend(0), blend(1), blend(2), blend(3));
        // m[r][c] holds element (r, c) of the four blended matrices.
        let lanes = |r: usize| {
            let t = Mat4::from_cols(a[r], b[r], c[r], d[r]).transpose();
            [t.x_axis, t.y_axis, t.z_axis, t.w_axis]
        };
        let m = [lanes(0), lanes(1), lanes(2)];
        let [px, py, pz] = to_lanes(&block.p[g..]);
        let position = |r: usize| m[r][0] * px + m[r][1] * py + m[r][2] * pz + m[r][3];
        from_lanes([position(0), position(1), position(2)], &mut out_p[g..]);
        if NORMALS {
            // Columns c0, c1, c2 of the 3×3 part; the cofactor's columns are c1×c2, c2×c0, c0×c1.
            let col = |c: usize| [m[0][c], m[1][c], m[2][c]];
            let cross = |u: [Vec4; 3], v: [Vec4; 3]| {
                [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]]
            };
            let (c0, c1, c2) = (col(0), col(1), col(2));
            let (ca, cb, cc) = (cross(c1, c2), cross(c2, c0), cross(c0, c1));
            let det = c0[0] * ca[0] + c0[1] * ca[1] + c0[2] * ca[2];
            let [nx, ny, nz] = to_lanes(&block.n[g..]);
            let normal = |r: usize| ca[r] * nx + cb[r] * ny + cc[r] * nz;
            let (x, y, z) = (normal(0), normal(1), normal(2));
            let len2 = x * x + y * y + z * z;
            let valid = len2.cmpgt(Vec4::ZERO) & len2.is_finite_mask();
            let inv = Vec4::select(valid, crate::math::sqrt4(len2).recip(), Vec4::ZERO);
            let inv = Vec4::select(det.cmplt(Vec4::ZERO), -inv, inv);
            from_lanes([x * inv, y * inv, z * inv], &mut out_n[g..]);
        }
    }
}

/// x86-64 only: the AVX2 build of the kernel (three-operand instructions: fewer register
/// copies; the same arithmetic, so the same results), chosen at run time, and prefetching.
#[cfg(target_arch = "x86_64")]
#[allow(unsafe_code)]
mod simd {
    use super::{BLOCK, BlockIn, JobError, RowSource, Streams, lbs_blocks};
    use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};

    /// Whether this CPU runs [`lbs_blocks_avx2`] (detected once, then cached by std).
    pub(super) fn has_avx2() -> bool {
        std::arch::is_x86_feature_detected!("avx2")
    }

    /// [`lbs_blocks`] compiled for AVX2.
    pub(super) fn lbs_blocks_avx2<S: RowSource>(
        source: &S,
        joints: usize,
        streams: Streams<'_, '_>,
    ) -> Result<(), JobError> {
        #[target_feature(enable = "avx2")]
        fn run<S: RowSource>(source: &S, joints: usize, streams: Streams<'_, '_>) -> Result<(), JobError> {
            lbs_blocks(source, joints, streams)
        }
        // SAFETY: callers check `has_avx2()` first, so the CPU has the feature.
        unsafe { run(source, joints, streams) }
    }

    /// Asks for the streams four blocks ahead of this one (a hint; it never faults).
    #[inline(always)]
    pub(super) fn prefetch_ahead(block: &BlockIn<'_>) {
        fn lines<T>(block: &[T; BLOCK]) {
            let bytes = size_of::<[T; BLOCK]>();
            let ahead = block.as_ptr().cast::<i8>().wrapping_add(4 * bytes);
            for line in (0..bytes).step_by(64) {
                // SAFETY: a prefetch is a hint: it does not fault, any address is fine.
                unsafe { _mm_prefetch::<_MM_HINT_T0>(ahead.wrapping_add(line)) }
            }
        }
        lines(block.p);
        lines(block.n);
        lines(block.j);
        lines(block.w);
    }
}

/// Skins with any [`SkinningMethod`]: the one entry point the instance, the tests and the
/// benchmarks use, dispatching to [`LbsJob`], [`RigidJob`], [`DqsJob`], [`SjbJob`] or [`SjbbeJob`].
#[derive(Debug)]
pub struct SkinJob<'a> {
    /// The method.
    pub method: SkinningMethod,
    /// Bind-pose (morphed) positions.
    pub positions: &'a [[f32; 3]],
    /// Bind-pose normals; empty to skip normals.
    pub normals: &'a [[f32; 3]],
    /// Joint indices per vertex.
    pub joints: &'a [[u16; 8]],
    /// Weights per vertex.
    pub weights: &'a [[f32; 8]],
    /// Skinning matrices ([`PaletteJob`]).
    pub palette: &'a [Mat4],
    /// The palette split for dual quaternions ([`DqPrepareJob`](super::dqs::DqPrepareJob)); read
    /// by DQS and SJB only.
    pub joints_dq: &'a [JointDq],
    /// Joint centres of this primitive; required by SJB and SJBBE.
    pub plan: Option<&'a SjbPlan>,
    /// The example poses of this primitive and their current weights (SJBBE; `None` is SJB).
    pub examples: Option<(&'a SjbbeRig, &'a [[f32; MAX_EXAMPLES]])>,
    /// Output positions, at least `positions.len()`.
    pub out_positions: &'a mut [[f32; 3]],
    /// Output normals, at least `normals.len()`.
    pub out_normals: &'a mut [[f32; 3]],
}

impl SkinJob<'_> {
    /// Runs the method's job (which validates its inputs first).
    ///
    /// # Errors
    /// The job's error; `InvalidInput` for SJB without a plan.
    pub fn run(&mut self) -> Result<(), JobError> {
        let (positions, normals, joints, weights) = (self.positions, self.normals, self.joints, self.weights);
        let (out_positions, out_normals) = (&mut *self.out_positions, &mut *self.out_normals);
        match self.method {
            SkinningMethod::Linear => {
                LbsJob { positions, normals, joints, weights, palette: self.palette, out_positions, out_normals }.run()
            }
            SkinningMethod::Rigid => {
                RigidJob { positions, normals, joints, weights, palette: self.palette, out_positions, out_normals }
                    .run()
            }
            SkinningMethod::DualQuaternion => {
                DqsJob { positions, normals, joints, weights, joints_dq: self.joints_dq, out_positions, out_normals }
                    .run()
            }
            SkinningMethod::SphericalJointBlend | SkinningMethod::SphericalJointBlendByExample => {
                let plan =
                    self.plan.ok_or_else(|| JobError::InvalidInput("spherical joint blending needs a plan".into()))?;
                if let Some((rig, alphas)) =
                    self.examples.filter(|_| self.method == SkinningMethod::SphericalJointBlendByExample)
                {
                    return SjbbeJob {
                        positions,
                        normals,
                        joints,
                        weights,
                        palette: self.palette,
                        joints_dq: self.joints_dq,
                        plan,
                        rig,
                        alphas,
                        out_positions,
                        out_normals,
                    }
                    .run();
                }
                SjbJob {
                    positions,
                    normals,
                    joints,
                    weights,
                    palette: self.palette,
                    joints_dq: self.joints_dq,
                    plan,
                    out_positions,
                    out_normals,
                }
                .run()
            }
        }
    }
}

/// The length checks every skinning job makes: per-vertex streams of equal length (normals
/// may be empty) and outputs large enough.
pub(crate) fn check_vertex_streams(
    positions: &[[f32; 3]],
    normals: &[[f32; 3]],
    joints: &[[u16; 8]],
    weights: &[[f32; 8]],
    out_positions: usize,
    out_normals: usize,
) -> Result<(), JobError> {
    let n = positions.len();
    if !normals.is_empty() {
        check_eq("normals", n, normals.len())?;
    }
    check_eq("joints", n, joints.len())?;
    check_eq("weights", n, weights.len())?;
    check_len("out_positions", n, out_positions)?;
    check_len("out_normals", normals.len(), out_normals)?;
    Ok(())
}

/// `table[j]`, or `IndexOutOfRange` naming the vertex joint stream.
pub(crate) fn joint_at<T>(table: &[T], j: u16) -> Result<&T, JobError> {
    table.get(j as usize).ok_or(JobError::IndexOutOfRange { what: "joints", index: j as usize, len: table.len() })
}

/// Transforms a normal by the inverse transpose of `m`'s upper 3×3 (as its cofactor
/// matrix, signed by the determinant) and renormalizes; zero stays zero.
pub fn transform_normal(m: &Mat4, n: Vec3) -> Vec3 {
    let a = Mat3::from_mat4(*m);
    let (c0, c1, c2) = (a.x_axis, a.y_axis, a.z_axis);
    let cofactor = Mat3::from_cols(c1.cross(c2), c2.cross(c0), c0.cross(c1));
    let sign = if a.determinant() < 0.0 { -1.0 } else { 1.0 };
    (cofactor * n * sign).normalize_or_zero()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::{Quat, Transform};

    /// Runs [`LbsJob`] on valid streams; returns skinned positions and normals.
    fn lbs(
        positions: &[[f32; 3]],
        normals: &[[f32; 3]],
        joints: &[[u16; 8]],
        weights: &[[f32; 8]],
        palette: &[Mat4],
    ) -> (Vec<[f32; 3]>, Vec<[f32; 3]>) {
        let mut out_p = vec![[0.0; 3]; positions.len()];
        let mut out_n = vec![[0.0; 3]; normals.len()];
        LbsJob { positions, normals, joints, weights, palette, out_positions: &mut out_p, out_normals: &mut out_n }
            .run()
            .expect("valid");
        (out_p, out_n)
    }

    #[test]
    fn palette_multiplies_world_by_inverse_bind() {
        let worlds = [Mat4::from_translation(Vec3::X), Mat4::from_rotation_z(1.0)];
        let ibm = [Mat4::from_translation(-Vec3::Y), Mat4::from_scale(Vec3::splat(2.0))];
        let mut palette = [Mat4::ZERO; 2];
        PaletteJob { joints: &[1, 0], inverse_bind: &ibm, worlds: &worlds, palette: &mut palette }
            .run()
            .expect("valid");
        assert_eq!(palette[0], worlds[1] * ibm[0]);
        assert_eq!(palette[1], worlds[0] * ibm[1]);
        let mut job = PaletteJob { joints: &[2], inverse_bind: &ibm[..1], worlds: &worlds, palette: &mut palette };
        assert!(matches!(job.run(), Err(JobError::IndexOutOfRange { .. })));
    }

    #[test]
    fn normals_use_inverse_transpose() {
        let m = Mat4::from_scale(Vec3::new(2.0, 1.0, 1.0));
        // A 45° normal in xy under x-scale 2 tilts towards y.
        let n = transform_normal(&m, Vec3::new(1.0, 1.0, 0.0).normalize());
        assert!(n.abs_diff_eq(Vec3::new(1.0, 2.0, 0.0).normalize(), 1e-6), "{n}");
        let mirrored = transform_normal(&Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0)), Vec3::X);
        assert!(mirrored.abs_diff_eq(-Vec3::X, 1e-6));
    }

    /// A two-joint rig by hand: joint 0 at the origin, joint 1 one unit up, bent 90° about z.
    #[test]
    fn two_joint_rig_matches_hand_computation() {
        let rest = [Transform::IDENTITY, Transform { translation: Vec3::Y, ..Transform::IDENTITY }];
        let posed = [
            Transform::IDENTITY,
            Transform {
                translation: Vec3::Y,
                rotation: Quat::from_rotation_z(std::f32::consts::FRAC_PI_2),
                ..Transform::IDENTITY
            },
        ];
        let parents = [None, Some(0)];
        let mut bind = [Mat4::IDENTITY; 2];
        crate::job::world::WorldJob { parents: &parents, order: &[0, 1], locals: &rest, worlds: &mut bind }
            .run()
            .expect("valid");
        let inverse_bind = [bind[0].inverse(), bind[1].inverse()];
        let mut worlds = [Mat4::IDENTITY; 2];
        crate::job::world::WorldJob { parents: &parents, order: &[0, 1], locals: &posed, worlds: &mut worlds }
            .run()
            .expect("valid");
        let mut palette = [Mat4::ZERO; 2];
        PaletteJob { joints: &[0, 1], inverse_bind: &inverse_bind, worlds: &worlds, palette: &mut palette }
            .run()
            .expect("valid");
        // Vertex 0 at (1, 2, 0) fully on joint 1: rotating (1, 1, 0) about z by 90° around (0, 1, 0)
        // gives (-1, 1, 0) + (0, 1, 0) = (-1, 2, 0). Vertex 1 half on each: mean of (1, 2) and (-1, 2)
        // = (0, 2, 0). Normal +x on joint 1 becomes +y; half/half: (1,0)+(0,1) normalized.
        let positions = [[1.0, 2.0, 0.0], [1.0, 2.0, 0.0]];
        let normals = [[1.0, 0.0, 0.0], [1.0, 0.0, 0.0]];
        let joints = [[1, 0, 0, 0, 0, 0, 0, 0], [0, 1, 0, 0, 0, 0, 0, 0]];
        let weights = [[1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0], [0.5, 0.5, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]];
        let (out_p, out_n) = lbs(&positions, &normals, &joints, &weights, &palette);
        let close = |a: [f32; 3], b: [f32; 3]| Vec3::from(a).abs_diff_eq(Vec3::from(b), 1e-5);
        assert!(close(out_p[0], [-1.0, 2.0, 0.0]), "{:?}", out_p[0]);
        assert!(close(out_p[1], [0.0, 2.0, 0.0]), "{:?}", out_p[1]);
        assert!(close(out_n[0], [0.0, 1.0, 0.0]), "{:?}", out_n[0]);
        let h = std::f32::consts::FRAC_1_SQRT_2;
        assert!(close(out_n[1], [h, h, 0.0]), "{:?}", out_n[1]);
    }

    /// The block kernel against a per-vertex reference (blend the matrices, transform the
    /// point, cofactor the normal) on every path: the stack row table and the in-place palette
    /// (> `ROW_TABLE` joints), a partial last block, JOINTS_1 in some blocks only, unweighted
    /// out-of-range joints, and no normals.
    #[test]
    fn lbs_blocks_match_per_vertex_reference() {
        let mut rng = crate::testutil::xorshift(7);
        let mut unit = move || rng() * 2.0 - 1.0;
        for (joints, n) in [(19usize, 3 * BLOCK + 5), (300, 2 * BLOCK + 1), (1, 3), (19, BLOCK)] {
            let palette: Vec<Mat4> = (0..joints)
                .map(|_| {
                    let axis = Vec3::new(unit(), unit(), unit() + 2.0).normalize();
                    Mat4::from_scale_rotation_translation(
                        Vec3::new(1.0 + 0.3 * unit(), 1.0, 1.0 - 0.2 * unit()),
                        Quat::from_axis_angle(axis, 3.0 * unit()),
                        Vec3::new(unit(), unit(), unit()),
                    )
                })
                .collect();
            let positions: Vec<[f32; 3]> = (0..n).map(|_| [unit(), unit(), unit()]).collect();
            let normals: Vec<[f32; 3]> =
                (0..n).map(|_| Vec3::new(unit(), unit(), unit() + 2.0).normalize().to_array()).collect();
            let mut ids = Vec::new();
            let mut weights = Vec::new();
            for v in 0..n {
                let mut j = [0u16; 8];
                let mut w = [0.0f32; 8];
                // JOINTS_1 only in the second block; an unweighted slot may point anywhere.
                let slots = if v / BLOCK == 1 { 8 } else { 4 };
                for k in 0..slots {
                    j[k] = ((unit() * 0.5 + 0.5) * (joints as f32 - 1.0)).round() as u16;
                    w[k] = unit() * 0.5 + 0.5;
                }
                j[slots - 1] = if v % 3 == 0 { 9999 } else { j[slots - 1] };
                if v % 3 == 0 {
                    w[slots - 1] = 0.0;
                }
                let sum: f32 = w.iter().sum();
                w.iter_mut().for_each(|x| *x /= sum.max(1e-6));
                ids.push(j);
                weights.push(w);
            }
            for with_normals in [true, false] {
                let normals = if with_normals { &normals[..] } else { &[] };
                let (out_p, out_n) = lbs(&positions, normals, &ids, &weights, &palette);
                for v in 0..n {
                    let mut m = Mat4::ZERO;
                    for k in 0..8 {
                        if weights[v][k] != 0.0 {
                            m += palette[ids[v][k] as usize] * weights[v][k];
                        }
                    }
                    let p = m.transform_point3(Vec3::from(positions[v]));
                    assert!(
                        Vec3::from(out_p[v]).abs_diff_eq(p, 1e-5),
                        "{joints} joints, vertex {v}: {:?} vs {p}",
                        out_p[v]
                    );
                    if with_normals {
                        let q = transform_normal(&m, Vec3::from(normals[v]));
                        assert!(
                            Vec3::from(out_n[v]).abs_diff_eq(q, 1e-5),
                            "{joints} joints, normal {v}: {:?} vs {q}",
                            out_n[v]
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn lbs_refuses_bad_joints_and_short_outputs() {
        let palette = [Mat4::IDENTITY];
        let mut out = [[0.0; 3]; 1];
        let mut job = LbsJob {
            positions: &[[0.0; 3]],
            normals: &[],
            joints: &[[3, 0, 0, 0, 0, 0, 0, 0]],
            weights: &[[1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]],
            palette: &palette,
            out_positions: &mut out,
            out_normals: &mut [],
        };
        assert!(matches!(job.run(), Err(JobError::IndexOutOfRange { index: 3, .. })));
        let mut job = LbsJob {
            positions: &[[0.0; 3]; 2],
            normals: &[],
            joints: &[[0; 8]; 2],
            weights: &[[0.0; 8]; 2],
            palette: &palette,
            out_positions: &mut out,
            out_normals: &mut [],
        };
        assert!(matches!(job.run(), Err(JobError::BufferTooSmall { .. })));
    }
}

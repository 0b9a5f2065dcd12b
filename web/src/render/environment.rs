//! Image-based lighting: environments as equirectangular HDR images (made in code for the
//! presets, or read from a Radiance `.hdr` file), prefiltered once per device on the GPU
//! (`shaders/ibl.wgsl`) into what `shaders/mesh.wgsl` samples for its ambient light:
//!
//! - a specular chain: [`SPECULAR_LEVELS`] mips of an equirectangular texture
//!   ([`SPECULAR_FORMAT`]: 8-bit RGB with a shared power of two, `encode_radiance`),
//!   level `k` the environment seen through glTF's GGX lobe at roughness `k / (levels − 1)`
//!   (importance sampled, with the source's own mips taken by each sample's solid angle);
//! - diffuse irradiance as nine spherical-harmonic coefficients ([`HdrImage::irradiance_sh`],
//!   summed on the CPU; the frame uniform carries them): the cosine-weighted integral over the
//!   whole environment, divided by π (what a white Lambert surface reflects), with no texture
//!   lookup per pixel;
//! - the split sum's scale and bias on F0 come from Karis's analytic fit, not a table: one
//!   texture lookup per pixel in all, the specular chain's.
//!
//! Directions map to the equirectangular square as `shaders/equirect.wgsl` says: u = 0.5 looks
//! down −Z, u grows towards +X; v = 0 is straight up.
//!
//! Everything stays within WebGL2's limits: 2D textures only, fragment shaders, `rgba16float`
//! render targets for the source's mips (EXT_color_buffer_float, which WebGL2 browsers have)
//! and `rgba8unorm` ones for the chain. Where a device cannot render to `rgba16float`
//! ([`supports_ibl`]) the meshes keep the hemisphere's ambient.

use std::f32::consts::PI;

/// Mips of the specular chain: roughness 0, 0.2, …, 1.
pub const SPECULAR_LEVELS: u32 = 6;
/// Width of the specular chain's first level (its height is half).
pub const SPECULAR_WIDTH: u32 = 256;
/// The widest image the spherical-harmonic irradiance is summed over (wider ones are averaged
/// down first: nine coefficients hold nothing finer).
pub const SH_SOURCE_WIDTH: u32 = 128;
/// The texture format of the environment's source image and its mips (the prefilter's input).
pub const HDR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
/// The texture format of the specular chain: 8-bit RGB with a shared power of two in alpha
/// (`encode_radiance` in shaders/equirect.wgsl). A CPU rasterizer filters it in a fraction of a
/// half-float texel's time (SwiftShader: 11 % of CesiumMan's frame; BENCHMARKS.md, "Frame cost",
/// stop 61), and it takes half the memory.
pub const SPECULAR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;
/// The most pixels an `.hdr` file given to the viewer may have (2048 × 1024).
pub const MAX_HDR_PIXELS: u64 = 2048 * 1024;
/// The largest environment image taken as it is: larger ones are averaged down to this width
/// first (the specular chain's finest level is [`SPECULAR_WIDTH`] wide anyway).
pub const MAX_SOURCE_WIDTH: u32 = 1024;

/// An equirectangular HDR image: linear RGB radiance, row-major, top row first (straight up).
#[derive(Clone, Debug, PartialEq)]
pub struct HdrImage {
    /// Width in pixels (twice the height for a full sphere).
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `width * height` pixels.
    pub rgb: Vec<[f32; 3]>,
}

/// The environments a page names (`environment-image`, model-viewer's attribute): `neutral` is
/// made in code, `studio` and `outdoor` are photographs ([`Photo`]) the page fetches when one is
/// first chosen.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum EnvironmentName {
    /// A light grey room with soft ceiling panels ([`Procedural::Neutral`]).
    #[default]
    Neutral,
    /// A photographer's studio ([`Photo::Studio`]).
    Studio,
    /// A city square under an overcast sky ([`Photo::Outdoor`]).
    Outdoor,
}

impl EnvironmentName {
    /// The names a page may use, in menu order.
    pub const ALL: [EnvironmentName; 3] = [EnvironmentName::Neutral, EnvironmentName::Studio, EnvironmentName::Outdoor];

    /// The page name: `neutral`, `studio`, `outdoor`.
    pub fn name(self) -> &'static str {
        match self {
            EnvironmentName::Neutral => "neutral",
            EnvironmentName::Studio => "studio",
            EnvironmentName::Outdoor => "outdoor",
        }
    }

    /// The environment named `name`.
    ///
    /// # Errors
    /// A message naming the accepted names.
    pub fn from_name(name: &str) -> Result<Self, String> {
        Self::ALL.into_iter().find(|e| e.name() == name).ok_or_else(|| {
            format!("environment {name:?}: expected \"neutral\", \"studio\", \"outdoor\" or the URL of an .hdr image")
        })
    }

    /// What it is made from.
    pub fn builtin(self) -> Builtin {
        match self {
            EnvironmentName::Neutral => Builtin::Procedural(Procedural::Neutral),
            EnvironmentName::Studio => Builtin::Photo(Photo::Studio),
            EnvironmentName::Outdoor => Builtin::Photo(Photo::Outdoor),
        }
    }
}

/// An environment the viewer ships: made in code, or a photograph.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Builtin {
    /// Made in code ([`Procedural::image`]).
    Procedural(Procedural),
    /// A photograph (`web/environments/`: [`crate::photos`]).
    Photo(Photo),
}

impl Builtin {
    /// A name for messages.
    pub fn name(self) -> &'static str {
        match self {
            Builtin::Procedural(p) => p.name(),
            Builtin::Photo(p) => p.name(),
        }
    }
}

/// The photographs the viewer ships (`web/environments/`, Poly Haven, CC0): small Radiance files
/// (256 × 128) the page fetches from beside its module when a viewer first lights with one, and
/// the native build embeds ([`crate::photos`]). Read like any `.hdr` the page gives
/// ([`HdrImage::from_three_layout`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Photo {
    /// Poly Haven's "Studio Small 03": a white studio, softboxes either side.
    Studio,
    /// Poly Haven's "Potsdamer Platz": a city square under an overcast sky.
    Outdoor,
}

impl Photo {
    /// Every photograph.
    pub const ALL: [Photo; 2] = [Photo::Studio, Photo::Outdoor];

    /// The page name (as [`EnvironmentName::name`]).
    pub fn name(self) -> &'static str {
        match self {
            Photo::Studio => "studio",
            Photo::Outdoor => "outdoor",
        }
    }

    /// The file, in `web/environments/` (and `environments/` beside the page's module).
    pub fn file(self) -> &'static str {
        match self {
            Photo::Studio => "studio.hdr",
            Photo::Outdoor => "outdoor.hdr",
        }
    }

    /// Its index in [`Photo::ALL`].
    pub fn index(self) -> usize {
        self as usize
    }
}

/// The environments made in code: the lighting presets' own ([`super::uniforms::Lighting`]),
/// and `neutral`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Procedural {
    /// A light grey room with soft ceiling panels: even light from everywhere, mild
    /// reflections (model-viewer's default look).
    #[default]
    Neutral,
    /// A dark studio with three softboxes (key, fill and rim) over a dark floor.
    Studio,
    /// A blue sky, brighter towards the sun, over brown ground.
    Outdoor,
    /// Light grey everywhere, a little brighter above: textures as authored (the `flat`
    /// lighting preset's).
    Flat,
}

impl Procedural {
    /// Every one (the tests go over them).
    pub const ALL: [Procedural; 4] = [Procedural::Neutral, Procedural::Studio, Procedural::Outdoor, Procedural::Flat];

    /// A name for messages and tests.
    pub fn name(self) -> &'static str {
        match self {
            Procedural::Neutral => "neutral",
            Procedural::Studio => "studio (made in code)",
            Procedural::Outdoor => "outdoor (made in code)",
            Procedural::Flat => "flat",
        }
    }

    /// The environment as an image ([`PROCEDURAL_WIDTH`] × half). Made while a page waits for its
    /// first frame, so each pixel's [`direction`] takes its sines and cosines from its row and
    /// column (the same values), and a light's edge is only evaluated near it ([`SoftBox`]).
    pub fn image(self) -> HdrImage {
        let (w, h) = (PROCEDURAL_WIDTH, PROCEDURAL_WIDTH / 2);
        let columns: Vec<(f32, f32)> = (0..w)
            .map(|x| {
                let phi = ((x as f32 + 0.5) / w as f32 - 0.5) * 2.0 * PI;
                (phi.sin(), phi.cos())
            })
            .collect();
        let lights = self.soft_boxes();
        let mut rgb = Vec::with_capacity((w * h) as usize);
        for y in 0..h {
            let theta = (y as f32 + 0.5) / h as f32 * PI;
            let (st, ct) = (theta.sin(), theta.cos());
            // Away from the lights (and the outdoor sun's glow) a row is one colour: the gradient
            // depends on the height alone, and every light adds exactly 0 there.
            if self != Procedural::Outdoor && !lights.iter().any(|l| l.reaches_row(st, ct)) {
                let (sp, cp) = columns.first().copied().unwrap_or((0.0, 1.0));
                let c = self.radiance([st * sp, ct, -st * cp], &lights);
                rgb.extend(std::iter::repeat_n(c, columns.len()));
                continue;
            }
            for &(sp, cp) in &columns {
                rgb.push(self.radiance([st * sp, ct, -st * cp], &lights));
            }
        }
        HdrImage { width: w, height: h, rgb }
    }

    /// The round lights of this environment (what `radiance` adds over its gradient).
    fn soft_boxes(self) -> Vec<SoftBox> {
        let lights: &[([f32; 3], f32)] = match self {
            // Softboxes: key (upper left of the default view), fill (right), rim (behind, above).
            Procedural::Studio => &[([-0.45, 0.75, 0.5], 0.22), ([0.85, 0.3, 0.45], 0.25), ([0.25, 0.55, -0.8], 0.18)],
            Procedural::Neutral => &[([-0.5, 0.85, 0.2], 0.2), ([0.5, 0.85, -0.2], 0.2), ([0.0, 0.5, 0.86], 0.2)],
            Procedural::Outdoor | Procedural::Flat => &[],
        };
        lights.iter().map(|&(toward, radius)| SoftBox::new(toward, radius)).collect()
    }

    /// Radiance arriving from direction `d` (unit); `lights`: [`Procedural::soft_boxes`].
    fn radiance(self, d: [f32; 3], lights: &[SoftBox]) -> [f32; 3] {
        let up = d[1] * 0.5 + 0.5;
        let mix = |a: [f32; 3], b: [f32; 3], t: f32| [0, 1, 2].map(|k| a[k] + (b[k] - a[k]) * t);
        let add = |a: [f32; 3], b: [f32; 3], s: f32| [0, 1, 2].map(|k| a[k] + b[k] * s);
        let light = |i: usize| lights.get(i).map_or(0.0, |l| l.at(d));
        match self {
            Procedural::Studio => {
                let mut c = mix([0.15, 0.14, 0.13], [0.3, 0.32, 0.35], smooth(0.35, 0.75, up));
                c = add(c, [1.0, 0.97, 0.92], 4.0 * light(0));
                c = add(c, [0.9, 0.95, 1.0], 1.6 * light(1));
                add(c, [1.0, 1.0, 1.0], 3.0 * light(2))
            }
            Procedural::Outdoor => {
                let sky = mix([0.62, 0.68, 0.75], [0.22, 0.36, 0.66], smooth(0.5, 1.0, up));
                let ground = [0.2, 0.16, 0.11];
                let mut c = mix(ground, sky, smooth(0.48, 0.52, up));
                // The glow around the sun (the sun itself is the preset's key light).
                let sun = normalize([0.35, 1.0, 0.25]);
                let toward = dot(d, sun).max(0.0);
                c = add(c, [1.0, 0.9, 0.75], 0.8 * toward.powi(24));
                c
            }
            Procedural::Neutral => {
                let mut c = mix([0.3, 0.3, 0.3], [0.55, 0.55, 0.55], smooth(0.3, 0.8, up));
                for i in 0..3 {
                    c = add(c, [1.0, 1.0, 1.0], 1.5 * light(i));
                }
                c
            }
            Procedural::Flat => mix([0.8; 3], [0.95; 3], up),
        }
    }
}

/// A round light of angular radius `radius` (radians, about) around a direction: 1 inside,
/// fading over its edge.
struct SoftBox {
    /// The unit direction of its centre.
    toward: [f32; 3],
    radius: f32,
    /// Below this cosine a direction is past the edge (by a margin over rounding): 0 there,
    /// without an `acos`.
    outside: f32,
}

impl SoftBox {
    fn new(toward: [f32; 3], radius: f32) -> Self {
        Self { toward: normalize(toward), radius, outside: radius.cos() - 1e-3 }
    }

    /// Whether some direction of the row at polar angle θ (`sin θ`, `cos θ`; every azimuth) may
    /// be lit: the greatest cosine to the centre over the row, `sin θ·|t_xz| + cos θ·t_y`, is
    /// past the edge by less than a margin far over `at`'s rounding.
    fn reaches_row(&self, st: f32, ct: f32) -> bool {
        let [x, y, z] = self.toward;
        st * (x * x + z * z).sqrt() + ct * y >= self.outside - 1e-4
    }

    fn at(&self, d: [f32; 3]) -> f32 {
        let cos = dot(d, self.toward).clamp(-1.0, 1.0);
        if cos < self.outside {
            return 0.0;
        }
        1.0 - smooth(self.radius * 0.7, self.radius, cos.acos())
    }
}

/// Width of the environments made in code.
pub const PROCEDURAL_WIDTH: u32 = 256;

fn dot(a: [f32; 3], b: [f32; 3]) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn normalize(a: [f32; 3]) -> [f32; 3] {
    let l = dot(a, a).sqrt();
    a.map(|c| c / l)
}

fn smooth(e0: f32, e1: f32, x: f32) -> f32 {
    let t = ((x - e0) / (e1 - e0)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// The unit direction of equirectangular coordinates `(u, v)` (`shaders/equirect.wgsl`).
pub fn direction(u: f32, v: f32) -> [f32; 3] {
    let phi = (u - 0.5) * 2.0 * PI;
    let theta = v * PI;
    [theta.sin() * phi.sin(), theta.cos(), -theta.sin() * phi.cos()]
}

impl HdrImage {
    /// The cosine-weighted irradiance over π arriving at a surface facing `n`, summed over every
    /// pixel (the reference [`HdrImage::irradiance_sh`] is tested against; calibration).
    pub fn irradiance(&self, n: [f32; 3]) -> [f32; 3] {
        let mut sum = [0.0f32; 3];
        let (w, h) = (self.width as usize, self.height as usize);
        for y in 0..h {
            let v = (y as f32 + 0.5) / h as f32;
            let solid = (2.0 * PI / w as f32) * (PI / h as f32) * (v * PI).sin();
            for x in 0..w {
                let d = direction((x as f32 + 0.5) / w as f32, v);
                let c = dot(n, d).max(0.0) * solid;
                let p = self.rgb[y * w + x];
                for k in 0..3 {
                    sum[k] += p[k] * c;
                }
            }
        }
        sum.map(|s| s / PI)
    }

    /// This image averaged down (2×2 boxes) until it is at most [`MAX_SOURCE_WIDTH`] wide.
    pub fn fitted(mut self) -> Self {
        while self.width > MAX_SOURCE_WIDTH && self.height >= 2 {
            let (w, h) = (self.width as usize / 2, self.height as usize / 2);
            let src = self.width as usize;
            let mut rgb = Vec::with_capacity(w * h);
            for y in 0..h {
                for x in 0..w {
                    let at = |dx: usize, dy: usize| self.rgb[(2 * y + dy) * src + 2 * x + dx];
                    let (a, b, c, d) = (at(0, 0), at(1, 0), at(0, 1), at(1, 1));
                    rgb.push([0, 1, 2].map(|k| 0.25 * (a[k] + b[k] + c[k] + d[k])));
                }
            }
            self = HdrImage { width: w as u32, height: h as u32, rgb };
        }
        self
    }

    /// The irradiance over π ([`HdrImage::irradiance`]) as nine spherical-harmonic coefficients
    /// (bands 0–2, Ramamoorthi and Hanrahan 2001), each with its basis constant and its band's
    /// cosine-lobe factor folded in: the irradiance at a unit normal `n` (environment frame) is
    /// `c0 + c1·y + c2·z + c3·x + c4·xy + c5·yz + c6·(3z² − 1) + c7·xz + c8·(x² − y²)`
    /// ([`irradiance_from_sh`]; `shaders/mesh.wgsl` evaluates the same). Summed over blocks of
    /// pixels, at most [`SH_SOURCE_WIDTH`] across (nine coefficients need no more).
    pub fn irradiance_sh(&self) -> [[f32; 3]; 9] {
        // Blocks of `step`² pixels, each summed and projected at its centre (no copy of the
        // image is made). Each pixel is taken as the GPU takes it: capped at the half float's
        // largest value, non-finite as 0 (an .hdr may hold values that would overflow the sums).
        let (width, height) = (self.width as usize, self.height as usize);
        let step = (self.width / SH_SOURCE_WIDTH).max(1) as usize;
        let taken = |c: f32| f64::from(if c.is_finite() { c.clamp(0.0, 65504.0) } else { 0.0 });
        // Each block's direction as `direction` gives it, its sines and cosines taken once per
        // row and column of blocks (the same values).
        let columns: Vec<(f32, f32)> = (0..width)
            .step_by(step)
            .map(|x0| {
                let u = 0.5 * (x0 + (x0 + step).min(width)) as f32 / width as f32;
                let phi = (u - 0.5) * 2.0 * PI;
                (phi.sin(), phi.cos())
            })
            .collect();
        let mut sum = [[0.0f64; 3]; 9];
        for y0 in (0..height).step_by(step) {
            let y1 = (y0 + step).min(height);
            let v = 0.5 * (y0 + y1) as f32 / height as f32;
            let theta = v * PI;
            let (st, ct) = (theta.sin(), theta.cos());
            for (&(sp, cp), x0) in columns.iter().zip((0..width).step_by(step)) {
                let x1 = (x0 + step).min(width);
                let mut block = [0.0f64; 3];
                for y in y0..y1 {
                    for p in self.rgb.get(y * width + x0..y * width + x1).unwrap_or_default() {
                        block[0] += taken(p[0]);
                        block[1] += taken(p[1]);
                        block[2] += taken(p[2]);
                    }
                }
                // One pixel's solid angle at the block's latitude (the block holds their sum).
                let solid = f64::from((2.0 * PI / width as f32) * (PI / height as f32) * st);
                let basis = sh_basis([st * sp, ct, -st * cp]);
                for (s, b) in sum.iter_mut().zip(basis) {
                    for k in 0..3 {
                        s[k] += block[k] * f64::from(b) * solid;
                    }
                }
            }
        }
        // Irradiance = Σ A_l L_lm Y_lm with A = π, 2π/3, π/4 by band; over π: 1, 2/3, 1/4. The
        // basis constants are folded in too, so the shader multiplies by bare polynomials.
        let mut out = [[0.0f32; 3]; 9];
        for (i, (o, s)) in out.iter_mut().zip(sum).enumerate() {
            let factor = SH_BAND_FACTOR[i] * SH_CONSTANT[i];
            *o = s.map(|c| (c * f64::from(factor)) as f32);
        }
        out
    }

    /// This image as an environment: an equirectangular image is twice as wide as it is tall.
    ///
    /// # Errors
    /// A message giving the size, for any other shape.
    pub fn check_equirectangular(&self) -> Result<(), String> {
        if self.width < 2 || self.width != 2 * self.height || self.rgb.len() != (self.width * self.height) as usize {
            return Err(format!(
                "{}×{} pixels: an equirectangular environment is twice as wide as it is tall",
                self.width, self.height
            ));
        }
        Ok(())
    }

    /// An image laid out as three.js and model-viewer read equirectangular files (their u = 0.5
    /// looks along +X; Kloub's along −Z), turned to Kloub's: the same file lights a model from
    /// the same side in both. Column `x` of the result is column `x − width / 4` of the file.
    pub fn from_three_layout(&self) -> Self {
        let (w, h) = (self.width as usize, self.height as usize);
        let mut rgb = Vec::with_capacity(self.rgb.len());
        for y in 0..h {
            for x in 0..w {
                rgb.push(self.rgb.get(y * w + (x + w - w / 4) % w.max(1)).copied().unwrap_or_default());
            }
        }
        Self { width: self.width, height: self.height, rgb }
    }

    /// Kloub's layout as three.js reads equirectangular files (the inverse of
    /// [`HdrImage::from_three_layout`]).
    pub fn to_three_layout(&self) -> Self {
        let (w, h) = (self.width as usize, self.height as usize);
        let mut rgb = Vec::with_capacity(self.rgb.len());
        for y in 0..h {
            for x in 0..w {
                rgb.push(self.rgb.get(y * w + (x + w / 4) % w.max(1)).copied().unwrap_or_default());
            }
        }
        Self { width: self.width, height: self.height, rgb }
    }

    /// RGBA half floats for an [`HDR_FORMAT`] texture (alpha 1; values beyond half's range
    /// clamped to its largest).
    pub fn rgba16f(&self) -> Vec<u16> {
        let one = f32_to_f16(1.0);
        let mut out = Vec::with_capacity(self.rgb.len() * 4);
        // A run of equal pixels (the environments made in code are mostly such rows) is
        // converted once.
        let mut last: Option<([f32; 3], [u16; 4])> = None;
        for &p in &self.rgb {
            let half = match last {
                Some((q, half))
                    if q[0].to_bits() == p[0].to_bits()
                        && q[1].to_bits() == p[1].to_bits()
                        && q[2].to_bits() == p[2].to_bits() =>
                {
                    half
                }
                _ => [f32_to_f16(p[0]), f32_to_f16(p[1]), f32_to_f16(p[2]), one],
            };
            last = Some((p, half));
            out.extend_from_slice(&half);
        }
        out
    }
}

/// The real spherical-harmonic basis constants of bands 0–2 (`Y_lm = constant × polynomial`).
const SH_CONSTANT: [f32; 9] =
    [0.282_095, 0.488_603, 0.488_603, 0.488_603, 1.092_548, 1.092_548, 0.315_392, 1.092_548, 0.546_274];
/// The cosine lobe's band factors over π (A_l / π: 1, 2/3, 1/4), per coefficient.
const SH_BAND_FACTOR: [f32; 9] = [1.0, 2.0 / 3.0, 2.0 / 3.0, 2.0 / 3.0, 0.25, 0.25, 0.25, 0.25, 0.25];

/// The polynomials of the basis at unit direction `d` (the constants apart): 1, y, z, x, xy,
/// yz, 3z² − 1, xz, x² − y².
fn sh_polynomials(d: [f32; 3]) -> [f32; 9] {
    let [x, y, z] = d;
    [1.0, y, z, x, x * y, y * z, 3.0 * z * z - 1.0, x * z, x * x - y * y]
}

/// The basis `Y_lm` of bands 0–2 at unit direction `d`.
fn sh_basis(d: [f32; 3]) -> [f32; 9] {
    let p = sh_polynomials(d);
    std::array::from_fn(|i| p[i] * SH_CONSTANT[i])
}

/// The irradiance over π at unit normal `n` from [`HdrImage::irradiance_sh`]'s coefficients
/// (what `shaders/mesh.wgsl`'s `sh_irradiance` computes).
pub fn irradiance_from_sh(sh: &[[f32; 3]; 9], n: [f32; 3]) -> [f32; 3] {
    let p = sh_polynomials(n);
    let mut out = [0.0f32; 3];
    for (c, w) in sh.iter().zip(p) {
        for k in 0..3 {
            out[k] += c[k] * w;
        }
    }
    out.map(|c| c.max(0.0))
}

/// `x` as an IEEE half float, rounded to nearest even; negative and NaN become 0 (radiance),
/// too large the largest half.
pub fn f32_to_f16(x: f32) -> u16 {
    if x.is_nan() || x <= 0.0 {
        return 0;
    }
    if x >= 65504.0 {
        return 0x7bff;
    }
    let bits = x.to_bits();
    let exp = ((bits >> 23) & 0xff) as i32 - 127 + 15;
    let mantissa = bits & 0x7f_ffff;
    if exp <= 0 {
        // Subnormal half (or zero): shift the implicit 1 in.
        if exp < -10 {
            return 0;
        }
        let m = mantissa | 0x80_0000;
        let shift = (14 - exp) as u32;
        let half = m >> shift;
        let rest = m & ((1 << shift) - 1);
        let midpoint = 1 << (shift - 1);
        let round = u32::from(rest > midpoint || (rest == midpoint && half & 1 == 1));
        return (half + round) as u16;
    }
    let half = ((exp as u32) << 10) | (mantissa >> 13);
    let rest = mantissa & 0x1fff;
    let round = u32::from(rest > 0x1000 || (rest == 0x1000 && half & 1 == 1));
    // A carry out of the mantissa steps the exponent, as it should (up to 0x7c00 is excluded
    // by the range check above: 65504 is the largest value that rounds below infinity).
    (half + round).min(0x7bff) as u16
}

/// Reads an environment file as the page's `.hdr` images and the shipped photographs are read:
/// parsed, checked to be a whole sphere, turned from the usual layout into Kloub's
/// ([`HdrImage::from_three_layout`]) and averaged down where wide ([`HdrImage::fitted`]).
///
/// # Errors
/// The file is not an equirectangular Radiance image within [`MAX_HDR_PIXELS`].
pub fn read_environment(bytes: &[u8]) -> Result<HdrImage, String> {
    let image = parse_hdr(bytes, MAX_HDR_PIXELS)?;
    image.check_equirectangular()?;
    Ok(image.from_three_layout().fitted())
}

/// Reads a Radiance RGBE (`.hdr`) file: the `#?RADIANCE`/`#?RGBE` header, `FORMAT=32-bit_rle_rgbe`,
/// the `-Y h +X w` resolution line, then flat or run-length-encoded scanlines. The size is
/// checked against `max_pixels` before anything is allocated.
///
/// # Errors
/// A message naming what is wrong (not an HDR file, an unsupported orientation or format, a
/// scanline cut short).
pub fn parse_hdr(bytes: &[u8], max_pixels: u64) -> Result<HdrImage, String> {
    if !(bytes.starts_with(b"#?RADIANCE") || bytes.starts_with(b"#?RGBE")) {
        return Err("not a Radiance .hdr file (no #?RADIANCE line)".into());
    }
    let mut at = 0;
    let mut line = || -> Result<&[u8], String> {
        let rest = bytes.get(at..).ok_or("the header is cut short")?;
        let end = rest.iter().position(|&b| b == b'\n').ok_or("the header is cut short")?;
        at += end + 1;
        Ok(&rest[..end])
    };
    line()?;
    loop {
        let l = line()?;
        if l.is_empty() {
            break;
        }
        if let Some(format) = l.strip_prefix(b"FORMAT=")
            && format.trim_ascii() != b"32-bit_rle_rgbe"
        {
            return Err(format!("format {:?} is not supported (32-bit_rle_rgbe is)", String::from_utf8_lossy(format)));
        }
    }
    let size = String::from_utf8_lossy(line()?).into_owned();
    let parts: Vec<&str> = size.split_whitespace().collect();
    let (height, width) = match parts.as_slice() {
        ["-Y", h, "+X", w] => (h.parse::<u32>().ok(), w.parse::<u32>().ok()),
        _ => return Err(format!("resolution {size:?} is not supported (-Y height +X width is)")),
    };
    let (Some(height), Some(width)) = (height, width) else {
        return Err(format!("resolution {size:?} is not two numbers"));
    };
    if width == 0 || height == 0 || u64::from(width) * u64::from(height) > max_pixels {
        return Err(format!("{width}×{height} pixels: at most {max_pixels} are read"));
    }
    let (w, h) = (width as usize, height as usize);
    let mut rgb = Vec::with_capacity(w * h);
    let mut scan = vec![[0u8; 4]; w];
    let cut = "a scanline is cut short";
    for _ in 0..h {
        let head = bytes.get(at..at + 4).ok_or(cut)?;
        let rle = (8..32768).contains(&w) && head[0] == 2 && head[1] == 2 && head[2] & 0x80 == 0;
        if rle {
            if (usize::from(head[2]) << 8 | usize::from(head[3])) != w {
                return Err("a run-length scanline's width differs from the image's".into());
            }
            at += 4;
            for channel in 0..4 {
                let mut x = 0;
                while x < w {
                    let count = *bytes.get(at).ok_or(cut)?;
                    at += 1;
                    if count > 128 {
                        let run = usize::from(count - 128);
                        let value = *bytes.get(at).ok_or(cut)?;
                        at += 1;
                        let span = scan.get_mut(x..x + run).ok_or("a run goes past the scanline")?;
                        span.iter_mut().for_each(|p| p[channel] = value);
                        x += run;
                    } else {
                        let run = usize::from(count);
                        if run == 0 {
                            return Err("a run of length 0".into());
                        }
                        let values = bytes.get(at..at + run).ok_or(cut)?;
                        at += run;
                        let span = scan.get_mut(x..x + run).ok_or("a run goes past the scanline")?;
                        span.iter_mut().zip(values).for_each(|(p, &v)| p[channel] = v);
                        x += run;
                    }
                }
            }
        } else {
            // Flat scanline (old-style run-length files are not supported).
            for p in scan.iter_mut() {
                let b = bytes.get(at..at + 4).ok_or(cut)?;
                *p = [b[0], b[1], b[2], b[3]];
                at += 4;
            }
        }
        rgb.extend(scan.iter().map(|&[r, g, b, e]| {
            if e == 0 {
                [0.0; 3]
            } else {
                let scale = 2f32.powi(i32::from(e) - 136);
                [f32::from(r) * scale, f32::from(g) * scale, f32::from(b) * scale]
            }
        }));
    }
    Ok(HdrImage { width, height, rgb })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_file_that_is_not_an_environment_is_refused() {
        assert!(read_environment(b"not an image").expect_err("refused").contains("Radiance"));
        // A Radiance file, but square: not a whole sphere.
        let mut square = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 8 +X 8\n".to_vec();
        square.extend(std::iter::repeat_n([128u8, 128, 128, 129], 64).flatten());
        assert!(read_environment(&square).expect_err("refused").contains("twice as wide"));
    }

    #[test]
    fn procedural_images_are_exactly_the_per_pixel_formula() {
        for name in Procedural::ALL {
            let image = name.image();
            let (w, h) = (image.width, image.height);
            let lights = name.soft_boxes();
            for y in 0..h {
                for x in 0..w {
                    let d = direction((x as f32 + 0.5) / w as f32, (y as f32 + 0.5) / h as f32);
                    let got = image.rgb[(y * w + x) as usize];
                    assert_eq!(got.map(f32::to_bits), name.radiance(d, &lights).map(f32::to_bits), "{x},{y}");
                    // Each light as the formula has it: the acos of every direction, no shortcut.
                    for l in &lights {
                        let angle = dot(d, l.toward).clamp(-1.0, 1.0).acos();
                        let exact = 1.0 - smooth(l.radius * 0.7, l.radius, angle);
                        assert_eq!(l.at(d).to_bits(), exact.to_bits(), "{x},{y}");
                    }
                }
            }
        }
    }

    #[test]
    fn directions_match_the_shader_convention() {
        let close = |a: [f32; 3], b: [f32; 3]| (0..3).all(|k| (a[k] - b[k]).abs() < 1e-6);
        assert!(close(direction(0.5, 0.5), [0.0, 0.0, -1.0]));
        assert!(close(direction(0.75, 0.5), [1.0, 0.0, 0.0]));
        assert!(close(direction(0.0, 0.5), [0.0, 0.0, 1.0]));
        assert!(close(direction(0.3, 0.0), [0.0, 1.0, 0.0]));
    }

    #[test]
    fn half_float_images_convert_every_pixel() {
        // Runs of equal pixels are converted once: the same halves as pixel by pixel, for the
        // environments made in code (mostly such runs) and an image whose neighbours differ,
        // including -0.0 beside 0.0 and NaNs.
        let mut mixed = Procedural::Studio.image();
        for (i, p) in mixed.rgb.iter_mut().enumerate().step_by(7) {
            *p = [[0.0, -0.0, f32::NAN], [1e-6, 70000.0, 0.3], [0.0; 3]][i % 3];
        }
        for image in Procedural::ALL.into_iter().map(Procedural::image).chain([mixed]) {
            let each: Vec<u16> =
                image.rgb.iter().flat_map(|p| [f32_to_f16(p[0]), f32_to_f16(p[1]), f32_to_f16(p[2]), 0x3c00]).collect();
            assert_eq!(image.rgba16f(), each);
        }
    }

    #[test]
    fn half_floats_round_like_ieee() {
        assert_eq!(f32_to_f16(1.0), 0x3c00);
        assert_eq!(f32_to_f16(0.5), 0x3800);
        assert_eq!(f32_to_f16(65504.0), 0x7bff);
        assert_eq!(f32_to_f16(1e9), 0x7bff);
        assert_eq!(f32_to_f16(-3.0), 0);
        assert_eq!(f32_to_f16(f32::NAN), 0);
        // The smallest subnormal half, and half of it (rounds to even: 0).
        assert_eq!(f32_to_f16(5.960_464_5e-8), 1);
        assert_eq!(f32_to_f16(2.980_232_2e-8), 0);
        // 1 + 2^-11 is halfway between 1 and the next half: ties to even (1).
        assert_eq!(f32_to_f16(1.0 + 2f32.powi(-11)), 0x3c00);
        assert_eq!(f32_to_f16(1.0 + 3.0 * 2f32.powi(-11)), 0x3c02);
        assert_eq!(f32_to_f16(0.1), 0x2e66);
    }

    /// The nine coefficients give the irradiance the full sum gives: within a few percent of the
    /// brightest direction's for the environments made in code, and within the bound that
    /// Ramamoorthi and Hanrahan give for any lighting (band-2 truncation loses at most ~9 % of
    /// a point light's irradiance) for a small bright patch, the hardest case.
    #[test]
    fn spherical_harmonics_give_the_irradiance_of_the_full_sum() {
        let mut patch = HdrImage { width: 64, height: 32, rgb: vec![[0.05; 3]; 64 * 32] };
        for y in 6..9 {
            for x in 40..43 {
                patch.rgb[y * 64 + x] = [40.0, 30.0, 20.0];
            }
        }
        let mut failures = Vec::new();
        let images = Procedural::ALL.into_iter().map(|n| (n.name(), n.image()));
        for (name, image) in images.chain([("bright patch", patch)]) {
            let sh = image.irradiance_sh();
            let mut worst = 0.0f32;
            let mut peak = 0.0f32;
            for i in 0..64 {
                // Normals spread over the sphere (a Fibonacci spiral).
                let z = 1.0 - (i as f32 + 0.5) / 32.0;
                let r = (1.0 - z * z).max(0.0).sqrt();
                let phi = i as f32 * 2.399_963;
                let n = [r * phi.cos(), z, r * phi.sin()];
                let (exact, fit) = (image.irradiance(n), irradiance_from_sh(&sh, n));
                for k in 0..3 {
                    worst = worst.max((exact[k] - fit[k]).abs());
                    peak = peak.max(exact[k]);
                }
            }
            let relative = worst / peak.max(1e-6);
            eprintln!("{name}: largest difference {worst:.4} ({:.1} % of the brightest)", relative * 100.0);
            let bound = if name == "bright patch" { 0.12 } else { 0.05 };
            failures.extend((relative > bound).then(|| format!("{name}: {relative}")));
        }
        assert!(failures.is_empty(), "{failures:?}");
    }

    /// Values an .hdr file may hold but a half float cannot (and non-finite ones) give finite
    /// coefficients: capped as the GPU's copy of the image is.
    #[test]
    fn spherical_harmonics_of_extreme_values_stay_finite() {
        let mut image = HdrImage { width: 512, height: 256, rgb: vec![[1.0e38; 3]; 512 * 256] };
        image.rgb[7] = [f32::INFINITY, f32::NAN, -1.0];
        let sh = image.irradiance_sh();
        assert!(sh.iter().flatten().all(|c| c.is_finite()), "{sh:?}");
        let up = irradiance_from_sh(&sh, [0.0, 1.0, 0.0]);
        assert!((up[0] / 65504.0 - 1.0).abs() < 0.05, "a uniform environment at the cap lights at the cap: {up:?}");
    }

    /// The environments light about as the hemispheres they replace did: what a white surface
    /// facing up and facing down reflects, per preset.
    #[test]
    fn procedural_environments_light_like_the_hemispheres() {
        let luma = |c: [f32; 3]| 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2];
        let mut failures = Vec::new();
        for (name, up, down) in [
            (Procedural::Studio, 0.45, 0.14),
            (Procedural::Outdoor, 0.45, 0.2),
            (Procedural::Neutral, 0.62, 0.32),
            (Procedural::Flat, 0.92, 0.83),
        ] {
            let image = name.image();
            let (u, d) = (luma(image.irradiance([0.0, 1.0, 0.0])), luma(image.irradiance([0.0, -1.0, 0.0])));
            eprintln!("{}: up {u:.3}, down {d:.3}", name.name());
            failures.extend(
                (((u / up - 1.0).abs() > 0.2) || ((d / down - 1.0).abs() > 0.25))
                    .then(|| format!("{}: up {u}, down {d}, expected about {up} and {down}", name.name())),
            );
        }
        assert!(failures.is_empty(), "{failures:?}");
    }

    fn rgbe(value: [f32; 3]) -> [u8; 4] {
        let m = value.iter().copied().fold(0.0f32, f32::max);
        if m < 1e-32 {
            return [0; 4];
        }
        let e = m.log2().floor() as i32 + 1;
        let scale = 256.0 / 2f32.powi(e);
        [(value[0] * scale) as u8, (value[1] * scale) as u8, (value[2] * scale) as u8, (e + 128) as u8]
    }

    #[test]
    fn hdr_files_read_flat_and_run_length_encoded() {
        let header =
            |w: u32, h: u32| format!("#?RADIANCE\nFORMAT=32-bit_rle_rgbe\nEXPOSURE=1\n\n-Y {h} +X {w}\n").into_bytes();
        // Flat: 2×1.
        let mut flat = header(2, 1);
        flat.extend(rgbe([1.0, 0.5, 0.25]));
        flat.extend(rgbe([4.0, 0.0, 2.0]));
        let image = parse_hdr(&flat, 1 << 20).expect("flat");
        assert_eq!((image.width, image.height), (2, 1));
        assert_eq!(image.rgb, [[1.0, 0.5, 0.25], [4.0, 0.0, 2.0]]);
        // Run-length: 8×1, channel by channel: a run of 8 (R), literals (G), runs (B, E).
        let mut rle = header(8, 1);
        rle.extend([2, 2, 0, 8]);
        rle.extend([128 + 8, 128]);
        rle.extend([8, 0, 32, 64, 96, 128, 160, 192, 224]);
        rle.extend([128 + 4, 0, 128 + 4, 255]);
        rle.extend([128 + 8, 129]);
        let image = parse_hdr(&rle, 1 << 20).expect("run-length");
        assert_eq!(image.rgb[0], [1.0, 0.0, 0.0]);
        assert_eq!(image.rgb[7], [1.0, 1.75, 255.0 / 128.0]);
        // Refused: not HDR, a bad size, too large, cut short, a run past the end.
        assert!(parse_hdr(b"P6\n1 1\n255\n", 100).expect_err("refused").contains("not a Radiance"));
        assert!(parse_hdr(b"not an image", 100).expect_err("refused").contains("not a Radiance"));
        let mut wrong = header(2, 1);
        wrong.truncate(wrong.len() - "-Y 1 +X 2\n".len());
        wrong.extend(b"+Y 1 +X 2\n");
        assert!(parse_hdr(&wrong, 100).expect_err("refused").contains("not supported"));
        assert!(parse_hdr(&header(4096, 4096), 1 << 20).expect_err("refused").contains("at most"));
        assert!(parse_hdr(&flat[..flat.len() - 2], 100).expect_err("refused").contains("cut short"));
        let mut past = header(8, 1);
        past.extend([2, 2, 0, 8, 128 + 9, 1]);
        assert!(parse_hdr(&past, 100).expect_err("refused").contains("past"));
        // Never a panic on any prefix of a valid file.
        for n in 0..rle.len() {
            let _ = parse_hdr(&rle[..n], 100);
        }
    }

    #[test]
    fn environments_are_equirectangular_and_turn_to_three_js_layout_and_back() {
        let image = Procedural::Studio.image();
        assert!(image.check_equirectangular().is_ok());
        assert_eq!(image.to_three_layout().from_three_layout(), image);
        // three.js's u = 0.5 looks along +X: Kloub's u = 0.75.
        let three = image.to_three_layout();
        let (w, h) = (image.width as usize, image.height as usize);
        let row = h / 2;
        assert_eq!(three.rgb[row * w + w / 2], image.rgb[row * w + 3 * w / 4]);
        for (w, h) in [(64u32, 64u32), (1, 1), (2048 * 1024, 1), (128, 16384)] {
            let wrong = HdrImage { width: w, height: h, rgb: vec![[0.0; 3]; (w * h) as usize] };
            assert!(wrong.check_equirectangular().is_err(), "{w}×{h}");
        }
    }

    #[test]
    fn large_images_are_averaged_down() {
        let image = HdrImage { width: 2048, height: 1024, rgb: vec![[2.0, 1.0, 0.5]; 2048 * 1024] }.fitted();
        assert_eq!((image.width, image.height), (MAX_SOURCE_WIDTH, MAX_SOURCE_WIDTH / 2));
        assert!(image.rgb.iter().all(|&p| p == [2.0, 1.0, 0.5]));
    }
}

/// Whether `adapter` can prefilter environments: it renders to and filters [`HDR_FORMAT`].
pub fn supports_ibl(adapter: &wgpu::Adapter) -> bool {
    let features = adapter.get_texture_format_features(HDR_FORMAT);
    features.allowed_usages.contains(wgpu::TextureUsages::RENDER_ATTACHMENT)
        && features.flags.contains(wgpu::TextureFormatFeatureFlags::FILTERABLE)
}

/// `Prefilter` in ibl.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct PrefilterUniform {
    params: [f32; 4],
}

/// GGX samples per texel of the specular chain.
const SAMPLES: f32 = 128.0;

/// The prefiltering pipeline of one device (built on first use, shared by every viewer of the
/// device with the kit).
pub struct IblKit {
    layout: wgpu::BindGroupLayout,
    specular: wgpu::RenderPipeline,
    /// The sampler of the prefiltered textures: linear with mips, wrapping around in u.
    sampler: wgpu::Sampler,
    mips: super::texture::MipMaker,
}

/// An environment ready to light meshes: its bind group ([`super::pipelines::Layouts::environment`])
/// and its diffuse irradiance ([`HdrImage::irradiance_sh`], for the frame uniform).
#[derive(Clone)]
pub struct GpuEnvironment {
    /// Group 3 of the mesh pipelines.
    pub bind_group: wgpu::BindGroup,
    /// The irradiance's spherical-harmonic coefficients (rgb; w unused).
    pub irradiance: [[f32; 4]; 9],
    /// The specular chain ([`SPECULAR_FORMAT`]; tests read it back); `None` on a device
    /// without [`IblKit`].
    pub specular: Option<wgpu::Texture>,
}

fn environment_texture(
    device: &wgpu::Device,
    label: &str,
    format: wgpu::TextureFormat,
    width: u32,
    height: u32,
    mips: u32,
    usage: wgpu::TextureUsages,
) -> wgpu::Texture {
    device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d { width, height, depth_or_array_layers: 1 },
        mip_level_count: mips,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage,
        view_formats: &[],
    })
}

fn mip_view(texture: &wgpu::Texture, mip: u32) -> wgpu::TextureView {
    texture.create_view(&wgpu::TextureViewDescriptor {
        label: Some("kloub ibl level"),
        base_mip_level: mip,
        mip_level_count: Some(1),
        ..Default::default()
    })
}

impl IblKit {
    /// Compiles ibl.wgsl; `None` where the device cannot render [`HDR_FORMAT`] ([`supports_ibl`]).
    pub fn new(device: &wgpu::Device, adapter_supports: bool) -> Option<Self> {
        if !adapter_supports {
            return None;
        }
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("kloub ibl.wgsl"),
            source: super::pipelines::shader_source!(super::pipelines::IBL_WGSL),
        });
        let f = wgpu::ShaderStages::FRAGMENT;
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("kloub ibl"),
            entries: &[
                super::pipelines::uniform_entry(0, f, size_of::<PrefilterUniform>(), false),
                super::pipelines::texture_entry(1, f, wgpu::TextureSampleType::Float { filterable: true }),
                super::pipelines::sampler_entry(2, f, wgpu::SamplerBindingType::Filtering),
            ],
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("kloub ibl"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let specular = super::pipelines::fill_pipeline(
            device,
            "fs_specular",
            &pipeline_layout,
            &module,
            ("vs_full", "fs_specular"),
            SPECULAR_FORMAT,
        );
        let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("kloub environment"),
            address_mode_u: wgpu::AddressMode::Repeat,
            address_mode_v: wgpu::AddressMode::ClampToEdge,
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            mipmap_filter: wgpu::MipmapFilterMode::Linear,
            ..Default::default()
        });
        let mips = super::texture::MipMaker::new(device, HDR_FORMAT);
        Some(Self { layout, specular, sampler, mips })
    }

    /// One full-screen pass of `pipeline` from `source` into `target` with `params`.
    fn pass(
        &self,
        device: &wgpu::Device,
        encoder: &mut wgpu::CommandEncoder,
        pipeline: &wgpu::RenderPipeline,
        source: &wgpu::TextureView,
        target: &wgpu::TextureView,
        params: [f32; 4],
    ) {
        use wgpu::util::DeviceExt;
        let uniform = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("kloub prefilter"),
            contents: bytemuck::bytes_of(&PrefilterUniform { params }),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("kloub prefilter"),
            layout: &self.layout,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: uniform.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::TextureView(source) },
                wgpu::BindGroupEntry { binding: 2, resource: wgpu::BindingResource::Sampler(&self.sampler) },
            ],
        });
        let mut pass = super::pipelines::fill_pass(encoder, "kloub prefilter", target);
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, &bind_group, &[]);
        pass.draw(0..3, 0..1);
    }

    /// Prefilters `image` (fitted to [`MAX_SOURCE_WIDTH`] first) into an environment whose
    /// bind group has the layout `layout`.
    pub fn environment(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        layout: &wgpu::BindGroupLayout,
        image: &HdrImage,
    ) -> Result<GpuEnvironment, String> {
        let max = device.limits().max_texture_dimension_2d;
        let fitted;
        let image = if image.width > MAX_SOURCE_WIDTH.min(max) {
            fitted = image.clone().fitted();
            &fitted
        } else {
            image
        };
        image.check_equirectangular()?;
        let (width, height) = (image.width, image.height);
        if width > max || height > max {
            return Err(format!("{width}×{height} pixels: this device takes at most {max}×{max}"));
        }
        let levels = super::texture::mip_count(width, height);
        let source = environment_texture(
            device,
            "kloub environment source",
            HDR_FORMAT,
            width,
            height,
            levels,
            super::texture::GPU_MIPPED,
        );
        queue.write_texture(
            source.as_image_copy(),
            bytemuck::cast_slice(&image.rgba16f()),
            wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(width * 8), rows_per_image: Some(height) },
            wgpu::Extent3d { width, height, depth_or_array_layers: 1 },
        );
        self.mips.generate(device, queue, &source);
        let source_view = source.create_view(&wgpu::TextureViewDescriptor::default());
        // Copied from by tests (`GpuEnvironment::specular`).
        let usage = wgpu::TextureUsages::TEXTURE_BINDING
            | wgpu::TextureUsages::RENDER_ATTACHMENT
            | wgpu::TextureUsages::COPY_SRC;
        let specular = environment_texture(
            device,
            "kloub environment specular",
            SPECULAR_FORMAT,
            SPECULAR_WIDTH,
            SPECULAR_WIDTH / 2,
            SPECULAR_LEVELS,
            usage,
        );
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("kloub ibl") });
        let source_levels = levels as f32;
        for level in 0..SPECULAR_LEVELS {
            let roughness = level as f32 / (SPECULAR_LEVELS - 1) as f32;
            // Level 0 copies the source at its own resolution: the source mip as wide as it.
            let lod = ((width as f32) / (SPECULAR_WIDTH as f32)).log2().max(0.0);
            let params = if level == 0 {
                [0.0, lod, source_levels, width as f32]
            } else {
                [roughness, SAMPLES, source_levels, width as f32]
            };
            self.pass(device, &mut encoder, &self.specular, &source_view, &mip_view(&specular, level), params);
        }
        queue.submit([encoder.finish()]);
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("kloub environment"),
            layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: wgpu::BindingResource::TextureView(&specular.create_view(&Default::default())),
                },
                wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::Sampler(&self.sampler) },
            ],
        });
        let irradiance = image.irradiance_sh().map(|[r, g, b]| [r, g, b, 0.0]);
        Ok(GpuEnvironment { bind_group, irradiance, specular: Some(specular) })
    }
}

/// The bind group of meshes on a device without [`IblKit`]: `white` as the specular chain (the
/// shader reads it not: `Frame.environment.z` is 0, the hemisphere lights instead).
pub fn fallback_environment(
    device: &wgpu::Device,
    layout: &wgpu::BindGroupLayout,
    white: &wgpu::TextureView,
) -> GpuEnvironment {
    let sampler =
        device.create_sampler(&wgpu::SamplerDescriptor { label: Some("kloub no environment"), ..Default::default() });
    let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("kloub no environment"),
        layout,
        entries: &[
            wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(white) },
            wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::Sampler(&sampler) },
        ],
    });
    GpuEnvironment { bind_group, irradiance: [[0.0; 4]; 9], specular: None }
}

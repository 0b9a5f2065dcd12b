// Makes the environments `environment-image="studio"` and `"outdoor"` light with (web/environments/*.hdr)
// from Poly Haven photographs (CC0) as the npm package @pmndrs/assets ships them (512×256 OpenEXR, DWAB): decoded
// with three.js's EXRLoader (a dev dependency), averaged down to WIDTH × WIDTH/2 and written as run-length encoded
// Radiance files, the format Kloub reads for any `environment-image` URL. Run by hand when they change:
//   node scripts/environments.mjs
// The package is fetched with `npm pack` into a temporary folder (it is not a dependency of the project).
import { execFileSync } from 'node:child_process';
import { mkdtempSync, readFileSync, writeFileSync, mkdirSync, rmSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join, dirname } from 'node:path';
import { fileURLToPath } from 'node:url';
import * as THREE from 'three';
import { EXRLoader } from 'three/examples/jsm/loaders/EXRLoader.js';

const PACKAGE = '@pmndrs/assets@1.7.0';
/** The width written (the specular chain's finest level is 256 wide: web/src/render/environment.rs). */
const WIDTH = Number(process.env.KLOUB_ENVIRONMENT_WIDTH ?? 256);
/** Kloub's name → the package's file, and the Poly Haven original it was made from. */
export const ENVIRONMENTS = {
  studio: { file: 'studio', original: 'studio_small_03' },
  outdoor: { file: 'city', original: 'potsdamer_platz' },
};

/**
 * The mean luminance over the sphere each photograph is scaled to: the `neutral` room's (made in code,
 * web/src/render/environment.rs), so that moving between the three names keeps the model about as bright (the
 * photographs as shot differ eightfold: Poly Haven's files are not calibrated to one another).
 */
const MEAN_LUMINANCE = 0.445;
/** The largest finite half float. */
const HALF_MAX = 65504;

const root = join(dirname(fileURLToPath(import.meta.url)), '..');

/** The package's EXR (a module exporting a base64 data URL) as RGB floats, top row first. */
function readExr(dir, file) {
  const text = readFileSync(join(dir, 'package', 'hdri', `${file}.exr.js`), 'utf8');
  const base64 = text.match(/base64,([A-Za-z0-9+/=]+)/)?.[1];
  if (!base64) throw new Error(`${file}.exr.js: no data URL`);
  const bytes = Buffer.from(base64, 'base64');
  const loader = new EXRLoader().setDataType(THREE.FloatType);
  const { width, height, data } = loader.parse(bytes.buffer.slice(bytes.byteOffset, bytes.byteOffset + bytes.length));
  const channels = data.length / (width * height);
  const rgb = new Float32Array(width * height * 3);
  // EXRLoader gives the bottom row first (a texture's first row, as WebGL uploads it).
  for (let y = 0; y < height; y++) {
    for (let x = 0; x < width; x++) {
      const from = ((height - 1 - y) * width + x) * channels;
      const to = (y * width + x) * 3;
      // The sun's pixels are past half floats' range in the package (infinite): held at its largest value, which
      // is also the most the prefiltered rgba16float textures hold.
      for (let k = 0; k < 3; k++) {
        const v = data[from + k];
        rgb[to + k] = Number.isNaN(v) ? 0 : Math.min(Math.max(v, 0), HALF_MAX);
      }
    }
  }
  return { width, height, rgb };
}

/** Averages `image` down by a whole factor to `width` wide. */
function shrink(image, width) {
  const f = image.width / width;
  if (!Number.isInteger(f) || f < 1) throw new Error(`${image.width} wide: cannot average down to ${width}`);
  const height = image.height / f;
  const rgb = new Float32Array(width * height * 3);
  for (let y = 0; y < height; y++) {
    for (let x = 0; x < width; x++) {
      for (let k = 0; k < 3; k++) {
        let sum = 0;
        for (let dy = 0; dy < f; dy++) for (let dx = 0; dx < f; dx++) sum += image.rgb[((y * f + dy) * image.width + x * f + dx) * 3 + k];
        rgb[(y * width + x) * 3 + k] = sum / (f * f);
      }
    }
  }
  return { width, height, rgb };
}

/** `image` scaled to MEAN_LUMINANCE (weighted by each row's solid angle), held within half floats. */
function normalise(image) {
  const { width, height, rgb } = image;
  let sum = 0;
  let weights = 0;
  for (let y = 0; y < height; y++) {
    const w = Math.sin(((y + 0.5) / height) * Math.PI);
    for (let x = 0; x < width; x++) {
      const i = (y * width + x) * 3;
      sum += w * (0.2126 * rgb[i] + 0.7152 * rgb[i + 1] + 0.0722 * rgb[i + 2]);
      weights += w;
    }
  }
  const scale = MEAN_LUMINANCE / (sum / weights);
  return { width, height, scale, rgb: rgb.map((v) => Math.min(v * scale, HALF_MAX)) };
}

/** One pixel as Radiance's shared-exponent bytes. */
function rgbe(r, g, b) {
  const m = Math.max(r, g, b);
  if (m < 1e-32) return [0, 0, 0, 0];
  const e = Math.ceil(Math.log2(m * (256 / 255)));
  const scale = 256 / 2 ** e;
  return [Math.floor(r * scale), Math.floor(g * scale), Math.floor(b * scale), e + 128].map((v) => Math.min(255, Math.max(0, v)));
}

/** The image as a run-length encoded Radiance file (new-style scanlines, each channel apart). */
function radiance({ width, height, rgb }, comment) {
  const out = [...Buffer.from(`#?RADIANCE\n# ${comment}\nFORMAT=32-bit_rle_rgbe\n\n-Y ${height} +X ${width}\n`)];
  for (let y = 0; y < height; y++) {
    const line = [];
    for (let x = 0; x < width; x++) {
      const i = (y * width + x) * 3;
      line.push(rgbe(rgb[i], rgb[i + 1], rgb[i + 2]));
    }
    out.push(2, 2, width >> 8, width & 255);
    for (let c = 0; c < 4; c++) {
      const values = line.map((p) => p[c]);
      let x = 0;
      while (x < width) {
        let run = 1;
        while (x + run < width && run < 127 && values[x + run] === values[x]) run++;
        if (run >= 3) {
          out.push(128 + run, values[x]);
          x += run;
          continue;
        }
        // Literals up to the next run of three or more.
        let end = x;
        while (end < width && end - x < 128) {
          if (end + 2 < width && values[end] === values[end + 1] && values[end] === values[end + 2]) break;
          end++;
        }
        out.push(end - x, ...values.slice(x, end));
        x = end;
      }
    }
  }
  return Buffer.from(out);
}

if (process.argv[1] === fileURLToPath(import.meta.url)) {
  const dir = mkdtempSync(join(tmpdir(), 'kloub-environments-'));
  try {
    execFileSync('npm', ['pack', PACKAGE, '--silent'], { cwd: dir, stdio: ['ignore', 'pipe', 'inherit'] });
    execFileSync('tar', ['xzf', 'pmndrs-assets-1.7.0.tgz'], { cwd: dir });
    const target = join(root, 'web', 'environments');
    mkdirSync(target, { recursive: true });
    for (const [name, { file, original }] of Object.entries(ENVIRONMENTS)) {
      const image = normalise(shrink(readExr(dir, file), WIDTH));
      const note = `${original} by Poly Haven (CC0), via ${PACKAGE} hdri/${file}.exr, scaled by ${image.scale.toFixed(4)}`;
      const bytes = radiance(image, note);
      writeFileSync(join(target, `${name}.hdr`), bytes);
      console.log(`${name}.hdr: ${image.width}×${image.height}, ${bytes.length} bytes (${note})`);
    }
  } finally {
    rmSync(dir, { recursive: true, force: true });
  }
}

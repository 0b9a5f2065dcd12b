// three.js r187's pictures of Kloub's reference scenes (tests/reference/<scene>/view.json; the models made in code
// and the environment are in tests/out/reference/, written by `cargo test -p kloub-tests --test reference`): its GLTFLoader's MeshStandardMaterial, the scene's
// environment (an equirectangular .hdr through HDRLoader and the renderer's PMREM), one DirectionalLight as Kloub's
// key light (three.js's intensity is irradiance: π times Kloub's), Khronos PBR Neutral tone mapping at the same
// exposure, sRGB output, no antialiasing, a transparent clear — in the same headless Debian chromium as the browser
// tests (WebGL2, SwiftShader). Writes tests/reference/<scene>/three.png, which tests/reference.rs compares with
// Kloub's own picture.
//
//   node scripts/reference-three.mjs            # every scene
//   node scripts/reference-three.mjs cesiumman  # some
//
// `renderReferences(names)` gives the pictures (PNG objects) without writing them: the browser test checks that
// the committed ones are still what three.js draws.
import { createServer } from 'node:http';
import { readFileSync, readdirSync, statSync, writeFileSync } from 'node:fs';
import { extname, join, resolve } from 'node:path';
import { fileURLToPath } from 'node:url';
import { PNG } from 'pngjs';
import { ROOT, openBrowser } from '../tests/browser/lib.mjs';

const PAGE = `<!doctype html><html><head><meta charset="utf-8">
<script type="importmap">{"imports":{"three":"/three/build/three.module.js","three/addons/":"/three/examples/jsm/"}}</script>
</head><body style="margin:0"><script type="module">
import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { HDRLoader } from 'three/addons/loaders/HDRLoader.js';
window.render = async (view) => {
  const [width, height] = view.size;
  const canvas = document.createElement('canvas');
  document.body.append(canvas);
  const renderer = new THREE.WebGLRenderer({ canvas, antialias: false, alpha: true, preserveDrawingBuffer: true });
  renderer.setPixelRatio(1);
  renderer.setSize(width, height, false);
  renderer.outputColorSpace = THREE.SRGBColorSpace;
  renderer.toneMapping = THREE.NeutralToneMapping;
  renderer.toneMappingExposure = view.exposure;
  renderer.setClearColor(0x000000, 0);
  const scene = new THREE.Scene();
  const environment = await new HDRLoader().loadAsync('/' + view.environment);
  environment.mapping = THREE.EquirectangularReflectionMapping;
  scene.environment = environment;
  const light = new THREE.DirectionalLight(new THREE.Color().setRGB(...view.light.color, THREE.LinearSRGBColorSpace), view.light.intensity);
  light.position.set(...view.light.direction);
  scene.add(light);
  const gltf = await new GLTFLoader().loadAsync('/' + view.model);
  scene.add(gltf.scene);
  if (view.clip !== null) {
    const mixer = new THREE.AnimationMixer(gltf.scene);
    mixer.clipAction(gltf.animations[view.clip]).play();
    mixer.setTime(view.time);
  }
  const c = view.camera;
  const camera = new THREE.PerspectiveCamera(c.fov_y_degrees, width / height, c.near, c.far);
  camera.position.set(...c.eye);
  camera.lookAt(new THREE.Vector3(...c.target));
  renderer.render(scene, camera);
  const url = canvas.toDataURL('image/png');
  renderer.dispose();
  canvas.remove();
  return url;
};
window.ready = true;
</script></body></html>`;

const MIME = { '.js': 'text/javascript', '.html': 'text/html', '.glb': 'model/gltf-binary', '.hdr': 'application/octet-stream' };

/** Serves the page, three.js from node_modules, and the repository's tests/ folder. */
function startServer() {
  const roots = { '/three/': resolve(ROOT, 'node_modules/three'), '/tests/': resolve(ROOT, 'tests') };
  const server = createServer((req, res) => {
    const path = decodeURIComponent(new URL(req.url, 'http://x').pathname);
    if (path === '/reference.html') {
      res.writeHead(200, { 'content-type': 'text/html' }).end(PAGE);
      return;
    }
    const prefix = Object.keys(roots).find((p) => path.startsWith(p));
    const dir = prefix && roots[prefix];
    const file = dir && resolve(dir, path.slice(prefix.length));
    if (!file || !file.startsWith(dir) || !statSync(file, { throwIfNoEntry: false })?.isFile()) {
      res.writeHead(404).end('not found');
      return;
    }
    res.writeHead(200, { 'content-type': MIME[extname(file)] ?? 'application/octet-stream' }).end(readFileSync(file));
  });
  return new Promise((ok) => server.listen(0, '127.0.0.1', () => ok({ url: `http://127.0.0.1:${server.address().port}`, stop: () => server.close() })));
}

/** The scenes of tests/reference (folders with a view.json). */
export function referenceScenes() {
  const dir = join(ROOT, 'tests/reference');
  return readdirSync(dir).filter((name) => statSync(join(dir, name, 'view.json'), { throwIfNoEntry: false })?.isFile()).sort();
}

/** three.js's picture of each scene in `names`: `{ name, png }`. */
export async function renderReferences(names = referenceScenes()) {
  const server = await startServer();
  const { browser, page, logs } = await openBrowser();
  try {
    await page.goto(`${server.url}/reference.html`);
    await page.waitForFunction(() => window.ready === true, null, { timeout: 60000 });
    const out = [];
    for (const name of names) {
      const view = JSON.parse(readFileSync(join(ROOT, 'tests/reference', name, 'view.json'), 'utf8'));
      for (const file of [view.model, view.environment]) {
        if (!statSync(join(ROOT, file), { throwIfNoEntry: false })?.isFile()) {
          throw new Error(`${name}: ${file} is missing: run \`cargo test -p kloub-tests --test reference\` first (it writes it)`);
        }
      }
      const url = await page.evaluate((v) => window.render(v), view);
      out.push({ name, png: PNG.sync.read(Buffer.from(url.replace(/^data:image\/png;base64,/, ''), 'base64')) });
    }
    return out;
  } catch (e) {
    throw new Error(`${e.message}\n${logs.join('\n')}`);
  } finally {
    await browser.close();
    server.stop();
  }
}

if (process.argv[1] && resolve(process.argv[1]) === fileURLToPath(import.meta.url)) {
  const names = process.argv.length > 2 ? process.argv.slice(2) : referenceScenes();
  for (const { name, png } of await renderReferences(names)) {
    const path = join(ROOT, 'tests/reference', name, 'three.png');
    writeFileSync(path, PNG.sync.write(png));
    console.log(`reference-three: ${path} (${png.width}×${png.height})`);
  }
}

// The reference side of core/benches/import_cases.rs, in Node, measured the same way (median of 7 batches of ~150 ms):
// - decoding: the reference decoders from npm on the same compressed data: draco3dgltf (Google's Draco decoder
//   compiled to wasm, used as three.js's DRACOLoader uses it: decode, then every attribute and the triangles copied
//   out as typed arrays) and meshoptimizer's decoder (wasm, SIMD where Node has it: decodeGltfBuffer per view).
//   Decoded MB/s (10^6 bytes).
// - import: three.js r187's GLTFLoader.parse of each character and its optimized copies without images (as the Rust
//   side strips them), with meshoptimizer's decoder and draco3dgltf behind a DRACOLoader stand-in that decodes on the
//   calling thread (DRACOLoader itself needs Web Workers). Milliseconds per parse, to the loaded scene.
//
//   node scripts/bench-import.mjs        (part of scripts/bench-import.sh)
import { readFileSync } from 'node:fs';
import { join, dirname } from 'node:path';
import { createRequire } from 'node:module';
import { MeshoptDecoder } from 'meshoptimizer';
import { BufferAttribute, BufferGeometry } from 'three';
import { GLTFLoader } from 'three/examples/jsm/loaders/GLTFLoader.js';

const require = createRequire(import.meta.url);
const root = join(dirname(new URL(import.meta.url).pathname), '..');
const FILES = [
  'Fox.draco.glb', 'CesiumMan.draco.glb', 'RobotExpressive.draco.glb',
  'Fox.gltfpack-cc.glb', 'CesiumMan.gltfpack-cc.glb', 'RobotExpressive.gltfpack-cc.glb',
  'Fox.gltfpack-khr.glb', 'CesiumMan.gltfpack-khr.glb',
];
const COMPONENT = { 5120: Int8Array, 5121: Uint8Array, 5122: Int16Array, 5123: Uint16Array, 5125: Uint32Array, 5126: Float32Array };
const WIDTH = { SCALAR: 1, VEC2: 2, VEC3: 3, VEC4: 4, MAT4: 16 };

function split(bytes) {
  const jsonLength = bytes.readUInt32LE(12);
  const json = JSON.parse(bytes.subarray(20, 20 + jsonLength).toString());
  const at = 20 + jsonLength;
  return { json, bin: bytes.subarray(at + 8, at + 8 + bytes.readUInt32LE(at)) };
}

/** Calls `run`, awaiting it only when it returns a promise (three.js's parse): an `await` costs a few µs, as much
 * as a small view's decode, which the Rust side's loop does not pay either. */
async function call(run) {
  const r = run();
  if (r && typeof r.then === 'function') await r;
}

/** Milliseconds per `run()`: the median of 7 batches of ~150 ms. */
async function measure(run) {
  const start = performance.now();
  let calibration = 0;
  while (performance.now() - start < 50 || calibration < 3) { await call(run); calibration++; }
  const perBatch = Math.max(1, Math.floor(150 / ((performance.now() - start) / calibration)));
  const times = [];
  for (let b = 0; b < 7; b++) {
    const t = performance.now();
    for (let i = 0; i < perBatch; i++) await call(run);
    times.push((performance.now() - t) / perBatch);
  }
  times.sort((a, b) => a - b);
  return times[3];
}

const draco = await require('draco3dgltf').createDecoderModule({});
await MeshoptDecoder.ready;

function dracoCase({ json, bin }) {
  const prims = [];
  for (const mesh of json.meshes ?? []) {
    for (const p of mesh.primitives) {
      const x = p.extensions?.KHR_draco_mesh_compression;
      if (!x) continue;
      const v = json.bufferViews[x.bufferView];
      const stream = new Int8Array(bin.buffer, bin.byteOffset + (v.byteOffset ?? 0), v.byteLength);
      const attributes = Object.entries(x.attributes).map(([name, id]) => {
        const a = json.accessors[p.attributes[name]];
        return { id, Type: COMPONENT[a.componentType] };
      });
      prims.push({ stream, attributes });
    }
  }
  let decoded = 0;
  const run = () => {
    let bytes = 0;
    const decoder = new draco.Decoder();
    for (const { stream, attributes } of prims) {
      const mesh = new draco.Mesh();
      const status = decoder.DecodeArrayToMesh(stream, stream.byteLength, mesh);
      if (!status.ok()) throw new Error(status.error_msg());
      const count = mesh.num_points();
      for (const { id, Type } of attributes) {
        const attribute = decoder.GetAttributeByUniqueId(mesh, id);
        const n = count * attribute.num_components();
        const type = { Float32Array: draco.DT_FLOAT32, Int8Array: draco.DT_INT8, Int16Array: draco.DT_INT16, Uint8Array: draco.DT_UINT8, Uint16Array: draco.DT_UINT16, Uint32Array: draco.DT_UINT32 }[Type.name];
        const ptr = draco._malloc(n * Type.BYTES_PER_ELEMENT);
        decoder.GetAttributeDataArrayForAllPoints(mesh, attribute, type, n * Type.BYTES_PER_ELEMENT, ptr);
        const array = new Type(draco.HEAPF32.buffer, ptr, n).slice();
        draco._free(ptr);
        bytes += array.byteLength;
      }
      const indices = mesh.num_faces() * 3;
      const ptr = draco._malloc(indices * 4);
      decoder.GetTrianglesUInt32Array(mesh, indices * 4, ptr);
      bytes += new Uint32Array(draco.HEAPF32.buffer, ptr, indices).slice().byteLength;
      draco._free(ptr);
      draco.destroy(mesh);
    }
    draco.destroy(decoder);
    decoded = bytes;
  };
  run();
  return { decoded, run };
}

/** One meshopt view decoded into a new buffer, as GLTFLoader's EXT_meshopt_compression extension does. */
const decodeView = (v) => MeshoptDecoder.decodeGltfBuffer(new Uint8Array(v.count * v.stride), v.count, v.stride, v.source, v.mode, v.filter);

function meshoptCase({ json, bin }) {
  const views = [];
  for (const v of json.bufferViews) {
    const x = v.extensions?.EXT_meshopt_compression ?? v.extensions?.KHR_meshopt_compression;
    if (!x) continue;
    const source = new Uint8Array(bin.buffer, bin.byteOffset + (x.byteOffset ?? 0), x.byteLength);
    views.push({ i: views.length, source, count: x.count, stride: x.byteStride, mode: x.mode, filter: x.filter ?? 'NONE' });
  }
  const decoded = views.reduce((sum, v) => sum + v.count * v.stride, 0);
  const run = () => views.forEach(decodeView);
  return { decoded, run, views };
}

/** Runs each of `runs` for about `ms` milliseconds, untimed, before anything is measured (as
 * core/benches/import_cases.rs's warm_up: the engine swaps optimised code in some time after the first calls). */
async function warmUp(runs, ms) {
  for (const run of runs) {
    const start = performance.now();
    while (performance.now() - start < ms) await call(run);
  }
}

const decodeCases = FILES.map((name) => {
  const file = split(readFileSync(join(root, 'tests/optimized', name)));
  return [name, name.includes('draco') ? dracoCase(file) : meshoptCase(file)];
});
await warmUp(decodeCases.map(([, c]) => c.run), 200);
for (const [name, { decoded, run, views }] of decodeCases) {
  const isDraco = name.includes('draco');
  const rate = decoded / ((await measure(run)) / 1000) / 1e6;
  console.log(`decode reference ${isDraco ? 'draco' : 'meshopt'} ${name} ${decoded} B: ${rate.toFixed(1)} MB/s`);
  // KLOUB_BENCH_VIEWS=1: each meshopt view on its own, as core/benches/import_cases.rs's measure_views.
  if (process.env.KLOUB_BENCH_VIEWS && !isDraco) {
    for (const v of views) {
      const ms = await measure(() => decodeView(v));
      console.log(`view reference ${name} ${v.i}:${v.mode}:${v.filter}:${v.count}x${v.stride}: ${(ms * 1000).toFixed(2)} us`);
    }
  }
}

/** DRACOLoader's decodeDracoFile on the calling thread: its worker's decodeGeometry and its _createGeometry. */
const dracoLoader = {
  preload() {},
  decodeDracoFile(buffer, callback, attributeIDs, attributeTypes, colorSpace, onError) {
    try {
      const decoder = new draco.Decoder();
      const array = new Int8Array(buffer);
      const mesh = new draco.Mesh();
      const status = decoder.DecodeArrayToMesh(array, array.byteLength, mesh);
      if (!status.ok()) throw new Error(status.error_msg());
      const geometry = new BufferGeometry();
      const count = mesh.num_points();
      for (const name in attributeIDs) {
        const Type = globalThis[attributeTypes[name]];
        const attribute = decoder.GetAttributeByUniqueId(mesh, attributeIDs[name]);
        const itemSize = attribute.num_components();
        const n = count * itemSize;
        const type = { Float32Array: draco.DT_FLOAT32, Int8Array: draco.DT_INT8, Int16Array: draco.DT_INT16, Uint8Array: draco.DT_UINT8, Uint16Array: draco.DT_UINT16, Uint32Array: draco.DT_UINT32 }[Type.name];
        const ptr = draco._malloc(n * Type.BYTES_PER_ELEMENT);
        decoder.GetAttributeDataArrayForAllPoints(mesh, attribute, type, n * Type.BYTES_PER_ELEMENT, ptr);
        geometry.setAttribute(name, new BufferAttribute(new Type(draco.HEAPF32.buffer, ptr, n).slice(), itemSize));
        draco._free(ptr);
      }
      const indices = mesh.num_faces() * 3;
      const ptr = draco._malloc(indices * 4);
      decoder.GetTrianglesUInt32Array(mesh, indices * 4, ptr);
      geometry.setIndex(new BufferAttribute(new Uint32Array(draco.HEAPF32.buffer, ptr, indices).slice(), 1));
      draco._free(ptr);
      draco.destroy(mesh);
      draco.destroy(decoder);
      callback(geometry);
    } catch (e) {
      onError(e);
    }
    return Promise.resolve();
  },
};

/** The GLB at `path` without its images, textures and samplers, and the materials' references to them. */
function withoutImages(path) {
  const bytes = readFileSync(path);
  const { json, bin } = split(bytes);
  for (const key of ['images', 'textures', 'samplers']) delete json[key];
  const strip = (o) => { for (const key of Object.keys(o ?? {})) if (key.endsWith('Texture')) delete o[key]; };
  for (const m of json.materials ?? []) { strip(m); strip(m.pbrMetallicRoughness); }
  let text = Buffer.from(JSON.stringify(json));
  text = Buffer.concat([text, Buffer.alloc((4 - (text.length % 4)) % 4, 32)]);
  const binPadded = Buffer.concat([bin, Buffer.alloc((4 - (bin.length % 4)) % 4)]);
  const head = Buffer.alloc(20);
  head.write('glTF', 0);
  head.writeUInt32LE(2, 4);
  head.writeUInt32LE(20 + text.length + 8 + binPadded.length, 8);
  head.writeUInt32LE(text.length, 12);
  head.write('JSON', 16);
  const binHead = Buffer.alloc(8);
  binHead.writeUInt32LE(binPadded.length, 0);
  binHead.write('BIN\0', 4, 'latin1');
  const glb = Buffer.concat([head, text, binHead, binPadded]);
  return glb.buffer.slice(glb.byteOffset, glb.byteOffset + glb.length);
}

const IMPORTS = [
  ['original', 'tests/assets/khronos/Fox/glTF-Binary/Fox.glb'],
  ['gltfpack', 'tests/optimized/Fox.gltfpack.glb'],
  ['meshopt', 'tests/optimized/Fox.gltfpack-cc.glb'],
  ['draco', 'tests/optimized/Fox.draco.glb'],
  ['original', 'tests/assets/khronos/CesiumMan/glTF-Binary/CesiumMan.glb'],
  ['gltfpack', 'tests/optimized/CesiumMan.gltfpack.glb'],
  ['meshopt', 'tests/optimized/CesiumMan.gltfpack-cc.glb'],
  ['draco', 'tests/optimized/CesiumMan.draco.glb'],
  ['original', 'tests/assets/threejs/RobotExpressive/RobotExpressive.glb'],
  ['gltfpack', 'tests/optimized/RobotExpressive.gltfpack.glb'],
  ['meshopt', 'tests/optimized/RobotExpressive.gltfpack-cc.glb'],
  ['draco', 'tests/optimized/RobotExpressive.draco.glb'],
  ['original', 'tests/assets/kaykit/Knight/Knight.glb'],
];
const loader = new GLTFLoader().setMeshoptDecoder(MeshoptDecoder).setDRACOLoader(dracoLoader);
const importCases = IMPORTS.map(([variant, path]) => {
  const glb = withoutImages(join(root, path));
  return [variant, path, glb, () => new Promise((resolve, reject) => loader.parse(glb, '', resolve, reject))];
});
await warmUp(importCases.map(([, , , parse]) => parse), 200);
for (const [variant, path, glb, parse] of importCases) {
  const gltf = await parse();
  if (!gltf.scene) throw new Error(`${path}: no scene`);
  const ms = await measure(parse);
  console.log(`import three ${variant} ${path.split('/').pop()} ${glb.byteLength} B: ${ms.toFixed(3)} ms`);
}

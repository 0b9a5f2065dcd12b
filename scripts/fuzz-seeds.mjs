// Seed corpora for the fuzz targets of core/fuzz (scripts/fuzz.sh), from tests/assets and tests/optimized:
//   import      every .glb and .gltf
//   gltf_files  each .gltf with one external .bin: the JSON, a NUL byte, the .bin
//   draco       the Draco stream of every KHR_draco_mesh_compression primitive
//   meshopt     every meshopt-compressed view, as its four parameter bytes and its data (core/fuzz/fuzz_targets/meshopt.rs)
//   sidecar     a few sidecars for Fox (joint limits and stiffness, example poses)
//
//   node scripts/fuzz-seeds.mjs OUT_DIR [EXTRA_DIR]
import { mkdirSync, readFileSync, readdirSync, statSync, writeFileSync, existsSync } from 'node:fs';
import { join, dirname, basename } from 'node:path';

const [out, extra] = process.argv.slice(2);
const root = join(dirname(new URL(import.meta.url).pathname), '..');
const dirs = [join(root, 'tests/assets'), join(root, 'tests/optimized'), extra].filter(Boolean);
const targets = ['import', 'gltf_files', 'draco', 'meshopt', 'sidecar'];
for (const t of targets) mkdirSync(join(out, t), { recursive: true });
let n = 0;
const write = (target, name, bytes) => writeFileSync(join(out, target, `${n++}-${basename(name)}`), bytes);

function* files(dir) {
  for (const entry of readdirSync(dir)) {
    const path = join(dir, entry);
    const s = statSync(path);
    if (s.isDirectory()) yield* files(path);
    else if (/\.(glb|gltf)$/.test(entry) && s.size < 4 << 20) yield path;
  }
}

/** The JSON and BIN chunk of a GLB, or the JSON of a .gltf with its external .bin (when it has exactly one). */
function open(path) {
  const bytes = readFileSync(path);
  if (bytes.subarray(0, 4).toString() === 'glTF') {
    const jsonLength = bytes.readUInt32LE(12);
    const json = JSON.parse(bytes.subarray(20, 20 + jsonLength).toString());
    const binAt = 20 + jsonLength;
    const bin = binAt + 8 <= bytes.length ? bytes.subarray(binAt + 8, binAt + 8 + bytes.readUInt32LE(binAt)) : null;
    return { json, buffers: [bin] };
  }
  const json = JSON.parse(bytes.toString());
  const buffers = (json.buffers ?? []).map((b) => {
    const file = b.uri && !b.uri.startsWith('data:') ? join(dirname(path), decodeURIComponent(b.uri)) : null;
    return file && existsSync(file) ? readFileSync(file) : null;
  });
  return { json, buffers };
}

const view = ({ json, buffers }, index, ext) => {
  const v = json.bufferViews[index];
  const src = ext ?? v;
  const buffer = buffers[src.buffer];
  return buffer?.subarray(src.byteOffset ?? 0, (src.byteOffset ?? 0) + src.byteLength);
};

const MODES = ['ATTRIBUTES', 'TRIANGLES', 'INDICES'];
const FILTERS = ['NONE', 'OCTAHEDRAL', 'QUATERNION', 'EXPONENTIAL', 'COLOR'];
for (const dir of dirs) {
  for (const path of files(dir)) {
    write('import', path, readFileSync(path));
    let doc;
    try { doc = open(path); } catch { continue; }
    if (path.endsWith('.gltf') && doc.buffers.length === 1 && doc.buffers[0]) {
      write('gltf_files', path, Buffer.concat([readFileSync(path), Buffer.from([0]), doc.buffers[0]]));
    }
    for (const mesh of doc.json.meshes ?? []) {
      for (const p of mesh.primitives ?? []) {
        const x = p.extensions?.KHR_draco_mesh_compression;
        const stream = x && view(doc, x.bufferView);
        if (stream) write('draco', path, stream);
      }
    }
    (doc.json.bufferViews ?? []).forEach((v, i) => {
      for (const [name, khr] of [['EXT_meshopt_compression', 0], ['KHR_meshopt_compression', 1]]) {
        const x = v.extensions?.[name];
        const stream = x && view(doc, i, x);
        if (!stream || x.byteStride > 255 || x.count > 65535) continue;
        const pick = khr | (MODES.indexOf(x.mode) << 1) | (FILTERS.indexOf(x.filter ?? 'NONE') << 3);
        const head = Buffer.from([pick, x.byteStride, x.count & 255, x.count >> 8]);
        write('meshopt', path, Buffer.concat([head, stream]));
      }
    });
  }
}
const sidecars = [
  '{"ik":{}}',
  '{"ik":{"limits":{"b_Neck_04":{"hinge":{"axis":[1,0,0],"min":-45,"max":45}}},"stiffness":{"b_Neck_04":0.5}}}',
  '{"ik":{"limits":{"b_Spine01_02":{"ball":{"axis":[0,1,0],"swing":30,"twist":[-10,10]}},"b_Head_05":"free"}}}',
  // Example poses (SJB by example) on the left forearm: inline offsets for Fox's 1,728 vertices.
  JSON.stringify({ examples: { b_LeftForeArm_010: [
    { rotation: [0, 0, 0.5, 0.8660254], offsets: Buffer.from(new Float32Array(1728 * 3).fill(0.5).buffer).toString('base64') },
    { rotation: [0, 0, -0.3, 0.9539392], offsets: Buffer.from(new Float32Array(1728 * 3).buffer).toString('base64'), normals: Buffer.from(new Float32Array(1728 * 3).fill(0.1).buffer).toString('base64') },
  ] }, example_sigma: { b_LeftForeArm_010: 0.7 } }),
];
sidecars.forEach((s, i) => write('sidecar', `fox-${i}.kloub.json`, s));
console.log(`fuzz-seeds: ${n} seeds in ${out}`);

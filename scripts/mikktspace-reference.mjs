// The reference MikkTSpace for tests/tangents.rs: three.js r187's port of Mikkelsen's
// reference (three/examples/jsm/libs/mikktspace.module.js, an npm dev dependency), run on the
// corners in the JSON file named by the first argument ({positions, normals, uvs}: flat
// arrays, one triangle per three corners). Prints the corners' tangents (xyz and the
// reference's handedness w, not negated) as a flat JSON array.
import { readFileSync } from 'node:fs';
import * as MikkTSpace from 'three/examples/jsm/libs/mikktspace.module.js';

const input = JSON.parse(readFileSync(process.argv[2], 'utf8'));
const tangents = MikkTSpace.generateTangents(
  new Float32Array(input.positions),
  new Float32Array(input.normals),
  new Float32Array(input.uvs),
);
process.stdout.write(JSON.stringify(Array.from(tangents)));

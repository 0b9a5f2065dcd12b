#!/usr/bin/env bash
# Regenerates tests/optimized/: the shared characters as web developers ship them, made by gltfpack and glTF
# Transform (npm dev dependencies, fixed versions): gltfpack `-c` (EXT_meshopt_compression), `-cc` (with its
# filters), `-cc -ce khr` (KHR_meshopt_compression) and its default (quantized only, KHR_mesh_quantization);
# `gltf-transform draco` (KHR_draco_mesh_compression) and `gltf-transform webp` (EXT_texture_webp). The files
# are committed; the tests compare each one with its original (or its quantized twin).
#
#   npm install && bash scripts/make-optimized.sh
set -euo pipefail
cd "$(dirname "$0")/.."
pack=node_modules/.bin/gltfpack
transform=node_modules/.bin/gltf-transform
out=tests/optimized
mkdir -p "$out"
declare -A sources=(
  [Fox]=tests/assets/khronos/Fox/glTF-Binary/Fox.glb
  [CesiumMan]=tests/assets/khronos/CesiumMan/glTF-Binary/CesiumMan.glb
  [RobotExpressive]=tests/assets/threejs/RobotExpressive/RobotExpressive.glb
  [AnimatedMorphCube]=tests/assets/khronos/AnimatedMorphCube/glTF-Binary/AnimatedMorphCube.glb
)
for model in Fox CesiumMan RobotExpressive AnimatedMorphCube; do
  src=${sources[$model]}
  "$pack" -i "$src" -o "$out/$model.gltfpack.glb" >/dev/null
  "$pack" -i "$src" -o "$out/$model.gltfpack-cc.glb" -cc >/dev/null
done
"$pack" -i "${sources[Fox]}" -o "$out/Fox.gltfpack-c.glb" -c >/dev/null
for model in Fox CesiumMan; do
  "$pack" -i "${sources[$model]}" -o "$out/$model.gltfpack-khr.glb" -cc -ce khr >/dev/null
done
for model in Fox CesiumMan RobotExpressive AnimatedMorphCube; do
  "$transform" draco "${sources[$model]}" "$out/$model.draco.glb" >/dev/null
done
# The two characters with textures (the others have none to re-encode).
for model in Fox CesiumMan; do
  "$transform" webp "${sources[$model]}" "$out/$model.webp.glb" >/dev/null
done
ls -l "$out"/*.glb

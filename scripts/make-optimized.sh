#!/usr/bin/env bash
# Regenerates tests/optimized/: the shared characters as web developers ship them, made by gltfpack (the npm dev
# dependency, a fixed version): `-c` (EXT_meshopt_compression), `-cc` (with its filters), `-cc -ce khr`
# (KHR_meshopt_compression) and gltfpack's default (quantized only, KHR_mesh_quantization). The files are
# committed; the importer's tests compare each compressed file with its quantized twin.
#
#   npm install && bash scripts/make-optimized.sh
set -euo pipefail
cd "$(dirname "$0")/.."
pack=node_modules/.bin/gltfpack
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
ls -l "$out"/*.glb

#!/usr/bin/env bash
# The main job on the bundled sample (data/bunny.ply): install, build, then read the cloud,
# estimate and orient normals and evaluate them, compress it, verify and decode the file, and
# evaluate the decoded cloud against the original, and ray-trace the MLS surface of the original
# (out/bunny.png) and of the compressed model rendered directly (out/bunny_compressed.png, and
# out/bunny_codewords.png coloured by code word).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install_deps.sh
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release -DSSPC_BUILD_TESTS=OFF -DSSPC_BUILD_BENCH=OFF
cmake --build build -j "$(nproc)"
mkdir -p out
set -x
build/sspc info data/bunny.ply
build/sspc normals data/bunny.ply out/bunny_normals.ply --normals estimate --force
build/sspc eval data/bunny.ply out/bunny_normals.ply
build/sspc encode data/bunny.ply out/bunny.sspc --force
build/sspc verify out/bunny.sspc
build/sspc info out/bunny.sspc
build/sspc decode out/bunny.sspc out/bunny_decoded.ply --force
build/sspc eval data/bunny.ply out/bunny_decoded.ply --compressed out/bunny.sspc
build/sspc render data/bunny.ply -o out/bunny.png --size 512x512 --force
build/sspc render out/bunny.sspc -o out/bunny_compressed.png --size 512x512 --force
build/sspc render out/bunny.sspc -o out/bunny_codewords.png --size 512x512 --shade codeword --force
set +x
cat <<DONE

Done. The outputs are in $PWD/out:
  out/bunny.png             the point cloud's MLS surface, ray-traced
  out/bunny_compressed.png  the compressed model, ray-traced directly (bricks decoded as rays reach them)
  out/bunny_codewords.png   the same, coloured by code word
  out/bunny.sspc            the compressed model (build/sspc info out/bunny.sspc describes it)
  out/bunny_decoded.ply     the model decoded
  out/bunny_normals.ply     the cloud with estimated normals
The sspc used is build/sspc; README.md's commands run from $PWD as written.
DONE

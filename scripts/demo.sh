#!/usr/bin/env bash
# Set up (see setup.sh) and run the main job on the sample files, writing into out/demo:
# the sewn mesh of the base pattern, the body's signed distance field, pictures and reports.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
out=out/demo
mkdir -p "$out"
sf=.venv/bin/seamfit
pattern=sample_files/patterns/gc_pencil_skirt/size06/pattern.json
base=sample_files/bodies/women_size06.obj
$sf validate "$pattern"
$sf mesh "$pattern" --out "$out/mesh"
$sf sdf "$base" --out "$out/base_body.sdf.npz"
echo "demo results in $out"

#!/usr/bin/env bash
# Set up (see setup.sh) and run the main job on the sample files: grade the sample pencil
# skirt from the base body (US size 6) to size 10. Writes into out/demo/grade the adjusted
# pattern (pattern.json), the graded nest (pattern.svg, pattern.png), the drape on the new body
# (garment.obj, drape.png) and report.json, which also compares the result with the
# pattern the drafting system made for size 10. Run again, it replaces that folder whole.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
out=out/demo
mkdir -p "$out"
sf=.venv/bin/seamfit
samples=sample_files
pattern=$samples/patterns/gc_pencil_skirt/size06/pattern.json
$sf validate "$pattern"
$sf grade "$pattern" \
    --base-body $samples/bodies/women_size06.obj \
    --target-body $samples/bodies/women_size10.obj \
    --truth $samples/patterns/gc_pencil_skirt/size10/pattern.json \
    --edge-length 3 --max-iterations 64 --out "$out/grade" --force   # --force: a re-run replaces the set
echo "results in $out/grade: pattern.json pattern.svg pattern.png garment.obj drape.png report.json"

#!/usr/bin/env bash
# Set up (see setup.sh) and run every test.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh --blender
.venv/bin/python -m pytest -q -p no:cacheprovider tests "$@"

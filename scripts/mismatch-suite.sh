#!/usr/bin/env bash
# Concealed-effect suite for agvcal diagnose: simulated recordings with one hidden effect
# per drive type, controls, the confusion table (docs/mismatch.md). Options: see
#   scripts/mismatch-suite.sh --help
set -euo pipefail
exec python3 "$(cd "$(dirname "$0")" && pwd)/mismatch_suite.py" "$@"

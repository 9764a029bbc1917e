#!/usr/bin/env bash
# Installs the independent bag writers of package.json (npm registry) into DIR/node_modules,
# once: tests/ros/install.sh DIR. Never into the checkout (node_modules is not committed).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
dir=${1:?usage: tests/ros/install.sh DIR}
mkdir -p "$dir"
if [ ! -f "$dir/node_modules/.agvcal-installed" ] || ! cmp -s "$here/package.json" "$dir/package.json"; then
  cp "$here/package.json" "$dir/package.json"
  command -v npm >/dev/null || { echo "no npm: the bag writers are not installed" >&2; exit 1; }
  (cd "$dir" && npm install --no-audit --no-fund --no-package-lock --loglevel=error >&2)
  touch "$dir/node_modules/.agvcal-installed"
fi

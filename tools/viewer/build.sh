#!/bin/sh
# Build the report viewer (main.js + the parts of three.js it uses) into the
# package asset src/pointatlas/viz/assets/viewer.min.js, and copy three.js's
# licence beside it. Versions are pinned in package.json / package-lock.json.
#
#   cd tools/viewer && sh build.sh      (runs `npm ci` when node_modules is missing)
set -eu
cd "$(dirname "$0")"
ASSETS=../../src/pointatlas/viz/assets
[ -d node_modules/three ] || npm ci --no-audit --no-fund
mkdir -p "$ASSETS"
THREE_VERSION=$(node -p "require('./node_modules/three/package.json').version")
./node_modules/.bin/esbuild main.js \
  --bundle --minify --format=iife --target=es2020 \
  --legal-comments=none \
  --banner:js="/* pointatlas report viewer; includes three.js ${THREE_VERSION} (MIT, see THREE_LICENSE) */" \
  --outfile="$ASSETS/viewer.min.js"
cp node_modules/three/LICENSE "$ASSETS/THREE_LICENSE"
# the bundle is inlined in a <script> element: it must not close it
if grep -qi '</script' "$ASSETS/viewer.min.js"; then
  echo "viewer.min.js contains '</script'; cannot be inlined" >&2
  exit 1
fi
ls -l "$ASSETS/viewer.min.js" "$ASSETS/THREE_LICENSE"

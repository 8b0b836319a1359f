#!/usr/bin/env bash
# Vendor the panel's front-end libraries from the npm registry at pinned versions, with their
# licences, into src/flexhrc/web/static/vendor/ (served by flexhrc; nothing comes from a CDN).
# Run by a maintainer when a version changes; the result is committed (the set-up never
# downloads).   usage: bash scripts/vendor_web.sh
set -euo pipefail
cd "$(dirname "$0")/.."
THREE=0.160.1   # the last release with a single-file minified ES module build
dest=src/flexhrc/web/static/vendor
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
(cd "$tmp" && npm pack --silent "three@$THREE" >/dev/null && tar xzf "three-$THREE.tgz")
mkdir -p "$dest/three"
cp "$tmp/package/build/three.module.min.js" "$dest/three/"
cp "$tmp/package/LICENSE" "$dest/three/LICENSE"
echo "three $THREE (npm), build/three.module.min.js; MIT, see LICENSE" > "$dest/three/VERSION"
echo "vendored three $THREE into $dest/three"

#!/usr/bin/env bash
# Rebuilds the page of `squish serve` (web/ → crates/squish-cli/web-bundle, committed) and records
# the hash of its sources, which a Rust test compares with the sources (a stale bundle fails it).
set -euo pipefail
cd "$(dirname "$0")"
[ -d node_modules ] || npm ci --no-audit --no-fund
npx vite build --logLevel warn
node tools/sources-hash.mjs . > ../crates/squish-cli/web-bundle/SOURCES
echo "web-bundle built from sources $(cat ../crates/squish-cli/web-bundle/SOURCES)"

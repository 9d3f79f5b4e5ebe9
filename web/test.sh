#!/usr/bin/env bash
# Browser tests of `squish serve` (web/tests): installs the npm packages (npm ci; Playwright's own
# browser download is skipped) and Debian's chromium if missing, builds the `squish` binary, and
# runs the tests in Chromium (software WebGL through SwiftShader).
set -euo pipefail
cd "$(dirname "$0")"
export PLAYWRIGHT_SKIP_BROWSER_DOWNLOAD=1
if [ ! -x /usr/bin/chromium ]; then
    apt-get update -qq && apt-get install -y -qq chromium >/dev/null
fi
npm ci --no-audit --no-fund --loglevel=error
# $SQUISH: a binary already built (CI passes the one `cargo test --workspace` built, which a
# `cargo build -p squish-cli` would rebuild with other dependency features).
if [ -z "${SQUISH:-}" ]; then
    (cd .. && cargo build -p squish-cli --bin squish)
fi
SQUISH="${SQUISH:-$PWD/../target/debug/squish}" node --test --test-concurrency=1 tests/

#!/bin/sh
# Installs Foxglove's readers pinned in package-lock.json into test/js/node_modules (needs node >= 18 and npm);
# test/test_foxglove_decode.py runs decode_bag.js with them and is skipped without them.
set -e
cd "$(dirname "$0")"
npm ci --no-audit --no-fund

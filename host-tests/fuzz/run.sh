#!/usr/bin/env bash
# Runs one fuzz target for a bounded time: bash host-tests/fuzz/run.sh TARGET [SECONDS]
# Targets: params_toml, record_csv, plant_step. Needs `cargo install cargo-fuzz`; the stable
# toolchain works with RUSTC_BOOTSTRAP=1 (libFuzzer's sanitizer flags are -Z flags).
# New inputs go to corpus/TARGET (not committed); seeds/TARGET are the committed seeds.
set -euo pipefail
cd "$(dirname "$0")/../.."
target="$1"; secs="${2:-60}"
mkdir -p "host-tests/fuzz/corpus/$target"
RUSTC_BOOTSTRAP=1 cargo fuzz run --fuzz-dir host-tests/fuzz "$target" \
  "host-tests/fuzz/corpus/$target" "host-tests/fuzz/seeds/$target" -- -max_total_time="$secs"

#!/usr/bin/env bash
# Runs one fuzz target for a bounded time: bash host-tests/fuzz/run.sh TARGET [SECONDS]
# Targets: params_toml, record_csv, plant_step. Needs `cargo install cargo-fuzz`; the stable
# toolchain works with RUSTC_BOOTSTRAP=1 (libFuzzer's sanitizer flags are -Z flags).
# The run starts from the committed seeds, seeds/TARGET (past crashes among them, named
# regression-*), and adds what it finds to corpus/TARGET (not committed); libFuzzer runs
# every seed first, so a crash that comes back fails at once.
# No sanitizer by default: the code under test has no `unsafe` (unsafe_code = "forbid"), so
# AddressSanitizer has nothing to find and costs about six times the executions (measured on
# plant_step: 1880 against 318 per second). FUZZ_SANITIZER=address turns it back on.
set -euo pipefail
cd "$(dirname "$0")/../.."
target="$1"; secs="${2:-60}"
mkdir -p "host-tests/fuzz/corpus/$target"
RUSTC_BOOTSTRAP=1 cargo fuzz run --sanitizer "${FUZZ_SANITIZER:-none}" --fuzz-dir host-tests/fuzz \
  "$target" "host-tests/fuzz/corpus/$target" "host-tests/fuzz/seeds/$target" \
  -- -max_total_time="$secs"

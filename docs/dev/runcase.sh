#!/usr/bin/env bash
# runcase.sh TAG KIND DRAW [BIN]: one case of the foreign suite (records of the independent
# reference, suite length), then `diagnose --validate` with the debug trace. Records and
# results go to $CASES/case-KIND-DRAW (CASES defaults to /work/tr): stdout out-TAG.txt, trace
# log-TAG.txt. Needs `cargo build --release -p geared-servo-cli -p geared-servo-host-tests
# --examples` in the repository this script is in (BIN: another build's CLI, to compare).
set -eu
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
TAG=$1; KIND=$2; DRAW=$3; BIN=${4:-$ROOT/target/release/geared-servo}
D=${CASES:-/work/tr}/case-$KIND-$DRAW
[ -f "$D/estimation.csv" ] || "$ROOT/target/release/examples/foreign_records" "$D" --kind "$KIND" --draw "$DRAW" >/dev/null
cd "$D"
RUST_LOG=geared_servo_host=debug "$BIN" --params file.toml diagnose --data estimation.csv --validate validation.csv > "out-$TAG.txt" 2> "log-$TAG.txt" || echo "rc $?"

#!/usr/bin/env bash
# runcase.sh TAG KIND DRAW [BIN]: records of the independent reference (suite length), then
# diagnose with the debug trace; stdout to /work/tr/case-KIND-DRAW/out-TAG.txt, log to log-TAG.txt
set -eu
TAG=$1; KIND=$2; DRAW=$3; BIN=${4:-/work/main/target/release/geared-servo}
D=/work/tr/case-$KIND-$DRAW
[ -f $D/estimation.csv ] || /work/main/target/release/examples/foreign_records $D --kind $KIND --draw $DRAW >/dev/null
cd $D
RUST_LOG=geared_servo_host=debug $BIN --params file.toml diagnose --data estimation.csv --validate validation.csv > out-$TAG.txt 2> log-$TAG.txt || echo "rc $?"

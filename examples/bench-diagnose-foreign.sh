#!/usr/bin/env bash
# Wall time of `diagnose` on 20 s of 2 kHz data with all candidates (issue 12 benchmark), on
# records of the independent reference integrator (host-tests/src/foreign.rs): a 20 s stepped
# sine for estimation and the 9 V square + 2 V multisine for validation, for a clean unit, one
# with a hidden load_viscous and one with two hidden effects. Run from the repository root.
set -euo pipefail
cargo build -q --release -p geared-servo-cli
cargo build -q --release -p geared-servo-host-tests --example foreign_records
B=target/release/geared-servo
T=$(mktemp -d)
for c in clean:0 load_viscous:1 pair:1; do
    kind=${c%%:*}; draw=${c##*:}
    target/release/examples/foreign_records "$T/$kind" --kind "$kind" --draw "$draw" --seconds 20 > /dev/null
    /usr/bin/time -f "$kind/$draw: %e s wall, %P CPU, %M kB" $B --params "$T/$kind/file.toml" \
        diagnose --data "$T/$kind/estimation.csv" --validate "$T/$kind/validation.csv" \
        | grep -E '^(added|final:|validation|unexplained|nothing)' || true
done
rm -rf "$T"

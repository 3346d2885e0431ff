#!/usr/bin/env bash
# Wall time of `diagnose` on 20 s of 2 kHz data with all seven candidates (issue 5 benchmark).
# Run from the repository root after `cargo build --release -p geared-servo-cli`.
set -euo pipefail
B=target/release/geared-servo
T=$(mktemp -d)
$B synth --output "$T/clean.csv" --duration 20 --noise 0.01 --seed 2 > /dev/null
$B synth --output "$T/one.csv" --duration 20 --noise 0.01 --seed 2 --effect mesh_damping=0.05 > /dev/null
$B synth --output "$T/three.csv" --duration 20 --noise 0.01 --seed 2 \
    --effect mesh_damping=0.05 --effect input_delay=0.001 --effect tach_gain=0.1 > /dev/null
for f in clean one three; do
    /usr/bin/time -f "$f: %e s wall, %P CPU" $B diagnose --data "$T/$f.csv" > /dev/null
done
rm -rf "$T"

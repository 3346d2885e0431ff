#!/usr/bin/env bash
# Regenerates the diagnose walk-throughs of docs/diagnose.md: examples/real-data (needs the
# bench record in ../shared/data beside the clone) and examples/synthetic-hidden-effect.
# Run from the repository root after `cargo build --release -p geared-servo-cli`.
set -e
B=target/release/geared-servo
D=examples/real-data; rm -rf $D; mkdir -p $D
$B --params data/kord-geartrain.toml diagnose --data ../shared/data/geartrain-square-wave.csv --out $D > $D/stdout.txt
D=examples/synthetic-hidden-effect; rm -rf $D; mkdir -p $D
# The "true" actuator: the reference with stiffness 18 % low, load inertia 15 % high and
# mesh damping 0.05 N*m*s/rad that the file given to diagnose does not declare.
sed -e 's/^inertia_kg_m2 = 1.0e-3 /inertia_kg_m2 = 1.15e-3/' -e 's/^length_m = 0.045 /length_m = 0.0549/' -e 's/^mesh_damping = 0.0 /mesh_damping = 0.05/' data/reference-actuator.toml > $D/true-actuator.toml
$B --params $D/true-actuator.toml synth --output $D/meas.csv --excitation multisine --amplitude 10 --f-min 2 --f-max 300 --duration 3 --noise 0.01 --seed 5 > /dev/null
$B --params $D/true-actuator.toml synth --output $D/val.csv --excitation chirp --amplitude 10 --f-min 2 --f-max 300 --duration 3 --noise 0.01 --seed 11 > /dev/null
$B diagnose --data $D/meas.csv --validate $D/val.csv --out $D > $D/stdout.txt
$B --json diagnose --data $D/meas.csv --validate $D/val.csv > $D/diagnose-stdout.json

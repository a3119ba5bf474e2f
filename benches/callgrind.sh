#!/usr/bin/env bash
# Counts the instructions of the MNI frame (the VTK peer scene, 256×256, sample distance 0.5
# voxel, shaded, the paper's node gradients, as the packet march takes them) with callgrind, on one thread: deterministic, so two builds compare to the
# instruction. Prints the instructions of one steady frame (half the
# difference between a run that renders the frame three times and one that renders it once:
# the dataset load and the first frame's precomputation cancel) and of the whole one-frame run.
#
#   bash benches/callgrind.sh [step] [flags]   # needs valgrind and ../shared/data's MNI template
#
# The step (voxels, default 0.5) and further flags go to examples/mni.rs: the usual count is
# `bash benches/callgrind.sh` (the packet march at 0.5 voxel); the pre-integrated march at a
# coarser step, say, `bash benches/callgrind.sh 2 --preintegrate`; the accuracy study's steep ramp
# with `--ramp=0.35,0.55`.
#
# valgrind does not run AVX-512, so this counts the eight-lane (AVX2) packet march.
set -euo pipefail
cd "$(dirname "$0")/.."
step=${1:-0.5}
extra=("${@:2}")
cargo build --release --quiet -p vlconvert -p vlib-volume --bin vlconvert --example mni
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
mni=../shared/data/mni_icbm152_t1_tal_nlin_sym_09a_converted.nii.gz
if [[ -f target/bench-data/mni.vlb ]]; then # converted before (benches/mni.rs, the examples)
    cp target/bench-data/mni.vlb "$work/mni.vlb"
else
    target/release/vlconvert nifti "$mni" "$work/mni.vlb" >/dev/null
fi
run() { # run <name> <extra frames>
    RAYON_NUM_THREADS=1 valgrind --tool=callgrind --callgrind-out-file="$work/$1.out" \
        target/release/examples/mni "$work/mni.vlb" "$work/$1.png" "$step" "${extra[@]}" --gradient=nodes \
        --size=256 --frames="$2" \
        >/dev/null 2>"$work/$1.log"
}
run one 0
run three 2
count() { sed -n 's/.*Collected : \([0-9]*\).*/\1/p' "$1"; }
one=$(count "$work/one.log")
three=$(count "$work/three.log")
echo "MNI frame 256², one thread: $(( (three - one) / 2 )) instructions a steady frame (the whole run with one frame: $one)"
cmp -s "$work/one.png" "$work/three.png" || { echo "the two runs' images differ"; exit 1; }

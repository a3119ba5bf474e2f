#!/usr/bin/env bash
# Counts the instructions of the MNI frame (the VTK peer scene, 256×256, sample distance 0.5
# voxel, shaded) with callgrind, on one thread: deterministic, so two builds compare to the
# instruction. Prints the count of the rendering alone (`render_image` and what it calls; the
# dataset load and the scene's compilation are outside it) and of the whole run.
#
#   bash benches/callgrind.sh            # needs valgrind and ../shared/data's MNI template
#
# valgrind does not run AVX-512, so this counts the eight-lane (AVX2) packet march.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --quiet -p vlib --bin vlconvert --example mni
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
mni=../shared/data/mni_icbm152_t1_tal_nlin_sym_09a_converted.nii.gz
target/release/vlconvert nifti "$mni" "$work/mni.vlb" >/dev/null
RAYON_NUM_THREADS=1 valgrind --tool=callgrind --callgrind-out-file="$work/all.out" \
    target/release/examples/mni "$work/mni.vlb" "$work/all.png" --size=256 >/dev/null 2>"$work/all.log"
RAYON_NUM_THREADS=1 valgrind --tool=callgrind --callgrind-out-file="$work/render.out" \
    --toggle-collect='*render_image*' \
    target/release/examples/mni "$work/mni.vlb" "$work/render.png" --size=256 >/dev/null 2>"$work/render.log"
count() { sed -n 's/.*Collected : \([0-9]*\).*/\1/p' "$1"; }
echo "MNI frame 256², one thread: rendering $(count "$work/render.log") instructions, whole run $(count "$work/all.log")"
cmp -s "$work/all.png" "$work/render.png" || { echo "the two runs' images differ"; exit 1; }

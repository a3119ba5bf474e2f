#!/usr/bin/env bash
# vlib against VTK's CPU ray caster on the MNI brain, back to back on this machine.
#
#   bash benches/peer.sh            # installs vtk + nibabel with pip if missing
#
# Runs `cargo bench --bench mni` (criterion: vlib's steady frame with and without empty-space
# skipping and early termination) and `python3 ../shared/bench/vtk_dvr.py --only main` (VTK's
# median frame of the same scene), then prints each vlib time and its ratio to VTK's.
# Absolute times drift between machines and runs: only the ratios of one run mean anything.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)
shared="$root/../shared/bench"
work="$root/target/bench-work"
mkdir -p "$work"

python3 -c "import vtk, nibabel" 2>/dev/null || pip install -q vtk nibabel

echo "== VTK (vtkFixedPointVolumeRayCastMapper), $(nproc) threads"
export VLIB_BENCH_DIR="$work"
[ -e "$work/data/mni152_t1.json" ] || python3 "$shared/prepare_data.py" >/dev/null
python3 "$shared/vtk_dvr.py" --only main | tail -n 2

echo "== vlib (criterion)"
cargo bench --bench mni 2>&1 | grep -E "first frame|^mni_|time:" || true

python3 - "$work/out/vtk_results.json" "$root/target/criterion/mni_512_sd0.5" <<'PY'
import json, os, sys
vtk = json.load(open(sys.argv[1]))["results"][0]
vtk_s, vtk_first = vtk["median_s"], vtk["first_frame_s"]
print(f"\nVTK main (shaded, sd 0.5): median {vtk_s*1e3:.1f} ms, first frame {vtk_first*1e3:.1f} ms")
print(f"{'vlib variant':34} {'median ms':>10} {'vlib/VTK':>9} {'VTK/vlib':>9}")
for name in ["shaded", "shaded_no_skipping", "shaded_no_early_termination", "shaded_neither", "unshaded"]:
    p = os.path.join(sys.argv[2], name, "new", "estimates.json")
    if not os.path.exists(p):
        continue
    ns = json.load(open(p))["median"]["point_estimate"]
    print(f"{name:34} {ns/1e6:10.1f} {ns/1e9/vtk_s:9.2f} {vtk_s/(ns/1e9):9.2f}")
PY
echo "images: $work/out/vtk_mni.png and (cargo run --release --example mni) out/mni.png"

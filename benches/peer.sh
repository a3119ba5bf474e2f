#!/usr/bin/env bash
# vlib against VTK's CPU ray caster on the MNI brain, back to back on this machine.
#
#   bash benches/peer.sh            # the main scene: shaded, sample distance 0.5
#   bash benches/peer.sh --sweep    # every sample distance of the sweep, shaded and unshaded,
#                                   # and the table written to docs/performance.md
#
# Installs vtk + nibabel with pip if missing. Runs `cargo bench --bench mni` (criterion) and
# `python3 ../shared/bench/vtk_dvr.py` (VTK's median frame of the same scene), then prints each
# vlib time and its ratio to VTK's. Absolute times drift between machines and runs: only the
# ratios of one run mean anything. The images: target/bench-work/out/vtk_mni*.png and
# target/bench-work/out/vlib_mni*.png.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)
shared="$root/../shared/bench"
work="$root/target/bench-work"
mkdir -p "$work/out"
sweep=0
[ "${1:-}" = "--sweep" ] && sweep=1

python3 -c "import vtk, nibabel" 2>/dev/null || pip install -q vtk nibabel

export VLIB_BENCH_DIR="$work"
[ -e "$work/data/mni152_t1.json" ] || python3 "$shared/prepare_data.py" >/dev/null
if [ $sweep = 1 ]; then
  configs="main noshade_sd0.5 shade_sd2.0 shade_sd1.0 shade_sd0.25 shade_sd0.125 noshade_sd2.0 noshade_sd1.0 noshade_sd0.25 noshade_sd0.125"
  filter="mni_"
else
  configs="main"
  filter="mni_512_sd0.5"
fi
echo "== VTK (vtkFixedPointVolumeRayCastMapper), $(nproc) threads"
# shellcheck disable=SC2086
python3 "$shared/vtk_dvr.py" --only $configs | tail -n $(( $(echo $configs | wc -w) + 1 ))

echo "== vlib (criterion)"
cargo bench --bench mni -- "$filter" 2>&1 | grep -E "first frame|time:" || true
cargo build --release --example mni -q
target/release/examples/mni target/bench-data/mni.vlb "$work/out/vlib_mni.png" 0.5 >/dev/null

python3 - "$work/out/vtk_results.json" "$root/target/criterion" "$sweep" "$root/docs/performance.md" "$(nproc)" <<'PY'
import json, os, platform, sys
vtk = {r["name"]: r for r in json.load(open(sys.argv[1]))["results"]}
crit, sweep, doc, cpus = sys.argv[2], sys.argv[3] == "1", sys.argv[4], sys.argv[5]

def vlib_ms(group, name):
    p = os.path.join(crit, group, name, "new", "estimates.json")
    return json.load(open(p))["median"]["point_estimate"] / 1e6 if os.path.exists(p) else None

main = vtk["main"]["median_s"] * 1e3
print(f"\nVTK main (shaded, sd 0.5): median {main:.1f} ms, first frame {vtk['main']['first_frame_s']*1e3:.1f} ms")
print(f"{'vlib variant (sd 0.5)':34} {'median ms':>10} {'vlib/VTK':>9}")
for name in ["shaded", "shaded_no_skipping", "shaded_no_early_termination", "shaded_neither", "unshaded"]:
    ms = vlib_ms("mni_512_sd0.5", name)
    if ms is not None:
        print(f"{name:34} {ms:10.1f} {ms/main:9.2f}")
if not sweep:
    sys.exit(0)
rows = []
for shade in ["shade", "noshade"]:
    for sd in ["2.0", "1.0", "0.5", "0.25", "0.125"]:
        key = "main" if (shade, sd) == ("shade", "0.5") else f"{shade}_sd{sd}"
        v = vlib_ms("mni_sweep", f"{shade}_sd{float(sd):g}")
        t = vtk.get(key, {}).get("median_s")
        if v is None or t is None:
            continue
        # The physical limit of ../shared/bench/README.md is given for sample distance 0.5.
        limit = {"shade": 11.0, "noshade": 7.0}[shade] if sd == "0.5" else None
        lim = f"{v/limit:.1f}" if limit else "—"
        rows.append(f"| {sd} | {'on' if shade == 'shade' else 'off'} | {t*1e3:.1f} | {v:.1f} | {t*1e3/v:.2f} | {lim} |")
table = "\n".join([
    "| sample distance (voxels) | shading | VTK median (ms) | vlib median (ms) | speed-up (VTK / vlib) | vlib / physical limit |",
    "|---|---|---|---|---|---|",
    *rows,
])
print("\n" + table)
begin, end = "<!-- peer:begin -->", "<!-- peer:end -->"
text = open(doc).read() if os.path.exists(doc) else ""
machine = f"{platform.processor() or platform.machine()}, {cpus} cores, {platform.system()} {platform.release()}"
block = f"{begin}\nMeasured by `bash benches/peer.sh --sweep` on {machine}.\n\n{table}\n{end}"
if begin in text and end in text:
    a, b = text.index(begin), text.index(end) + len(end)
    text = text[:a] + block + text[b:]
else:
    text += "\n" + block + "\n"
open(doc, "w").write(text)
print(f"updated {doc}")
PY

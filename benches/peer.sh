#!/usr/bin/env bash
# vlib against VTK's CPU ray caster on the MNI brain, back to back on this machine.
#
#   bash benches/peer.sh            # the main scene: shaded, sample distance 0.5
#   PEER_ROUNDS=5 bash benches/peer.sh   # more interleaved VTK/vlib rounds (default 3)
#   bash benches/peer.sh --sweep    # every sample distance of the sweep, shaded and unshaded,
#                                   # and the table written to docs/performance.md
#   PEER_SWEEP_ROUNDS=5 bash benches/peer.sh --sweep   # more sweep rounds (default 3)
#
# Installs vtk + nibabel with pip if missing. Runs `cargo bench --bench mni` (criterion),
# `python3 ../shared/bench/vtk_dvr.py` (VTK's median frame of the same scene) and the
# physical-limit kernel of ../shared/bench/limit (`simd_cd_oracle` shaded, `simd_noshade_oracle`
# unshaded, on every core: the cost of the frame's essential samples alone; built here with
# its sample distance set to each of the sweep's), then prints each vlib time and its ratios
# to VTK's and to the limit's. Absolute times drift between machines and runs: only the
# ratios of one run mean anything. The images: target/bench-work/out/vtk_mni*.png and
# target/bench-work/out/vlib_mni*.png, and both main frames side by side (VTK left, vlib right)
# in docs/performance-mni.png.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)
shared="$root/../shared/bench"
work="$root/target/bench-work"
mkdir -p "$work/out"
sweep=0
[ "${1:-}" = "--sweep" ] && sweep=1

python3 -c "import vtk, nibabel, PIL" 2>/dev/null || pip install -q vtk nibabel pillow

export VLIB_BENCH_DIR="$work"
[ -e "$work/data/mni152_t1.json" ] || python3 "$shared/prepare_data.py" >/dev/null
if [ $sweep = 1 ]; then
  configs="main noshade_sd0.5 shade_sd2.0 shade_sd1.0 shade_sd0.25 shade_sd0.125 noshade_sd2.0 noshade_sd1.0 noshade_sd0.25 noshade_sd0.125"
  filter="mni_"
else
  configs="main"
  filter="mni_512_sd0.5"
fi
# The physical-limit kernel, built once per sample distance (its `SD` constant; the shared
# source stays as it is, a copy is patched under target/) for this processor.
limit_bin() { # $1: sample distance in voxels; sets limit_exe[$1]
  local sd=$1 src="$root/target/limit-src/sd$1" new="$root/target/limit-src/sd$1.new"
  rm -rf "$new"
  mkdir -p "$new"
  cp -r "$shared/limit/Cargo.toml" "$shared/limit/Cargo.lock" "$shared/limit/src" "$new/"
  chmod -R u+w "$new" # (the shared files may be read-only)
  # (A package of its own, not of vlib's workspace, which holds target/.)
  printf '\n[workspace]\n' >> "$new/Cargo.toml"
  grep -q '^const SD: f64 = 0.5;' "$new/src/main.rs" ||
    { echo "the limit kernel's sample distance is not where peer.sh expects it" >&2; exit 1; }
  sed -i "s/^const SD: f64 = 0.5;/const SD: f64 = $sd;/" "$new/src/main.rs"
  # The same source as the last build's: its files (and their times) stay, and cargo does not
  # build it again.
  if diff -rq "$new" "$src" >/dev/null 2>&1; then
    rm -rf "$new"
  else
    rm -rf "$src"
    mv "$new" "$src"
  fi
  RUSTFLAGS="-C target-cpu=native" CARGO_TARGET_DIR="$root/target/limit-sd$sd" \
    cargo build --release --quiet --manifest-path "$src/Cargo.toml"
  limit_exe[$sd]="$root/target/limit-sd$sd/release/dvr_limit"
}
limit_sds="2.0 1.0 0.5 0.25 0.125"
declare -A limit_exe
# shellcheck disable=SC2046
for sd in $([ $sweep = 1 ] && echo "$limit_sds" || echo 0.5); do limit_bin "$sd"; done
limit_run() { # $1: sample distance; $2: variants (comma-separated); prints "variant median_ms"
  # lines, from the kernel's own timings (full precision); none for a variant it cannot run
  # here (its simd_* variants need AVX-512), and none, with its message, where it fails.
  local timings="$work/out/limit_timings.json"
  rm -f "$timings"
  if ! "${limit_exe[$1]}" --runs 9 --threads "$(nproc)" --only "$2" --out "$work/out/limit.ppm" \
    >/dev/null 2>"$work/out/limit.err"; then
    echo "the limit kernel failed at sample distance $1: $(tail -n 3 "$work/out/limit.err")" >&2
    return 0
  fi
  grep -h "not available" "$work/out/limit.err" >&2 || true
  [ -e "$timings" ] || return 0
  python3 -c 'import json, sys
for r in json.load(open(sys.argv[1]))["results"]:
    print(r["variant"], r["median_s"] * 1e3)' "$timings"
}
limit_sweep() { # $1: where the round's limits go (json: shade_sd2 … noshade_sd0.125 → ms)
  for sd in $limit_sds; do
    limit_run "$sd" simd_cd_oracle,simd_noshade_oracle |
      awk -v sd="$sd" '{n = ($1 == "simd_cd_oracle") ? "shade" : "noshade"; printf "%s_sd%g %s\n", n, sd, $2}'
  done | python3 -c 'import json, sys; json.dump({k: float(v) for k, v in (l.split() for l in sys.stdin)}, open(sys.argv[1], "w"))' "$1"
}

echo "== VTK (vtkFixedPointVolumeRayCastMapper), $(nproc) threads"
# shellcheck disable=SC2086
python3 "$shared/vtk_dvr.py" --only $configs | tail -n $(( $(echo $configs | wc -w) + 1 ))

echo "== vlib (criterion)"
cargo bench --bench mni -- "$filter" 2>&1 | tee "$work/out/vlib_bench.txt" | grep -E "first frame|time:" || true
# The sweep's medians of one run: VTK's frames moved by up to 1.7x between runs on a shared
# host, vlib's by a few per cent. So the sweep is repeated in rounds, VTK's sweep then vlib's,
# the first round being the two runs above, and the table gives each distance's median ratio
# over the rounds with its range.
sweep_configs="shade_sd2.0 shade_sd1.0 main shade_sd0.25 shade_sd0.125 noshade_sd2.0 noshade_sd1.0 noshade_sd0.5 noshade_sd0.25 noshade_sd0.125"
collect_sweep() { # $1: VTK's json of the round; $2: where the round goes; $3: the limit's json
  python3 - "$1" "$root/target/criterion/mni_sweep" "$2" "$3" <<'PY'
import json, os, sys
vtk = {r["name"]: r["median_s"] * 1e3 for r in json.load(open(sys.argv[1]))["results"]}
vlib = {}
for name in os.listdir(sys.argv[2]):
    p = os.path.join(sys.argv[2], name, "new", "estimates.json")
    if os.path.exists(p):
        vlib[name] = json.load(open(p))["median"]["point_estimate"] / 1e6
limit = json.load(open(sys.argv[4]))
json.dump({"vtk": vtk, "vlib": vlib, "limit": limit}, open(sys.argv[3], "w"))
PY
}
sweep_rounds=${PEER_SWEEP_ROUNDS:-3}
rm -f "$work"/out/sweep_round*.json
if [ $sweep = 1 ]; then
  echo "== the physical-limit kernel at every sample distance"
  limit_sweep "$work/out/limit_sweep_round.json"
  collect_sweep "$work/out/vtk_results.json" "$work/out/sweep_round1.json" "$work/out/limit_sweep_round.json"
  for r in $(seq 2 "$sweep_rounds"); do
    echo "== sweep round $r of $sweep_rounds: VTK, then vlib, then the limit"
    rm -f "$work/out/vtk_sweep_round.json"
    # shellcheck disable=SC2086
    python3 "$shared/vtk_dvr.py" --only $sweep_configs --json "$work/out/vtk_sweep_round.json" >/dev/null
    cargo bench --bench mni -- 'mni_sweep' > "$work/out/vlib_sweep_round.txt" 2>&1
    limit_sweep "$work/out/limit_sweep_round.json"
    collect_sweep "$work/out/vtk_sweep_round.json" "$work/out/sweep_round$r.json" "$work/out/limit_sweep_round.json"
  done
fi
# The machine's speed drifts between minutes (a shared host): the main comparison is repeated
# in interleaved rounds, VTK then vlib, and the ratio of each round is reported.
rounds=${PEER_ROUNDS:-3}
echo "== $rounds interleaved rounds: VTK main, then vlib shaded (sd 0.5), then the limit kernel"
: > "$work/out/rounds.txt"
est="$root/target/criterion/mni_512_sd0.5/shaded/new/estimates.json"
cp "$est" "$work/out/shaded_estimates.json" # the tables report the full run above
for r in $(seq "$rounds"); do
  vt=$(python3 "$shared/vtk_dvr.py" --only main --json "$work/out/vtk_round.json" | awk '$1 == "main" {print $7}')
  cargo bench --bench mni -- 'mni_512_sd0.5/shaded$' > "$work/out/vlib_round.txt" 2>&1
  vl=$(python3 -c 'import json, sys; print(json.load(open(sys.argv[1]))["median"]["point_estimate"] / 1e9)' "$est")
  li=$(limit_run 0.5 simd_cd_oracle | awk '{print $2 / 1000}')
  li=${li:-nan} # (no limit kernel on this processor)
  echo "$vt $vl $li" >> "$work/out/rounds.txt"
  echo "round $r: VTK ${vt} s, vlib ${vl} s, limit ${li} s"
done
cp "$work/out/shaded_estimates.json" "$est"

cargo build --release --example mni -q
target/release/examples/mni target/bench-data/mni.vlb "$work/out/vlib_mni.png" 0.5 --gradient=nodes >/dev/null
# The same at VTK's termination threshold (its fixed-point remaining opacity below 0xff/0x7fff;
# the exact double of mni_scene::VTK_TERMINATION, 255.0 / 32767.0, as Python prints it).
target/release/examples/mni target/bench-data/mni.vlb "$work/out/vlib_mni_vtk_termination.png" 0.5 \
  --gradient=nodes --termination="$(python3 -c 'print(255 / 32767)')" >/dev/null
# The converged reference both images are measured against: step 0.125 voxel, Catmull–Rom,
# adaptive 2×2 super-sampling (several seconds).
ref="$work/out/reference_mni.png"
target/release/examples/mni target/bench-data/mni.vlb "$ref" 0.125 --cubic --ss=2 --gradient=nodes >/dev/null
python3 - "$work/out/vtk_mni.png" "$work/out/vlib_mni.png" "$root/docs/performance-mni.png" <<'PY'
import sys
from PIL import Image
a, b = (Image.open(p).convert("RGB") for p in sys.argv[1:3])
h = max(a.height, b.height)
out = Image.new("RGB", (a.width + b.width + 8, h), (255, 255, 255))
out.paste(a, (0, 0))
out.paste(b, (a.width + 8, 0))
out.save(sys.argv[3], optimize=True)
print(f"side by side (VTK left, vlib right): {sys.argv[3]}")
PY
python3 - "$work/out/vtk_mni.png" "$work/out/vlib_mni.png" "$ref" "$work/out/errors.json" \
  "$work/out/vlib_mni_vtk_termination.png" <<'PY'
import json, sys
import numpy as np
from PIL import Image
vtk, vlib, ref, vlib_vt = (
    np.asarray(Image.open(p).convert("RGB"), dtype=float) for p in sys.argv[1:4] + sys.argv[5:6]
)
def rms(a, b):
    return float(np.sqrt(np.mean((a - b) ** 2)))
err = {"vtk": rms(vtk, ref), "vlib": rms(vlib, ref), "vlib_vtk_termination": rms(vlib_vt, ref)}
json.dump(err, open(sys.argv[4], "w"))
print(f"RMS difference from the converged reference (8-bit levels): VTK {err['vtk']:.2f}, "
      f"vlib {err['vlib']:.2f}, vlib at VTK's termination threshold {err['vlib_vtk_termination']:.2f}")
PY

python3 - "$work/out/vtk_results.json" "$root/target/criterion" "$sweep" "$root/docs/performance.md" "$(nproc)" "$work/out/vlib_bench.txt" "$work/out/errors.json" "$work/out/rounds.txt" "$work/out" <<'PY'
import glob, json, os, platform, re, statistics, sys
errors = json.load(open(sys.argv[7]))
rounds = [tuple(map(float, line.split())) for line in open(sys.argv[8]) if line.strip()]
vtk = {r["name"]: r for r in json.load(open(sys.argv[1]))["results"]}
crit, sweep, doc, cpus = sys.argv[2], sys.argv[3] == "1", sys.argv[4], sys.argv[5]
m = re.search(r"first frame.*?: ([0-9.]+) s", open(sys.argv[6]).read())
vlib_first = float(m.group(1)) * 1e3 if m else None

def cpu_model():
    try:
        for line in open("/proc/cpuinfo"):
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()

def write_block(text, name, block):
    begin, end = f"<!-- {name}:begin -->", f"<!-- {name}:end -->"
    block = f"{begin}\n{block}\n{end}"
    if begin in text and end in text:
        a, b = text.index(begin), text.index(end) + len(end)
        return text[:a] + block + text[b:]
    return text + "\n" + block + "\n"

def simd():
    try:
        flags = next(l for l in open("/proc/cpuinfo") if l.startswith("flags")).split()
    except (OSError, StopIteration):
        return ""
    return " (AVX-512)" if "avx512f" in flags else " (AVX2)" if "avx2" in flags else ""

machine = f"{cpu_model()}{simd()}, {cpus} cores, {platform.system()} {platform.release()}"

def vlib_ms(group, name):
    p = os.path.join(crit, group, name, "new", "estimates.json")
    return json.load(open(p))["median"]["point_estimate"] / 1e6 if os.path.exists(p) else None

main = vtk["main"]["median_s"] * 1e3
vtk_first = vtk["main"]["first_frame_s"] * 1e3
print(f"\nVTK main (shaded, sd 0.5): median {main:.1f} ms, first frame {vtk_first:.1f} ms")
print(f"{'vlib variant (sd 0.5)':34} {'median ms':>10} {'vlib/VTK':>9}")
main_rows = [f"| VTK `vtkFixedPointVolumeRayCastMapper` | {main:.0f} ms (first frame {vtk_first:.0f} ms) | — |"]
labels = {
    "shaded": "vlib, skipping + early termination + lean kernel + packet march (sixteen lanes where AVX-512)",
    "shaded_no_skipping": "vlib, no empty-space skipping",
    "shaded_no_early_termination": "vlib, no early termination",
    "shaded_neither": "vlib, neither skipping nor early termination",
    "shaded_no_lean_kernel": "vlib, general interpreter instead of the lean kernel",
    "shaded_scalar": "vlib, scalar march instead of the packet march",
    "shaded_eight_lanes": "vlib, packet march in eight AVX2 lanes instead of sixteen AVX-512 lanes",
    "shaded_vtk_termination": "vlib, rays stopped at VTK's threshold (transmittance 255/32767, not 1/512)",
    "unshaded": "vlib, unshaded (against VTK shaded)",
}
for name, label in labels.items():
    ms = vlib_ms("mni_512_sd0.5", name)
    if ms is not None:
        print(f"{name:34} {ms:10.1f} {ms/main:9.2f}")
        first = f" (first frame {vlib_first:.0f} ms, the median of five fresh loads)" if name == "shaded" and vlib_first else ""
        main_rows.append(f"| {label} | {ms:.0f} ms{first} | {ms/main:.2f} |")
round_ratios = [v / t for t, v, _ in rounds]
# (The limit kernel runs where the processor has AVX-512: without it, no limit is given.)
limited = all(li > 0 for _, _, li in rounds)  # (NaN where it did not run)
limit_ratios = [v / li for _, v, li in rounds] if limited else []
if round_ratios:
    print("vlib/VTK in the interleaved rounds: "
          + ", ".join(f"{r:.2f}" for r in round_ratios)
          + f" (median {statistics.median(round_ratios):.2f})")
if limit_ratios:
    print("vlib/limit in the interleaved rounds: "
          + ", ".join(f"{r:.2f}" for r in limit_ratios)
          + f" (median {statistics.median(limit_ratios):.2f})")
if limited:
    rounds_line = (
        f"Interleaved rounds (VTK main, then vlib shaded, then the physical-limit kernel, "
        f"{len(rounds)} times): "
        + "; ".join(f"{t * 1e3:.0f} ms, {v * 1e3:.1f} ms and {li * 1e3:.1f} ms "
                    f"(vlib / VTK {v / t:.2f}, vlib / limit {v / li:.2f})" for t, v, li in rounds)
        + f". Median vlib / VTK: {statistics.median(round_ratios):.2f}; median vlib / limit: "
        f"{statistics.median(limit_ratios):.2f} (the target: at most 1.5)."
        if rounds else ""
    )
else:
    rounds_line = (
        f"Interleaved rounds (VTK main, then vlib shaded, {len(rounds)} times; no limit kernel "
        f"on this processor): "
        + "; ".join(f"{t * 1e3:.0f} ms against {v * 1e3:.1f} ms, {v / t:.2f}" for t, v, _ in rounds)
        + f". Median vlib / VTK: {statistics.median(round_ratios):.2f}."
        if rounds else ""
    )
text = open(doc).read() if os.path.exists(doc) else ""
main_table = "\n".join([
    f"Measured by `bash benches/peer.sh` on {machine}.",
    "",
    "| renderer, MNI brain, 512², shaded, sample distance 0.5 | median frame | vlib / VTK |",
    "|---|---|---|",
    *main_rows,
    *([f"| physical-limit kernel (`../shared/bench/limit`, `simd_cd_oracle`: perfect free "
       f"empty-space skipping, sixteen lanes, stops at transmittance 0.01), the rounds' median "
       f"| {statistics.median(li for _, _, li in rounds) * 1e3:.1f} ms | — |"]
      if rounds and limited else []),
    "",
    *([rounds_line, ""] if rounds_line else []),
    "RMS difference of each main image from a converged vlib reference (step 0.125 voxel, "
    "Catmull–Rom, adaptive 2×2 super-sampling), in 8-bit levels: "
    f"VTK {errors['vtk']:.2f}, vlib {errors['vlib']:.2f}"
    + (f", vlib at VTK's termination threshold {errors['vlib_vtk_termination']:.2f}"
       if "vlib_vtk_termination" in errors else "")
    + ". The images side by side (VTK left, vlib right): `performance-mni.png`.",
])
text = write_block(text, "peer-main", main_table)
open(doc, "w").write(text)
if not sweep:
    sys.exit(0)
sweep_rounds = [json.load(open(p)) for p in
                sorted(glob.glob(os.path.join(sys.argv[9], "sweep_round*.json")),
                       key=lambda p: int(re.search(r"round(\d+)", p).group(1)))]
rows, worst = [], []
for shade in ["shade", "noshade"]:
    for sd in ["2.0", "1.0", "0.5", "0.25", "0.125"]:
        key = "main" if (shade, sd) == ("shade", "0.5") else f"{shade}_sd{sd}"
        name = f"{shade}_sd{float(sd):g}"
        pairs = [(r["vtk"][key], r["vlib"][name]) for r in sweep_rounds
                 if key in r["vtk"] and name in r["vlib"] and r["vlib"][name] > 0]
        if not pairs:
            continue
        t = statistics.median(p[0] for p in pairs)
        v = statistics.median(p[1] for p in pairs)
        ratios = [a / b for a, b in pairs]
        worst.append(min(ratios))
        # vlib over the physical-limit kernel at the same distance, round by round.
        limits = [(r["vlib"][name], r["limit"][name]) for r in sweep_rounds
                  if name in r["vlib"] and r.get("limit", {}).get(name, 0) > 0]
        lim_ms = f"{statistics.median(li for _, li in limits):.1f}" if limits else "—"
        lim = (f"{statistics.median(a / b for a, b in limits):.2f}" if limits else "—")
        rows.append(f"| {sd} | {'on' if shade == 'shade' else 'off'} | {t:.1f} | {v:.1f} "
                    f"| {statistics.median(ratios):.2f} | {min(ratios):.2f}–{max(ratios):.2f} "
                    f"| {lim_ms} | {lim} |")
table = "\n".join([
    "| sample distance (voxels) | shading | VTK median (ms) | vlib median (ms) "
    "| speed-up (VTK / vlib), median of the rounds | its range over the rounds "
    "| limit kernel median (ms) | vlib / limit, median of the rounds |",
    "|---|---|---|---|---|---|---|---|",
    *rows,
])
n = len(sweep_rounds)
summary = (f"{n} rounds (VTK's sweep, then vlib's, then the limit kernel's); each time the median over the rounds of each "
           f"renderer's median frame, each speed-up the median of the {n} rounds' ratios. "
           f"The lowest ratio of any round at any distance: {min(worst):.2f}." if worst else "")
print("\n" + table + "\n" + summary)
text = write_block(text, "peer", f"Measured by `bash benches/peer.sh --sweep` on {machine}, {summary}\n\n{table}")
open(doc, "w").write(text)
print(f"updated {doc}")
PY

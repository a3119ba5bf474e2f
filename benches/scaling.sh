#!/usr/bin/env bash
# How vlib's memory and time grow with the dataset, against VTK's CPU ray caster: the MNI peer
# scene (../shared/bench/README.md) on the template repeated 2× and 3× per axis, resampled 2× and
# 4× per axis (8- and 16-bit) and a 512³ 16-bit CT-like phantom (benches/scaling/volumes.rs).
# Each volume is the template at (ny − 1)/232 voxels per mm: the camera 360 mm away, opacity per
# mm, sample distance 0.5 voxel, 512², shaded with the paper's node gradients (as the peer
# scene: benches/scaling/render.c, examples/mni.rs --fit --gradient=nodes, whose images are then
# the same bytes; benches/scaling/vtk_scaled.py). Per volume it runs, each as a process of its own under
# /usr/bin/time (peak resident memory, wall time):
#   - the Rust path, examples/mni (load, first image, then three steady frames);
#   - the C path, benches/scaling/render.c through libvlib.so (vlLoad, one image: a whole run);
#   - VTK's vtkFixedPointVolumeRayCastMapper (a warm-up frame and two timed frames).
# Then it rewrites the block between the scaling markers of docs/performance.md.
#
#   bash benches/scaling.sh                 # about 2.5 GB of volumes in target/scaling
#   SCALING_ONLY="mni rep2" bash benches/scaling.sh   # some volumes (the table keeps the others
#                                                     # whose results target/scaling/out holds)
#   SCALING_NO_VTK=1 bash benches/scaling.sh           # vlib only
#
# Needs a C compiler, /usr/bin/time, the template (target/bench-data/mni.vlb as the benches make
# it, or $VLIB_MNI_VLB, else ../shared/data's NIfTI, converted); VTK with pip (vtk, numpy).
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
work=$root/target/scaling
mkdir -p "$work/out"
cargo build --release --quiet -p vlib-capi -p vlconvert
cargo build --release --quiet -p vlib-volume --example mni --example scaling_volumes
ln -sf libvlib.so target/release/libvlib.so.0
cc -O2 -Iinclude benches/scaling/render.c -Ltarget/release -lvlib \
  -Wl,-rpath,"$root/target/release" -o "$work/render"
if [ -z "${SCALING_NO_VTK:-}" ]; then
  python3 -c "import vtk, numpy" 2>/dev/null || pip install -q vtk numpy
fi
vol=target/release/examples/scaling_volumes
# The template: the benches' converted copy where there is one, else converted here.
if [ ! -f "$work/mni.vlb" ]; then
  nifti=$root/../shared/data/mni_icbm152_t1_tal_nlin_sym_09a_converted.nii.gz
  converted=${VLIB_MNI_VLB:-$root/target/bench-data/mni.vlb}
  if [ -f "$converted" ]; then
    cp "$converted" "$work/mni.vlb"
    # (Its placement too, as vlconvert writes it.)
    if [ -f "$converted.geom" ]; then cp "$converted.geom" "$work/mni.vlb.geom"; fi
  elif [ -f "$nifti" ]; then
    target/release/vlconvert -q nifti "$nifti" "$work/mni.vlb" >/dev/null
  else
    echo "scaling.sh: no MNI template: neither $converted nor $nifti" >&2
    exit 1
  fi
fi
# name: how it is made
make_volume() {
  case $1 in
    mni) ;;
    rep2) $vol repeat "$work/mni.vlb" "$work/rep2.vlb" 2 ;;
    rep3) $vol repeat "$work/mni.vlb" "$work/rep3.vlb" 3 ;;
    res2_8) $vol resample "$work/mni.vlb" "$work/res2_8.vlb" 2 8 ;;
    res2_16) $vol resample "$work/mni.vlb" "$work/res2_16.vlb" 2 16 ;;
    res4_8) $vol resample "$work/mni.vlb" "$work/res4_8.vlb" 4 8 ;;
    res4_16) $vol resample "$work/mni.vlb" "$work/res4_16.vlb" 4 16 ;;
    ct512) $vol ct "$work/ct512.vlb" 512 ;;
  esac
}
names=${SCALING_ONLY:-mni rep2 rep3 res2_8 res2_16 res4_8 res4_16 ct512}
for n in $names; do
  v=$work/$n.vlb
  [ -f "$v" ] || { echo "== making $n"; make_volume "$n"; }
  # The page cache is warm for every run alike: read the file once first.
  cat "$v" >/dev/null
  echo "== $n: Rust path"
  /usr/bin/time -f "%e %M" -o "$work/out/$n.rust.time" target/release/examples/mni "$v" \
    "$work/out/$n.rust.png" 0.5 --fit --gradient=nodes --frames=3 >"$work/out/$n.rust.txt"
  echo "== $n: C path"
  /usr/bin/time -f "%e %M" -o "$work/out/$n.c.time" "$work/render" "$v" "$work/out/$n.c.png" 512 0.5
  cmp -s "$work/out/$n.rust.png" "$work/out/$n.c.png" || echo "   (the two paths' images differ)"
  if [ -z "${SCALING_NO_VTK:-}" ]; then
    echo "== $n: VTK"
    rm -f "$work/out/$n.vtk.json"
    /usr/bin/time -f "%e %M" -o "$work/out/$n.vtk.time" python3 benches/scaling/vtk_scaled.py "$v" \
      "$work/out/$n.vtk.json" --frames 2 >"$work/out/$n.vtk.txt" 2>&1
  fi
done
uptime > "$work/out/load.txt"

python3 - "$work" "$root/docs/performance.md" "$(nproc)" <<'PY'
import json, math, os, platform, re, struct, sys
work, doc, cpus = sys.argv[1:4]
out = os.path.join(work, "out")
order = ["mni", "rep2", "rep3", "res2_8", "res2_16", "res4_8", "res4_16", "ct512"]
label = {"mni": "MNI template", "rep2": "template repeated 2× per axis", "rep3": "repeated 3×",
         "res2_8": "resampled 2× per axis, 8-bit", "res2_16": "resampled 2×, 16-bit",
         "res4_8": "resampled 4×, 8-bit", "res4_16": "resampled 4×, 16-bit",
         "ct512": "CT-like phantom, 16-bit"}
IMAGE = 512 * 512 * 4  # the image in memory: four bytes a pixel
def timing(path):
    if not os.path.exists(path):
        return None
    wall, kb = open(path).read().split()[-2:]
    return float(wall), int(kb) * 1024
rows = {}
for n in order:
    v = os.path.join(work, n + ".vlb")
    rust = timing(os.path.join(out, n + ".rust.time"))
    if not os.path.exists(v) or rust is None:
        continue
    head = open(v, "rb").read(28)
    dims = struct.unpack("<3I", head[4:16])
    width = struct.unpack("<I", head[16:20])[0]
    data = dims[0] * dims[1] * dims[2] * width
    txt = open(os.path.join(out, n + ".rust.txt")).read()
    m = re.search(r"median ([0-9.]+) ms", txt)
    load = re.search(r"load ([0-9.]+) s", txt)
    first = re.search(r"in ([0-9.]+) s \(load", txt)
    c = timing(os.path.join(out, n + ".c.time"))
    vt = timing(os.path.join(out, n + ".vtk.time"))
    vj = os.path.join(out, n + ".vtk.json")
    vr = json.load(open(vj))["results"][0] if os.path.exists(vj) else None
    rows[n] = dict(dims=dims, width=width, data=data, rust=rust, c=c, vtk=vt, vtkr=vr,
                   steady=float(m.group(1)) if m else None, load=float(load.group(1)) if load else None)
MB = 1 << 20
def mb(x):
    return f"{x / MB:.0f}"
lines = ["| volume | nodes | bytes | dataset MiB | load (MiB/s) | vlib steady frame | VTK median frame "
         "| vlib / VTK | vlib C run | vlib peak RSS MiB, C / Rust | RSS / dataset, C | target 1.25× + image, MiB | VTK peak RSS MiB |",
         "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
def opt(x, f):
    return f.format(x) if x else "—"
for n, r in rows.items():
    vtk_ms = r["vtkr"]["median_s"] * 1e3 if r["vtkr"] else None
    c_wall, c_rss = r["c"] if r["c"] else (None, None)
    target = 1.25 * r["data"] + IMAGE
    rate = r["data"] / MB / max(r["load"], 1e-6)
    ratio = r["steady"] / vtk_ms if vtk_ms else None
    lines.append(
        f"| {label[n]} | {'×'.join(map(str, r['dims']))} | {r['width']} | {mb(r['data'])} "
        f"| {r['load']:.2f} s ({rate:.0f}) | {r['steady']:.0f} ms | {opt(vtk_ms, '{:.0f} ms')} "
        f"| {opt(ratio, '{:.2f}')} | {opt(c_wall, '{:.2f} s')} "
        f"| {mb(c_rss) if c_rss else '—'} / {mb(r['rust'][1])} "
        f"| {opt(c_rss and c_rss / r['data'], '{:.2f}')} | {mb(target)} "
        f"| {mb(r['vtk'][1]) if r['vtk'] else '—'} |")
# The growth law: the exponent p of cost ∝ voxels^p between a family's two largest volumes
# (the template's own row is dominated by the process's fixed memory and the per-pixel costs).
fams = [("8-bit, repeated", ["rep2", "rep3"]), ("8-bit, resampled", ["res2_8", "res4_8"]),
        ("16-bit, resampled", ["res2_16", "res4_16"])]
law = ["| family | voxels from → to | exponent p of peak RSS (C) | of the C run's time | of vlib's steady frame | of VTK's median frame |",
       "|---|---|---|---|---|---|"]
def p(a, b, na, nb):
    return f"{math.log(b / a) / math.log(nb / na):.2f}" if a and b and a > 0 and b > 0 else "—"
for fam, names in fams:
    have = [n for n in names if n in rows]
    if len(have) < 2:
        continue
    a, b = rows[have[0]], rows[have[-1]]
    na, nb = a["data"] / a["width"], b["data"] / b["width"]
    law.append(f"| {fam} | {na / 1e6:.1f} M → {nb / 1e6:.0f} M "
               f"| {p(a['c'][1] if a['c'] else None, b['c'][1] if b['c'] else None, na, nb)} "
               f"| {p(a['c'][0] if a['c'] else None, b['c'][0] if b['c'] else None, na, nb)} "
               f"| {p(a['steady'], b['steady'], na, nb)} "
               f"| {p(a['vtkr']['median_s'] if a['vtkr'] else None, b['vtkr']['median_s'] if b['vtkr'] else None, na, nb)} |")
def cpu_model():
    for line in open("/proc/cpuinfo"):
        if line.startswith("model name"):
            return line.split(":", 1)[1].strip()
    return platform.machine()
loadavg = open(os.path.join(out, "load.txt")).read().split("load average:")[-1].strip()
block = "\n".join([
    f"Measured by `bash benches/scaling.sh` on {cpu_model()}, {cpus} cores, {platform.system()} "
    f"{platform.release()}; load average at the end {loadavg} (times are only comparable within "
    "a row; memory does not depend on the load).",
    "", *lines, "", *law])
text = open(doc).read()
begin, end = "<!-- scaling:begin -->", "<!-- scaling:end -->"
block = f"{begin}\n{block}\n{end}"
if begin in text and end in text:
    text = text[:text.index(begin)] + block + text[text.index(end) + len(end):]
else:
    text += "\n" + block + "\n"
open(doc, "w").write(text)
print(block)
PY

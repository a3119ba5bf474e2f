#!/usr/bin/env bash
# The main job: builds the library in release, makes the datasets the examples load (a word and
# the chess profiles drawn by Rust examples, converted with vlconvert; the MNI brain when
# ../shared/data holds it), compiles every C example with the documented build line, runs every
# example (the C ones at their default sizes: figure2, figure5, text, chess, cvg, textures,
# smoke, deform, metaballs, reflectance, invisible, refraction, bump; the Rust ones figure2,
# and mni, twisted_brain and mip_brain when the brain is there), and
# leaves the images in out/ (PNG for each, plus the PPM files the programs ask for). The
# programs are run from cargo's target directory (target/, or CARGO_TARGET_DIR or
# build.target-dir where set).
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --workspace --lib --bins --examples
# Where cargo put the build: target/, or CARGO_TARGET_DIR or build.target-dir where set.
release="$(cargo metadata --format-version 1 --no-deps |
  sed -n 's/.*"target_directory":"\([^"]*\)".*/\1/p')/release"
if [ ! -e "$release/libvlib.so" ]; then
  echo "gallery.sh: no libvlib.so in $release (cargo metadata's target directory)" >&2
  exit 1
fi
# The programs ask the loader for the library's SONAME (libvlib.so.0): link it to the build.
soname=$(readelf -d "$release/libvlib.so" | sed -n 's/.*Library soname: \[\(.*\)\]/\1/p')
if [ -n "$soname" ]; then ln -sf libvlib.so "$release/$soname"; fi
mkdir -p out/bin out/inputs
vlconvert="$release/vlconvert"
# Inputs of the C examples, which run with cwd = out/: word.vlb (text.c) and the chess profiles
# (chess.c), drawn as PNGs in out/inputs/ and converted to datasets in out/.
echo "== datasets"
"$release"/examples/word_png out/inputs/word.png
"$vlconvert" image out/inputs/word.png out/word.vlb
"$release"/examples/profiles out/inputs
for piece in pawn rook knight knight_head bishop queen king; do
  "$vlconvert" image "out/inputs/$piece.png" "out/$piece.vlb"
done
mni=../shared/data/mni_icbm152_t1_tal_nlin_sym_09a_converted.nii.gz
if [ -e "$mni" ]; then
  "$vlconvert" nifti "$mni" out/mni.vlb
else
  echo "($mni not found: no MNI dataset)"
fi
for src in examples/c/*.c; do
  name=$(basename "$src" .c)
  cc -std=gnu89 "$src" -Iinclude -L"$release" -lvlib -lm -o "out/bin/$name"
  echo "== $name"
  (cd out && LD_LIBRARY_PATH="$release" "./bin/$name")
done
# PPM outputs get a PNG twin so the whole gallery can be browsed as PNG.
for ppm in out/*.ppm; do
  [ -e "$ppm" ] || continue
  png="${ppm%.ppm}.png"
  [ -e "$png" ] && [ "$png" -nt "$ppm" ] && continue
  "$release"/examples/ppm2png "$ppm" "$png"
done
echo "== figure2 (Rust)"
"$release"/examples/figure2 out/stone-rust.png
if [ -e out/mni.vlb ]; then
  echo "== mni (Rust)"
  "$release"/examples/mni out/mni.vlb out/mni.png
  echo "== twisted_brain (Rust, the paper's Figure 6(b))"
  "$release"/examples/twisted_brain out/mni.vlb out/twisted_brain.png
  echo "== mip_brain (Rust, maximum intensity projection)"
  "$release"/examples/mip_brain out/mni.vlb out/mip_brain.png
fi
echo "gallery:"
ls -1 out/*.png

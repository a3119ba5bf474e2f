#!/usr/bin/env bash
# The main job: builds the library in release, compiles every C example with the documented
# build line, runs every example, and leaves the images in out/ (PNG for each, plus the PPM
# files the programs ask for).
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)
cargo build --release --workspace --examples
mkdir -p out/bin
for src in examples/c/*.c; do
  name=$(basename "$src" .c)
  cc -std=gnu89 "$src" -Iinclude -Ltarget/release -lvlib -lm -o "out/bin/$name"
  echo "== $name"
  (cd out && LD_LIBRARY_PATH="$root/target/release" "./bin/$name")
done
# PPM outputs get a PNG twin so the whole gallery can be browsed as PNG.
for ppm in out/*.ppm; do
  [ -e "$ppm" ] || continue
  png="${ppm%.ppm}.png"
  [ -e "$png" ] && [ "$png" -nt "$ppm" ] && continue
  target/release/examples/ppm2png "$ppm" "$png"
done
echo "== figure2 (Rust)"
target/release/examples/figure2 out/stone-rust.png
echo "gallery:"
ls -1 out/*.png

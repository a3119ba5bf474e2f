#!/usr/bin/env bash
# MPI scale-out (docs/mpi.md, docs/performance.md "MPI scale-out"): a frame split over
# `mpirun -np 2` ranks of one thread each against one process of one thread, on the MNI brain
# (512², shaded, sample distance 0.5) and on the paper's Figure 2 (512²), by
# examples/mpi_bench.rs. Each round runs both, one after the other; the script runs
# MPI_ROUNDS rounds (default 3) and prints each time, the medians over the rounds and their
# ratio (the speed-up), the ranks' busy times, and checks that both write the same bytes.
#
#   bash benches/mpi.sh
#   MPI_ROUNDS=5 MPI_FRAMES=9 MPI_SIZE=512 bash benches/mpi.sh
#
# A time is the median of MPI_FRAMES frames (default 5) rendered to memory after one frame
# that builds the caches (the MNI scene's empty-space grid); a two-rank frame includes every
# exchange of the ranks. Needs Open MPI (mpirun) and the MNI template in ../shared/data (or
# $VLIB_MNI_VLB). The machine's load (/proc/loadavg) is printed before and after: on a shared
# machine the times move with it, so only a quiet machine's ratios are to be recorded.
set -euo pipefail
cd "$(dirname "$0")/.."
rounds=${MPI_ROUNDS:-3}
frames=${MPI_FRAMES:-5}
size=${MPI_SIZE:-512}
cargo build --release --quiet --features mpi --example mpi_bench
# The converter, for the MNI dataset's first conversion.
cargo build --release --quiet -p vlconvert
exe=target/release/examples/mpi_bench
work=target/bench-work/mpi
mkdir -p "$work"
root=()
[ "$(id -u)" = 0 ] && root=(--allow-run-as-root)
mpirun=(mpirun -np 2 --oversubscribe --bind-to none "${root[@]}" -x RAYON_NUM_THREADS)
export RAYON_NUM_THREADS=1
echo "load before: $(cat /proc/loadavg), $(nproc) cores"
for scene in mni figure2; do
    ones=() twos=()
    for r in $(seq "$rounds"); do
        one=$("$exe" "$scene" "$work/${scene}_one.png" --size="$size" --frames="$frames" |
            awk '/^median_s/ {print $2}')
        "${mpirun[@]}" "$exe" "$scene" "$work/${scene}_two.png" --size="$size" \
            --frames="$frames" >"$work/${scene}_two.txt"
        two=$(awk '/^median_s/ {print $2}' "$work/${scene}_two.txt")
        cmp "$work/${scene}_one.png" "$work/${scene}_two.png" ||
            { echo "$scene: two ranks wrote other bytes than one process"; exit 1; }
        echo "$scene round $r: one process ${one} s, two ranks ${two} s (images identical)"
        ones+=("$one") twos+=("$two")
    done
    echo "$scene busy seconds and items of the last two-rank run (all its frames):"
    grep -v median_s "$work/${scene}_two.txt"
    python3 - "$scene" "${ones[*]}" "${twos[*]}" <<'PY'
import statistics, sys
scene, ones, twos = sys.argv[1], [float(v) for v in sys.argv[2].split()], [float(v) for v in sys.argv[3].split()]
a, b = statistics.median(ones), statistics.median(twos)
print(f"{scene}: median one process {a:.4f} s, median two ranks {b:.4f} s, speed-up {a / b:.2f}")
PY
done
echo "load after: $(cat /proc/loadavg)"

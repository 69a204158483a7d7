#!/usr/bin/env bash
# Issue 15: split jobs on existing job engines (make, GNU parallel). Prints a table per part:
#   1. overhead per cell (process start, model load, the frame's plan) against the whole frame,
#      and the cell size at which the overhead drops under 10%
#   2. a 120-frame turntable through make -j1 / -j2 and parallel -j1 / -j2 (speed-up 1 -> 2)
#   3. prospero.vm at 16384x16384 (2D) in tiles through make -j2: time and peak memory per process
#   4. (--poster) a 32768x32768 tiled render of a CAD model through make -j2: peak memory per
#      process, time (long: about 20 minutes on 2 cores)
# Every cell runs with --threads 1, so the engines' processes are the only parallelism.
#
#   bench/jobs.sh [BUILD_DIR] [--poster]     (default build dir: build)
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-$here/build}
[ "${1:-}" = "--poster" ] && build=$here/build
poster=0
for a in "$@"; do [ "$a" = "--poster" ] && poster=1; done
crisp=$(cd "$build" && pwd)/crisp
data=$here/data
work=$(mktemp -d /tmp/crisp-bench-jobs.XXXXXX)
trap 'rm -rf "$work"' EXIT
cd "$work"
now() { date +%s.%N; }
secs() { echo "$2 - $1" | bc -l; }
peak() { sort -t, -k2 -n "$1" | tail -1 | cut -d, -f2; } # KB, from /usr/bin/time -f %e,%M lines

echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //')"
echo "load before: $(cut -d' ' -f1-3 /proc/loadavg)"
echo

# ---- 1. overhead per cell
m=$data/nurbs/occt_bearing.iges
echo "1. overhead per cell: $m, 1280x720, 4 samples, 1 thread (median of 5)"
med() { sort -n | awk '{a[NR]=$1} END {print a[int((NR+1)/2)]}'; }
t_version=$(for i in 1 2 3 4 5; do s=$(now); $crisp version > /dev/null; secs "$s" "$(now)"; done | med)
t_whole=$(for i in 1 2 3 4 5; do s=$(now); $crisp render "$m" --threads 1 -o w.png -q; secs "$s" "$(now)"; done | med)
t_corner=$(for i in 1 2 3 4 5; do s=$(now); $crisp render "$m" --threads 1 --tile 0/40x22 -o c.png -q; secs "$s" "$(now)"; done | med)
px=$((1280 * 720))
k=$(echo "($t_whole - $t_corner) / $px" | bc -l)
px10=$(echo "9 * $t_corner / $k" | bc -l)
printf "   %-44s %10s\n" "what" "seconds"
printf "   %-44s %10.3f\n" "process start (crisp version)" "$t_version"
printf "   %-44s %10.3f\n" "a cell's overhead (a 32x32 corner tile)" "$t_corner"
printf "   %-44s %10.3f\n" "the whole frame in one process" "$t_whole"
printf "   overhead under 10%% from cells of %.0f pixels (%.0f%% of the frame; about %.0fx%.0f)\n" \
  "$px10" "$(echo "100 * $px10 / $px" | bc -l)" "$(echo "sqrt($px10)" | bc -l)" "$(echo "sqrt($px10)" | bc -l)"
echo

# ---- 2. turntable
echo "2. turntable: 120 frames of $m at 480x270 (4 samples, 1 thread a frame)"
printf "   %-28s %10s %10s\n" "engine" "seconds" "speed-up"
for engine in make parallel; do
  t1=""
  for j in 1 2; do
    rm -rf tt
    $crisp jobs turntable "$m" --frames 120 --size 480x270 --threads 1 -o tt -q
    s=$(now)
    if [ $engine = make ]; then make -s -j$j -C tt > /dev/null; else parallel -j$j < tt/jobs.txt; fi
    t=$(secs "$s" "$(now)")
    n=$(ls tt/frames/*.png | wc -l)
    [ "$n" = 120 ] || { echo "only $n frames"; exit 1; }
    [ -z "$t1" ] && t1=$t
    printf "   %-28s %10.2f %10.2f\n" "$engine -j$j" "$t" "$(echo "$t1 / $t" | bc -l)"
  done
done
echo "   load after: $(cut -d' ' -f1-3 /proc/loadavg)"
echo

# ---- 3. prospero 16384^2 in tiles
p=$data/frep/prospero.vm
echo "3. $p at 16384x16384 (2D), tiles through make -j2"
rm -rf pro
$crisp jobs frep-render "$p" --size 16384 --threads 1 -o pro | head -2 | sed 's/^/   /'
s=$(now)
make -s -j2 -C pro CRISP="/usr/bin/time -a -o $work/pro.mem -f %e,%M $crisp" > /dev/null
t=$(secs "$s" "$(now)")
cells=$(grep -c '^  cells/' pro/Makefile)
printf "   %d cells and the merge: %.1f s on 2 processes; peak memory of a process %.0f MB\n" \
  "$cells" "$t" "$(echo "$(peak pro.mem) / 1024" | bc -l)"
s=$(now)
/usr/bin/time -o one.mem -f %e,%M $crisp frep render "$p" --size 16384 --threads 1 -o one.png > /dev/null
printf "   one process, whole image: %.1f s, peak %.0f MB\n" "$(secs "$s" "$(now)")" \
  "$(echo "$(cut -d, -f2 one.mem) / 1024" | bc -l)"
echo "   load after: $(cut -d' ' -f1-3 /proc/loadavg)"
echo

# ---- 4. the poster
if [ $poster = 1 ]; then
  c=$data/nurbs/gpucast_part.igs
  echo "4. $c at 32768x32768 (4 samples), tiles through make -j2 (--max-cell-memory 900M)"
  rm -rf poster
  $crisp jobs render "$c" --size 32768x32768 --threads 1 --max-cell-memory 900M -o poster | head -2 | sed 's/^/   /'
  s=$(now)
  make -s -j2 -C poster CRISP="/usr/bin/time -a -o $work/poster.mem -f %e,%M $crisp" > /dev/null
  t=$(secs "$s" "$(now)")
  printf "   %.0f s on 2 processes; peak memory of a process %.0f MB (the merge's: %.0f MB)\n" "$t" \
    "$(echo "$(head -n -1 poster.mem | sort -t, -k2 -n | tail -1 | cut -d, -f2) / 1024" | bc -l)" \
    "$(echo "$(tail -1 poster.mem | cut -d, -f2) / 1024" | bc -l)"
  echo "   load after: $(cut -d' ' -f1-3 /proc/loadavg)"
fi

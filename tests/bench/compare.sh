#!/bin/sh
# Speed claims as ratios measured in one run: builds the benchmarks of REF (a commit, branch or
# tag) in a worktree of its own and those of the working tree (build/), runs each benchmark of
# both in interleaved rounds on this machine (ref, new, new, ref, … so drift and heat fall on
# both), and prints each figure's median in both, the ratio new/ref and the spread of the
# rounds' ratios (tests/bench/compare.py).
#
#   tests/bench/compare.sh REF [--rounds N] [--filter REGEX] [--bench NAME]... [--min-time S]
#                              [--cpus LIST]
#
# --cpus runs every benchmark under `taskset -c LIST` (e.g. --cpus 1: one core's figures, as the
# *OneThread targets are stated).
#
# Example: tests/bench/compare.sh main --bench dbb_analysis_bench --filter Pair --rounds 7
# The reference build lives in build-compare/<sha> (kept, so a second comparison with the same
# REF builds nothing); ccache serves both builds. Results: build-compare/results-<time>/.
set -eu
cd "$(dirname "$0")/../.."
[ $# -ge 1 ] || { sed -n '2,16p' "$0"; exit 2; }
ref=$1
shift
rounds=5 filter=. min_time=0.2 benches="" cpus=""
while [ $# -gt 0 ]; do
  case $1 in
    --rounds) rounds=$2; shift 2 ;;
    --filter) filter=$2; shift 2 ;;
    --bench) benches="$benches $2"; shift 2 ;;
    --min-time) min_time=$2; shift 2 ;;
    --cpus) cpus=$2; shift 2 ;;
    *) echo "compare.sh: unknown option $1" >&2; exit 2 ;;
  esac
done
sha=$(git rev-parse --verify "$ref^{commit}") || { echo "compare.sh: no commit '$ref'" >&2; exit 2; }
jobs=$(nproc)
export CCACHE_BASEDIR="$PWD" CCACHE_NOHASHDIR=1
launcher=""
if command -v ccache >/dev/null; then launcher="-DCMAKE_CXX_COMPILER_LAUNCHER=ccache"; fi
gen=""
if command -v ninja >/dev/null; then gen="-G Ninja"; fi

build_benchmarks() {  # SOURCE_DIR BUILD_DIR
  # shellcheck disable=SC2086
  cmake -S "$1" -B "$2" $gen -DCMAKE_BUILD_TYPE=Release -DKINEMETRIC_TESTS=ON \
    -DKINEMETRIC_BENCHMARKS=ON $launcher >/dev/null
  targets=""
  for b in $benches; do targets="$targets --target $b"; done
  # shellcheck disable=SC2086
  cmake --build "$2" -j"$jobs" $targets >/dev/null
}

mkdir -p build-compare
tree=build-compare/src-$sha
if [ ! -d "$tree" ]; then git worktree add --detach "$tree" "$sha" >/dev/null; fi
echo "compare.sh: building $ref ($sha) and the working tree" >&2
build_benchmarks "$tree" "build-compare/build-$sha"
build_benchmarks . build-compare/build-new
out=build-compare/results-$(date -u +%Y%m%dT%H%M%SZ)
mkdir -p "$out"
if [ -z "$benches" ]; then
  benches=$(cd build-compare/build-new/bench && ls)
fi
pin=""
if [ -n "$cpus" ]; then pin="taskset -c $cpus"; fi
run() {  # SIDE DIR BENCH ROUND
  if [ -x "$2/bench/$3" ]; then
    # shellcheck disable=SC2086
    $pin "$2/bench/$3" --benchmark_filter="$filter" --benchmark_min_time="$min_time" \
      --benchmark_format=json >"$out/$3.$1.$4.json" 2>/dev/null || rm -f "$out/$3.$1.$4.json"
  fi
}
for b in $benches; do
  i=1
  while [ "$i" -le "$rounds" ]; do
    echo "compare.sh: $b round $i of $rounds" >&2
    if [ $((i % 2)) -eq 1 ]; then
      run ref "build-compare/build-$sha" "$b" "$i"
      run new build-compare/build-new "$b" "$i"
    else
      run new build-compare/build-new "$b" "$i"
      run ref "build-compare/build-$sha" "$b" "$i"
    fi
    i=$((i + 1))
  done
done
/usr/bin/python3 tests/bench/compare.py "$out"

#!/usr/bin/env bash
# Builds kinemetric and runs every test (unit, integration, browser) through CTest, the
# integration and browser tests again on PostgreSQL, then every test once more under
# AddressSanitizer + UndefinedBehaviorSanitizer, then fuzzes every parser for a
# bounded time (clang, libFuzzer). Exits non-zero on any failure.
#   KINEMETRIC_SKIP_SANITIZERS=1  skip the sanitizer pass (local quick runs only)
#   KINEMETRIC_LONG=1             also run the long soak / load tests, and fuzz 300 s a target
#   KINEMETRIC_SKIP_FUZZ=1        skip the fuzz stage (libFuzzer targets, docs/fuzzing.md)
# KINEMETRIC_CI=1 is exported: every dependency is installed here, so a test that would skip
# for a missing one (a Python peer, a library) fails instead.
set -euo pipefail
export KINEMETRIC_CI=1
cd "$(dirname "$0")/.."
jobs=$(nproc)
start=$SECONDS
# Prints each stage with the minutes spent so far, so a slow stage shows in the CI log.
stage() { echo "== [$(( (SECONDS - start) / 60 )) min] $*"; }

deploy/install-deps.sh

# A full disk fails a build midway with a linker error far from its cause: say it first. The
# three build directories and the tests' temporary files take about 8 GB from scratch.
need_mb=8192
have_mb=0
for d in build build-asan build-fuzz; do
  if [ -d "$d" ]; then have_mb=$((have_mb + $(du -sm "$d" | cut -f1))); fi
done
free_mb=$(df -Pm . | awk 'NR == 2 {print $4}')
if [ "$free_mb" -lt $((need_mb - have_mb)) ]; then
  echo "deploy/test.sh: only ${free_mb} MB free on the disk of $PWD; the builds and tests need" \
    "about $((need_mb - have_mb)) MB more (build/, build-asan/, build-fuzz/, $(dirname "$(mktemp -u)"))" >&2
  exit 1
fi

stage "format check (clang-format)"
files=$(git ls-files '*.cpp' '*.h' 2>/dev/null || true)
if [ -n "$files" ]; then
  # shellcheck disable=SC2086
  clang-format --dry-run --Werror $files
fi

# ccache (Debian) keeps compiled objects between runs of this script, also from another checkout
# of the repository (paths relative to it); a first run builds everything.
launcher=()
if command -v ccache >/dev/null; then
  export CCACHE_BASEDIR="$PWD" CCACHE_NOHASHDIR=1
  launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache -DCMAKE_C_COMPILER_LAUNCHER=ccache)
fi
# Ninja (Debian ninja-build) for a new build directory; one made with another generator keeps it.
gen=()
use_generator_for() {
  gen=()
  if command -v ninja >/dev/null &&
    { [ ! -f "$1/CMakeCache.txt" ] || grep -q '^CMAKE_GENERATOR:INTERNAL=Ninja$' "$1/CMakeCache.txt"; }; then
    gen=(-G Ninja)
  fi
}

stage "Release build"
use_generator_for build
cmake -S . -B build "${gen[@]}" -DCMAKE_BUILD_TYPE=Release -DKINEMETRIC_TESTS=ON -DKINEMETRIC_BENCHMARKS=ON \
  "${launcher[@]}" >/dev/null
cmake --build build -j"$jobs"

label_args=()
if [ "${KINEMETRIC_LONG:-0}" != 1 ]; then label_args=(-LE long); fi

stage "tests (Release)"
(cd build && ctest --output-on-failure -j"$jobs" "${label_args[@]}")

# The integration suite again with every test server's data in PostgreSQL: a private cluster on a
# loopback port (tests/tools/pg_cluster.sh), a database per server data directory. The browser
# scenarios labelled `page` (what the page draws and reads, whatever stores the answers) run on
# PostgreSQL only with KINEMETRIC_LONG=1.
stage "integration and browser tests on PostgreSQL"
pg_label_args=(-LE 'long|page')
if [ "${KINEMETRIC_LONG:-0}" = 1 ]; then pg_label_args=(); fi
pg_dir=$(mktemp -d /tmp/kinemetric-test-pg.XXXXXX)
pg_url=$(tests/tools/pg_cluster.sh start "$pg_dir")
trap 'tests/tools/pg_cluster.sh stop "$pg_dir" >/dev/null 2>&1 || true' EXIT
(cd build && KINEMETRIC_TEST_DATABASE="$pg_url" ctest --output-on-failure -j"$jobs" \
  -L 'integration|browser' "${pg_label_args[@]}")

stage "benchmarks (short smoke run; full figures: build/bench/<name>)"
for b in build/bench/*; do
  [ -x "$b" ] || continue
  "$b" --benchmark_min_time=0.01 >/dev/null
done
stage "HTTP load benchmark (short form; full figures: tests/bench/http/load_bench.py)"
/usr/bin/python3 tests/bench/http/load_bench.py build/bin/kinemetricd --seconds 2 --idle 200 --slow 20
pg_load_db=$(KINEMETRIC_TEST_DATABASE="$pg_url" tests/tools/test_database.sh "$pg_dir/load")
/usr/bin/python3 tests/bench/http/load_bench.py build/bin/kinemetricd --seconds 2 --idle 200 --slow 20 \
  --database "$pg_load_db"

if [ "${KINEMETRIC_SKIP_SANITIZERS:-0}" != 1 ]; then
  stage "AddressSanitizer + UBSan build"
  use_generator_for build-asan
  # The product (libraries, kinemetricd, the CLI) is instrumented at -O1 with line tables and
  # asserts on; the test programs' own files are compiled as in the Release build above, so
  # ccache serves them and only the product is compiled again (CMakeLists.txt,
  # KM_PRODUCT_COMPILE_OPTIONS).
  cmake -S . -B build-asan "${gen[@]}" -DCMAKE_BUILD_TYPE=Release -DCMAKE_CXX_FLAGS="" \
    -DKINEMETRIC_SANITIZE=ON -DKINEMETRIC_TESTS=ON -DKINEMETRIC_BENCHMARKS=OFF "${launcher[@]}" >/dev/null
  cmake --build build-asan -j"$jobs"
  stage "tests (ASan + UBSan)"
  # The slowest numerical studies run here only with KINEMETRIC_LONG=1 (tests/sanitizer_long.txt
  # names them and what covers their code in every run), and so do the browser tests: the page's
  # requests reach routes the integration tests drive under the sanitizers in every run, and the
  # page itself runs in Chromium, not in the instrumented product.
  san_args=("${label_args[@]}")
  if [ "${KINEMETRIC_LONG:-0}" != 1 ]; then
    san_args=(-LE 'long|browser' -E "^($(grep -v '^#' tests/sanitizer_long.txt | awk 'NF {print $1}' | paste -sd'|'))\$")
  fi
  # LeakSanitizer passes over what third-party libraries keep until exit (deploy/lsan.supp).
  lsan_supp="$PWD/deploy/lsan.supp"
  (cd build-asan && ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 \
    LSAN_OPTIONS="suppressions=$lsan_supp:print_suppressions=0" \
    UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
    ctest --output-on-failure -j"$jobs" "${san_args[@]}")
fi
if [ "${KINEMETRIC_SKIP_FUZZ:-0}" != 1 ]; then
  # Every parser under libFuzzer + ASan + UBSan: known crash inputs (tests/fuzz/crashes/) are
  # replayed, then each target fuzzes from its seed corpus for a bounded time.
  stage "fuzz build (clang, libFuzzer + ASan + UBSan)"
  use_generator_for build-fuzz
  CC=clang CXX=clang++ cmake -S . -B build-fuzz "${gen[@]}" -DCMAKE_BUILD_TYPE=Debug -DCMAKE_CXX_FLAGS="-O1" \
    -DKINEMETRIC_FUZZ=ON -DKINEMETRIC_TESTS=OFF -DKINEMETRIC_BENCHMARKS=OFF "${launcher[@]}" >/dev/null
  cmake --build build-fuzz -j"$jobs" --target fuzz_targets
  fuzz_seconds=10
  if [ "${KINEMETRIC_LONG:-0}" = 1 ]; then fuzz_seconds=300; fi
  KINEMETRIC_FUZZ_BUILD=build-fuzz KINEMETRIC_FUZZ_SECONDS=$fuzz_seconds tests/fuzz/run.sh
fi
stage "all tests passed"

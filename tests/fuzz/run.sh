#!/usr/bin/env bash
# Runs the libFuzzer targets (docs/fuzzing.md) for a bounded time each and prints a summary
# table. Per target, first every committed crash reproducer in tests/fuzz/crashes/<target>/ is
# replayed (each must now run clean), then the target fuzzes from its committed seed corpus
# tests/fuzz/corpus/<target>/ (replayed first by libFuzzer) plus a working corpus in the build
# directory. Exits non-zero when any reproducer still fails or fuzzing finds a crash, a leak, a
# timeout or an out-of-memory input; the input is kept under <build>/fuzz-artifacts/<target>/.
#
#   tests/fuzz/run.sh [TARGET...]        default: every target
#   KINEMETRIC_FUZZ_BUILD=DIR            build directory (default build-fuzz), already built
#   KINEMETRIC_FUZZ_SECONDS=N            fuzzing time per target (default 10)
#   KINEMETRIC_FUZZ_FLAGS="..."          extra libFuzzer flags (e.g. -jobs=2, -seed=1)
#   KINEMETRIC_FUZZ_PARALLEL=N           targets run at the same time (default: the cores, nproc);
#                                        each target is one process, so each still gets its time
set -uo pipefail
cd "$(dirname "$0")/../.." || exit 1

build=${KINEMETRIC_FUZZ_BUILD:-build-fuzz}
seconds=${KINEMETRIC_FUZZ_SECONDS:-10}
all_targets=(dbb tracker straightness flatness parallelism servo positioning rotary upload machine_json modbus_config
  stream_frames request time api)
targets=("$@")
if [ ${#targets[@]} -eq 0 ]; then targets=("${all_targets[@]}"); fi

# Memory and time bounds of one input (see docs/fuzzing.md).
limits=(-rss_limit_mb=512 -malloc_limit_mb=256 -timeout=10)
# shellcheck disable=SC2206
extra=(${KINEMETRIC_FUZZ_FLAGS:-})

if command -v llvm-symbolizer >/dev/null; then
  export ASAN_SYMBOLIZER_PATH=${ASAN_SYMBOLIZER_PATH:-$(command -v llvm-symbolizer)}
fi
# ASan's default quarantine keeps 256 MB of freed memory to catch use after free; that alone
# would fill half the RSS limit of the targets that analyse uploads, so it is kept at 64 MB.
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:detect_stack_use_after_return=1:quarantine_size_mb=64}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
# What third-party libraries keep until exit (fontconfig, for the PDF reports the api target
# renders) is not a leak of the product: deploy/lsan.supp.
export LSAN_OPTIONS=${LSAN_OPTIONS:-suppressions=$PWD/deploy/lsan.supp:print_suppressions=0}

# Fuzzes one target and writes its summary row (target|reproducers|runs|secs|exec/s|result) to
# <build>/fuzz-logs/<target>.row; messages about failures go to stderr.
fuzz_target() {
  local t=$1 exe logs work artifacts status replay bad c rc runs secs rate
  local -a crashes dict_args
  exe="$build/fuzz/fuzz_$t"
  if [ ! -x "$exe" ]; then
    echo "fuzz: $exe is missing (build with -DKINEMETRIC_FUZZ=ON, target fuzz_targets)" >&2
    mkdir -p "$build/fuzz-logs"
    echo "$t|missing|-|-|-|FAIL" >"$build/fuzz-logs/$t.row"
    return
  fi
  logs="$build/fuzz-logs"
  work="$build/fuzz-corpus/$t"
  artifacts="$build/fuzz-artifacts/$t"
  mkdir -p "$logs" "$work" "$artifacts"
  status=ok

  # 1. Known crash inputs: each must run clean now.
  replay="none"
  shopt -s nullglob
  crashes=(tests/fuzz/crashes/"$t"/*)
  shopt -u nullglob
  if [ ${#crashes[@]} -gt 0 ]; then
    bad=0
    for c in "${crashes[@]}"; do
      if ! "$exe" "${limits[@]}" "$c" >"$logs/$t.replay.log" 2>&1; then
        bad=$((bad + 1))
        echo "fuzz: $t: reproducer $c still fails:" >&2
        grep -E 'ERROR: |runtime error|kinemetric fuzz finding|^    #[0-9] ' "$logs/$t.replay.log" |
          head -12 >&2
      fi
    done
    replay="$((${#crashes[@]} - bad))/${#crashes[@]} clean"
    if [ "$bad" -gt 0 ]; then status=FAIL; fi
  fi

  # 2. Fuzz from the committed seeds (libFuzzer replays them first) for a bounded time.
  dict_args=()
  if [ -f "tests/fuzz/dict/$t.dict" ]; then dict_args=(-dict="tests/fuzz/dict/$t.dict"); fi
  echo "== fuzz $t (${seconds}s)"
  "$exe" "${limits[@]}" -max_total_time="$seconds" -print_final_stats=1 \
    -artifact_prefix="$artifacts/" "${dict_args[@]}" "${extra[@]}" \
    "$work" "tests/fuzz/corpus/$t" >"$logs/$t.log" 2>&1
  rc=$?
  runs=$(sed -n 's/^Done \([0-9]*\) runs in \([0-9]*\) second.*/\1/p' "$logs/$t.log" | tail -1)
  secs=$(sed -n 's/^Done \([0-9]*\) runs in \([0-9]*\) second.*/\2/p' "$logs/$t.log" | tail -1)
  if [ "$rc" -ne 0 ] || [ -z "$runs" ]; then
    status=FAIL
    runs=${runs:-$(sed -n 's/^stat::number_of_executed_units: *//p' "$logs/$t.log" | tail -1)}
    echo "fuzz: $t found a failure (log $logs/$t.log):" >&2
    grep -E 'ERROR: |runtime error|kinemetric fuzz finding|^    #[0-9] |Test unit written' \
      "$logs/$t.log" | head -20 >&2
    echo "fuzz: minimise with: $exe -minimize_crash=1 -runs=10000 ${limits[*]} <artifact>;" \
      "keep the result under tests/fuzz/crashes/$t/" >&2
  fi
  rate="-"
  if [ -n "${runs:-}" ] && [ -n "${secs:-}" ] && [ "${secs:-0}" -gt 0 ]; then
    rate=$((runs / secs))
  fi
  echo "$t|$replay|${runs:--}|${secs:--}|$rate|$status" >"$logs/$t.row"
}

# The targets run side by side, at most `parallel` at a time; the table keeps their order.
parallel=${KINEMETRIC_FUZZ_PARALLEL:-$(nproc)}
running=0
for t in "${targets[@]}"; do
  rm -f "$build/fuzz-logs/$t.row"
  fuzz_target "$t" &
  running=$((running + 1))
  if [ "$running" -ge "$parallel" ]; then
    wait -n
    running=$((running - 1))
  fi
done
wait
rows=()
failed=()
for t in "${targets[@]}"; do
  row=$(cat "$build/fuzz-logs/$t.row" 2>/dev/null || echo "$t|no result|-|-|-|FAIL")
  rows+=("$row")
  if [ "${row##*|}" != ok ]; then failed+=("$t"); fi
done

echo
echo "== fuzz summary (${seconds}s a target; limits: ${limits[*]})"
printf '%-14s %-14s %12s %6s %9s  %s\n' target reproducers runs secs "exec/s" result
for r in "${rows[@]}"; do
  IFS='|' read -r t replay runs secs rate status <<<"$r"
  printf '%-14s %-14s %12s %6s %9s  %s\n' "$t" "$replay" "$runs" "$secs" "$rate" "$status"
done
if [ ${#failed[@]} -gt 0 ]; then
  echo "fuzz: failures in: ${failed[*]}" >&2
  exit 1
fi

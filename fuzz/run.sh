#!/usr/bin/env bash
# Runs every fuzz target for a bounded time on seeds made by gonio itself (docs/testing.md
# "Fuzzing"); what `bash scripts/test --fuzz` and CI call. Any finding (a crash, a sanitizer
# report, an accepted input that breaks a target's invariants) fails the run and is left in
# FUZZ_DIR/findings/ to replay: FUZZ_DIR/fuzz_TARGET FUZZ_DIR/findings/TARGET-crash-...
# usage: bash fuzz/run.sh GONIO_BINARY FUZZ_DIR SECONDS [JOBS]
set -euo pipefail
gonio="$1"
dir="$2"
seconds="$3"
jobs="${4:-1}"
here="$(cd "$(dirname "$0")" && pwd)"
seeds="$dir/corpus"   # from fuzz/make_corpus.sh, kept between runs
work="$dir/corpus-work"  # what libFuzzer adds, kept between runs so local runs build on it
findings="$dir/findings"
targets=(session board camera_model photometric observations scene)

[ -d "$seeds/scene" ] || bash "$here/make_corpus.sh" "$gonio" "$seeds" > /dev/null
mkdir -p "$findings"
# halt_on_error: libFuzzer sees a UBSan report as a finding, as an ASan one.
export UBSAN_OPTIONS="halt_on_error=1:print_stacktrace=1"
export ASAN_OPTIONS="detect_leaks=1"
# Each target writes its inputs under the temp dir (fuzz_util.h WorkDir, one folder per
# process); one of the run's own, removed at the end, leaves nothing in /tmp.
export TMPDIR="$dir/tmp"
mkdir -p "$TMPDIR"
trap 'rm -rf "$TMPDIR"' EXIT

run_target() {
  local t="$1" max_len=8192
  [ "$t" = photometric ] && max_len=65536  # its seed holds a 4096-entry table (43 kB)
  mkdir -p "$work/$t"
  local rc=0
  "$dir/fuzz_$t" "$work/$t" "$seeds/$t" -max_total_time="$seconds" -max_len="$max_len" \
    -artifact_prefix="$findings/$t-" -print_final_stats=1 > "$dir/fuzz_$t.log" 2>&1 || rc=$?
  echo "$rc" > "$dir/fuzz_$t.rc"
}

start=$SECONDS
for t in "${targets[@]}"; do
  while [ "$(jobs -rp | wc -l)" -ge "$jobs" ]; do wait -n || true; done
  rm -f "$dir/fuzz_$t.rc"
  run_target "$t" &
done
wait
failed=()
for t in "${targets[@]}"; do
  [ "$(cat "$dir/fuzz_$t.rc" 2>/dev/null)" = 0 ] || failed+=("$t")
done
for t in "${targets[@]}"; do
  runs="$(sed -n 's/^stat::number_of_executed_units: *//p' "$dir/fuzz_$t.log")"
  echo "fuzz_$t: ${runs:-?} runs in ${seconds} s$([[ " ${failed[*]} " == *" $t "* ]] && echo ': FINDING')"
done
echo "fuzz: ${#targets[@]} targets, $((SECONDS - start)) s wall"
if [ "${#failed[@]}" -gt 0 ]; then
  for t in "${failed[@]}"; do
    echo "--- fuzz_$t ($dir/fuzz_$t.log):" >&2
    grep -a -m 20 -E 'ERROR|runtime error|GONIO_FUZZ_REQUIRE|Test unit written|SUMMARY' \
      "$dir/fuzz_$t.log" >&2 || tail -n 20 "$dir/fuzz_$t.log" >&2
  done
  exit 1
fi

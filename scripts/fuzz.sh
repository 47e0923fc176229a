#!/usr/bin/env bash
# Fuzzes the model loader for SECONDS (default 180) with libFuzzer, ASan and UBSan: installs
# clang 14 and libFuzzer when missing, builds only the fuzz target in BUILD_DIR (default
# build-fuzz), runs it on a copy of fuzz/corpus (the committed corpus is never written) and
# prints one summary line. Exits nonzero on any finding (crash, broken invariant, leak, timeout,
# out of memory), leaving the reproducer in BUILD_DIR/findings/. Usage: scripts/fuzz.sh [SECONDS]
# FUZZ_KEEP_GOING=1 runs libFuzzer's fork mode instead, which goes on past findings and so
# collects all it meets in the time (for triage; its cov and ft are counted differently).
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-180}
if ! [[ "$seconds" =~ ^[1-9][0-9]*$ ]]; then
  echo "usage: scripts/fuzz.sh [SECONDS]  (a whole number of seconds, default 180)" >&2
  exit 2
fi
bash scripts/install-deps.sh --fuzz
build_dir=${BUILD_DIR:-build-fuzz}
CC=clang-14 CXX=clang++-14 cmake -S . -B "$build_dir" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DKANEDYN_FUZZ=ON -DKANEDYN_BUILD_BENCH=OFF -DKANEDYN_BUILD_TESTS=OFF >/dev/null
cmake --build "$build_dir" -j"$(nproc)" --target kanedyn_fuzz_model_loader
fuzzer="$build_dir/fuzz/kanedyn_fuzz_model_loader"

# Fresh each run, so that what is in findings/ is what this run found.
work="$build_dir/work"
findings="$build_dir/findings"
rm -rf "$work" "$findings"
mkdir -p "$work" "$findings"
cp -R fuzz/corpus "$work/corpus"
log="$work/fuzz.log"

export ASAN_OPTIONS=detect_leaks=1:abort_on_error=1
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
if [[ -x /usr/lib/llvm-14/bin/llvm-symbolizer ]]; then
  export ASAN_SYMBOLIZER_PATH=/usr/lib/llvm-14/bin/llvm-symbolizer
fi
mode=()
if [[ "${FUZZ_KEEP_GOING:-0}" == 1 ]]; then
  mode=(-fork=1 -ignore_crashes=1 -ignore_timeouts=1 -ignore_ooms=1)
fi
echo "fuzz: running $fuzzer${mode[*]:+ ${mode[*]}} for $seconds s (log: $log)"
status=0
started=$(date +%s)
"$fuzzer" "${mode[@]}" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 \
  -dict=fuzz/model.dict -print_final_stats=1 -artifact_prefix="$findings/" "$work/corpus" \
  </dev/null >"$log" 2>&1 || status=$?
elapsed=$(($(date +%s) - started))

# The last status line ("#N  DONE  cov: C ft: F corp: ...") and the final stats.
last=$(grep -E '^#[0-9]+' "$log" | tail -n 1 || true)
execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -n 1)
if [[ -z "$execs" ]]; then execs=$(sed -E -n 's/^#([0-9]+).*/\1/p' <<<"$last"); fi
cov=$(sed -E -n 's/.* cov: ([0-9]+).*/\1/p' <<<"$last")
ft=$(sed -E -n 's/.* ft: ([0-9]+).*/\1/p' <<<"$last")
corp=$(sed -E -n 's/.* corp: ([0-9]+).*/\1/p' <<<"$last")
mapfile -t found < <(find "$findings" -type f \( -name 'crash-*' -o -name 'leak-*' \
  -o -name 'timeout-*' -o -name 'oom-*' \) | sort)
if ((status != 0)) && ((${#found[@]} == 0)); then found=("(exit status $status, no reproducer)"); fi
echo "fuzz: ${mode:+fork mode, }${elapsed} s of ${seconds}, ${execs:-?} executions, cov: ${cov:-?}, ft: ${ft:-?}," \
  "corpus: ${corp:-?} inputs, findings: ${#found[@]}"
if ((${#found[@]} > 0)); then
  echo "fuzz: FINDINGS; the reports (with counts), then the log's last lines:" >&2
  grep -E 'kanedyn fuzz:|ERROR: |SUMMARY: |runtime error:' "$log" | sed -E 's/^==[0-9]+== //' |
    sort | uniq -c |
    sort -rn | head -n 10 >&2 || true
  tail -n 25 "$log" >&2
  for f in "${found[@]:0:10}"; do
    echo "fuzz: reproducer $f; replay: $fuzzer $f" >&2
  done
  if ((${#found[@]} > 10)); then echo "fuzz: ... and $((${#found[@]} - 10)) more in $findings" >&2; fi
  exit 1
fi

#!/usr/bin/env bash
# Fuzzes the model loader, the URDF import, the inputs table reader and the study file reader
# for SECONDS in all (default 180) with libFuzzer, ASan and UBSan: installs clang 14 and
# libFuzzer when missing, builds only the fuzz targets in BUILD_DIR (default build-fuzz), runs
# each in turn on a copy of its seed corpus (the committed corpora are never written) and prints
# one summary line per target. The time is shared in the proportions 10 : 5 : 4 : 5 (model
# loader, URDF, inputs table, study; 120 s: 50, 25, 20 and 25 s), among the targets given.
# Exits nonzero on any finding (crash, broken invariant, leak, timeout, out of memory) of any
# target, after running them all, leaving the reproducers in BUILD_DIR/findings/TARGET/.
# Usage: scripts/fuzz.sh [SECONDS] [TARGET...]
#   TARGET: model_loader, urdf, inputs_table, study (default all four)
# FUZZ_KEEP_GOING=1 runs libFuzzer's fork mode instead, which goes on past findings and so
# collects all it meets in the time (for triage; its cov and ft are counted differently).
set -euo pipefail
cd "$(dirname "$0")/.."
usage() {
  echo "usage: scripts/fuzz.sh [SECONDS] [TARGET...]  (SECONDS a whole number, default 180;" \
    "TARGET model_loader, urdf, inputs_table or study, default all four)" >&2
  exit 2
}
seconds=${1:-180}
if ! [[ "$seconds" =~ ^[1-9][0-9]*$ ]]; then usage; fi
shift || true
targets=("$@")
if ((${#targets[@]} == 0)); then targets=(model_loader urdf inputs_table study); fi
declare -A corpus_of=([model_loader]=fuzz/corpus [urdf]=fuzz/corpus-urdf
  [inputs_table]=fuzz/corpus-inputs [study]=fuzz/corpus-study)
declare -A dict_of=([model_loader]=fuzz/model.dict [urdf]=fuzz/urdf.dict
  [inputs_table]=fuzz/inputs.dict [study]=fuzz/study.dict)
declare -A share_of=([model_loader]=10 [urdf]=5 [inputs_table]=4 [study]=5)
shares=0
for t in "${targets[@]}"; do
  if [[ -z "${corpus_of[$t]:-}" ]]; then usage; fi
  shares=$((shares + share_of[$t]))
done

bash scripts/install-deps.sh --fuzz
build_dir=${BUILD_DIR:-build-fuzz}
# Line tables only: the reports name files and lines with them, and the build is faster than
# with full debug information.
CC=clang-14 CXX=clang++-14 cmake -S . -B "$build_dir" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O2 -gline-tables-only -DNDEBUG" \
  -DKANEDYN_FUZZ=ON -DKANEDYN_BUILD_BENCH=OFF -DKANEDYN_BUILD_TESTS=OFF >/dev/null
build_targets=()
for t in "${targets[@]}"; do build_targets+=("kanedyn_fuzz_$t"); done
cmake --build "$build_dir" -j"$(nproc)" --target "${build_targets[@]}"

export ASAN_OPTIONS=detect_leaks=1:abort_on_error=1
# urdfdom's own leaks on its error paths, as in CI's sanitizer stage (.ci/lsan.supp).
export LSAN_OPTIONS=suppressions=$PWD/.ci/lsan.supp
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
if [[ -x /usr/lib/llvm-14/bin/llvm-symbolizer ]]; then
  export ASAN_SYMBOLIZER_PATH=/usr/lib/llvm-14/bin/llvm-symbolizer
fi
mode=()
if [[ "${FUZZ_KEEP_GOING:-0}" == 1 ]]; then
  mode=(-fork=1 -ignore_crashes=1 -ignore_timeouts=1 -ignore_ooms=1)
fi

# Fresh each run, so that what is in findings/ is what this run found.
rm -rf "$build_dir/work" "$build_dir/findings"
failed=0
left=$seconds
left_shares=$shares
for t in "${targets[@]}"; do
  # This target's share of what is left (the last takes the rest), at least 1 s.
  time_t=$((left * share_of[$t] / left_shares))
  if ((time_t < 1)); then time_t=1; fi
  left=$((left > time_t ? left - time_t : 0))
  left_shares=$((left_shares - share_of[$t]))
  fuzzer="$build_dir/fuzz/kanedyn_fuzz_$t"
  work="$build_dir/work/$t"
  findings="$build_dir/findings/$t"
  # The inputs table target writes each input to a file in a folder of its own under TMPDIR.
  mkdir -p "$work/tmp" "$findings"
  tmp=$(realpath "$work/tmp")
  cp -R "${corpus_of[$t]}" "$work/corpus"
  log="$work/fuzz.log"
  echo "fuzz: $t: running $fuzzer${mode[*]:+ ${mode[*]}} for $time_t s (log: $log)"
  status=0
  started=$(date +%s)
  TMPDIR="$tmp" "$fuzzer" "${mode[@]}" -max_total_time="$time_t" -timeout=10 -rss_limit_mb=2048 \
    -dict="${dict_of[$t]}" -print_final_stats=1 -artifact_prefix="$findings/" "$work/corpus" \
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
  echo "fuzz: $t: ${mode:+fork mode, }${elapsed} s of ${time_t}, ${execs:-?} executions," \
    "cov: ${cov:-?}, ft: ${ft:-?}, corpus: ${corp:-?} inputs, findings: ${#found[@]}"
  if ((${#found[@]} > 0)); then
    failed=1
    echo "fuzz: $t: FINDINGS; the reports (with counts), then the log's last lines:" >&2
    grep -E 'kanedyn fuzz:|ERROR: |SUMMARY: |runtime error:' "$log" | sed -E 's/^==[0-9]+== //' |
      sort | uniq -c |
      sort -rn | head -n 10 >&2 || true
    tail -n 25 "$log" >&2
    for f in "${found[@]:0:10}"; do
      echo "fuzz: $t: reproducer $f; replay: $fuzzer $f" >&2
    done
    if ((${#found[@]} > 10)); then echo "fuzz: $t: ... and $((${#found[@]} - 10)) more in $findings" >&2; fi
  fi
done
exit "$failed"

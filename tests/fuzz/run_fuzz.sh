#!/bin/sh
# Runs each libFuzzer target for SECONDS from its committed seeds
# (tests/fuzz/corpus/<target>), keeping new inputs in BUILD/corpus/<target> and
# findings (crash-*, leak-*, timeout-*, oom-*) in BUILD/findings/<target>.
# Exit status 1 when any target found something. Usage: run_fuzz.sh BUILD SECONDS TARGET...
# SECONDS may be runs=N: N inputs from a fixed seed (-seed=1), the same inputs on every
# machine and every run (make test's smoke: it fails only on a change, never by chance).
set -u
build=$(cd "$1" && pwd); seconds=$2; shift 2  # absolute: the serve harness changes its folder
case "$seconds" in
  runs=*) budget="-runs=${seconds#runs=} -seed=1" ;;
  *) budget="-max_total_time=$seconds" ;;
esac
here=$(cd "$(dirname "$0")" && pwd)
status=0
for t in "$@"; do
  work=$build/corpus/$t; found=$build/findings/$t
  mkdir -p "$work" "$found"
  log=$build/fuzz_$t.log
  # -timeout: one input may take 10 s (a render of the serve target is capped far below);
  # -rss_limit_mb: a reader that allocates past 2 GiB for a small file is a finding.
  # Leaks in third-party code are suppressed by frame name (lsan.supp), which needs full
  # stacks through the uninstrumented libraries: the slow unwinder for the OIIO targets.
  # (Its memory: ASan's quarantine kept small, as OIIO interns every string it reads, for good.)
  unwind=""
  case "$t" in image|texture) unwind=":fast_unwind_on_malloc=0:quarantine_size_mb=16:malloc_context_size=12" ;; esac
  if ASAN_OPTIONS=detect_leaks=1:allocator_may_return_null=1$unwind LSAN_OPTIONS=suppressions=$here/lsan.supp \
     UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
     nice -n 5 "$build/fuzz/fuzz_$t" $budget -timeout=10 -rss_limit_mb=2048 \
       -artifact_prefix="$found/" -print_final_stats=1 "$work" "$here/corpus/$t" >"$log" 2>&1; then
    result=ok
  else
    result="FINDING (see $log and $found)"; status=1
  fi
  stats=$(grep -E "^stat::(number_of_executed_units|average_exec_per_sec|new_units_added)" "$log" | tr '\n' ' ')
  echo "fuzz $t: $seconds, corpus $(ls "$work" | wc -l) + $(ls "$here/corpus/$t" | wc -l) seeds, $stats: $result"
done
exit $status

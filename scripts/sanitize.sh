#!/usr/bin/env bash
# Build the C++ extension with AddressSanitizer and UndefinedBehaviorSanitizer
# (GCC's -fsanitize=address,undefined; any undefined behaviour stops the run)
# in a virtual environment and build directory of its own, and run the tests
# of the core, the interval evaluator and the sampling kernels under them.
#
#   bash scripts/sanitize.sh                 # the default test files
#   bash scripts/sanitize.sh tests/test_core.py -k insert
#
# Python itself is not instrumented, so libasan is preloaded, and libstdc++
# with it (else ASan finds no __cxa_throw to intercept and stops at the first
# C++ exception); CPython keeps memory until exit, so leak detection is off. Needs what quickstart.sh needs
# (run that first on a fresh machine).
# Environment: RDMESH_SANITIZE_VENV (default .venv-sanitize), PYTHON (default python3).
set -euo pipefail
cd "$(dirname "$0")/.."

venv="${RDMESH_SANITIZE_VENV:-.venv-sanitize}"
python="${PYTHON:-python3}"
say() { printf 'sanitize: %s\n' "$*" >&2; }

if [[ ! -x "$venv/bin/python" ]]; then
  say "creating virtual environment $venv"
  "$python" -m venv "$venv"
fi
say "building rdmesh with -fsanitize=address,undefined (several minutes)"
"$venv/bin/python" -m pip --disable-pip-version-check -q install ".[test]" \
  --config-settings=build-dir=build/sanitize \
  --config-settings=cmake.build-type=RelWithDebInfo \
  --config-settings=cmake.define.RDMESH_SANITIZE=ON

libasan=$(g++ -print-file-name=libasan.so)
libstdcxx=$(g++ -print-file-name=libstdc++.so)
for lib in "$libasan" "$libstdcxx"; do
  if [[ ! -e "$lib" ]]; then
    say "no $(basename "$lib") next to g++ ($lib)"
    exit 1
  fi
done
export LD_PRELOAD="$libasan $libstdcxx${LD_PRELOAD:+ $LD_PRELOAD}"
# allocator_may_return_null: a huge allocation becomes std::bad_alloc (MemoryError),
# as without the sanitizer, instead of an ASan report.
export ASAN_OPTIONS="detect_leaks=0:allocator_may_return_null=1:abort_on_error=1${ASAN_OPTIONS:+:$ASAN_OPTIONS}"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1${UBSAN_OPTIONS:+:$UBSAN_OPTIONS}"

if (($# == 0)); then
  set -- tests/test_core.py tests/test_core_threads.py tests/test_interval_core.py \
    tests/test_intervals.py tests/test_sample_scan.py tests/test_voronoi.py
fi
say "running pytest $* (LD_PRELOAD=$LD_PRELOAD)"
exec "$venv/bin/python" -m pytest -q -p no:cacheprovider "$@"

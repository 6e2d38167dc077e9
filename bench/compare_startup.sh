#!/usr/bin/env bash
# Start-up (issue #19): the CPU time of `servokit analyze` on every shipped model, the whole
# process (dynamic loading, reading and compiling the model, the analysis, exit), against the
# start-up of the SciPy peer's imports alone (`python3 -c 'import numpy, scipy.linalg, yaml'`,
# what bench/scipy_sweep.py needs before its first point). The goal: at most 5 ms of CPU. The
# libraries few commands need are plugins loaded on first use (reports/plugins.h): the count of
# shared libraries the executable loads is printed too.
#
# Usage: bench/compare_startup.sh [BUILD_DIR]      (default: build)
# Environment: REPEAT (default 50), PYTHON (default /usr/bin/python3, Debian's, with SciPy).
set -euo pipefail

build=${1:-build}
root=$(cd "$(dirname "$0")/.." && pwd)
servokit="$(cd "$build" 2>/dev/null && pwd)/application/servokit"
python=${PYTHON:-/usr/bin/python3}
repeat=${REPEAT:-50}
cpu() { "$python" "$root/bench/child_cpu.py" "$repeat" "$@"; }

echo "shared libraries loaded by servokit: $(LD_DEBUG=libs "$servokit" --version 2>&1 |
  grep -c 'calling init:')"
peer=$(cpu "$python" -c 'import numpy, scipy.linalg, yaml')
printf "%-24s %10s | %12s | %6s\n" command cpu_ms peer_cpu_ms ratio
version=$(cpu "$servokit" --version)
printf "%-24s %10s | %12s | %6.1f\n" "--version" "$version" "$peer" "$(echo "$peer / $version" | bc -l)"
for model in "$root"/models/*.yaml; do
  ms=$(cpu "$servokit" analyze "$model")
  printf "%-24s %10s | %12s | %6.1f\n" "analyze $(basename "$model" .yaml)" "$ms" "$peer" \
    "$(echo "$peer / $ms" | bc -l)"
done

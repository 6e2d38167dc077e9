#!/usr/bin/env bash
# `make demo`: the paper's classification of both examples (Seifried & Blajer 2013, Sects. 3-4).
set -euo pipefail
servokit=${1:-build/reports/servokit}
root=$(cd "$(dirname "$0")/.." && pwd)
models="$root/models"

section() { printf '\n=== %s ===\n' "$1"; }

section "Mass on car, case 1: vertical mass (alpha = 90 deg, d = 1)"
"$servokit" analyze "$models/mass_on_car.yaml" --set alpha="90 deg" --set d=1
section "Mass on car, case 2: tilted mass (alpha = 5 deg, d = 1)"
"$servokit" analyze "$models/mass_on_car.yaml" --set alpha="5 deg" --set d=1
section "Mass on car, case 2 undamped (alpha = 5 deg, d = 0): internal vibration at 2.887 Hz"
"$servokit" analyze "$models/mass_on_car.yaml" --set alpha="5 deg" --set d=0
section "Mass on car, case 3: horizontal, damped (alpha = 0, d = 1)"
"$servokit" analyze "$models/mass_on_car.yaml" --set alpha=0 --set d=1
section "Mass on car, case 4: horizontal, undamped (alpha = 0, d = 0): flat"
"$servokit" analyze "$models/mass_on_car.yaml" --set alpha=0 --set d=0
section "Rotational arm, output at s = 0.5 l: stable zero dynamics"
"$servokit" analyze "$models/rotational_arm.yaml" --set s=0.5
section "Rotational arm, end effector s = l: unstable zero dynamics (non-minimum phase)"
"$servokit" analyze "$models/rotational_arm.yaml" --set s=1
section "Rotational arm, exact tip angle (atan2 of Eq. 51)"
"$servokit" analyze "$models/rotational_arm_tip.yaml"

section "The paper's report: table of cases, Figs. 6 and 8, located thresholds, closed forms"
"$servokit" report paper --out "$root/demo/paper-report" --models "$models"
echo "open $root/demo/paper-report/report.html (or report.md) to read it"

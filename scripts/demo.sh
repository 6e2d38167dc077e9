#!/usr/bin/env bash
# `make demo`: the paper's classification of both examples (Seifried & Blajer 2013, Sects. 3-4)
# and the inverse models of Sect. 5, with two closed kinematic chains.
set -euo pipefail
servokit=${1:-build/application/servokit}
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
section "Acrobot written as bodies (kind: planar-bodies): shoulder angle held, non-minimum phase"
"$servokit" analyze "$models/acrobot.yaml"
section "Cart carrying a pendulum written as energies (kind: lagrangian): rod tip, then 2l/3 (flat)"
"$servokit" analyze "$models/cart_pendulum.yaml"
"$servokit" analyze "$models/cart_pendulum.yaml" --set s=0.6666666666666666

mkdir -p "$root/demo"
# The lines of the JSON a reader looks at first: the method, its status and the forward check.
summary='^  "(method|status|samples|max_servo_residual)"|"(passed|max_tracking_error|bound)"'
section "Solve case 4 (flat): algebraic inversion gives Eq. (47), every millisecond; checked on the model"
"$servokit" solve "$models/mass_on_car.yaml" --set alpha=0 --set d=0 \
  --trajectory rest-to-rest --y0 0.5 --yf 2.5 --t0 0 --tf 6 --t-end 10 \
  --sample-time 0.001 --verify --out "$root/demo/case4.csv" | grep -E "$summary"
section "Solve case 2 undamped with auto: the normal form (Dormand-Prince) keeps the 2.887 Hz vibration"
"$servokit" solve "$models/mass_on_car.yaml" --set alpha="5 deg" --set d=0 \
  --trajectory rest-to-rest --y0 0.5 --yf 2.5 --t0 0 --tf 6 --t-end 10 \
  --sample-time 0.001 --verify --out "$root/demo/case2.csv" | grep -E "$summary"
section "Solve case 3 (tangential, relative degree 3) with auto: the input-output normal form, exact to its tolerance"
"$servokit" solve "$models/mass_on_car.yaml" --set alpha=0 --set d=1 \
  --trajectory rest-to-rest --y0 0.5 --yf 2.5 --t0 0 --tf 6 --t-end 10 \
  --sample-time 0.001 --verify --out "$root/demo/case3.csv" | grep -E "$summary"
section "Gantry crane: the load moved 1 m in 3 s, flat through a dynamic extension of the hoist"
"$servokit" analyze "$models/gantry_crane.yaml" | grep -E "nonlinear structure|note"
"$servokit" solve "$models/gantry_crane.yaml" --trajectory rest-to-rest --y0 0,2 --yf 1,2 \
  --t0 0 --tf 3 --t-end 4 --sample-time 0.001 --verify --out "$root/demo/crane.csv" |
  grep -E "$summary"
section "The same crane in absolute coordinates, its rope a loop constraint: the same feedforward, and the rope force lambda"
"$servokit" solve "$models/gantry_crane_absolute.yaml" --trajectory rest-to-rest --y0 0,2 \
  --yf 1,2 --t0 0 --tf 3 --t-end 4 --sample-time 0.001 --verify \
  --out "$root/demo/crane_absolute.csv" | grep -E "$summary|max_constraint_violation"
section "A five-bar with a sprung passive crank, closed by two constraints: BDF on the loop DAE"
"$servokit" solve "$models/five_bar.yaml" --trajectory rest-to-rest --y0 1 --yf 1.1 \
  --t0 0 --tf 2 --t-end 4 --sample-time 0.001 --verify --out "$root/demo/five_bar.csv" |
  grep -E "$summary|max_constraint_violation"
echo "feedforward u_d(t), q_d(t) every millisecond: $root/demo/case4.csv, case2.csv, case3.csv,"
echo "crane.csv, crane_absolute.csv and five_bar.csv (with the loop forces lambda1, ...)"

section "The paper's report: table of cases, Figs. 6 and 8 (thresholds, closed forms), Figs. 9-13 (solvers)"
"$servokit" report paper --out "$root/demo/paper-report" --models "$models"
echo "open $root/demo/paper-report/report.html (or report.md) to read it"

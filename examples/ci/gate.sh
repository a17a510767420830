#!/usr/bin/env bash
# Gate a ship FMU in CI: IMO MSC.137(76) criteria and agreement with the reference ship.
#
#   examples/ci/gate.sh [FMU]
#
# Without an FMU argument the script first makes one the way a project would: synthetic
# KVLCC2 trial logs -> python -m identifier fit -> build_fmu.py (native FMU). Then it runs
# two gates and keeps going after a failure, so that both reports are always written:
#
#   python -m scenarios imo --strict             exit 3 when any IMO criterion fails
#   python -m scenarios validate --max-error-pct exit 3 when any |error| exceeds P %
#
# Exit status of this script: 0 both gates pass, 3 a gate failed, anything else: an error
# (a bad FMU, a failed build, ...), passed through unchanged.
#
# Environment: PYTHON (default python), OUT (default build/ci), MAX_ERROR_PCT (default 10).
set -euo pipefail

PY=${PYTHON:-python}
OUT=${OUT:-build/ci}
MAX_ERROR_PCT=${MAX_ERROR_PCT:-10}
fmu=${1:-}

if [ -z "$fmu" ]; then
    $PY -m scenarios synthesize --vessel kvlcc2 --scale full --seed 1 \
        --maneuver turning-35 --maneuver zigzag-10 --maneuver zigzag-20 -o "$OUT/logs"
    $PY -m identifier fit "$OUT/logs/turning-35.csv" "$OUT/logs/zigzag-10.csv" \
        "$OUT/logs/zigzag-20.csv" -o "$OUT/params.json" --quiet
    fmu=$OUT/ship.fmu
    $PY build_fmu.py --params "$OUT/params.json" -o "$fmu"
fi

failed=0

# run_gate NAME COMMAND...: 0 pass, 3 gate failed (remember it), other: stop with it.
run_gate() {
    local name=$1 status=0
    shift
    "$@" || status=$?
    case $status in
        0) echo "gate $name: pass" ;;
        3) echo "gate $name: FAILED" >&2; failed=1 ;;
        *) echo "gate $name: error (exit status $status)" >&2; exit "$status" ;;
    esac
}

run_gate imo $PY -m scenarios imo --fmu "$fmu" --strict --quiet --json "$OUT/imo.json"
run_gate validation $PY -m scenarios validate --fmu "$fmu" --reference kvlcc2 \
    --report "$OUT/report" --max-error-pct "$MAX_ERROR_PCT" --quiet

if [ "$failed" -ne 0 ]; then
    exit 3
fi

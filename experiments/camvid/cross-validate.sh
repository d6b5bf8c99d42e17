#!/usr/bin/env bash
# Leave-one-run-out cross-validation over CamVid's six labelled runs (docs/camvid.md, "Choosing by
# cross-validation"): experiments/camvid/cross-validate.sh CAMVID_DIR OUT CONFIG [--reuse BENCH_OUT]
# [--runs NAME,...] [--jobs N]. CONFIG: experiments/camvid/cross-validation.json is the benchmark's
# headline runs. Everything is in cross_validate.py (its docstring says the protocol and the output).
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
python=/usr/bin/python3
[[ -x $python ]] || python=python3
exec "$python" "$here/cross_validate.py" "$@"

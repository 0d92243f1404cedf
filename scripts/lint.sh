#!/usr/bin/env bash
# Lint, types and sizes: ruff (ruff.toml) over the code and tests, mypy (mypy.ini) over the package,
# then scripts/metrics.py as a report of modules/classes/functions over the size limits.
# Exits 1 when ruff or mypy report anything (the metrics report does not fail it).
# Usage: scripts/lint.sh        (after scripts/setup.sh; .ci/run runs it before the tests)
set -uo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
if [ -x "$ROOT/.venv/bin/python" ]; then PY="$ROOT/.venv/bin/python"; else PY="${PYTHON:-python3}"; fi

status=0
echo "[lint] ruff check dynamixel_handler bench scripts examples test"
"$PY" -m ruff check dynamixel_handler bench scripts examples test || status=1
echo "[lint] mypy dynamixel_handler"
"$PY" -m mypy dynamixel_handler || status=1
echo "[lint] sizes (report only)"
"$PY" scripts/metrics.py || true
if [ $status != 0 ]; then
  echo "[lint] FAILED: fix the ruff/mypy findings above" >&2
fi
exit $status

#!/usr/bin/env bash
# Lint, types and sizes: ruff (ruff.toml) over the code and tests, mypy (mypy.ini) over the package,
# then scripts/metrics.py --check --structure (no module over 400 lines, class over 250, function of
# complexity over 12; no class lineage over 3 in-package classes or 400 lines, at most 2 family-name
# comparisons outside control_table/, no import circle), then scripts/docs_touched.py (a commit after
# .ci/docs-baseline, or the uncommitted tree, that changes the public surface changes the docs too).
# Exits 1 when ruff, mypy or the size and structure check report anything.
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
echo "[lint] sizes and structure: modules <= 400 lines, classes <= 250, functions of complexity <= 12;"
echo "       lineages of at most 3 in-package classes and 400 lines, family-name comparisons <= 2, no import circle"
"$PY" scripts/metrics.py --check --structure || status=1
echo "[lint] docs touched: a change to the public surface (scripts/surface.py) comes with a docs change"
"$PY" scripts/docs_touched.py || status=1
if [ $status != 0 ]; then
  echo "[lint] FAILED: fix the ruff/mypy/metrics findings above" >&2
fi
exit $status

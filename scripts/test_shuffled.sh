#!/usr/bin/env bash
# The test modules whose tests share a node or a bus (a module-scoped fixture), each run with its
# tests shuffled (pytest-random-order, bucket = module), once per seed: a test that leans on what
# an earlier test left behind fails here. Seeds: the arguments, else a fixed list; a failing run
# prints its seed, and `scripts/test_shuffled.sh SEED` runs that order again.
# Usage: scripts/test_shuffled.sh [SEED ...]      (about 4 minutes a seed on 2 cores)
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
seeds=("$@")
[ ${#seeds[@]} -gt 0 ] || seeds=(11 23 37)
mapfile -t modules < <(grep -l 'scope="module"' test/*.py | sort)
status=0
for seed in "${seeds[@]}"; do
  echo "[shuffled] seed $seed: ${#modules[@]} modules"
  if ! scripts/test.sh -n 2 --dist loadfile -p random_order --random-order-bucket=module --random-order-seed="$seed" "${modules[@]}"; then
    echo "[shuffled] FAILED with seed $seed: scripts/test_shuffled.sh $seed runs that order again" >&2
    status=1
  fi
done
exit $status

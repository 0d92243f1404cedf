#!/usr/bin/env bash
# Run the whole test suite (sets up .venv and builds first if needed). Extra args go to pytest,
# e.g. scripts/test.sh -k sim -x
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$ROOT/scripts/setup.sh"
export ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST
export ROS_DOMAIN_ID="${ROS_DOMAIN_ID:-$((1 + $$ % 100))}"
# shellcheck disable=SC1091
set +u; source "$ROOT/env.sh"; set -u
cd "$ROOT"
exec python -m pytest -q -p no:cacheprovider "$@" test

#!/usr/bin/env bash
# Run the whole test suite (sets up .venv and builds first if needed). Extra args go to pytest,
# e.g. scripts/test.sh -k sim -x
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$ROOT/scripts/setup.sh"
export ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST
# test/conftest.py claims a ROS_DOMAIN_ID no other test run on this machine holds
# shellcheck disable=SC1091
set +u; source "$ROOT/env.sh"; set -u
cd "$ROOT"
# the whole test folder unless a test file or folder is named
paths=(test)
for arg in "$@"; do
  case "$arg" in -*) ;; *) [ -e "${arg%%::*}" ] && paths=() ;; esac  # a file, folder or file::test
done
# the whole folder on one worker more than there are cores, 3 at most (a node test mostly waits for
# its node and virtual bus: two workers on two cores kept them about half busy), a file's tests
# together on one worker; DXL_TEST_WORKERS=1 runs them one after another
workers=()
if [ ${#paths[@]} -gt 0 ]; then
  n="${DXL_TEST_WORKERS:-$(python -c 'import os; print(min(3, len(os.sched_getaffinity(0)) + 1))')}"
  [ "$n" -gt 1 ] && workers=(-n "$n" --dist loadfile)
fi
# the 15 slowest tests are listed at the end: the suite is kept under ten minutes
exec python -m pytest -q -p no:cacheprovider --durations=15 "${workers[@]}" "$@" "${paths[@]}"

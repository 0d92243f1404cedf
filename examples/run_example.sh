#!/usr/bin/env bash
# One command to see the example move servos, no hardware needed:
#   examples/run_example.sh                 # until Ctrl-C
#   examples/run_example.sh --duration 10   # 10 s of motion, then stop
# Sets up .venv and builds if needed, starts the virtual Dynamixel bus (XM430-W350 #1,
# XM540-W270 #2, PH54 #3, H54 #4) and dynamixel_handler on it in the background, then runs
# examples/position_oscillation.py on the X servos 1 and 2 in the foreground. Everything stops
# on Ctrl-C or when the duration is over; the node's log is kept in a file (path printed).
# Other args go to the example (e.g. --amplitude 45 --frequency 1).
# With DXL_DEVICE=/dev/ttyUSB0 the handler runs on that device instead of a virtual bus, and the
# caller's ROS_AUTOMATIC_DISCOVERY_RANGE is kept (unset: ROS's default, the subnet); on the virtual
# bus discovery is kept on this machine (LOCALHOST). Both are said in the output.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$ROOT/scripts/setup.sh" >&2
# shellcheck disable=SC1091
source "$ROOT/scripts/discovery.sh"
# shellcheck disable=SC1091
set +u; source "$ROOT/env.sh"; set -u
discovery_for_device example

LOG_DIR="$(mktemp -d "${TMPDIR:-/tmp}/dxl_example.XXXXXX")"
SIM_PID=""; NODE_PID=""
cleanup() {
  trap - EXIT INT TERM
  # the node first (SIGINT: it stops the servos and turns torque off), then the bus
  if [ -n "$NODE_PID" ] && kill -0 "$NODE_PID" 2>/dev/null; then
    kill -INT "$NODE_PID" 2>/dev/null || true
    for _ in $(seq 100); do kill -0 "$NODE_PID" 2>/dev/null || break; sleep 0.1; done
    kill -KILL "$NODE_PID" 2>/dev/null || true
  fi
  [ -n "$SIM_PID" ] && kill -TERM "$SIM_PID" 2>/dev/null || true
  wait 2>/dev/null || true
}
trap cleanup EXIT
trap 'exit 130' INT TERM

EXTRA=()
if [ -n "${DXL_DEVICE:-}" ]; then
  DEVICE="$DXL_DEVICE"
  echo "[example] node log: $LOG_DIR/node.log" >&2
else
  FIFO="$LOG_DIR/sim.fifo"; mkfifo "$FIFO"
  # own sessions: a Ctrl-C reaches only the example; cleanup stops the node, then the bus
  setsid dynamixel_handler_sim --quiet > "$FIFO" 2> "$LOG_DIR/sim.log" &
  SIM_PID=$!
  read -r DEVICE < "$FIFO"; rm -f "$FIFO"
  [ -n "$DEVICE" ] || { echo "[example] the virtual bus did not start: see $LOG_DIR/sim.log" >&2; exit 1; }
  echo "[example] virtual Dynamixel bus on $DEVICE; node log: $LOG_DIR/node.log" >&2
  EXTRA=(--params-file "$ROOT/config/config_virtual_bus.yaml")
fi

setsid dynamixel_handler --ros-args --params-file "$ROOT/config/config_dynamixel_handler.yaml" \
  "${EXTRA[@]}" -p "device_name:=$DEVICE" > "$LOG_DIR/node.log" 2>&1 &
NODE_PID=$!

set +e
python "$ROOT/examples/position_oscillation.py" --ids 1,2 "$@"
CODE=$?
set -e
if [ $CODE -ne 0 ] && [ $CODE -ne 130 ]; then
  echo "[example] the example failed ($CODE); last lines of the node log:" >&2
  tail -20 "$LOG_DIR/node.log" >&2
fi
exit $CODE

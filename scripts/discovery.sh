# shellcheck shell=bash
# Sourced by scripts/run.sh and examples/run_example.sh, before they source env.sh:
#   source scripts/discovery.sh; <source env.sh>; discovery_for_device TAG
# On the virtual bus (no DXL_DEVICE) DDS discovery is kept on this machine (LOCALHOST); on a real
# device (DXL_DEVICE set) the caller's ROS_AUTOMATIC_DISCOVERY_RANGE is kept as it was before env.sh
# (unset: the ROS default, the subnet), so the robot's other computers see the node. Says which.
CALLER_RANGE="${ROS_AUTOMATIC_DISCOVERY_RANGE-}"

discovery_for_device() {
  local tag="$1"
  if [ -n "${DXL_DEVICE:-}" ]; then
    if [ -n "$CALLER_RANGE" ]; then export ROS_AUTOMATIC_DISCOVERY_RANGE="$CALLER_RANGE"; else unset ROS_AUTOMATIC_DISCOVERY_RANGE; fi
    echo "[$tag] device $DXL_DEVICE; ROS discovery as your environment says (ROS_AUTOMATIC_DISCOVERY_RANGE=${CALLER_RANGE:-unset: the ROS default, SUBNET})" >&2
  else
    export ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST
    echo "[$tag] ROS discovery kept on this machine (ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST) for the virtual bus" >&2
  fi
}

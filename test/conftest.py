"""Test-wide settings: DDS discovery stays on this machine, on a domain of this test run's own."""
import fcntl
import os
import tempfile

# Before anything imports rclpy: loopback-only discovery and a domain no other run shares.
os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"


def _claim_domain() -> str:
    """A ROS domain ID that no other test run on this machine holds (a lock file per domain, held
    for the life of this process), so concurrent runs never see each other's topics."""
    start = os.getpid() % 100
    for k in range(100):
        domain = 1 + (start + k) % 100
        handle = open(os.path.join(tempfile.gettempdir(), f"dynamixel_handler_test_domain_{domain}.lock"), "w")
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            handle.close()
            continue
        _claim_domain.handle = handle  # keep the lock until this process exits
        return str(domain)
    return str(1 + start)


os.environ["ROS_DOMAIN_ID"] = _claim_domain()

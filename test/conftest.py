"""Test-wide settings: DDS discovery stays on this machine, on a domain of this test run's own."""
import os

# Before anything imports rclpy: loopback-only discovery and a domain no other run shares.
os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
os.environ.setdefault("ROS_DOMAIN_ID", str(1 + os.getpid() % 100))

"""Publishers and subscriptions without rclpy's default QoS-event handlers.

By default every publisher and subscription brings two event handlers (incompatible QoS, incompatible
type). Each is a waitable the executor rebuilds into its wait set on every spin; with the handler's
~40 topics they cost more CPU per received command than the command itself.
"""
from __future__ import annotations

from typing import Callable

from rclpy.event_handler import PublisherEventCallbacks, SubscriptionEventCallbacks
from rclpy.node import Node


def lean_publisher(node: Node, typ, topic: str, depth=10):
    return node.create_publisher(typ, topic, depth, event_callbacks=PublisherEventCallbacks(use_default_callbacks=False))


def lean_subscription(node: Node, typ, topic: str, callback: Callable, depth=10):
    return node.create_subscription(typ, topic, callback, depth,
                                    event_callbacks=SubscriptionEventCallbacks(use_default_callbacks=False))

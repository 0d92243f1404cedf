"""Publishers and subscriptions without rclpy's default QoS-event handlers, and publishers of
nested-dict messages (``cdr.Codec``) as raw CDR bytes.

By default every publisher and subscription brings two event handlers (incompatible QoS, incompatible
type). Each is a waitable the executor rebuilds into its wait set on every spin; with the handler's
~40 topics they cost more CPU per received command than the command itself.
"""
from __future__ import annotations

from typing import Any, Callable

from rclpy.event_handler import PublisherEventCallbacks, SubscriptionEventCallbacks
from rclpy.node import Node

from .cdr import Codec, Unsupported
from .fastpath import RAW_ENV


def lean_publisher(node: Node, typ, topic: str, depth=10):
    return node.create_publisher(typ, topic, depth, event_callbacks=PublisherEventCallbacks(use_default_callbacks=False))


def lean_subscription(node: Node, typ, topic: str, callback: Callable, depth=10, raw: bool = False):
    return node.create_subscription(typ, topic, callback, depth, raw=raw,
                                    event_callbacks=SubscriptionEventCallbacks(use_default_callbacks=False))


class TreePublisher:
    """Publishes ``cdr.Codec`` values (nested dicts of numpy arrays): encoded to CDR bytes when
    ``raw``, else turned into an rclpy message object."""

    def __init__(self, node: Node, typ, topic: str, depth: int, raw: bool) -> None:
        self.publisher = lean_publisher(node, typ, topic, depth)
        self.codec = Codec.of(typ)
        self.raw = raw

    def wanted(self) -> bool:
        """Somebody subscribes (a message nobody receives is not even built)."""
        return self.publisher.get_subscription_count() > 0

    def publish(self, value: dict[str, Any]) -> None:
        self.publisher.publish(self.codec.encode(value) if self.raw else self.codec.to_message(value))


__all__ = ["RAW_ENV", "TreePublisher", "Unsupported", "lean_publisher", "lean_subscription"]

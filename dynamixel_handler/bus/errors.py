"""Errors the bus layer raises to users."""


class BusError(Exception):
    """The serial bus cannot be used; the message says what, why and what to do."""

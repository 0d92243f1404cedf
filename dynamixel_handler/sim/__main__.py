"""``python -m dynamixel_handler.sim``: same as the ``dynamixel_handler_sim`` command."""

from .cli import main

raise SystemExit(main())

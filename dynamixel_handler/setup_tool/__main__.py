"""``python -m dynamixel_handler.setup_tool``: the same as ``dynamixel_handler_setup``."""
import sys

from . import main

sys.exit(main())

"""``python -m kinematics_node.cli``: the `kinematics` command line without its console script
(where the package is on the path but not pip-installed, e.g. a colcon workspace)."""

import sys

from .main import main

sys.exit(main())

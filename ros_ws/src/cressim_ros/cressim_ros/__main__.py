"""`python -m cressim_ros [--ros-args ...]`: runs the twin node."""
import sys

from cressim_ros.twin_node import main

sys.exit(main(sys.argv))

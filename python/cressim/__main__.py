import sys

from cressim.cli import main

sys.exit(main())

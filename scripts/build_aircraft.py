"""Build an aircraft's aerodynamic tables and JSBSim files from its description file (the paper's aircraft by default)."""

import sys

from aircraft.design.build import main

if __name__ == "__main__":
    sys.exit(main())

"""Regenerate the solar UAV's aerodynamic tables and JSBSim files from its documented geometry."""

import sys

from aircraft.design.build import main

if __name__ == "__main__":
    sys.exit(main())

"""Aircraft analysis on the simulation: linear modes and their envelope, stability and control
derivatives, actuator effectiveness, and standalone JSBSim runscripts."""

"""The loop bench: the attitude controller in its own process, over a serial line, against the
aircraft model flown in real time (or in lockstep). ``plant`` is the flight computer's side,
``node`` the controller's process, ``wire`` the MAVLink messages, ``link`` the line itself."""

"""The host stage: compile the generated C here, load it with ctypes and run it over a log."""

"""The logs stage: the log table (CSV in and out), MDF4, channel maps, unit checks and the
quasi-steady segments of a log."""

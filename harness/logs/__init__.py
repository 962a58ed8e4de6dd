"""The logs stage: reading logs. The log table (CSV in and out, uniform grid, gaps), logs read in
chunks, MDF4, raw CAN with a DBC, channel maps; what the signals say about a log is the physics
stage's, the estimates files the outputs stage's."""

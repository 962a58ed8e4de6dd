"""The starter stage: what a user's project starts with (``vsegen init``: a vehicle file, a channel
map, a README) and the reference pages ``vsegen docs`` writes into it (conventions, vehicle-file
keys, signals and status bits)."""

"""The truth plant of simulated logs: a two-track vehicle with Magic-Formula tyres.

Equations and parameters: ``tyre.py`` (combined-slip tyre), ``two_track.py`` (vehicle). The
parameters come from the vehicle file's ``[vehicle]`` and ``[plant]`` tables.
"""

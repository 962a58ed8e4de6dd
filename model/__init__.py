"""Symbolic side of vsegen: parameters, vehicle models, discretisation, filter blocks, estimators.

Pure: builds expressions, does no file I/O, printing or compiling.
"""

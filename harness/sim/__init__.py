"""The simulation stage: the two-track truth plant with Magic Formula tyres, the driver, the
sensor model and the scenarios that make simulated logs."""

"""Software in the loop: an estimator's generated C packaged as a co-simulation FMU."""

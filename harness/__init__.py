"""Everything around the generated C: building and loading it, the NumPy reference estimators,
the truth plant and scenarios, sensor models, log I/O, comparison and the ``vsegen`` CLI."""

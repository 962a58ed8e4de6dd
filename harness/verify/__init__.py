"""The verify stage: the generated C against the NumPy reference (step by step, tolerances) and
fuzzing of the compiled C."""

"""The score stage: estimates against ground truth (tables and plots)."""

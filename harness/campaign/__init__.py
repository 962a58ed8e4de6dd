"""Campaigns: every log of a validation database through estimators and settings files, on a cluster."""

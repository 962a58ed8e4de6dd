"""The outputs stage: estimates files, as ``vsegen run`` writes them and ``score`` and ``plot``
read them (CSV, MDF4, Parquet)."""

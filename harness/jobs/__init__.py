"""Spreading independent runs over worker processes or a Dask cluster, progress on stderr, and
bounded per-process memos of expensive job inputs."""

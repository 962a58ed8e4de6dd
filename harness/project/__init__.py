"""The project stage: where things live (the user's project, shipped vehicle files, the build
cache), reading user files with one-line errors, writing files atomically, loading vehicle files,
and the results for machines every checking command writes."""

"""The project stage: where things live (the user's project, shipped vehicle files, the build
cache), reading user files with one-line errors, writing files atomically, and loading vehicle files."""

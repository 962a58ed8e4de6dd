"""``python -m vsegen.harness.cli``: the vsegen command line."""

from vsegen.harness.cli import entry

entry()

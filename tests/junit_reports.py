"""Reading a command's JUnit XML in the tests: validated first against docs/junit.xsd (xmlschema, the
outside judge of its form), then read with junitparser (the outside judge of its content)."""

from __future__ import annotations

from pathlib import Path

import xmlschema
from junitparser import JUnitXml
from locations import REPO

SCHEMA = xmlschema.XMLSchema(str(REPO / "docs" / "junit.xsd"))


def read_junit(path: Path | str) -> JUnitXml:
    """The report at ``path``; xmlschema's error when it does not follow the schema."""
    SCHEMA.validate(str(path))
    return JUnitXml.fromfile(str(path))

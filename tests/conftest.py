"""Shared fixtures of the test suite."""
from __future__ import annotations

import importlib
import sys
from pathlib import Path

import pytest

#: the folder of the validation scripts (not a package: its scripts import each other by name)
VALIDATION = Path(__file__).resolve().parents[1] / "validation"


@pytest.fixture()
def validation_script():
    """``validation_script("name")`` imports ``validation/name.py`` (with ``validation/`` on
    ``sys.path`` for the test's duration, as the scripts expect when run)."""
    sys.path.insert(0, str(VALIDATION))
    try:
        yield importlib.import_module
    finally:
        sys.path.remove(str(VALIDATION))

"""Shared fixtures of the test suite."""
from __future__ import annotations

import importlib
from pathlib import Path

import pytest

#: the folder of the validation scripts (not a package: its scripts import each other by name)
VALIDATION = Path(__file__).resolve().parents[1] / "validation"


@pytest.fixture()
def validation_script(monkeypatch):
    """``validation_script("name")`` imports ``validation/name.py`` (with ``validation/`` on
    ``sys.path`` for the test's duration, as the scripts expect when run; ``sys.path`` is
    restored whole afterwards, also when a script inserted the folder again)."""
    monkeypatch.syspath_prepend(str(VALIDATION))
    return importlib.import_module

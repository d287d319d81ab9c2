"""Shared fixtures: the repository's paths and a writer of scenario files."""
from __future__ import annotations

from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
PAPER_DIR = REPO / "scenarios" / "paper"


@pytest.fixture
def write_scenario(tmp_path):
    """``write_scenario(text, name="scenario.toml") -> Path``: a scenario file in a temp dir."""
    def write(text: str, name: str = "scenario.toml") -> Path:
        path = tmp_path / name
        path.write_text(text, encoding="utf-8")
        return path
    return write

"""Shared test fixtures: paths to the committed fixtures and to ../shared/data."""

from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
FIXTURES = ROOT / "tests" / "fixtures"
SHARED_DATA = ROOT.parent / "shared" / "data"


@pytest.fixture
def fixtures_dir():
    return FIXTURES


@pytest.fixture
def shared_data():
    """Path to ../shared/data; skips the test when it is not there."""
    if not SHARED_DATA.is_dir():
        pytest.skip(f"needs the real motion capture in {SHARED_DATA} (not present)")
    return SHARED_DATA

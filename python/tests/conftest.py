"""Shared test helpers."""

from __future__ import annotations

import os
from pathlib import Path

from hypothesis import settings

REPO_ROOT = Path(__file__).resolve().parents[2]
"""The repository root (holds spec/, tools/, c/, python/)."""

# No per-example deadline: a stalled CI machine must not fail a correct property.
settings.register_profile("default", deadline=None)
# A long search, run by hand: HYPOTHESIS_PROFILE=thorough pytest tests
settings.register_profile("thorough", deadline=None, max_examples=5000)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "default"))

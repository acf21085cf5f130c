"""Shared test helpers."""

from __future__ import annotations

from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parents[2]
"""The repository root (holds spec/, tools/, c/, python/)."""

"""The base of every scenario config model and the one-line scenario error.

Config modules of missions that bring their own vehicle and sensors (``config_<mission>.py``)
import ``_M`` from here so that ``schema.py`` can import them without a cycle.
"""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict


class ScenarioError(ValueError):
    """A scenario file or override is invalid; the message is one line for the user."""


class _M(BaseModel):
    """Strict model: unknown keys are errors, assignments are validated."""

    model_config = ConfigDict(extra="forbid", validate_assignment=True)

"""The navigator interface: command dispatch and the Protocol check."""

import pytest

from visnav.measurements import Health, NavCommand, NavInit
from visnav.navigation.base import CommandDispatch, Navigator


class _Nav(CommandDispatch):
    def __init__(self):
        self.calls = []

    def update(self, m):
        pass

    def initialize(self, init):
        self.calls.append(("init", init.source))

    def estimate(self, t):
        return None

    def health(self, t):
        return Health()

    def _cmd_set_source(self, t, source):
        self.calls.append((t, source))


def test_command_dispatch_passes_time_and_args():
    n = _Nav()
    n.command(NavCommand(2.5, "set-source", {"source": "mpe"}))
    n.initialize(NavInit(t=0.0, source="survey"))
    assert n.calls == [(2.5, "mpe"), ("init", "survey")]
    assert isinstance(n, Navigator)


def test_unknown_command_names_the_known_ones():
    with pytest.raises(ValueError, match="known: set_source"):
        _Nav().command(NavCommand(0.0, "fly"))


def test_protocol_rejects_a_class_without_health():
    class Half:
        def update(self, m):
            pass

    assert not isinstance(Half(), Navigator)

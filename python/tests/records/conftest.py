"""The command-line fixtures (simulated motors, in-process ``drempower``) for the records tests."""

from ..cli.conftest import _fast_simulator, cli, host_frames, sim, virtual_channel  # noqa: F401

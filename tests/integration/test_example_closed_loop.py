#!/usr/bin/env python3
"""examples/closed_loop, run as its users would: `python3 -m pytest
examples/closed_loop`, with the cansim client from python/ (PYTHONPATH) and
the built cansimd (CANSIMD), on vcan0. A PI controller outside cansimd
(examples/closed_loop/controller.py, python-can) holds 6 bar through the
plant; the tests check on the wire the open-loop step response against the
plant's analytic solution, the closed loop at 6 bar, the controller's answer
to a leak and to a broken transmitter, and the second transmitter reporting
the same vessel. Every test must run and pass (a skip fails this check)."""

# ctest-timeout: 300

import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "lib"))
import cansim_it as it  # noqa: E402


def test(ctx: it.Context) -> None:
    it.require_iface("vcan0")
    it.run_pytest(ctx, "examples/closed_loop", "-s", "-p", "cansim.pytest_plugin", "--cansim-require",
                  "--cansim-bus", "vcan0", ctx.source("examples", "closed_loop", "test_closed_loop.py"), timeout=150)


it.main(test)

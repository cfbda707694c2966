#!/usr/bin/env python3
"""examples/closed_loop on the kernel-free bus, as its users run it on a
host without kernel CAN: `python3 -m pytest examples/closed_loop` with the
plugin's socketcand bus (--cansim-bus socketcand), the controller and the
bench on python-can's socketcand client (CI runs the example here only: on
vcan its checks were the same, and the VM's time is CI's longest path): the
open-loop step response
against the plant's analytic solution, the closed loop at 6 bar, the
controller's answer to a leak and to a broken transmitter, the second
transmitter reporting the same vessel. A skip fails this check."""

# ctest-timeout: 180

import cansim_it as it


def test(ctx: it.Context) -> None:
    it.run_pytest(ctx, "examples/closed_loop on socketcand", "-s", "-p", "cansim.pytest_plugin", "--cansim-require",
                  "--cansim-bus", "socketcand", ctx.source("examples", "closed_loop", "test_closed_loop.py"),
                  timeout=150)


it.main(test)

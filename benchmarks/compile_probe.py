"""Run one ``follicle`` command (or ``import follicle``) and record what numba compiles.

``python compile_probe.py OUT.json ARGS…`` runs ``follicle ARGS…`` in this process
(``--import`` as ARGS: only ``import follicle``) with a listener on numba's compile
events, and writes to OUT.json the seconds from start to exit, the seconds spent
compiling (outermost compilations only: a kernel compiled inside another's compilation
is counted once, in its caller) and each compiled kernel with its own seconds. numba is
imported only once the command makes a kernel, so the listener is put in place then,
through follicle's kernel hook; a command that compiles nothing never imports numba
here. Used by ``benchmarks/cold_start.py``, run by the Python of the environment under
test.
"""

from __future__ import annotations

import atexit
import json
import sys
import time

START = time.perf_counter()
OUT = sys.argv[1]
ARGS = sys.argv[2:]
records: list[dict] = []
_open: list[float] = []


def _listen() -> None:
    from numba.core import event

    class Listener(event.Listener):
        def on_start(self, ev: event.Event) -> None:
            _open.append(time.perf_counter())

        def on_end(self, ev: event.Event) -> None:
            began = _open.pop()
            func = ev.data["dispatcher"].py_func
            records.append(
                {
                    "kernel": f"{func.__module__}.{func.__qualname__}",
                    "seconds": time.perf_counter() - began,
                    "outermost": not _open,
                }
            )

    event.register("numba:compile", Listener())


def _dump() -> None:
    with open(OUT, "w") as out:
        json.dump(
            {
                "seconds": time.perf_counter() - START,
                "compile_seconds": sum(r["seconds"] for r in records if r["outermost"]),
                "kernels": records,
            },
            out,
        )


atexit.register(_dump)
if ARGS == ["--import"]:
    import follicle  # noqa: F401
else:
    from follicle import kernels

    original = kernels.Kernel.dispatcher

    def dispatcher(self: kernels.Kernel) -> object:
        if not _listening:
            _listening.append(True)
            _listen()
        return original(self)

    _listening: list[bool] = []
    kernels.Kernel.dispatcher = dispatcher  # type: ignore[method-assign]
    from follicle.cli import main

    main(ARGS, prog_name="follicle")

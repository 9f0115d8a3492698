"""AI2-THOR is shut down on every exit path: failures, Ctrl-C, `with` blocks, interpreter exit.

The fake Unity counts how often ai2thor's `Controller.stop()` reached its server.
"""

from __future__ import annotations

import gc
import signal

import pytest

from benchmark_adapter.sim.thor import ThorCrashed, ThorUnavailable
from benchmark_adapter.sim.thor import pool as pool_module
from benchmark_adapter.sim.thor.pool import ControllerPool, install_sigterm_exit, shutdown

from .conftest import needs_data, python_stdout, shared_config


def started(make_thor, library, **options):
    ctl = make_thor(shared_config(), **options)
    ctl.reset()
    return ctl, library.servers[-1]


@pytest.mark.parametrize("interrupt", [KeyboardInterrupt(), SystemExit(143)])
@pytest.mark.needs_thor
@needs_data
def test_interrupt_during_a_step_stops_ai2thor(make_thor, library, pool, interrupt):
    ctl, server = started(make_thor, library)
    server.fail_on["PickupObject"] = interrupt
    with pytest.raises(type(interrupt)):
        ctl.step("PickupObject", agentId=0, objectId="x", forceAction=True)
    assert server.stops == 1 and len(pool) == 0
    with pytest.raises(ThorCrashed, match="call reset"):
        ctl.step("Pass", agentId=0)
    ctl.reset()  # a fresh AI2-THOR
    assert len(library.servers) == 2 and ctl.step("Pass", agentId=0)[0]["lastActionSuccess"]


@pytest.mark.parametrize("failure", [OSError("broken pipe"), TimeoutError("no reply")])
@pytest.mark.needs_thor
@needs_data
def test_failure_during_a_step_stops_ai2thor(make_thor, library, pool, failure):
    ctl, server = started(make_thor, library)
    server.fail_on["Pass"] = failure
    with pytest.raises(ThorCrashed, match="AI2-THOR stopped after") as caught:
        ctl.step("Pass", agentId=1)
    # ai2thor stops its server itself, then we stop the whole controller.
    assert isinstance(caught.value.__cause__, (RuntimeError, TimeoutError))
    assert server.stops >= 1 and len(pool) == 0


@pytest.mark.needs_thor
@needs_data
def test_failure_during_reset_stops_ai2thor(make_thor, library, pool):
    ctl, server = started(make_thor, library)
    server.fail_on["Initialize"] = RuntimeError("scene failed to load")
    with pytest.raises(ThorCrashed):
        ctl.reset()
    assert server.stops >= 1 and len(pool) == 0


@pytest.mark.needs_thor
@needs_data
def test_a_dead_pooled_ai2thor_is_replaced_once(make_thor, library, pool):
    first, server = started(make_thor, library)
    first.stop()
    server.fail_on["Reset"] = OSError("Unity exited")
    second = make_thor(shared_config())
    assert len(second.reset()) == 2
    assert server.stops >= 1 and len(library.servers) == 2 and len(pool) == 1


@pytest.mark.needs_thor
@needs_data
def test_ctrl_c_inside_a_with_block_stops_ai2thor(make_thor, library, pool):
    with pytest.raises(KeyboardInterrupt), make_thor(shared_config()) as ctl:
        ctl.reset()
        raise KeyboardInterrupt
    assert library.servers[0].stops == 1 and len(pool) == 0


@pytest.mark.needs_thor
@needs_data
def test_an_ordinary_error_inside_a_with_block_keeps_ai2thor_for_reuse(make_thor, library, pool):
    with pytest.raises(ZeroDivisionError), make_thor(shared_config()) as ctl:
        ctl.reset()
        _ = 1 / 0
    assert library.servers[0].stops == 0 and len(pool) == 1
    with pytest.raises(RuntimeError, match=r"reset\(\) must be called first"):
        ctl.last_metadata()


@pytest.mark.needs_thor
@needs_data
def test_a_forgotten_controller_frees_its_ai2thor(make_thor, library, pool):
    ctl, _ = started(make_thor, library)
    del ctl
    gc.collect()
    started(make_thor, library)
    assert len(library.servers) == 1


@pytest.mark.needs_thor
@needs_data
def test_controllers_alive_at_once_get_their_own_ai2thor(make_thor, library, pool):
    first, _ = started(make_thor, library)
    second, _ = started(make_thor, library)
    assert len(library.servers) == 2
    assert first._session.controller is not second._session.controller


@pytest.mark.needs_thor
@needs_data
def test_pool_close_stops_every_ai2thor(make_thor, library, pool):
    started(make_thor, library)
    started(make_thor, library, width=400)  # other run options: another AI2-THOR process
    pool.close()
    assert [s.stops for s in library.servers] == [1, 1] and len(pool) == 0


@needs_data
def test_failing_start_leaves_nothing_behind(pool):
    from benchmark_adapter.sim.thor import ThorController

    def factory(options, scene, init):
        raise ThorUnavailable("no build", "download it")

    ctl = ThorController(shared_config(), factory=factory, pool=pool)
    with pytest.raises(ThorUnavailable):
        ctl.reset()
    assert len(pool) == 0
    with pytest.raises(RuntimeError, match="must be called first"):
        ctl.step("Pass")


# -- shutdown of one controller --------------------------------------------------------


class FakeProcess:
    def __init__(self) -> None:
        self.killed = False

    def poll(self):
        return 0 if self.killed else None

    def kill(self) -> None:
        self.killed = True


class Stoppable:
    def __init__(self, error: BaseException | None = None) -> None:
        self.error, self.stops = error, 0
        self.server = type("Server", (), {"unity_proc": FakeProcess()})()

    def stop(self) -> None:
        self.stops += 1
        if self.error is not None:
            raise self.error


def test_shutdown_stops_cleanly():
    ctl = Stoppable()
    shutdown(ctl)
    assert ctl.stops == 1 and not ctl.server.unity_proc.killed


def test_shutdown_kills_unity_when_stop_fails():
    ctl = Stoppable(RuntimeError("pipe closed"))
    shutdown(ctl)  # logged, not raised
    assert ctl.server.unity_proc.killed


def test_second_ctrl_c_during_shutdown_still_kills_unity():
    ctl = Stoppable(KeyboardInterrupt())
    with pytest.raises(KeyboardInterrupt):
        shutdown(ctl)
    assert ctl.server.unity_proc.killed


# -- process exit ----------------------------------------------------------------------


def test_first_session_registers_atexit_and_sigterm(monkeypatch):
    registered, finalizers, installed = [], [], []
    monkeypatch.setattr(pool_module.atexit, "register", registered.append)
    monkeypatch.setattr(
        pool_module.multiprocessing.util, "Finalize", lambda obj, fn, **kw: finalizers.append(fn)
    )
    monkeypatch.setattr(pool_module, "install_sigterm_exit", lambda: installed.append(True))
    hooked = ControllerPool(install_exit_hooks=True)
    owner = Stoppable()
    hooked.acquire("k", owner, Stoppable)
    hooked.acquire("k", Stoppable(), Stoppable)
    assert registered == finalizers == [hooked.close] and installed == [True]
    hooked.close()


def test_sigterm_becomes_a_normal_exit_unless_already_handled(monkeypatch):
    handlers = {signal.SIGTERM: signal.SIG_DFL}
    monkeypatch.setattr(pool_module.signal, "getsignal", handlers.get)
    monkeypatch.setattr(pool_module.signal, "signal", handlers.__setitem__)
    assert install_sigterm_exit() is True
    with pytest.raises(SystemExit) as caught:
        handlers[signal.SIGTERM](signal.SIGTERM, None)
    assert caught.value.code == 128 + signal.SIGTERM
    assert install_sigterm_exit() is False  # never replaces someone else's handler


def test_atexit_really_stops_sessions_at_interpreter_exit():
    script = (
        "from benchmark_adapter.sim.thor.pool import POOL\n"
        "class C:\n"
        "    def stop(self):\n"
        "        print('stopped', flush=True)\n"
        "owner = C()\n"
        "POOL.acquire('k', owner, C)\n"
    )
    assert python_stdout("-c", script) == "stopped\n"


WORKER_SCRIPT = """
import concurrent.futures, multiprocessing, sys
from benchmark_adapter.sim.thor.pool import POOL

class Unity:
    def stop(self):
        with open(sys.argv[1], "a") as f:
            f.write("stopped\\n")

owners = []

def episode(_):
    owners.append(Unity())  # still holding its session when the worker exits
    POOL.acquire("k", owners[-1], Unity)
    return len(POOL)

if __name__ == "__main__":
    context = multiprocessing.get_context(sys.argv[2])
    with concurrent.futures.ProcessPoolExecutor(1, mp_context=context) as pool:
        print(list(pool.map(episode, range(2))))
"""


@pytest.mark.parametrize("start_method", ["fork", "spawn"])
def test_worker_processes_stop_their_ai2thor_when_they_exit(tmp_path, start_method):
    script, log = tmp_path / "worker.py", tmp_path / "stops.log"
    script.write_text(WORKER_SCRIPT)
    out = python_stdout(str(script), str(log), start_method)
    assert out.strip() == "[1, 2]"  # one worker, two sessions (both still held)
    assert log.read_text() == "stopped\n" * 2  # stopped by the worker, not by the parent


def test_a_forked_worker_does_not_reuse_its_parents_sessions(monkeypatch):
    forked = ControllerPool(install_exit_hooks=False)
    parent_ctl = Stoppable()
    forked.acquire("k", Stoppable(), lambda: parent_ctl)
    monkeypatch.setattr(pool_module.os, "getpid", lambda: -1)
    assert len(forked) == 0
    forked.close()
    assert parent_ctl.stops == 0  # the parent's Unity is the parent's to stop

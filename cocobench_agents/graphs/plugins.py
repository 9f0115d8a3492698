"""Planners from the researcher's code: `FILE.py:NAME`, `package.module:NAME`, and installed
packages registering under the entry point group `cocobench.planners`.

NAME is a `PlannerSpec`, or a function returning a `StateGraph` (then: one team model,
centralized-style clients, condition code from the name: `build_claim_board` → `claim-board`).
Each reference is loaded once per process and kept as a string everywhere else, so forked
workers and Ray workers resolve the same planner from the same text. Loading user code fails
as a `PlannerError` naming the file or entry point, never as a traceback.
"""

from __future__ import annotations

import dataclasses
import hashlib
import importlib
import importlib.util
import inspect
import re
import sys
from collections.abc import Iterable
from dataclasses import dataclass
from importlib import metadata
from pathlib import Path
from typing import Any

from cocobench_agents.graphs.registry import (
    AGENT_SEAT,
    LED_ROUND,
    LOOPS,
    PLANNERS,
    PROMPTS,
    ROUND,
    TEAM_SEAT,
    PlannerError,
    PlannerSpec,
    UnknownPlanner,
)

GROUP = "cocobench.planners"
CODE = re.compile(r"[A-Za-z0-9][A-Za-z0-9._-]*")  # it names run folders


@dataclass(frozen=True)
class PlannerOrigin:
    """Where a planner comes from, as `cocobench planners` shows it and `run.json` records
    it."""

    kind: str  # "built-in", "entry point", "file" or "module"
    source: str  # the module:NAME (or file:NAME) that defines it
    file: str | None = None  # the file defining NAME, whose hash guards a resume
    sha256: str | None = None
    distribution: str | None = None  # "name version" of the package registering it
    # The folder of the package NAME's module belongs to: then `sha256` covers every .py
    # file under it (`_code_hash`), not `file` alone.
    package: str | None = None

    def describe(self) -> str:
        """One line for listings."""
        extra = f", {self.distribution}" if self.distribution else ""
        return f"{self.kind}: {self.source}{extra}"

    def record(self) -> dict[str, Any]:
        """What `run.json` keeps (the fields that are set)."""
        return {k: v for k, v in dataclasses.asdict(self).items() if v is not None}


@dataclass(frozen=True)
class LoadedPlanner:
    """A planner and where it comes from; `error` set for an installed one that is broken."""

    name: str
    spec: PlannerSpec | None
    origin: PlannerOrigin
    error: str | None = None


_LOADED: dict[str, LoadedPlanner] = {}  # by reference as given and by canonical name


def load_planner(ref: str) -> LoadedPlanner:
    """The planner `ref` names (not a built-in), loading its code on first use in this
    process."""
    loaded = _LOADED.get(ref)
    if loaded is None:
        loaded = _load(ref)
        _LOADED[ref] = _LOADED[loaded.name] = loaded
    return loaded


def forget_user_planners() -> None:
    """Load user planners afresh on next use (a notebook whose strategy file was edited);
    a run keeps the code it was checked and recorded with, so never call this during one.
    Their graphs compile again too: a planner loaded afresh is a new spec."""
    _LOADED.clear()


def find_user_planner(text: str) -> str | None:
    """The canonical name of the user planner `text` refers to, by reference or by the code
    of an installed planner; None when nothing matches."""
    if _is_code_reference(text) or any(ep.name == text for ep in _entry_points()):
        return load_planner(text).name
    for loaded in installed_planners():
        if loaded.spec is not None and loaded.spec.code == text:
            return loaded.name
    return None


def installed_planners() -> list[LoadedPlanner]:
    """Every planner installed packages register, loaded; a broken one carries its error
    instead of raising, so one broken package never hides the others."""
    out = []
    for ep in _entry_points():
        try:
            out.append(load_planner(ep.name))
        except PlannerError as exc:
            out.append(LoadedPlanner(ep.name, None, _entry_origin(ep), error=str(exc)))
    return out


def builtin_planners() -> list[LoadedPlanner]:
    """The planners shipped with cocobench-agents."""
    return [LoadedPlanner(name, spec, PlannerOrigin("built-in", _builtin_source(spec)))
            for name, spec in PLANNERS.items()]


def user_planners(names: Iterable[str]) -> list[LoadedPlanner]:
    """The planners among `names` that are not built in (each once)."""
    return [load_planner(n) for n in dict.fromkeys(names) if n not in PLANNERS]


def planners_record(names: Iterable[str]) -> dict[str, dict[str, Any]]:
    """`run.json`'s record of the user planners among `names`: code, origin and file hash,
    and what a reader of the run folder needs of the planner (whether it broadcasts, which
    prompt its calls render), so that no reader ever loads the planner's code."""
    return {p.name: {"code": p.spec.code, **p.origin.record(), "broadcast": p.spec.broadcast,
                     "prompt": p.spec.prompt_kind} for p in user_planners(names)}


def check_unchanged(names: Iterable[str], recorded: dict[str, Any]) -> None:
    """Refuse a user planner whose file (or package version) is not the one a run recorded
    (`run.json`'s `planners`)."""
    for loaded in user_planners(names):
        then = recorded.get(loaded.name)
        if not isinstance(then, dict):
            continue  # not recorded: the condition check names the difference
        now = loaded.origin
        if then.get("distribution") != now.distribution:
            raise PlannerError(f"--resume: planner {loaded.name} now comes from "
                               f"{now.distribution}, the run was recorded with "
                               f"{then.get('distribution')}; reinstall that version, or start "
                               "a new run in another --out")
        if then.get("sha256") != now.sha256 and not _recorded_before_packages(then, now):
            what = f"package {now.package}" if now.package else \
                f"file {now.file or now.source}"
            raise PlannerError(f"--resume: planner {what} changed since the run was recorded; "
                               "restore it, or start a new run in another --out")


def _recorded_before_packages(then: dict[str, Any], now: PlannerOrigin) -> bool:
    """Whether `then` is a record from before whole packages were hashed (no `package`) of
    the file that is there now."""
    return (now.package is not None and "package" not in then
            and then.get("sha256") == _file_hash(now.file))


# -- loading ---------------------------------------------------------------------------------


def _is_code_reference(ref: str) -> bool:
    return ":" in ref


def _load(ref: str) -> LoadedPlanner:
    if not _is_code_reference(ref):
        return _load_entry_point(ref)
    target, _, attribute = ref.rpartition(":")
    if not target or not attribute.isidentifier():
        raise PlannerError(f"planner {ref!r}: expected FILE.py:NAME or package.module:NAME")
    if target.endswith(".py") or "/" in target:
        module, origin = _exec_file(Path(target), attribute)
    else:
        module, origin = _import_module(target, attribute)
    canonical = f"{origin.file}:{attribute}" if origin.kind == "file" else ref
    value = _attribute(module, attribute, origin.source)
    return LoadedPlanner(canonical, _as_spec(value, canonical, attribute, origin.source), origin)


def _exec_file(path: Path, attribute: str) -> tuple[Any, PlannerOrigin]:
    """Run a planner file as a module of its own. The hash is of the bytes that ran."""
    path = path.expanduser().resolve()
    try:
        source = path.read_bytes()
    except OSError as exc:
        raise PlannerError(f"planner file {path}: {exc.strerror or exc}") from None
    name = f"_cocobench_planner_{_identifier(path.stem)}_{_sha256(str(path).encode())[:8]}"
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module  # dataclasses and type hints look their module up by name
    _importable(path.parent)
    try:
        exec(compile(source, str(path), "exec"), module.__dict__)
    except SyntaxError as exc:
        sys.modules.pop(name, None)
        raise PlannerError(f"planner file {path}, line {exc.lineno}: {exc.msg}") from None
    except Exception as exc:  # noqa: BLE001 - the user's code may raise anything on import
        sys.modules.pop(name, None)
        raise PlannerError(f"planner file {path}: importing it failed: {describe_error(exc)}"
                           ) from None
    return module, PlannerOrigin("file", f"{path}:{attribute}", str(path), _sha256(source))


def _importable(folder: Path) -> None:
    """Let a planner file import the modules beside it (`import helpers`), as `python
    FILE.py` allows: its folder goes first on `sys.path`, once. Every process that loads the
    file does this (forked and spawned workers, Ray workers), since they all load it here."""
    entry = str(folder)
    if entry not in sys.path:
        sys.path.insert(0, entry)


def _import_module(target: str, attribute: str) -> tuple[Any, PlannerOrigin]:
    try:
        module = importlib.import_module(target)
    except ModuleNotFoundError as exc:
        if exc.name and target.startswith(exc.name):
            raise PlannerError(f"planner module {target!r} not found (install its package, "
                               "or give a file: FILE.py:NAME)") from None
        raise PlannerError(f"planner module {target}: importing it failed: {describe_error(exc)}"
                           ) from None
    except Exception as exc:  # noqa: BLE001 - the user's code may raise anything on import
        raise PlannerError(f"planner module {target}: importing it failed: {describe_error(exc)}"
                           ) from None
    sha256, package = _code_hash(module)
    return module, PlannerOrigin("module", f"{target}:{attribute}",
                                 getattr(module, "__file__", None), sha256, package=package)


def _load_entry_point(name: str) -> LoadedPlanner:
    matches = [ep for ep in _entry_points() if ep.name == name]
    if not matches:
        installed = [ep.name for ep in _entry_points()]
        raise UnknownPlanner(
            f"unknown planner {name!r} (built in: {', '.join(PLANNERS)}"
            f"{'; installed: ' + ', '.join(installed) if installed else ''}; "
            "or your own: FILE.py:NAME, package.module:NAME)")
    ep = matches[0]
    origin = _entry_origin(ep)
    where = f"planner {name!r} (entry point {ep.value} of {origin.distribution})"
    if name in PLANNERS:
        raise PlannerError(f"{where}: the name is taken by a built-in planner")
    if len(matches) > 1:
        raise PlannerError(f"{where}: the name is registered by several packages")
    try:
        value = ep.load()
    except Exception as exc:  # noqa: BLE001 - a broken package may raise anything on import
        raise PlannerError(f"{where}: loading it failed: {describe_error(exc)}") from None
    module = sys.modules.get(ep.module)
    sha256, package = _code_hash(module)
    origin = dataclasses.replace(origin, file=getattr(module, "__file__", None), sha256=sha256,
                                 package=package)
    return LoadedPlanner(name, _as_spec(value, name, name, where), origin)


def _entry_points() -> list[metadata.EntryPoint]:
    return list(metadata.entry_points(group=GROUP))


def _entry_origin(ep: metadata.EntryPoint) -> PlannerOrigin:
    dist = ep.dist
    package = f"{dist.name} {dist.version}" if dist is not None else "an unknown package"
    return PlannerOrigin("entry point", ep.value, distribution=package)


def _attribute(module: Any, attribute: str, where: str) -> Any:
    try:
        return getattr(module, attribute)
    except AttributeError:
        raise PlannerError(f"planner {where}: {attribute!r} is not defined there") from None


def _as_spec(value: Any, name: str, attribute: str, where: str) -> PlannerSpec:
    """`value` as a `PlannerSpec` named `name`: a spec as it is, or a build function with
    the documented defaults."""
    if isinstance(value, PlannerSpec):
        spec = dataclasses.replace(value, name=name)
    elif callable(value) and not inspect.isclass(value):
        doc = inspect.getdoc(value) or ""
        spec = PlannerSpec(name=name, code=default_code(attribute), build=value,
                           decentralized=False, uses_models=True,
                           description=doc.splitlines()[0] if doc else "")
    else:
        raise PlannerError(f"planner {where}: {attribute} is of type {type(value).__name__}, "
                           "not a PlannerSpec or a function returning a StateGraph")
    _check_code(spec, where)
    _check_shape(spec, where)
    return spec


def default_code(name: str) -> str:
    """The condition code of a planner given as a function: `build_claim_board` →
    `claim-board`."""
    return name.removeprefix("build_").strip("_").replace("_", "-")


def _check_code(spec: PlannerSpec, where: str) -> None:
    if not CODE.fullmatch(spec.code or ""):
        raise PlannerError(f"planner {where}: condition code {spec.code!r} must be letters, "
                           "digits, '-', '_' or '.' (it names run folders and conditions)")
    taken = next((n for n, s in PLANNERS.items() if s.code == spec.code), None)
    if taken is not None:
        raise PlannerError(f"planner {where}: condition code {spec.code!r} is the built-in "
                           f"{taken}'s; choose another")


def _check_shape(spec: PlannerSpec, where: str) -> None:
    """The loop, prompt and calls a spec declares are ones the dry run knows how to count."""
    if spec.loop is not None and spec.loop not in LOOPS:
        raise PlannerError(f"planner {where}: loop {spec.loop!r} is not one of "
                           f"{', '.join(LOOPS)} (or None: not declared)")
    if spec.prompt is not None and spec.prompt not in PROMPTS:
        raise PlannerError(f"planner {where}: prompt {spec.prompt!r} is not one of "
                           f"{', '.join(PROMPTS)} (or None: from decentralized)")
    if spec.loop in (ROUND, LED_ROUND) and spec.prompt_kind != AGENT_SEAT:
        raise PlannerError(f"planner {where}: loop {spec.loop!r} asks every agent, so its "
                           f"prompt is {AGENT_SEAT!r}, not {TEAM_SEAT!r}")
    calls = spec.calls_per_seat
    if not isinstance(calls, int) or isinstance(calls, bool) or calls < 1:
        raise PlannerError(f"planner {where}: calls_per_seat {calls!r} must be a whole number "
                           "of at least 1 (the most calls one seat makes in a round)")


def _builtin_source(spec: PlannerSpec) -> str:
    return getattr(spec.build, "target", None) or f"{spec.build.__module__}:{spec.build.__name__}"


def _code_hash(module: Any) -> tuple[str | None, str | None]:
    """The hash that guards a resume of a planner defined in `module`, and the package folder
    it covers: every .py file under the folder of the top-level package `module` belongs to
    (a spec's `lazy_builder` names its graph's module by a string: the logic lives in
    modules the spec's own module never imports), else `module`'s own file."""
    name = getattr(module, "__name__", "")
    top = sys.modules.get(name.partition(".")[0])
    folders = list(getattr(top, "__path__", None) or [])
    if not folders:
        return _file_hash(getattr(module, "__file__", None)), None
    root = Path(folders[0])
    digest = hashlib.sha256()
    try:
        for path in sorted(p for p in root.rglob("*.py") if "__pycache__" not in p.parts):
            data = path.read_bytes()
            digest.update(f"{path.relative_to(root).as_posix()}\0{len(data)}\0".encode())
            digest.update(data)
    except OSError:
        return None, str(root)
    return digest.hexdigest(), str(root)


def _file_hash(file: str | None) -> str | None:
    try:
        return _sha256(Path(file).read_bytes()) if file else None
    except OSError:
        return None


def _sha256(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def _identifier(text: str) -> str:
    return re.sub(r"\W", "_", text)


def describe_error(exc: BaseException) -> str:
    """An exception in one line: its type and the first line of its message."""
    text = str(exc).strip().splitlines()
    return f"{type(exc).__name__}: {text[0]}" if text else type(exc).__name__

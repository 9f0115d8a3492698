"""A `RunRequest` from layers: given values > a YAML or TOML config file > a base request
(the recorded one, when resuming) > the defaults.

The layering is pydantic-settings' own (`settings_customise_sources`, deep-merging nested
groups); the command line puts its flags and ``COCOBENCH_RUN_*`` variables (click resolves
those two) in the top layer. Files are read here (PyYAML, tomllib) rather than by
pydantic-settings' file sources, whose errors name neither the file nor the problem. A config
file holds the request's fields, nested as in the model (`RunRequest.model_json_schema()`
describes them; ``cocobench run … --print-config`` writes one).
"""

from __future__ import annotations

import difflib
import sys
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from pydantic import ValidationError

from cocobench_agents.engine.request import RunRequest, iter_fields, leaf_paths
from cocobench_agents.setting_kinds import flag_of

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - Python 3.10
    import tomli as tomllib

CONFIG_SUFFIXES = (".yaml", ".yml", ".toml")
#: Deeper config files are refused when read: every later reader (pydantic-settings' deep
#: merge, the record) recurses per level, and a run's settings nest a few levels.
MAX_CONFIG_DEPTH = 64


class ConfigError(ValueError):
    """A request that cannot be built from its layers: one line per problem, each naming the
    file (or flag) and the key, and what was expected."""


def layered_request(given: Mapping[str, Any] | None = None, *, config_file: Path | None = None,
                    base: RunRequest | None = None) -> RunRequest:
    """The request of `given` values (nested as in `RunRequest`) over `config_file` over
    `base` over the defaults."""
    given = dict(given or {})
    _one_choice_form(given, "--conditions and --planner/--obs")
    if config_file is None and base is None:
        # One layer: nothing to merge. Validating it directly spares the command line
        # importing pydantic-settings (0.14 s of a 0.6 s mistake, measured here).
        try:
            return RunRequest.model_validate(given)
        except ValidationError as exc:
            raise ConfigError("\n".join(_error_lines(exc, given, {}, None))) from None
    file_values = read_config_file(config_file) if config_file is not None else {}
    _one_choice_form(file_values, f"{config_file}: conditions and planners/obs_modes")
    _upper_choice_decides(given, file_values)
    base_values = base.model_dump(mode="python") if base is not None else {}
    try:
        layered = _layers(given, file_values, base_values)()
    except ValidationError as exc:
        raise ConfigError("\n".join(_error_lines(exc, given, file_values, config_file))) \
            from None
    return RunRequest.model_validate(layered.model_dump(mode="python"))


#: The other form of the planner × observation choice than ``conditions``.
PER_PLANNER = ("planners", "obs_modes")


def _names(values: Mapping[str, Any], fields: tuple[str, ...]) -> bool:
    return any(values.get(name) is not None for name in fields)


def _one_choice_form(values: Mapping[str, Any], both: str) -> None:
    """Refuse a layer that names both forms of the planner × observation choice (`both` says
    where): ``conditions`` replace ``planners`` × ``obs_modes``, so one would be ignored."""
    if _names(values, ("conditions",)) and _names(values, PER_PLANNER):
        raise ConfigError(f"{both} both given: conditions replace planners × observation "
                          "modes, so one would be ignored; give one of them")


def _upper_choice_decides(*layers: dict[str, Any]) -> None:
    """The uppermost layer naming a form of the planner × observation choice decides it:
    planners (or observation modes) there replace the conditions of the layers below, the
    recorded request's too (an explicit ``conditions=None`` wins the merge)."""
    for layer in layers:
        if _names(layer, ("conditions",)):
            return
        if _names(layer, PER_PLANNER):
            layer["conditions"] = None
            return


def command_request(given: Mapping[str, Any] | None = None, *,
                    config_file: Path | None = None, resume: bool = False) -> RunRequest:
    """The request of a command: `given` values (nested as in `RunRequest`) over
    `config_file` over, with `resume`, the run recorded in the folder they name (``out``),
    over the defaults."""
    given = dict(given or {})
    file_values = read_config_file(config_file) if config_file is not None else {}
    out = given.get("out") or file_values.get("out")
    base = None
    if resume and out is not None:
        from cocobench_agents.engine.records import recorded_request
        from cocobench_agents.engine.resume import check_recorded_code

        base = recorded_request(Path(out))
        if base is not None:  # planners that are code run only when named again
            check_recorded_code(base, {**file_values, **given})
    return layered_request(given, config_file=config_file, base=base)


def _layers(*layers: dict[str, Any]) -> type[RunRequest]:
    """A settings class of the request whose sources are `layers`, the first winning (deep
    merge of nested groups: pydantic-settings'); nothing comes from the environment here,
    as the command line resolved its variables into the first layer."""
    from pydantic_settings import BaseSettings, InitSettingsSource, SettingsConfigDict

    class Layers(RunRequest, BaseSettings):
        model_config = SettingsConfigDict(frozen=True, extra="forbid",
                                          protected_namespaces=())

        @classmethod
        def settings_customise_sources(cls, settings_cls: type[BaseSettings], **_: Any
                                       ) -> tuple[InitSettingsSource, ...]:
            return tuple(InitSettingsSource(settings_cls, values) for values in layers)

    return Layers


def read_config_file(path: Path) -> dict[str, Any]:
    """The settings of a YAML or TOML config file (`ConfigError` naming the file if it is
    missing, unreadable, not YAML/TOML, or not a mapping)."""
    path = Path(path)
    if path.suffix.lower() not in CONFIG_SUFFIXES:
        raise ConfigError(f"{path}: a config file must end in .yaml, .yml or .toml")
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ConfigError(f"{path}: no such config file") from None
    except UnicodeDecodeError:
        raise ConfigError(f"{path}: not UTF-8 text") from None
    except OSError as exc:
        raise ConfigError(f"{path}: cannot read it ({exc.strerror or exc})") from None
    try:
        values = _parse(path, text)
    except ValueError as exc:  # yaml.YAMLError and tomllib.TOMLDecodeError are ValueErrors
        raise ConfigError(f"{path}: not {_format(path)}: {_one_line(exc)}") from None
    except RecursionError:  # both parsers recurse per level of nesting
        raise _too_deep(path) from None
    from benchmark_adapter.tasks.loading import depth_exceeds  # only when a file is read

    if depth_exceeds(values, MAX_CONFIG_DEPTH):
        raise _too_deep(path)
    if values is None:
        return {}  # an empty file sets nothing
    if not isinstance(values, dict):
        raise ConfigError(f"{path}: expected a mapping of settings at the top level, "
                          f"found {type(values).__name__}")
    return values


def _too_deep(path: Path) -> ConfigError:
    return ConfigError(f"{path}: nested more than {MAX_CONFIG_DEPTH} levels deep (a run's "
                       "settings nest a few levels)")


def _parse(path: Path, text: str) -> Any:
    if path.suffix.lower() == ".toml":
        return tomllib.loads(text)
    import yaml

    try:
        return yaml.safe_load(text)
    except yaml.YAMLError as exc:
        raise ValueError(str(exc)) from None


def _error_lines(exc: ValidationError, given: Mapping[str, Any],
                 file_values: Mapping[str, Any], config_file: Path | None) -> list[str]:
    """Each error as ``WHERE: what was expected``, WHERE naming the layer that set it: the
    option (and its setting), the file and its key, or the setting."""
    lines: list[str] = []
    for error in exc.errors(include_url=False):
        loc = _setting_loc(tuple(str(part) for part in error["loc"]))
        key = ".".join(loc)
        message = error["msg"].removeprefix("Value error, ")
        if error["type"] == "extra_forbidden":
            message = "not a setting of a run" + _suggestion(loc)
        elif error["type"] == "missing" and loc == ("out",):
            message = "the run folder is required (--out, or out in a config file)"
        flag = _flag(loc)
        if _has(given, loc) and flag:
            lines.append(f"{flag} ({key}): {message}")
        elif config_file is not None and _has(file_values, loc):
            lines.append(f"{config_file}: {key}: {message}")
        else:
            lines.append(f"{key}: {message}")
    return list(dict.fromkeys(lines))


def _setting_loc(loc: tuple[str, ...]) -> tuple[str, ...]:
    """`loc` without what pydantic adds below a setting (the member of a union it tried,
    ``temperature.float``), so that each setting's problem is one line."""
    known = {path[:n] for path, _ in iter_fields() for n in range(1, len(path) + 1)}
    for end in range(len(loc), 0, -1):
        if loc[:end] in known:
            return loc[:end] if loc[:end] in dict(iter_fields()) else loc
    return loc


def _flag(loc: tuple[str, ...]) -> str | None:
    """The option that sets the setting at `loc` (None for a group or a list item)."""
    fields = dict(iter_fields())
    return flag_of(fields[loc]) if loc in fields else None


def _suggestion(loc: tuple[str, ...]) -> str:
    """`; did you mean …?` for a misspelt key (leaf names and group names)."""
    names = [*leaf_paths(), *RunRequest.model_fields]
    close = difflib.get_close_matches(loc[-1], names, n=1)
    if not close:
        return ""
    path = leaf_paths().get(close[0], (close[0],))
    return f"; did you mean {'.'.join(path)}?"


def _has(values: Mapping[str, Any], loc: tuple[str, ...]) -> bool:
    node: Any = values
    for part in loc:
        if isinstance(node, Mapping) and part in node:
            node = node[part]
        elif isinstance(node, list) and part.isdigit() and int(part) < len(node):
            node = node[int(part)]
        else:
            return False
    return True


def _format(path: Path) -> str:
    return "TOML" if path.suffix.lower() == ".toml" else "YAML"


def _one_line(exc: BaseException) -> str:
    return " ".join(str(exc).split())


def request_as_config(request: RunRequest) -> dict[str, Any]:
    """The request as a config file holds it: JSON types, every field but the form of the
    planner × observation choice the request does not use (`conditions`, or `planners` with
    `obs_modes`), so that the file says which one runs."""
    config = request.model_dump(mode="json")
    unused = ("planners", "obs_modes") if request.conditions else ("conditions",)
    for name in unused:
        del config[name]
    return config

"""Prompt suites: versioned sets of text templates, plus named ablation variants.

A suite is a folder of `.txt` templates with `{named}` fields and a `suite.json`, shipped with
the package or anywhere on disk. A suite spec names a shipped suite or a folder and,
optionally, variants joined with `+`: `cocobench-v1+no-hint+no-history`, `./my-suite+no-hint`.
A loaded suite has a content hash: equal hashes mean equal prompts.
"""

from __future__ import annotations

import functools
import hashlib
import json
from collections.abc import Mapping
from dataclasses import dataclass, field
from importlib import resources
from importlib.resources.abc import Traversable
from pathlib import Path
from typing import Any

from cocobench_agents.prompts.fields import (
    OWN_TEMPLATE_NAME,
    TEMPLATE_FIELDS,
    field_problem,
    own_template_fields,
)

DEFAULT_SUITE = "cocobench-v1"
SUITE_FILE = "suite.json"

# Each variant switches one prompt section off (an ablation of what the planner is told).
VARIANTS = {
    "no-progress": "drop the live GOAL PROGRESS block",
    "no-hint": "drop the coordination hint (RESOURCE / RELAY CONSTRAINT)",
    "no-history": "drop the recent-actions history",
}

# suite.json keys; the windows are read by the renderers.
SETTINGS = {"name": str, "version": str, "description": str,
            "history_window": int, "message_window": int}


class PromptSuiteError(ValueError):
    """An unknown suite or variant, or a suite folder that is missing or malformed."""


@dataclass(frozen=True)
class PromptSuite:
    """Loaded templates of one suite and the variants applied to it."""

    name: str
    version: str
    templates: dict[str, str]
    variants: frozenset[str] = frozenset()
    settings: dict[str, Any] = field(default_factory=dict)
    path: str | None = None  # the folder's absolute path; None for a shipped suite
    digests: dict[str, str] = field(default_factory=dict)  # file name → sha256
    # The planners' own templates it holds (`PlannerSpec.templates`): each the suite folder's
    # `NAME.txt` when it has one, else the planner's default text.
    own: frozenset[str] = frozenset()

    @property
    def spec(self) -> str:
        """The spec string that reloads exactly this suite (recorded in run metadata)."""
        return "+".join([self.path or self.name, *sorted(self.variants)])

    @property
    def label(self) -> str:
        """A short name for the suite as an arm of a run (`cocobench-v1+no-hint`, a folder's
        name with its variants): the same wherever the run is resumed from."""
        return "+".join([self.name, *sorted(self.variants)])

    @property
    def content_hash(self) -> str:
        """sha256 of everything that decides the prompts: the files and the variants (not the
        suite's name or location, so an unedited copy hashes as its original)."""
        canonical = json.dumps({"files": self.digests, "variants": sorted(self.variants)},
                               sort_keys=True)
        return hashlib.sha256(canonical.encode()).hexdigest()

    def render(self, key: str, **fields: object) -> str:
        """One template with its fields filled."""
        return self.templates[key].format(**fields)

    def setting(self, key: str, default: int) -> int:
        """A numeric setting from suite.json (history window, etc.)."""
        return int(self.settings.get(key, default))

    def record(self) -> dict[str, Any]:
        """What run.json keeps of the suite: enough to reload it and to tell an edit."""
        out: dict[str, Any] = {"spec": self.spec, "version": self.version,
                               "content_hash": self.content_hash,
                               "files": {n: d[:16] for n, d in sorted(self.digests.items())}}
        if self.path:
            out["path"] = self.path
        return out


def available_suites() -> list[str]:
    """Names of the prompt suites shipped with the package."""
    root = _shipped_root()
    return sorted(p.name for p in root.iterdir() if p.is_dir() and (p / SUITE_FILE).is_file())


def load_prompt_suite(spec: str = DEFAULT_SUITE,
                      templates: Mapping[str, str] | None = None) -> PromptSuite:
    """Load `NAME|PATH[+variant…]`: a shipped suite by name, else a suite folder, with the
    planners' own `templates` (name → default text; `PlannerSpec.templates`): a suite
    folder's `NAME.txt` replaces a default, and the content hash covers them.

    Any problem (unknown name or variant, missing folder, file or template, malformed
    suite.json, unknown `{field}`) raises `PromptSuiteError` naming the file and the field.
    """
    own = dict(templates or {})
    _check_own(own)
    base, path, variants = _located(spec)
    contents = _read_shipped(base) if path is None else _read_folder(Path(path), path, own)
    meta, found, digests = contents
    found, digests = dict(found), dict(digests)
    for name, default in own.items():
        if name not in found:  # not replaced by the folder's file: the planner's default
            found[name] = default
            digests[f"{name}.txt"] = hashlib.sha256(default.encode("utf-8")).hexdigest()
    return PromptSuite(name=Path(path).name if path else base,
                       version=str(meta.get("version", "")), templates=found,
                       variants=frozenset(variants), settings=dict(meta), path=path,
                       digests=digests, own=frozenset(own))


def suite_spec(spec: str) -> str:
    """The canonical spec of `spec` (`PromptSuite.spec`: a folder's absolute path, variants
    sorted) without reading its files, whose templates depend on the run's planners."""
    base, path, variants = _located(spec)
    return "+".join([path or base, *sorted(variants)])


def suite_label(spec: str) -> str:
    """`PromptSuite.label` of `spec` (its arm's name) without reading its files."""
    base, path, variants = _located(spec)
    return "+".join([Path(path).name if path else base, *sorted(variants)])


def _located(spec: str) -> tuple[str, str | None, list[str]]:
    """The base of `spec`, its folder's absolute path (None: a shipped suite) and its
    variants, which must be known."""
    base, variants = _split_spec(spec)
    unknown = [v for v in variants if v not in VARIANTS]
    if unknown:
        raise PromptSuiteError(f"unknown prompt variant {unknown[0]!r} in {spec!r} "
                               f"(available: {', '.join(VARIANTS)})")
    if base in available_suites():
        return base, None, variants
    return base, str(_suite_folder(base)), variants


def merged_templates(planners: Mapping[str, Mapping[str, str]]) -> dict[str, str]:
    """The own templates of several planners (planner name → its templates) as one suite
    holds them; two planners giving one template name different texts are refused."""
    merged: dict[str, str] = {}
    owner: dict[str, str] = {}
    for planner, templates in planners.items():
        for name, text in templates.items():
            if name in merged and merged[name] != text:
                raise PromptSuiteError(
                    f"planners {owner[name]} and {planner} both declare the template "
                    f"{name!r}, with different texts; rename one of them")
            merged[name], owner[name] = text, owner.get(name, planner)
    return merged


def _check_own(templates: Mapping[str, Any]) -> None:
    """Refuse a planner's own template that no suite folder could hold or override."""
    for name, text in templates.items():
        where = f"planner template {name!r}"
        if not isinstance(name, str) or not OWN_TEMPLATE_NAME.fullmatch(name):
            raise PromptSuiteError(f"{where}: a template's name is lower-case letters, "
                                   f"digits and _, starting with a letter (its file NAME.txt)")
        if name in TEMPLATE_FIELDS or name == SUITE_FILE.removesuffix(".json"):
            raise PromptSuiteError(f"{where}: the name of a suite template; choose another")
        if not isinstance(text, str):
            raise PromptSuiteError(f"{where}: its default must be a string, not "
                                   f"{type(text).__name__}")
        try:
            fields = own_template_fields(text)
        except ValueError as exc:  # a malformed default: no field list to check against
            problem = f"{exc} (write {{{{ or }}}} for a literal brace)"
        else:
            odd = sorted(f for f in fields if not f.isidentifier())
            problem = (f"field {{{odd[0]}}}: a field is a name (letters, digits, _)" if odd
                       else field_problem(name, text, fields))
        if problem:
            raise PromptSuiteError(f"{where}: {problem}")


def shipped_suite_files(name: str) -> dict[str, bytes]:
    """The files of a shipped suite (suite.json and the templates), by file name."""
    if name not in available_suites():
        raise PromptSuiteError(f"unknown prompt suite {name!r} (shipped: "
                               f"{', '.join(available_suites())})")
    folder = _shipped_root() / name
    return {p.name: p.read_bytes() for p in folder.iterdir() if _is_suite_file(p.name)}


def check_unchanged(suite: PromptSuite, recorded: Mapping[str, Any]) -> None:
    """Refuse a suite that is not the one a run recorded (`run.json`'s `prompt_suite`)."""
    if not isinstance(recorded, Mapping):  # run folders of older versions kept only a name
        return
    spec = recorded.get("spec")
    if spec is not None and spec != suite.spec:
        raise PromptSuiteError(f"--resume: prompt suite {suite.spec!r} differs from the "
                               f"recorded run's {spec!r}; run with the recorded one")
    recorded_hash = recorded.get("content_hash")
    if recorded_hash is None or recorded_hash == suite.content_hash:
        return
    raise PromptSuiteError(
        f"--resume: prompt suite {suite.spec} changed since the run was recorded "
        f"({_changes(recorded.get('files') or {}, suite)}); restore it, or start a new run "
        f"in another --out")


def _changes(recorded_files: Mapping[str, str], suite: PromptSuite) -> str:
    # Every loadable suite has the same file names, so only contents can differ.
    changed = sorted(n for n, d in suite.digests.items() if recorded_files.get(n) != d[:16])
    return f"changed: {', '.join(changed)}" if recorded_files else "its content hash differs"


# -- locating and reading ------------------------------------------------------------------


def _shipped_root() -> Traversable:
    return resources.files(__package__) / "templates"


def _split_spec(spec: str) -> tuple[str, list[str]]:
    """Base and variants; the longest `+`-joined prefix naming a suite or a folder is the
    base, so a folder whose name holds `+` still works."""
    parts = spec.split("+")
    for cut in range(len(parts), 0, -1):
        base = "+".join(parts[:cut])
        if base in available_suites() or (base and Path(base).expanduser().is_dir()):
            return base, parts[cut:]
    return parts[0], parts[1:]


def _suite_folder(base: str) -> Path:
    folder = Path(base).expanduser()
    if folder.is_dir():
        return folder.resolve()
    if Path(base).name == base:  # a bare name: a misspelt shipped suite
        raise PromptSuiteError(f"unknown prompt suite {base!r} (shipped: "
                               f"{', '.join(available_suites())}; or a suite folder's path)")
    raise PromptSuiteError(f"prompt suite folder {base}: no such folder")


@functools.cache
def _read_shipped(name: str) -> tuple[dict[str, Any], dict[str, str], dict[str, str]]:
    """A shipped suite, read once per process (every episode loads its suite)."""
    folder = _shipped_root() / name
    return _read_folder(folder, str(folder))


def _read_folder(folder: Traversable, shown: str, own: Mapping[str, str] | None = None
                 ) -> tuple[dict[str, Any], dict[str, str], dict[str, str]]:
    """suite.json, the templates (the suite's, and files of the planners' `own` ones) and
    every file's sha256, checked; `shown` names the folder in errors."""
    files = {p.name: p for p in folder.iterdir() if p.is_file() and _is_suite_file(p.name)}
    if SUITE_FILE not in files:
        raise PromptSuiteError(f"{shown}/{SUITE_FILE}: missing (a prompt suite folder holds "
                               f"{SUITE_FILE} and its templates; start from `cocobench prompts "
                               f"export {DEFAULT_SUITE} DIR`)")
    try:
        raw = {name: path.read_bytes() for name, path in files.items()}
    except OSError as exc:
        raise PromptSuiteError(f"{shown}: cannot read {exc.filename}: {exc.strerror}") from None
    meta = _settings(raw[SUITE_FILE], f"{shown}/{SUITE_FILE}")
    templates = _templates(raw, shown, own or {})
    digests = {name: hashlib.sha256(data).hexdigest() for name, data in raw.items()}
    return meta, templates, digests


def _is_suite_file(name: str) -> bool:
    return name == SUITE_FILE or name.endswith(".txt")


def _settings(data: bytes, shown: str) -> dict[str, Any]:
    try:
        meta = json.loads(data.decode("utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise PromptSuiteError(f"{shown}: not valid JSON ({exc})") from None
    if not isinstance(meta, dict):
        raise PromptSuiteError(f"{shown}: must be a JSON object")
    for key, value in meta.items():
        kind = SETTINGS.get(key)
        if kind is None:
            raise PromptSuiteError(f"{shown}: unknown key {key!r} (known: "
                                   f"{', '.join(SETTINGS)})")
        if kind is int and (type(value) is not int or value < 1):
            raise PromptSuiteError(f"{shown}: {key} must be a positive integer, not {value!r}")
        if kind is str and not isinstance(value, str):
            raise PromptSuiteError(f"{shown}: {key} must be a string, not {value!r}")
    return meta


def _templates(raw: Mapping[str, bytes], shown: str, own: Mapping[str, str]
               ) -> dict[str, str]:
    names = {name.removesuffix(".txt") for name in raw if name != SUITE_FILE}
    extra = sorted(names - TEMPLATE_FIELDS.keys() - own.keys())
    if extra:
        planners = (f"; the planners' own: {', '.join(sorted(own))}" if own else
                    "; a planner's own template is read only with that planner")
        raise PromptSuiteError(f"{shown}/{extra[0]}.txt: not a template of a prompt suite "
                               f"(templates: {', '.join(TEMPLATE_FIELDS)}{planners})")
    for key in TEMPLATE_FIELDS:
        if key not in names:
            raise PromptSuiteError(f"{shown}/{key}.txt: template missing")
    allowed = {**TEMPLATE_FIELDS, **{name: own_template_fields(default)
                                      for name, default in own.items() if name in names}}
    templates = {}
    for key, fields in allowed.items():
        try:
            text = raw[f"{key}.txt"].decode("utf-8")
        except UnicodeDecodeError as exc:
            raise PromptSuiteError(f"{shown}/{key}.txt: not UTF-8 text ({exc})") from None
        problem = field_problem(key, text, fields)
        if problem:
            raise PromptSuiteError(f"{shown}/{key}.txt: {problem}")
        templates[key] = text
    return templates

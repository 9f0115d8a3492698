"""Goal predicates, the goal text and the live progress block (reference §6.1, §7.1).

Predicates are evaluated against agent 0's object metadata; `sliced_by` also needs the
recorded steps (who sliced what). Each check keeps the reference's form — the predicate as
the config states it, the resolved `objectId`, `passed`, and the reference's `detail`
wording — so tooling that reads the reference's `trajectory.json` reads ours.
"""

from __future__ import annotations

import copy
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from benchmark_adapter.tasks.config import GoalPredicate, TaskConfig

Objects = Mapping[str, Mapping[str, Any]]  # objectId → metadata record
Steps = Sequence[Mapping[str, Any]]  # recorded skill_result dicts


@dataclass(frozen=True)
class Check:
    """One predicate's verdict."""

    predicate: dict[str, Any]  # the goal predicate as the config states it
    objectId: str
    passed: bool
    detail: str

    def to_dict(self) -> dict[str, Any]:
        return {
            "predicate": self.predicate,
            "objectId": self.objectId,
            "passed": self.passed,
            "detail": self.detail,
        }


def _on(objs: Objects, g: Args, steps: Steps) -> tuple[bool, str]:
    parents = objs[g.obj].get("parentReceptacles") or []
    return g.receptacle in parents, f"parentReceptacles={parents} expected={g.receptacle}"


def _on_sliced_piece(objs: Objects, g: Args, steps: Steps) -> tuple[bool, str]:
    prefix = g.source + "|"
    pieces = [o for oid, o in objs.items()
              if oid.startswith(prefix) and (o.get("objectType") or "").endswith("Sliced")]
    on = [o for o in pieces if g.receptacle in (o.get("parentReceptacles") or [])]
    return bool(on), f"sliced_pieces={len(pieces)} on_{g.receptacle}={len(on)}"


def _flag(key: str, want: Callable[[Any, Args], bool]) -> Callable:
    def check(objs: Objects, g: Args, steps: Steps) -> tuple[bool, str]:
        value = objs[g.obj].get(key)
        return bool(want(value, g)), f"{key}={value}"

    return check


def _sliced_by(objs: Objects, g: Args, steps: Steps) -> tuple[bool, str]:
    sliced = bool(objs[g.obj].get("isSliced"))
    by_agent = any(
        s.get("skill") == "Slice"
        and s.get("success")
        and s.get("agent") == g.agent
        and (s.get("args") or {}).get("objectId") == g.obj
        for s in steps
    )
    return sliced and by_agent, f"isSliced={sliced} required_agent={g.agent} matched={by_agent}"


def _filled_check(objs: Objects, g: Args, steps: Steps) -> tuple[bool, str]:
    filled, liquid = objs[g.obj].get("isFilledWithLiquid"), objs[g.obj].get("fillLiquid")
    # As the reference: an unrecorded liquid satisfies any requested one.
    ok = bool(filled) and (not g.liquid or liquid in (g.liquid, None, ""))
    return ok, f"isFilledWithLiquid={filled} fillLiquid={liquid}"


@dataclass(frozen=True)
class Args:
    """A predicate's arguments, aliases resolved to object ids."""

    obj: str = ""
    receptacle: str = ""
    source: str = ""
    agent: str = ""
    value: Any = None
    liquid: str = ""

    @classmethod
    def of(cls, goal: GoalPredicate, config: TaskConfig) -> Args:
        def rid(key: str) -> str:
            v = goal.arg(key)
            return config.resolve(v) if isinstance(v, str) else ""

        return cls(
            obj=rid("object"),
            receptacle=rid("receptacle"),
            source=rid("source"),
            agent=goal.arg("agent") or "",
            value=goal.arg("value"),
            liquid=goal.arg("liquid") or "",
        )


CHECKS: dict[str, Callable[[Objects, Args, Steps], tuple[bool, str]]] = {
    "on": _on,
    "on_sliced_piece": _on_sliced_piece,
    "closed": _flag("isOpen", lambda v, g: not v),
    "open": _flag("isOpen", lambda v, g: bool(v)),
    "toggled": _flag("isToggled", lambda v, g: bool(v) == bool(g.value)),
    "sliced": _flag("isSliced", lambda v, g: bool(v)),
    "sliced_by": _sliced_by,
    "clean": _flag("isDirty", lambda v, g: v is False),
    "filled": _filled_check,
    "empty": _flag("isFilledWithLiquid", lambda v, g: not v),
    "cooked": _flag("isCooked", lambda v, g: bool(v)),
}


class GoalSet:
    """A config's goal predicates with their arguments resolved once (an episode evaluates
    them after every step)."""

    def __init__(self, config: TaskConfig) -> None:
        self.config = config
        self.goals = [(g, Args.of(g, config)) for g in config.goal_predicates]
        # Each check records its predicate as stated: dumped once, copied per evaluation.
        self._stated = [g.model_dump(mode="json", exclude_unset=True)
                        for g in config.goal_predicates]
        self._flat = [_flat(stated) for stated in self._stated]

    def evaluate(self, objects: Sequence[Mapping[str, Any]], steps: Steps) -> dict[str, Any]:
        """`{success, checks}` for every goal predicate; a missing object fails its check."""
        by_id = {o["objectId"]: o for o in objects}
        checks = [_check(goal, args, by_id, steps, dict(stated) if flat else copy.deepcopy(stated))
                  for (goal, args), stated, flat in zip(self.goals, self._stated, self._flat)]
        return {"success": all(c.passed for c in checks),
                "checks": [c.to_dict() for c in checks]}

    def phrases(self, alias_of: Mapping[str, str]) -> list[str]:
        """One phrase per predicate, naming objects by their current menu alias."""
        def name(object_id: str) -> str:
            alias = alias_of.get(object_id) or object_id.split("|")[0]
            return alias.replace("_", " ")

        out = []
        for goal, args in self.goals:
            phrase = PHRASES.get(goal.predicate)
            out.append(phrase(name, args) if phrase else f"{goal.predicate} {args.obj}")
        return out


def evaluate(
    config: TaskConfig, objects: Sequence[Mapping[str, Any]], steps: Steps
) -> dict[str, Any]:
    """`{success, checks}` for every goal predicate; a missing object fails its check."""
    return GoalSet(config).evaluate(objects, steps)


def _flat(stated: dict[str, Any]) -> bool:
    """Whether a dumped predicate holds only scalars: a shallow copy of it then shares
    nothing with it (else each evaluation deep-copies it)."""
    return all(v is None or isinstance(v, (str, int, float)) for v in stated.values())


def _check(goal: GoalPredicate, args: Args, by_id: Objects, steps: Steps,
           stated: dict[str, Any]) -> Check:
    fn = CHECKS.get(goal.predicate)
    if goal.predicate == "on_sliced_piece":  # counts the pieces: the source may be gone
        return Check(stated, args.source, *fn(by_id, args, steps))
    # The reference's order: a missing object first, then an unknown predicate.
    if args.obj not in by_id:
        return Check(stated, args.obj, False, f"object not found: {args.obj}")
    if fn is None:
        return Check(stated, args.obj, False, f"unsupported predicate: {goal.predicate}")
    return Check(stated, args.obj, *fn(by_id, args, steps))


# -- natural language --------------------------------------------------------------------

PHRASES: dict[str, Callable[[Callable[[str], str], Args], str]] = {
    "on": lambda n, g: f"Put the {n(g.obj)} in the {n(g.receptacle)}",
    "toggled": lambda n, g: f"{'Turn on' if g.value else 'Turn off'} the {n(g.obj)}",
    "closed": lambda n, g: f"Close the {n(g.obj)}",
    "open": lambda n, g: f"Open the {n(g.obj)}",
    "sliced_by": lambda n, g: f"{g.agent} must slice the {n(g.obj)}",
    "sliced": lambda n, g: f"Slice the {n(g.obj)}",
    "on_sliced_piece": lambda n, g: f"Place a slice of {n(g.source)} on the {n(g.receptacle)}",
    "filled": lambda n, g: f"Fill the {n(g.obj)} with {g.liquid or 'liquid'}",
    "empty": lambda n, g: f"Empty the {n(g.obj)}",
    "clean": lambda n, g: f"Clean the {n(g.obj)}",
    "cooked": lambda n, g: f"Cook the {n(g.obj)}",
}


def goal_title(config: TaskConfig) -> str:
    """task_name with `_` → space, capitalised as Python's `str.capitalize` does."""
    return config.task_name.replace("_", " ").capitalize()


def goal_phrases(config: TaskConfig, alias_of: Mapping[str, str],
                 goal_set: GoalSet | None = None) -> list[str]:
    """One phrase per predicate, naming objects by their current menu alias."""
    return (goal_set or GoalSet(config)).phrases(alias_of)


def goal_text(config: TaskConfig, alias_of: Mapping[str, str],
              goal_set: GoalSet | None = None) -> str:
    """`{Title}:` then the numbered predicate phrases."""
    phrases = goal_phrases(config, alias_of, goal_set)
    lines = [f"  {i}. {p}" for i, p in enumerate(phrases, 1)]
    return "\n".join([f"{goal_title(config)}:", *lines])


def progress_text(config: TaskConfig, alias_of: Mapping[str, str], evaluation: Mapping[str, Any],
                  goal_set: GoalSet | None = None) -> str:
    """The live progress block: `[✓]`/`[✗]` per predicate, then `k/n objectives complete.`"""
    checks = evaluation["checks"]
    if not checks:
        return "  (no goal predicates)"
    phrases = goal_phrases(config, alias_of, goal_set)
    lines = [f"  [{'✓' if c['passed'] else '✗'}] {p}" for c, p in zip(checks, phrases)]
    done = sum(1 for c in checks if c["passed"])
    return "\n".join([*lines, f"  {done}/{len(checks)} objectives complete."])

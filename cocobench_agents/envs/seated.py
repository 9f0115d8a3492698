"""`SeatedEpisode`: one benchmark episode stepped by its seats' actions instead of a graph's
model calls.

It drives the real `Episode` through the harness's `EpisodeTools`, turns each action into a
decision record with the planners' own `reply_decision` (the action as the reply text a
scripted model would send), and lands decisions with the planners' own landing rules
(`graphs.centralized.land_decision`, `graphs.nodes.land_decisions`, the leader's
`record_directives`), then scores the trajectory as `run_episode` does. So an episode played
here scores exactly as the same replies do under `cocobench run --model scripted:FILE`.
Seats without a learner are played by model clients through the planners' own `decide` /
`ask_leader`. No Gymnasium or PettingZoo here: `parallel.py` and `seat_env.py` wrap it.
"""

from __future__ import annotations

import asyncio
import dataclasses
import weakref
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from pydantic import ValidationError

from benchmark_adapter.episode import Episode
from benchmark_adapter.metrics import EpisodeResult
from cocobench_agents.conditions import condition_name
from cocobench_agents.envs.oracle_partner import OracleClient, OraclePlan
from cocobench_agents.episode_runner import (
    DEFAULT_MODEL_KEY,
    ClientFactory,
    EpisodeSpec,
    run_retry_policy,
)
from cocobench_agents.graphs import (
    ORACLE,
    PlannerContext,
    centralized,
    decentralized,
    planner_spec,
)
from cocobench_agents.graphs.centralized import build_centralized, land_decision
from cocobench_agents.graphs.decentralized import board, build_decentralized
from cocobench_agents.graphs.decision import decide, no_actions_decision, reply_decision
from cocobench_agents.graphs.leader_worker import (
    ask_leader,
    build_leader_worker,
    record_directives,
    team_lines,
)
from cocobench_agents.graphs.nodes import land_decisions
from cocobench_agents.graphs.registry import (
    AGENT_SEAT,
    LEADER_SEAT,
    LED_ROUND,
    STEP,
    TEAM_SEAT,
    PlannerSpec,
    Seat,
)
from cocobench_agents.graphs.state import TEAM, team_history
from cocobench_agents.models import ModelPool
from cocobench_agents.models.protocol import MenuOption, ModelReply
from cocobench_agents.models.settings import ModelSettings
from cocobench_agents.prompts import load_prompt_suite
from cocobench_agents.tools import EpisodeTools

#: The action that chooses no menu entry: ``ACTION: DONE`` (also what a waiting seat sends).
#: Menu ids start at 0, so DONE is -1.
DONE = -1
#: The graphs whose rules `SeatedEpisode` applies: a planner built by one of them is stepped.
STEPPED_GRAPHS = frozenset(f"{build.__module__}:{build.__name__}" for build in (
    build_centralized, build_decentralized, build_leader_worker))
LEAD, WORK = "lead", "work"  # the two phases of a leader–worker round
#: What an action off the menu does: be scored as an invalid id (the default: every element
#: of an action space is then a valid action, as RL libraries' exploration and Gymnasium's and
#: PettingZoo's checkers assume), or raise.
OFF_MENU = ("score", "error")


class EnvError(ValueError):
    """A call the environment cannot take: a bad action, a message where none is sent,
    stepping a finished episode, an unknown condition, seat or reward name."""


class EnvWarning(UserWarning):
    """Input the environment does not read but, to pass the ecosystem's checkers, does not
    refuse: an unknown `reset` option."""


@dataclass(frozen=True)
class SeatAction:
    """One seat's move: a menu id (or `DONE`) and, where the seat broadcasts, a message.
    The leader's move is its message: its instruction lines (``agent_0: …``)."""

    action: int = DONE
    message: str = ""

    def reply_text(self) -> str:
        """The reply a scripted model would send for this move."""
        choice = "DONE" if self.action == DONE else str(self.action)
        text = f"ACTION: {choice}"
        return f"{text}\nMSG: {self.message}" if self.message else text


@dataclass
class SeatView:
    """What one seat knows at the current decision."""

    seat: str
    acting: bool  # whether this phase reads the seat's action
    prompt: str  # the harness's prompt text ("" when text is off or the seat waits)
    menu: Sequence[MenuOption]  # the seat's menu (empty for the leader and waiting seats)
    menu_lines: list[str] = field(default_factory=list)
    sends_message: bool = False  # whether a message is read from it now


def check_stepped(planner: PlannerSpec) -> None:
    """Raise `EnvError` unless `planner` is built by a graph whose rules the environment
    applies (C0's, D0/D1's, leader–worker's)."""
    target = getattr(planner.build, "target", "").partition("(")[0]
    if target not in STEPPED_GRAPHS or planner.calls_per_seat != 1:
        raise EnvError(f"the environment steps the planners of the built-in C0, D0/D1 and "
                       f"leader-worker graphs (whose rules it applies), not {planner.name!r} "
                       f"({planner.code})")


def check_off_menu(off_menu: str) -> None:
    """Raise `EnvError` unless `off_menu` is one of `OFF_MENU`."""
    if off_menu not in OFF_MENU:
        raise EnvError(f"off_menu must be {' or '.join(map(repr, OFF_MENU))}, not "
                       f"{off_menu!r}")


def _client_key(seat: str) -> str:
    """The `PlannerContext.clients` key of a seat: "*" for the team's planner and the leader."""
    return DEFAULT_MODEL_KEY if seat in (TEAM_SEAT, LEADER_SEAT) else seat


def _client_agent(seat: str) -> str | None:
    return None if seat in (TEAM_SEAT, LEADER_SEAT) else seat


def with_partner_models(spec: EpisodeSpec, partners: Mapping[str, str]) -> EpisodeSpec:
    """`spec` naming the partners' models beside the learners' (`spec`'s own), as
    ``--model`` with ``--agent-model`` would, so that the result line says who played each
    seat."""
    if not partners:
        return spec
    learner = spec.model_for(None)
    models = {DEFAULT_MODEL_KEY: partners.get(TEAM_SEAT) or partners.get(LEADER_SEAT)
              or learner}
    if LEADER_SEAT in partners or set(partners) & set(spec.config.agent_ids):
        models.update({a: partners.get(a, learner) for a in spec.config.agent_ids})
    return dataclasses.replace(spec, models=models)


def partner_settings(given: ModelSettings | Mapping[str, Any] | None) -> ModelSettings:
    """How the partners' models are called: `given` (settings, or a mapping of their
    fields), else what the ``COCOBENCH_RUN_*`` variables say, as for `cocobench run`."""
    try:
        if given is None:
            return ModelSettings.from_run_variables()
        return given if isinstance(given, ModelSettings) else ModelSettings.model_validate(
            dict(given))
    except ValidationError as exc:
        raise EnvError("; ".join(f"model_settings.{'.'.join(map(str, e['loc']))}: {e['msg']}"
                                 for e in exc.errors())) from None
    except ValueError as exc:
        raise EnvError(str(exc)) from None


def seat_name(seat: Seat) -> str:
    """A seat's name as an environment agent: the robot's id, else its role."""
    return seat.agent if seat.role == AGENT_SEAT else seat.role


class SeatedEpisode:
    """One episode of `spec` (a built-in C0/D0/D1/leader-worker planner) whose seats act
    through `step`. `partners` maps seat names to the model specs that play those seats (any
    the harness runs: ``greedy``, ``random``, ``scripted:FILE``, ``replay:RUN``, a LiteLLM
    model; or ``oracle``: the reference plan, `oracle_partner.py`), their clients made by
    `pool` afresh for each episode (default: a pool with the ``COCOBENCH_RUN_*`` variables'
    settings, `partner_settings`); `text=False` skips
    rendering prompts (observations then carry no prompt text, and the trajectory's decisions
    name the empty prompt). An action off the seat's menu is scored as a model's reply naming
    an id not on its menu is (an ``invalid_action_id`` decision), and a message where none is
    read now is not read; with ``off_menu="error"`` either is an `EnvError`.
    Partners' model calls run on `loop` when given (its owner closes it: the parallel
    environment shares one among its episodes), else on a loop the episode makes and
    `close` closes."""

    def __init__(self, spec: EpisodeSpec, *, partners: Mapping[str, str] | None = None,
                 pool: ClientFactory | None = None, text: bool = True,
                 off_menu: str = "score", loop: asyncio.AbstractEventLoop | None = None
                 ) -> None:
        check_off_menu(off_menu)
        self.off_menu = off_menu
        self.text = text
        self.planner = planner_spec(spec.planner)
        check_stepped(self.planner)
        self.loop = self.planner.loop_kind
        self.broadcast = self.planner.broadcast
        self.policy = centralized.POLICY if self.loop == STEP else decentralized.POLICY
        self.seats = [seat_name(s) for s in self.planner.seats(spec.config.agent_ids)]
        self.partners = dict(partners or {})
        unknown = sorted(set(self.partners) - set(self.seats))
        if unknown:
            raise EnvError(f"no seat {unknown[0]!r} in {spec.planner}: seats are "
                           f"{', '.join(self.seats)}")
        self.learners = [s for s in self.seats if s not in self.partners]
        self.pool = pool if pool is not None else ModelPool(partner_settings(None))
        self.model = spec.model_for(None)  # the name the learners' decisions record
        self.spec = with_partner_models(spec, self.partners)
        self.condition = condition_name(self.planner.code, spec.obs_mode)
        self._suite = load_prompt_suite(spec.prompt_suite)
        self._episode = Episode(spec.config, spec.controller())
        self._loop = loop
        self._owns_loop = loop is None  # then made on the first partner call
        self.reset()

    # -- lifecycle ---------------------------------------------------------------------

    def reset(self) -> None:
        """Start the episode over: the scene reloaded, nothing recorded."""
        self.tools = EpisodeTools(self._episode, self._suite, obs_mode=self.spec.obs_mode,
                                  stable_ids=self.spec.stable_ids)
        self.pool.release(self.spec.episode)  # fresh clients: they keep state per episode
        plan = OraclePlan(self._episode) if ORACLE in self.partners.values() else None
        clients = {_client_key(s): OracleClient(plan) if model == ORACLE
                   else self.pool.client(model, episode=self.spec.episode,
                                         agent=_client_agent(s))
                   for s, model in self.partners.items()}
        self.ctx = PlannerContext(tools=self.tools, clients=clients, budget=self.spec.budget,
                                  sample_index=self.spec.sample_index,
                                  retry_policy=(self.planner.retry_policy
                                                or run_retry_policy(self.pool)))
        self.state: dict[str, Any] = {"agents": self.spec.config.agent_ids, "round_index": 1,
                                      "history": {}, "messages": [], "directives": {},
                                      "terminal_reason": None}
        self.phase = LEAD if self.loop == LED_ROUND else WORK
        self.result: EpisodeResult | None = None
        self.document: dict[str, Any] | None = None
        self.tools.start()
        self._views: dict[str, SeatView] = {}
        self._settle()

    @property
    def episode(self) -> Episode:
        return self._episode

    @property
    def finished(self) -> bool:
        return self.result is not None

    @property
    def terminal_reason(self) -> str | None:
        return self.state.get("terminal_reason")

    def close(self) -> None:
        """Close the event loop partners' model calls run on, if the episode made it (the
        pool's connections for it closed, its pending tasks cancelled)."""
        if self._owns_loop and self._loop is not None:
            close_loop(self._loop, self.pool)
            self._loop = None

    # -- observing ---------------------------------------------------------------------

    def view(self, seat: str) -> SeatView:
        """What `seat` knows now (rendered once per decision)."""
        view = self._views.get(seat)
        if view is None:
            view = self._views[seat] = self._render(seat)
        return view

    def acting(self, seat: str) -> bool:
        """Whether the current phase reads `seat`'s action."""
        if self.finished:
            return False
        if self.loop == LED_ROUND:
            return (seat == LEADER_SEAT) == (self.phase == LEAD)
        return True

    def _render(self, seat: str) -> SeatView:
        if not self.acting(seat):
            return SeatView(seat, False, "", ())
        tools = self.tools
        prompt = self.prompt_text(seat) if self.text else ""
        if seat == LEADER_SEAT:
            return SeatView(seat, True, prompt, (), sends_message=True)
        agent = None if seat == TEAM_SEAT else seat
        return SeatView(seat, True, prompt, tools.menu_options(agent), tools.menu_lines(agent),
                        sends_message=self._broadcasts(agent))

    def prompt_text(self, seat: str) -> str:
        """The prompt the harness would send `seat` now (rendered even when `text` is off:
        `render`'s text view)."""
        if not self.acting(seat):
            return ""
        if seat == LEADER_SEAT:
            return self.tools.leader_prompt(team_lines(self.tools), False)[0]
        agent = None if seat == TEAM_SEAT else seat
        return self.tools.prompt(agent, self._history(agent), self._board(agent),
                                 self._broadcasts(agent), with_images=False)[0]

    def _history(self, agent: str | None) -> list[str]:
        if agent is None:
            return team_history(self.state)
        return (self.state.get("history") or {}).get(agent, [])

    def _board(self, agent: str | None) -> list[dict[str, Any]]:
        if agent is None:
            return []
        return board(self.state.get("messages") or [],
                     (self.state.get("directives") or {}).get(agent))

    def _broadcasts(self, agent: str | None) -> bool:
        directive = (self.state.get("directives") or {}).get(agent) if agent else None
        return agent is not None and (self.broadcast or bool(directive))

    def frame(self, seat: str) -> bytes:
        """The PNG the seat's model would be shown (the team's merged view for C0 and the
        leader)."""
        agent = None if seat in (TEAM_SEAT, LEADER_SEAT) else seat
        return self.tools.images(agent)[0]

    # -- acting ------------------------------------------------------------------------

    def step(self, actions: Mapping[str, SeatAction]) -> None:
        """Play one phase: the learners' `actions` (one per acting learner), the partners'
        model calls, then the planner's landing rule; then play on through phases in which
        no learner acts."""
        if self.finished:
            raise EnvError("the episode has ended: call reset() before stepping again")
        self._play(self._checked(actions))
        self._settle()

    def _checked(self, actions: Mapping[str, SeatAction]) -> dict[str, SeatAction]:
        """`actions` checked, as they will be played (under ``off_menu="score"`` a message
        where none is read now dropped, as the planner would not read it)."""
        acting = [s for s in self.learners if self.acting(s)]
        unknown = sorted(set(actions) - set(self.seats))
        if unknown:
            raise EnvError(f"no seat {unknown[0]!r}: seats are {', '.join(self.seats)}")
        missing = [s for s in acting if s not in actions]
        if missing:
            raise EnvError(f"no action for seat {missing[0]!r}, which acts now")
        return {seat: self._checked_move(seat, move) for seat, move in actions.items()}

    def _checked_move(self, seat: str, move: SeatAction) -> SeatAction:
        view = self.view(seat)
        if seat in self.partners:
            raise EnvError(f"seat {seat!r} is played by {self.partners[seat]}: "
                           "pass no action for it")
        if move.message and not view.sends_message:
            if self.off_menu == "score":
                move = dataclasses.replace(move, message="")
            else:
                why = "waits this phase" if not view.acting else "sends no messages"
                raise EnvError(f"seat {seat!r} {why}: its action carries no message "
                               f"(got {move.message[:40]!r})")
        if move.action == DONE or self.off_menu == "score" or seat == LEADER_SEAT:
            return move  # (the leader's move is its message; its id is never read)
        if not view.acting:
            raise EnvError(f"seat {seat!r} waits this phase: its action must be DONE (-1), "
                           f"not {move.action}")
        if move.action not in {o.action_id for o in view.menu}:
            ids = sorted(o.action_id for o in view.menu)
            raise EnvError(f"action {move.action} of seat {seat!r} is not on its menu (the "
                           f"action mask): ids now are {ids[:12]}{'…' if len(ids) > 12 else ''}"
                           " or DONE (-1)")
        return move

    def _play(self, actions: Mapping[str, SeatAction]) -> None:
        if self.loop == LED_ROUND and self.phase == LEAD:
            self._lead(actions.get(LEADER_SEAT))
            self.phase = WORK
            return
        if self.loop == STEP:
            decision = self._decision(TEAM_SEAT, actions.get(TEAM_SEAT))
            self._apply(land_decision(self.ctx, self.state, decision))
        else:
            agents = self.spec.config.agent_ids
            self._apply(land_decisions(self.ctx, self.state,
                                       [self._decision(a, actions.get(a)) for a in agents]))
        if self.loop == LED_ROUND:
            self.phase = LEAD
        self._views = {}

    def _lead(self, move: SeatAction | None) -> None:
        history = team_lines(self.tools)
        self.state["history"] = {**self.state["history"], TEAM: history}
        if move is None:  # a partner leads
            directives = self._run(ask_leader(self.ctx, history))
        else:
            prompt = self.view(LEADER_SEAT).prompt
            directives = record_directives(self.tools, self.model, prompt,
                                           reply=ModelReply(text=move.message))
        self.state["directives"] = directives
        self._views = {}

    def _decision(self, seat: str, move: SeatAction | None) -> dict[str, Any]:
        agent = None if seat == TEAM_SEAT else seat
        if move is None:  # a partner decides, as the planner's node asks it
            return self._run(decide(self.ctx, agent, policy=self.policy,
                                    history=self._history(agent), messages=self._board(agent),
                                    broadcast=self._broadcasts(agent)))
        view = self.view(seat)
        if not view.menu:  # `decide` makes no call on an empty menu
            return no_actions_decision(self.tools, agent, policy=self.policy, model=self.model)
        return reply_decision(self.tools, agent, view.menu, view.prompt,
                              ModelReply(text=move.reply_text()), policy=self.policy,
                              model=self.model, broadcast=view.sends_message)

    def _apply(self, update: dict[str, Any]) -> None:
        """Merge a node's state update as LangGraph's channels would (`pending` is cleared
        by its reducer; the rest replace)."""
        self.state.update({k: v for k, v in update.items() if k != "pending"})

    def _settle(self) -> None:
        """Play the phases no learner acts in; score the episode once it has ended."""
        while not self.terminal_reason and not any(self.acting(s) for s in self.learners):
            self._play({})
        if self.terminal_reason and self.result is None:
            self.document, result = self.tools.finish(None, **self.spec.identifiers())
            # As the harness's result line names it (harness.batch).
            self.result = result.model_copy(update={"condition": self.condition})
        self._views = {}

    def _run(self, coroutine: Any) -> Any:
        if self._loop is None:
            self._loop = asyncio.new_event_loop()
            # Closed when the episode is collected or at exit, while the modules a close
            # needs are still there (not in a `__del__` during their teardown).
            weakref.finalize(self, close_quietly, self._loop)
        return self._loop.run_until_complete(coroutine)

    # -- what the rewards read -----------------------------------------------------------

    def progress(self) -> float:
        """The fraction of goal checks passing now."""
        checks = self._episode.items[-1]["eval"]["checks"]
        return sum(c["passed"] for c in checks) / len(checks) if checks else 0.0

    def landed(self, since: int) -> list[dict[str, Any]]:
        """The trajectory items of the steps landed since item `since`."""
        return [i for i in self._episode.items[since:] if "skill_result" in i]


def close_quietly(loop: asyncio.AbstractEventLoop) -> None:
    """Close `loop` unless it is closed or running (no model calls: a collected
    environment's loop, or one still open at exit)."""
    if not loop.is_closed() and not loop.is_running():
        loop.close()


def close_loop(loop: asyncio.AbstractEventLoop, pool: object | None = None) -> None:
    """Close `loop` (not running): `pool`'s connections for it first (``aclose``), then its
    pending tasks cancelled and awaited."""
    if loop.is_closed():
        return
    try:
        aclose = getattr(pool, "aclose", None)
        if aclose is not None:
            loop.run_until_complete(aclose())
        pending = asyncio.all_tasks(loop)
        for task in pending:
            task.cancel()
        if pending:
            loop.run_until_complete(asyncio.gather(*pending, return_exceptions=True))
        loop.run_until_complete(loop.shutdown_asyncgens())
    finally:
        loop.close()

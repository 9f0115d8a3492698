"""`SeatedEpisode`: one benchmark episode whose seats act through `step` instead of a model.

It plays the planner's own round, exactly as `cocobench run` plays it
(`episode_runner.play_episode`: a built-in's declared round functions awaited directly, a
strategy that gives only a graph through LangGraph): a learning seat's model client is a
`SeatClient`, whose reply waits for the seat's action, so the episode pauses where the
planner asks a learner and goes on once the learners answer (`PlannerTurns`). The step,
round and led-round rules are the planner's, written once in its round (or graph); the
environment knows a planner only by what its spec declares (`PlannerSpec.loop`, `seats`).
So any planner, built in or a plugin such as claim-board, is an environment, and an episode
played here scores exactly as the same replies do under `cocobench run --model
scripted:FILE`. Seats without a learner are played
by model clients. No Gymnasium or PettingZoo here: `parallel.py` and `seat_env.py` wrap it.
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
from cocobench_agents.envs.turns import (
    NoSeatClient,
    PartnerClient,
    PlannerTurns,
    SeatClient,
    new_loop,
)
from cocobench_agents.episode_runner import (
    DEFAULT_MODEL_KEY,
    ClientFactory,
    EpisodeSpec,
    episode_retry_policy,
    episode_tools,
    planner_context,
    play_episode,
)
from cocobench_agents.graphs import ORACLE, planner_spec
from cocobench_agents.graphs.registry import (
    AGENT_SEAT,
    LEADER_SEAT,
    TEAM_SEAT,
    PlannerSpec,
    Seat,
)
from cocobench_agents.models import ModelPool
from cocobench_agents.models.grammar import wants_message
from cocobench_agents.models.protocol import MenuOption, prompt_words
from cocobench_agents.models.settings import ModelSettings
from cocobench_agents.prompts import history_line

#: The action that chooses no menu entry: ``ACTION: DONE`` (also what a waiting seat sends).
#: Menu ids start at 0, so DONE is -1.
DONE = -1
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


def check_seated(planner: PlannerSpec) -> None:
    """Raise `EnvError` unless `planner` has a seat to play: a planner that calls no model
    (the oracle) asks nobody."""
    if not planner.uses_models:
        raise EnvError(f"planner {planner.name!r} ({planner.code}) calls no model: it has no "
                       "seat to play")


def check_off_menu(off_menu: str) -> None:
    """Raise `EnvError` unless `off_menu` is one of `OFF_MENU`."""
    if off_menu not in OFF_MENU:
        raise EnvError(f"off_menu must be {' or '.join(map(repr, OFF_MENU))}, not "
                       f"{off_menu!r}")


def _client_key(seat: str) -> str:
    """The `PlannerContext.clients` key of a seat: the team's for the leader too."""
    return TEAM_SEAT if seat == LEADER_SEAT else seat


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
    """One episode of `spec` (any planner that calls models) whose learning seats act through
    `step`. `partners` maps seat names to the model specs that play those seats (any the
    harness runs: ``greedy``, ``random``, ``scripted:FILE``, ``replay:RUN``, a LiteLLM model;
    or ``oracle``: the reference plan, `oracle_partner.py`), their clients made by `pool`
    afresh for each episode (default: a pool with the ``COCOBENCH_RUN_*`` variables'
    settings, `partner_settings`); `text=False` leaves the prompt text out of the seats'
    views. An action off the seat's menu is scored as a model's reply naming an id not on its
    menu is (an ``invalid_action_id`` decision), and a message where none is read now is not
    read; with ``off_menu="error"`` either is an `EnvError`. The episode runs on `loop` when
    given (its owner closes it: the parallel environment shares one among its episodes),
    else on a loop the episode makes and `close` closes."""

    def __init__(self, spec: EpisodeSpec, *, partners: Mapping[str, str] | None = None,
                 pool: ClientFactory | None = None, text: bool = True,
                 off_menu: str = "score", loop: asyncio.AbstractEventLoop | None = None
                 ) -> None:
        check_off_menu(off_menu)
        self.off_menu = off_menu
        self.text = text
        self.planner = planner_spec(spec.planner)
        check_seated(self.planner)
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
        self._episode = Episode(spec.config, spec.controller())
        self._loop = loop
        self._owns_loop = loop is None  # then made on the first reset
        self._played: asyncio.Task | None = None
        self.reset()

    # -- lifecycle ---------------------------------------------------------------------

    def reset(self) -> None:
        """Start the episode over: the scene reloaded, nothing recorded; the planner plays
        up to its first question to a learner."""
        self.abandon()
        self.tools = episode_tools(self.spec, self._episode)
        self.pool.release(self.spec.episode)  # fresh clients: they keep state per episode
        self.turns = PlannerTurns()
        context = planner_context(self.spec, self.tools, self._clients(), self.pool)
        self.result: EpisodeResult | None = None
        self.document: dict[str, Any] | None = None
        self._played = self._event_loop().create_task(play_episode(self.spec, context))
        self._views: dict[str, SeatView] = {}
        self._settle()

    def _clients(self) -> dict[str, Any]:
        """Each seat's client, under the key the planner asks it by (the team's: the
        leader's too): a learner's waits for its action; a partner's is a model (or the
        reference plan)."""
        plan = OraclePlan(self._episode) if ORACLE in self.partners.values() else None
        retry = episode_retry_policy(self.spec, self.pool)
        clients: dict[str, Any] = {
            TEAM_SEAT: NoSeatClient(self.model, self.planner.name, self.seats)}
        for seat in self.seats:
            model = self.partners.get(seat)
            if model is None:
                client: Any = SeatClient(seat, self.model, self.turns)
            elif model == ORACLE:
                client = PartnerClient(OracleClient(plan), self.turns, retry)
            else:
                client = PartnerClient(self.pool.client(model, episode=self.spec.episode,
                                                        agent=_client_agent(seat)),
                                       self.turns, retry)
            clients[_client_key(seat)] = client
        return clients

    @property
    def episode(self) -> Episode:
        return self._episode

    @property
    def finished(self) -> bool:
        return self.result is not None

    @property
    def terminal_reason(self) -> str | None:
        return self.result.terminal_reason if self.result is not None else None

    @property
    def phase(self) -> str:
        """Who acts now: "lead" while the leader does, else "work"."""
        return "lead" if LEADER_SEAT in self.turns.asks else "work"

    def close(self) -> None:
        """Abandon the episode, and close the event loop it runs on if the episode made it
        (the pool's connections for it closed, its pending tasks cancelled)."""
        self.abandon()
        if self._owns_loop and self._loop is not None:
            close_loop(self._loop, self.pool)
            self._loop = None

    def abandon(self) -> None:
        """Stop the planner of an episode not played to its end."""
        played, self._played = self._played, None
        if played is None or played.done() or self._loop is None or self._loop.is_closed():
            return
        self.turns.cancel()
        played.cancel()
        self._loop.run_until_complete(asyncio.gather(played, return_exceptions=True))

    # -- observing ---------------------------------------------------------------------

    def view(self, seat: str) -> SeatView:
        """What `seat` knows now (made once per decision)."""
        view = self._views.get(seat)
        if view is None:
            view = self._views[seat] = self._make_view(seat)
        return view

    def acting(self, seat: str) -> bool:
        """Whether the planner waits for `seat`'s action now."""
        return not self.finished and seat in self.turns.asks

    def _make_view(self, seat: str) -> SeatView:
        ask = self.turns.asks.get(seat) if not self.finished else None
        if ask is None:
            return SeatView(seat, False, "", ())
        request = ask.request
        # A strategy may send content parts: the observation holds what they say.
        prompt = prompt_words(request.prompt) if self.text else ""
        if not request.menu:  # a free-text ask (the leader's): the move's message answers
            return SeatView(seat, True, prompt, (), sends_message=True)
        return SeatView(seat, True, prompt, request.menu, self.tools.menu_lines(request.agent),
                        sends_message=wants_message(request.prompt))

    def prompt_text(self, seat: str) -> str:
        """The prompt the planner sent `seat` now (also when `text` is off: `render`'s text
        view); "" for a waiting seat."""
        ask = self.turns.asks.get(seat) if not self.finished else None
        return prompt_words(ask.request.prompt) if ask is not None else ""

    def history(self, seat: str) -> list[str]:
        """The landed calls `seat` answers for, oldest first ("call -> ok" / "call ->
        FAIL(…)"); the team's seat and the leader see every robot's."""
        every = seat in (TEAM_SEAT, LEADER_SEAT)
        return [history_line(i["label"], i["skill_result"]["success"],
                             i["skill_result"]["errorMessage"])
                for i in self._episode.items if "skill_result" in i
                and (every or i["policy_decision"].get("agent") == seat)]

    def frame(self, seat: str) -> bytes:
        """The PNG the seat's model would be shown (the team's merged view for the team's
        seat and the leader)."""
        agent = None if seat in (TEAM_SEAT, LEADER_SEAT) else seat
        return self.tools.images(agent)[0]

    # -- acting ------------------------------------------------------------------------

    def step(self, actions: Mapping[str, SeatAction]) -> None:
        """Answer the planner's pending asks with the learners' `actions` (one per acting
        learner); the planner plays on (partners' model calls, its landing rules) until it
        asks a learner again or the episode ends."""
        if self.finished:
            raise EnvError("the episode has ended: call reset() before stepping again")
        for seat, move in self._checked(actions).items():
            if self.acting(seat):  # a free-text ask (the leader's) is answered by the message
                self.turns.answer(seat, move.reply_text() if self.view(seat).menu
                                  else move.message)
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
        if move.action == DONE or self.off_menu == "score" or (view.acting and not view.menu):
            return move  # (a free-text ask's move is its message; its id is never read)
        if not view.acting:
            raise EnvError(f"seat {seat!r} waits this phase: its action must be DONE (-1), "
                           f"not {move.action}")
        if move.action not in {o.action_id for o in view.menu}:
            ids = sorted(o.action_id for o in view.menu)
            raise EnvError(f"action {move.action} of seat {seat!r} is not on its menu (the "
                           f"action mask): ids now are {ids[:12]}{'…' if len(ids) > 12 else ''}"
                           " or DONE (-1)")
        return move

    def _settle(self) -> None:
        """Let the planner play until it waits for a learner; score the episode once it
        has ended (a planner node's error is raised here, as `cocobench run` raises it)."""
        self._views = {}
        played = self._played
        try:
            self._event_loop().run_until_complete(self.turns.until_waiting(played))
        except RuntimeError as exc:
            raise EnvError(f"planner {self.planner.name}: {exc}") from None
        if played.done():
            self.document, result = played.result()
            # As the harness's result line names it (harness.batch).
            self.result = result.model_copy(update={"condition": self.condition})

    def _event_loop(self) -> asyncio.AbstractEventLoop:
        if self._loop is None:
            self._loop = new_loop()
            # Closed when the episode is collected or at exit, while the modules a close
            # needs are still there (not in a `__del__` during their teardown).
            weakref.finalize(self, close_quietly, self._loop)
        return self._loop

    # -- what the rewards read -----------------------------------------------------------

    def progress(self) -> float:
        """The fraction of goal checks passing now."""
        checks = self._episode.items[-1]["eval"]["checks"]
        return sum(c["passed"] for c in checks) / len(checks) if checks else 0.0

    def landed(self, since: int) -> list[dict[str, Any]]:
        """The trajectory items of the steps landed since item `since`."""
        return [i for i in self._episode.items[since:] if "skill_result" in i]


def close_quietly(loop: asyncio.AbstractEventLoop) -> None:
    """Close `loop` unless it is closed or running, its episodes' planners stopped first (a
    collected environment's loop, or one still open at exit: a planner left waiting for a
    learner would otherwise be torn down outside any loop)."""
    if loop.is_closed() or loop.is_running():
        return
    try:
        _cancel_pending(loop)
    finally:
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
        _cancel_pending(loop)
        loop.run_until_complete(loop.shutdown_asyncgens())
    finally:
        loop.close()


def _cancel_pending(loop: asyncio.AbstractEventLoop) -> None:
    """Cancel `loop`'s pending tasks and wait for them to end."""
    pending = asyncio.all_tasks(loop)
    for task in pending:
        task.cancel()
    if pending:
        loop.run_until_complete(asyncio.gather(*pending, return_exceptions=True))

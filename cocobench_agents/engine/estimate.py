"""What a planned run would cost before it runs: episodes, the most model calls its step
budgets allow, the tokens of every episode's first prompt and a cost range in USD, per
model × condition × arm (`cocobench run … --dry-run`, `cocobench_agents.plan`; see
docs/dry-run.md).

Nothing here calls a model, starts a simulator other than the embedded one, or writes a file:
first prompts are rendered on the embedded simulator through the planners' own code
(`EpisodeTools`, as `cocobench prompts show` does), turned into the chat messages the model
clients send (`build_messages`), and counted with LiteLLM's token counter; prices come from
the cost map LiteLLM ships (read offline).

Definitions (the docs give the reasons):

* An episode's **first prompt tokens** are what its first decision round sends to models:
  the team's prompt (C0); every agent's prompt (D0, D1); the leader's prompt and every
  agent's prompt (leader–worker). Each prompt is counted with the tokenizer of the model it
  goes to (`--agent-model` teams mix them). The oracle sends none (0).
* **max_calls** bounds the model calls of an episode from its step budget B (`--max-steps`,
  else `difficulty.step_budget`): C0 asks once per landed step (B); D0/D1 ask every one of
  the N agents each round, and a round lands at least one step or ends the episode (N × B);
  leader–worker adds the leader's call to every round ((N + 1) × B); the oracle asks none.
  Each planner's `PlannerSpec` declares its loop, prompt and broadcast, which these are read
  from; one that declares no `loop` is assumed to ask N × B (`CostRow.assumed`).
  Retries are not counted.
* **cost low** = each seat's first prompt × the calls of a run as short as the oracle's plan
  (its calls for C0, its busiest agent's calls, i.e. rounds, for teams) × input price.
  **cost high** = max_calls × the row's largest single first prompt × input price, plus
  max_calls × `max_tokens` × output price when `max_tokens` is set. Built-in models are free
  (0); a model without a price in the cost map has unknown cost (None), and so has the total.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from types import ModuleType
from typing import TYPE_CHECKING, Any

from benchmark_adapter.episode import Episode
from benchmark_adapter.tasks import TaskConfig
from cocobench_agents.episode_runner import EpisodeSpec
from cocobench_agents.graphs import planner_spec
from cocobench_agents.models import build_messages, import_litellm, is_builtin
from cocobench_agents.models.protocol import ModelRequest
from cocobench_agents.prompts import PromptSuite, load_prompt_suite
from cocobench_agents.tools import EpisodeTools

if TYPE_CHECKING:
    from cocobench_agents.harness.episodes import PlannedEpisode
    from cocobench_agents.models import ModelSettings

#: Seats of a decision round: the team's planner (C0), the leader (leader–worker), an agent.
TEAM, LEADER, AGENT = "team", "leader", "agent"

#: LiteLLM's Hugging Face tokenizers that it downloads from the Hub on first use (the
#: Anthropic and DeepSeek ones ship with it). A dry run fetches nothing, so models that would
#: use these are counted with tiktoken instead, and their counter says so.
_HUB_TOKENIZERS = {"llama2": "hf-internal-testing/llama-tokenizer",
                   "llama3": "Xenova/llama-3-tokenizer",
                   "cohere": "Xenova/c4ai-command-r-v01-tokenizer"}
#: Providers whose models' own tokenizers tiktoken has (named "the model's own").
_OPENAI_PROVIDERS = ("openai", "azure", "text-completion-openai")


# -- the result ---------------------------------------------------------------------------

@dataclass(frozen=True)
class CostRange:
    """USD a run is estimated to spend: `low` and `high`, None when a model has no price."""

    low: float | None
    high: float | None

    @property
    def known(self) -> bool:
        return self.low is not None and self.high is not None

    def to_json(self) -> dict[str, float | None]:
        """Rounded to a millionth of a dollar (sums of float products carry noise below)."""
        return {"low": _usd(self.low), "high": _usd(self.high)}


def _usd(amount: float | None) -> float | None:
    return None if amount is None else round(amount, 6)


@dataclass(frozen=True)
class CostRow:
    """The estimate of one model × condition × arm."""

    model: str  # the run's model label (the team's model; "oracle" for the oracle)
    condition: str
    arm: str  # "" for a run without prompt-suite arms (null in JSON)
    episodes: int
    max_calls: int
    prompt_tokens: int  # summed over the episodes: each one's first decision round
    cost_usd: CostRange
    #: Every model the row's calls go to, the team's first (`--agent-model` adds others).
    models: tuple[str, ...] = ()
    #: max_calls assumes one call per agent per landed step: a planner whose spec declares no
    #: `loop` (a strategy that asks again within a round can exceed it).
    assumed: bool = False

    def to_json(self) -> dict[str, Any]:
        return {"model": self.model, "condition": self.condition, "arm": self.arm or None,
                "episodes": self.episodes, "max_calls": self.max_calls,
                "prompt_tokens": self.prompt_tokens, "cost_usd": self.cost_usd.to_json()}


@dataclass(frozen=True)
class EpisodeTokens:
    """One planned episode's first-prompt tokens (0 for the oracle's)."""

    model: str
    condition: str
    arm: str  # "" for a run without prompt-suite arms (null in JSON)
    task_id: str
    epoch: int
    prompt_tokens: int  # everything its first decision round sends to models

    def to_json(self) -> dict[str, Any]:
        return {"model": self.model, "condition": self.condition, "arm": self.arm or None,
                "task_id": self.task_id, "epoch": self.epoch,
                "prompt_tokens": self.prompt_tokens}


@dataclass(frozen=True)
class CostTotal:
    """The rows summed; the cost is unknown (None) when any row's is."""

    episodes: int
    max_calls: int
    prompt_tokens: int
    cost_usd: CostRange

    def to_json(self) -> dict[str, Any]:
        return {"episodes": self.episodes, "max_calls": self.max_calls,
                "prompt_tokens": self.prompt_tokens, "cost_usd": self.cost_usd.to_json()}


@dataclass(frozen=True)
class CostPlan:
    """What a planned run would spend, per model × condition × arm, in plan order."""

    rows: tuple[CostRow, ...]
    total: CostTotal
    #: model → the token counter its prompts were counted with (one line, for people).
    token_counters: Mapping[str, str] = field(default_factory=dict)
    max_cost_usd: float | None = None  # the run's --max-cost, if any
    #: Whether the low / high total exceeds `max_cost_usd`; None without a limit or a price.
    low_exceeds_max_cost: bool | None = None
    high_exceeds_max_cost: bool | None = None
    #: Every episode's first-prompt tokens, in plan order (a row's `prompt_tokens` sums them).
    episodes: tuple[EpisodeTokens, ...] = ()

    def to_json(self) -> dict[str, Any]:
        """The `--dry-run --json` object: rows, total, token counters, the spend limit and
        every episode's first-prompt tokens."""
        limit = None
        if self.max_cost_usd is not None:
            limit = {"limit": self.max_cost_usd, "low_exceeds": self.low_exceeds_max_cost,
                     "high_exceeds": self.high_exceeds_max_cost}
        return {"rows": [row.to_json() for row in self.rows], "total": self.total.to_json(),
                "token_counters": dict(self.token_counters), "max_cost_usd": limit,
                "episodes": [episode.to_json() for episode in self.episodes]}


# -- the first decision round ---------------------------------------------------------------

@dataclass(frozen=True)
class FirstRequest:
    """One model call of an episode's first decision round, as its client would send it."""

    role: str  # TEAM, LEADER or AGENT
    agent: str | None  # the deciding agent (None for the team's planner and the leader)
    model: str
    messages: list[dict[str, Any]]  # [] when the seat has nothing to decide (empty menu)


@dataclass(frozen=True)
class _Loop:
    """How a planner asks models, as its `PlannerSpec` declares it (`loop`, `prompt`,
    `broadcast`)."""

    kind: str  # "step": one call per landed step; "round": every agent; "led-round": + leader
    prompt: str  # "team": the centralized prompt; "agent": each agent's own
    broadcast: bool = False  # agents see the message board (D1, leader–worker)
    assumed: bool = False  # the spec declares no loop: N calls per landed step are assumed


def _loop(planner: str) -> _Loop | None:
    """The planner's loop, from its spec; None for one that asks no model (the oracle)."""
    spec = planner_spec(planner)
    if not spec.uses_models:
        return None
    prompt = spec.prompt_kind
    # Undeclared (a strategy written before specs declared their loop): the team's model
    # asked as C0 asks it, or every agent as D0 asks them, each N times per landed step.
    kind = spec.loop or ("round" if prompt == "agent" else "step")
    return _Loop(kind, prompt, spec.broadcast, assumed=spec.loop is None)


def first_round_requests(spec: EpisodeSpec) -> list[FirstRequest]:
    """The requests of `spec`'s first decision round, in the order the planner makes them,
    rendered on the embedded simulator without calling a model (none for the oracle).

    The leader–worker's agents are shown without the leader's instruction, which is not known
    before the leader answers."""
    loop = _loop(spec.planner)
    if loop is None:
        return []
    return _FirstRounds().requests(spec, loop)


@dataclass(frozen=True)
class _SeatPrompt:
    """One seat's first prompt as rendered: "" when the seat has no menu (no call)."""

    role: str
    agent: str | None
    text: str
    frames: tuple[bytes, ...]


class _FirstRounds:
    """Renders first rounds, once per distinct (instance, planner loop, observation mode,
    suite, id mode, images): a plan repeats them across models, epochs and agent models."""

    def __init__(self) -> None:
        self._suites: dict[str, PromptSuite] = {}
        self._worlds: dict[int, Episode] = {}
        self._rendered: dict[tuple, list[_SeatPrompt]] = {}

    def requests(self, spec: EpisodeSpec, loop: _Loop) -> list[FirstRequest]:
        seats = _seat_order(spec.config, loop)
        models = [spec.model_for(agent) for _, agent in seats]
        images = spec.obs_mode == "image" and any(_reads_images(m) for m in models)
        # Keyed by the config object: a plan's episodes share one per instance, and all of
        # them are alive while the estimate runs.
        key = (id(spec.config), loop.kind, loop.prompt, loop.broadcast, spec.obs_mode,
               spec.prompt_suite, spec.stable_ids, images)
        rendered = self._rendered.get(key)
        if rendered is None:
            rendered = self._rendered[key] = self._render(spec, loop, images)
        out = []
        for seat, model in zip(rendered, models):
            frames = seat.frames if _reads_images(model) else ()
            messages = build_messages(ModelRequest(prompt=seat.text, images=frames))
            out.append(FirstRequest(seat.role, seat.agent, model,
                                    messages if seat.text else []))
        return out

    def _render(self, spec: EpisodeSpec, loop: _Loop, images: bool) -> list[_SeatPrompt]:
        """Every seat's first prompt, in the order the planner's nodes render them (the order
        `--stable-ids` numbers calls in)."""
        suite = self._suites.get(spec.prompt_suite)
        if suite is None:
            suite = self._suites[spec.prompt_suite] = load_prompt_suite(spec.prompt_suite)
        # One world per instance, reset once: every planner's first snapshot is the same
        # one, and the episode renders each agent's frame of a step once (most of the time
        # of an estimate goes into encoding frames).
        world = self._worlds.get(id(spec.config))
        if world is None:
            world = self._worlds[id(spec.config)] = Episode(spec.config)
            world.reset()
        tools = EpisodeTools(world, suite, obs_mode=spec.obs_mode, stable_ids=spec.stable_ids)
        tools.refresh()  # `start` without the reset: fresh menu views and stable ids
        out = []
        for role, agent in _seat_order(spec.config, loop):
            if role == LEADER:  # the leader is always asked (graphs/leader_worker.lead)
                text, frames = tools.leader_prompt([], with_images=images)
            else:
                text, frames, menu = tools.prompt(agent, [], (), loop.broadcast,
                                                  with_images=images)
                if not menu:  # `decide` makes no call on an empty menu
                    text, frames = "", ()
            out.append(_SeatPrompt(role, agent, text, frames))
        return out


def _seat_order(config: TaskConfig, loop: _Loop) -> list[tuple[str, str | None]]:
    if loop.kind == "step":  # one seat asked per step: the team, or (first) agent_1
        return [(TEAM, None)] if loop.prompt == "team" else [(AGENT, config.agent_ids[0])]
    agents = [(AGENT, a) for a in config.agent_ids]
    return [(LEADER, None), *agents] if loop.kind == "led-round" else agents


def _reads_images(model: str) -> bool:
    """Built-in clients read no frames (`accepts_images = False`), so none are rendered for
    them; remote models get them under image conditions."""
    return not is_builtin(model)


# -- counting and pricing ------------------------------------------------------------------

class _TokenCounter:
    """LiteLLM's token counter for one model, its tokenizer chosen once and named."""

    def __init__(self, litellm: ModuleType, model: str) -> None:
        self._litellm, self.model = litellm, model
        self._counted: dict[tuple[str, tuple[str, ...]], int] = {}
        self.tokenizer, self.description = _tokenizer(litellm, model)

    def count(self, messages: list[dict[str, Any]]) -> int:
        if not messages:
            return 0
        key = _messages_key(messages)
        tokens = self._counted.get(key)
        if tokens is None:
            tokens = self._counted[key] = int(self._litellm.token_counter(
                model="" if is_builtin(self.model) else self.model,
                custom_tokenizer=self.tokenizer, messages=messages))
        return tokens


def _messages_key(messages: list[dict[str, Any]]) -> tuple[str, tuple[str, ...]]:
    """A hashable key of one user message: its text and image URLs."""
    content = messages[0]["content"]
    if isinstance(content, str):
        return content, ()
    return content[0]["text"], tuple(part["image_url"]["url"] for part in content[1:])


def _tokenizer(litellm: ModuleType, model: str) -> tuple[dict[str, Any], str]:
    """The tokenizer LiteLLM's `token_counter` picks for `model`, and what it is.

    Built-in models are counted as LiteLLM counts a model it knows nothing about. Tokenizers
    LiteLLM would download are not: tiktoken, as LiteLLM's own fallback, stands in."""
    from litellm.litellm_core_utils.token_counter import openai_tokenizer_encoding_name
    from litellm.utils import huggingface_tokenizer_kind, select_tokenizer

    name = "" if is_builtin(model) else model
    encoding = openai_tokenizer_encoding_name(name)
    kind = huggingface_tokenizer_kind(name)
    if kind in _HUB_TOKENIZERS:
        # LiteLLM's tiktoken tokenizer; `token_counter` picks the encoding by the model's name.
        return select_tokenizer(""), (
            f"tiktoken {encoding} (LiteLLM would download {_HUB_TOKENIZERS[kind]} from the "
            "Hugging Face Hub; a dry run fetches nothing)")
    selected = select_tokenizer(name)
    if selected["type"] == "huggingface_tokenizer":
        return selected, f"Hugging Face {kind} tokenizer (bundled with LiteLLM)"
    if kind is not None:
        return selected, (f"tiktoken {encoding} (LiteLLM's fallback: its {kind} tokenizer "
                          "could not be loaded)")
    if is_builtin(model):
        return selected, f"tiktoken {encoding} (LiteLLM's default; a built-in model is free)"
    if _provider(litellm, name) in _OPENAI_PROVIDERS:
        return selected, f"tiktoken {encoding} (the model's own, via LiteLLM)"
    return selected, f"tiktoken {encoding} (LiteLLM's default: it has no tokenizer of this model)"


def _provider(litellm: ModuleType, model: str) -> str | None:
    """The provider the cost map lists `model` under, or None when it does not list it."""
    try:
        return litellm.get_model_info(model=model).get("litellm_provider")
    except Exception:  # noqa: BLE001 - LiteLLM raises several types for an unmapped model
        return None


def _prices(litellm: ModuleType, model: str) -> tuple[float, float] | None:
    """USD per (input, output) token: 0 for built-ins (they call nothing), the cost map's for
    a model it prices, None for one it does not."""
    if is_builtin(model):
        return 0.0, 0.0
    try:
        info = litellm.get_model_info(model=model)
    except Exception:  # noqa: BLE001 - LiteLLM raises several types for an unmapped model
        return None
    price_in, price_out = info.get("input_cost_per_token"), info.get("output_cost_per_token")
    if price_in is None or price_out is None:
        return None
    return float(price_in), float(price_out)


# -- calls ---------------------------------------------------------------------------------

def _oracle_length(config: TaskConfig) -> tuple[int, int]:
    """(calls, busiest agent's calls) of the instance's oracle plan; an instance without one
    counts as a single call (an episode asks at least once)."""
    from benchmark_adapter.generator.oracles import oracle_stats

    try:
        stats = oracle_stats(config)
    except LookupError:  # no plan for this task type, or one needing an alias it lacks
        return 1, 1
    return stats.calls, stats.makespan


def _seat_calls(loop: _Loop, agents: int, budget: int, oracle: tuple[int, int]
                ) -> tuple[int, int]:
    """(most, oracle-short) calls of one seat over an episode of step budget `budget`.

    A step loop's seat lands one step per call (N calls per step when the loop is assumed);
    every seat of a round is asked once per round, and a round lands at least one step (else
    it ends the episode), so at most `budget` rounds; a run as short as the oracle's plan
    takes its calls (step) or its busiest agent's calls (rounds)."""
    calls, makespan = oracle
    if loop.kind == "step":
        return budget * (agents if loop.assumed else 1), min(calls, budget)
    return budget, min(makespan, budget)


# -- the estimate --------------------------------------------------------------------------

@dataclass
class _ModelShare:
    """What one row sends to one model."""

    max_calls: int = 0
    low_tokens: int = 0  # Σ first-prompt tokens × oracle-short calls
    largest_prompt: int = 0  # the largest single first prompt of the row


@dataclass
class _RowSum:
    episodes: int = 0
    max_calls: int = 0
    prompt_tokens: int = 0
    assumed: bool = False
    shares: dict[str, _ModelShare] = field(default_factory=dict)


def estimate(episodes: Sequence[PlannedEpisode], settings: ModelSettings, *,
             max_cost_usd: float | None = None) -> CostPlan:
    """Estimate `episodes` (a run's plan) without calling any model or writing anything.

    Per model × condition × arm, in plan order: the episodes, the most model calls their
    step budgets allow (retries not included), the tokens of each episode's first decision
    round (every prompt it sends, counted with its own model's tokenizer), and a cost range
    in USD (None for a model without a price). `settings.max_tokens` bounds the completion
    cost in `high`; without it completions are left out. With `max_cost_usd`, says whether the
    low and high totals exceed it.

    Measured on 2 quiet cores: cocobench-240 × the six paper conditions (1,440 episodes) in
    11.5 s with a remote model (most of it encoding the image conditions' frames) and 3.1 s
    with a built-in one, plus LiteLLM's import (about 7 s) on first use."""
    tally = _Tally(import_litellm())
    for planned in episodes:
        tally.add(planned)
    prices = {model: _prices(tally.litellm, model) for model in tally.counters}
    rows = tuple(_cost_row(key, row, prices, settings.max_tokens)
                 for key, row in tally.rows.items())
    total = _total(rows)
    return CostPlan(
        rows=rows, total=total,
        token_counters={model: c.description for model, c in tally.counters.items()},
        max_cost_usd=max_cost_usd,
        low_exceeds_max_cost=_exceeds(total.cost_usd.low, max_cost_usd),
        high_exceeds_max_cost=_exceeds(total.cost_usd.high, max_cost_usd),
        episodes=tuple(tally.episodes))


class _Tally:
    """Adds up a plan's episodes, row by row and model by model."""

    def __init__(self, litellm: ModuleType) -> None:
        self.litellm = litellm
        self.rows: dict[tuple[str, str, str], _RowSum] = {}
        self.counters: dict[str, _TokenCounter] = {}  # by model, in order of first use
        self.episodes: list[EpisodeTokens] = []  # in plan order
        self._rounds = _FirstRounds()
        self._oracle: dict[int, tuple[int, int]] = {}  # by config object

    def add(self, planned: PlannedEpisode) -> None:
        key = planned.key
        row = self.rows.setdefault((key.model, key.condition, key.arm), _RowSum())
        before = row.prompt_tokens
        self._count(planned, row)
        self.episodes.append(EpisodeTokens(key.model, key.condition, key.arm, key.task_id,
                                           key.epoch, row.prompt_tokens - before))

    def _count(self, planned: PlannedEpisode, row: _RowSum) -> None:
        """Add the episode's calls, first-prompt tokens and cost shares to its row."""
        spec = planned.spec
        row.episodes += 1
        loop = _loop(spec.planner)
        if loop is None:  # the oracle: no model, no call
            return
        row.assumed = row.assumed or loop.assumed
        oracle = self._oracle_length(spec.config)
        for request in self._rounds.requests(spec, loop):
            tokens = self._counter(request.model).count(request.messages)
            most, short = _seat_calls(loop, spec.config.agent_count, spec.budget, oracle)
            share = row.shares.setdefault(request.model, _ModelShare())
            share.max_calls += most
            share.low_tokens += tokens * short
            share.largest_prompt = max(share.largest_prompt, tokens)
            row.max_calls += most
            row.prompt_tokens += tokens

    def _counter(self, model: str) -> _TokenCounter:
        counter = self.counters.get(model)
        if counter is None:
            counter = self.counters[model] = _TokenCounter(self.litellm, model)
        return counter

    def _oracle_length(self, config: TaskConfig) -> tuple[int, int]:
        length = self._oracle.get(id(config))
        if length is None:
            length = self._oracle[id(config)] = _oracle_length(config)
        return length


def _cost_row(key: tuple[str, str, str], row: _RowSum,
              prices: Mapping[str, tuple[float, float] | None],
              max_tokens: int | None) -> CostRow:
    low = high = 0.0
    for model, share in row.shares.items():
        price = prices[model]
        if price is None:
            low = high = None
            break
        price_in, price_out = price
        low += share.low_tokens * price_in
        high += share.max_calls * share.largest_prompt * price_in
        if max_tokens is not None:
            high += share.max_calls * max_tokens * price_out
    model, condition, arm = key
    return CostRow(model, condition, arm, row.episodes, row.max_calls, row.prompt_tokens,
                   CostRange(low, high), tuple(row.shares), row.assumed)


def _total(rows: Sequence[CostRow]) -> CostTotal:
    known = all(row.cost_usd.known for row in rows)
    return CostTotal(
        episodes=sum(row.episodes for row in rows),
        max_calls=sum(row.max_calls for row in rows),
        prompt_tokens=sum(row.prompt_tokens for row in rows),
        cost_usd=CostRange(sum(row.cost_usd.low for row in rows) if known else None,
                           sum(row.cost_usd.high for row in rows) if known else None))


def _exceeds(cost: float | None, limit: float | None) -> bool | None:
    return None if cost is None or limit is None else cost > limit

"""Playing episodes through the environment with simple policies, and the script of replies
that makes `--model scripted:FILE` send the same moves."""

from __future__ import annotations

import random
from collections.abc import Callable

from benchmark_adapter.oracles import oracle_plan
from cocobench_agents.envs import DONE, SeatAction, SeatedEpisode
from cocobench_agents.envs.seated import SeatView
from cocobench_agents.graphs.registry import LEADER_SEAT, TEAM_SEAT
from cocobench_agents.models.builtin import Script

Policy = Callable[[SeatedEpisode, SeatView], SeatAction]


def random_policy(seed: int) -> Policy:
    """Uniform over the menu (never DONE), with a message now and then."""
    rng = random.Random(seed)

    def act(episode: SeatedEpisode, view: SeatView) -> SeatAction:
        if view.seat == LEADER_SEAT:
            lines = [f"{a}: try option {rng.randint(0, 9)}" for a in episode.spec.config.agent_ids]
            return SeatAction(message="\n".join(lines))
        if not view.menu:
            return SeatAction()
        message = f"going for {rng.randint(0, 99)}" if view.sends_message and rng.random() < .5 \
            else ""
        return SeatAction(rng.choice(view.menu).action_id, message)
    return act


def oracle_policy() -> Policy:
    """The reference plan's next call where it is on the seat's menu, else DONE."""
    plans: dict[int, list] = {}

    def act(episode: SeatedEpisode, view: SeatView) -> SeatAction:
        plan = plans.setdefault(id(episode.tools), [oracle_plan(episode.spec.config), None, 0])
        landed = episode.tools.step_index
        if plan[1] is None or plan[2] != landed:  # the last call landed: the next one
            plan[1], plan[2] = next(plan[0], ""), landed
        if view.seat == LEADER_SEAT:
            return SeatAction(message=f"agent_0: {plan[1]}")
        entry = next((o for o in view.menu if o.call == plan[1]), None)
        return SeatAction(entry.action_id) if entry else SeatAction()
    return act


def illegal_first(seed: int) -> Policy:
    """Random, after a first move that fails in the simulator where the menu has one (a Put
    or Open with empty hands…), chosen by trying each entry on a copy of the world."""
    base = random_policy(seed)
    done: set[int] = set()

    def act(episode: SeatedEpisode, view: SeatView) -> SeatAction:
        if view.seat not in (LEADER_SEAT,) and view.menu and id(episode.tools) not in done:
            done.add(id(episode.tools))
            for option in view.menu:
                if option.call.split("(")[0] in ("Put", "Close", "ToggleOff", "Drop"):
                    return SeatAction(option.action_id)
        return base(episode, view)
    return act


def done_after(steps: int, seed: int) -> Policy:
    """Random for `steps` landed steps, then DONE from every seat."""
    base = random_policy(seed)

    def act(episode: SeatedEpisode, view: SeatView) -> SeatAction:
        if episode.tools.step_index >= steps and view.seat != LEADER_SEAT:
            return SeatAction(DONE)
        return base(episode, view)
    return act


def play(episode: SeatedEpisode, policy: Policy) -> dict[str, list[str]]:
    """Play `episode` to its end; the replies each seat's scripted client must send (keyed
    as `Script` reads them: the team's and the leader's under `TEAM_SEAT`)."""
    replies: dict[str, list[str]] = {}
    while not episode.finished:
        moves = {}
        for seat in episode.learners:
            view = episode.view(seat)
            move = policy(episode, view) if view.acting else SeatAction()
            moves[seat] = move
            if not view.acting:
                continue
            key = Script.TEAM if seat in (TEAM_SEAT, LEADER_SEAT) else seat
            if seat == LEADER_SEAT:
                replies.setdefault(key, []).append(move.message)
            elif view.menu:  # no model call on an empty menu
                replies.setdefault(key, []).append(move.reply_text())
        episode.step(moves)
    return replies

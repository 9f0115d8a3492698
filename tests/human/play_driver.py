"""A run whose person is played by code, for a test to kill while a decision is pending.

``python tests/human/play_driver.py REQUEST.json CALLS.json STOP_AT PENDING`` runs the request
with an `OracleDesk` playing CALLS; at its STOP_AT-th decision it writes that decision's id
to PENDING and waits for an answer that never comes.
"""

from __future__ import annotations

import asyncio
import json
import sys
from pathlib import Path

import cocobench_agents as cb
from cocobench_agents.models.human import Answer, Decision
from tests.human.desks import OracleDesk, number


class StoppingDesk(OracleDesk):
    def __init__(self, calls: list[str], stop_at: int, pending: Path) -> None:
        super().__init__(calls)
        self.stop_at, self.pending = stop_at, pending

    async def ask(self, decision: Decision) -> Answer:
        if number(decision) == self.stop_at:
            self.pending.write_text(decision.id)
            await asyncio.Event().wait()  # the person never answers: the test kills us
        return await super().ask(decision)


def main(request_file: str, calls_file: str, stop_at: str, pending: str) -> None:
    request = cb.RunRequest.model_validate_json(Path(request_file).read_text())
    calls = json.loads(Path(calls_file).read_text())
    cb.run(request, desk=StoppingDesk(calls, int(stop_at), Path(pending)))


if __name__ == "__main__":
    main(*sys.argv[1:])

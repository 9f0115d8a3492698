"""The dataset's columns: their names, types and meanings, once for the Parquet schema, the
`datasets` features written into it, and the dataset card."""

from __future__ import annotations

from typing import Any, Literal

Kind = Literal["string", "int64", "float64", "bool", "messages", "frame"]

#: The column of frames (a `datasets.Image`).
IMAGE_COLUMN = "image"
#: (name, kind, meaning): one row per model decision; the episode's columns repeat on each of
#: its decisions.
COLUMNS: tuple[tuple[str, Kind, str], ...] = (
    ("run", "string", "the run folder's name (run.json `name`)"),
    ("model", "string", "the episode's model (its row in `cocobench report`)"),
    ("condition", "string", "the condition code, e.g. C0_image, D1_blind"),
    ("arm", "string", "the prompt-suite arm of a run comparing several ('' otherwise)"),
    ("task_id", "string", "the instance"),
    ("cell", "string", "the instance's family × dimension cell (A_D1, …)"),
    ("epoch", "int64", "the epoch of a run of several (0 otherwise)"),
    ("decision_index", "int64", "the decision's place among the episode's model decisions"),
    ("step", "int64", "the environment step counter when the decision was asked for"),
    ("seat", "string", "who decided: the agent id, or 'team' for a decision for the whole "
                       "team (a centralized planner, a leader)"),
    ("seat_model", "string", "the model that made this decision (differs from `model` for "
                             "a seat of a mixed team)"),
    ("messages", "messages", "the chat messages exactly as sent ({role, content}); under "
                             "image conditions the frame sent with them is `image`"),
    ("reply", "string", "the model's reply text, as received (null: no reply, a backend "
                        "error)"),
    ("status", "string", "what the reply was: action, done, parse_error, invalid_action_id, "
                         "backend_error, or plan (a leader's instructions)"),
    ("parsed_action_id", "string", "the menu id (or DONE) read from the reply"),
    ("parsed_call", "string", "the skill call that id names (null when none)"),
    ("legal", "bool", "the reply named an action on the seat's menu, or DONE (null: no "
                      "reply, or a leader's plan)"),
    ("step_success", "bool", "the landed call succeeded in the simulator (null: nothing "
                             "landed)"),
    ("message", "string", "the message the seat sent its teammates (D1; null otherwise)"),
    ("prompt_tokens", "int64", "tokens of the prompt, as the provider counted them"),
    ("completion_tokens", "int64", "tokens of the reply"),
    ("reward", "float64", "the decision's reward as the environments pay its seat by default "
                          "(docs/environments.md): the goal progress its landed call made, "
                          "-0.002 for a failed call or a reply off the menu, and on the "
                          "seat's last decision 1 for success + 0.5 × the construct score "
                          "of a success"),
    (IMAGE_COLUMN, "frame", "the frame the run kept for the state the decision saw (null: a blind "
                       "condition, or a run that kept no frames)"),
    ("episode_success", "bool", "the episode reached its goal"),
    ("episode_progress", "float64", "the fraction of goal checks passed at the end"),
    ("legal_plan", "bool", "the episode's plan had no illegal step"),
    ("construct_score", "float64", "the episode's construct score (null: not scored)"),
    ("construct_status", "string", "scored, or why not (not_engaged, low_signal, …)"),
    ("failure_kind", "string", "the benchmark's failure taxonomy for the episode"),
    ("terminal_reason", "string", "why the episode ended"),
    ("infra_failure", "bool", "the episode is an infrastructure failure (kept only with "
                              "--include-infra)"),
)
NAMES = tuple(name for name, _, _ in COLUMNS)

_VALUE = {"string": "string", "int64": "int64", "float64": "float64", "bool": "bool"}


def features() -> dict[str, Any]:
    """The columns as Hugging Face `datasets` features (their JSON form, which `datasets`
    reads from the Parquet schema's ``huggingface`` metadata: it is what makes `image` an
    image column). Lists in the `[feature]` form every `datasets` version reads."""
    out: dict[str, Any] = {}
    for name, kind, _ in COLUMNS:
        if kind == "frame":
            out[name] = {"_type": "Image"}
        elif kind == "messages":
            out[name] = [{"role": _value("string"), "content": _value("string")}]
        else:
            out[name] = _value(_VALUE[kind])
    return out


def _value(dtype: str) -> dict[str, str]:
    return {"dtype": dtype, "_type": "Value"}


def arrow_schema() -> Any:
    """The Parquet schema (a `pyarrow.Schema`), with the features as its metadata."""
    import json

    import pyarrow as pa

    text = pa.string()
    types = {"string": text, "int64": pa.int64(), "float64": pa.float64(), "bool": pa.bool_(),
             "messages": pa.list_(pa.struct([("role", text), ("content", text)])),
             "frame": pa.struct([("bytes", pa.binary()), ("path", text)])}
    metadata = {"huggingface": json.dumps({"info": {"features": features()}})}
    return pa.schema([(name, types[kind]) for name, kind, _ in COLUMNS], metadata=metadata)

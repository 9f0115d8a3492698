"""Where the viewer puts a page or a file of a run folder: every name taken from a run folder
(model, condition, arm, task id, epoch, frame) becomes one plain path component, so that a
page and a copied file land inside the viewer's root by construction; `inside` checks it
again, on the resolved path, before anything is written.
"""

from __future__ import annotations

import hashlib
import re
from pathlib import Path

from cocobench_agents.viewer.errors import ViewerError

#: A name kept as it is: what runs write (`greedy`, `C0_image`, `A_D1__EmbKitchen05__…_seed0`,
#: `t1@e2`): no separator, no leading dot (never `.` or `..`), not too long for a file name.
PLAIN = re.compile(r"[A-Za-z0-9_-][A-Za-z0-9_.@-]{0,119}")
#: Characters a slug keeps; anything else becomes `_`.
UNSAFE = re.compile(r"[^A-Za-z0-9_.@-]+")
SLUG_CHARS = 80


def path_part(name: str) -> str:
    """`name` as one path component: itself when `PLAIN`, else a slug of it with a hash of the
    whole name (`.._.._ESCAPED~1a2b3c4d5e`), so two names never share a component."""
    if PLAIN.fullmatch(name):
        return name
    slug = UNSAFE.sub("_", name)[:SLUG_CHARS].strip("._") or "_"
    digest = hashlib.sha256(name.encode("utf-8", "surrogatepass")).hexdigest()[:10]
    return f"{slug}~{digest}"


def inside(root: Path, relative: str) -> Path:
    """`root / relative`, refused (`ViewerError`) unless its resolved path lies inside the
    resolved `root` (a check of the path itself, not only of its spelling)."""
    base = root.resolve()
    target = (base / relative).resolve()
    if target == base or not target.is_relative_to(base):
        raise ViewerError(f"refusing to write {relative!r}: it is not inside {root}")
    return target

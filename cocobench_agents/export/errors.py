"""Why an export could not be made: a mistake of the user's (`ExportError`: one line, exit
code 2), or an output folder that could not be written (`ExportWriteError`: exit code 1)."""

from __future__ import annotations


class ExportError(ValueError):
    """An export that cannot be made as asked: a path that is not a finished run folder, an
    output folder in use, an unknown `--where` selector, a selection that keeps nothing."""


class ExportWriteError(RuntimeError):
    """The output folder could not be written (a full disk, no permission); what was written
    of this export is removed."""

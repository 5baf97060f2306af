"""Error types shared by the whole package.

`InputError` is a `ValueError` whose message is one readable line naming the offending file
(and row, where there is one). The CLI prints it as-is and exits with status 2.
"""

from __future__ import annotations

import re
from pathlib import Path


class InputError(ValueError):
    """Bad user input: a malformed file, an invalid value, an inconsistent argument.

    Parameters
    ----------
    message : str
        What is wrong, and what was expected.
    path : str or Path, optional
        The file the problem was found in.
    row : int, optional
        1-based line number in ``path``.
    """

    def __init__(self, message: str, path: str | Path | None = None, row: int | None = None):
        self.path = None if path is None else Path(path)
        self.row = row
        where = ""
        if path is not None:
            where = f"{path}"
            if row is not None:
                where += f", row {row}"
            where += ": "
        # one readable line, whatever the wrapped library's message looked like
        super().__init__(where + re.sub(r"\s*\n\s*", " ", str(message)).strip())

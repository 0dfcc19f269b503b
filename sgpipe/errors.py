"""The one exception type that means "the user's input is wrong" (exit status 2)."""

from __future__ import annotations


class BadInput(Exception):
    """Bad user input: a config, file, mesh or image. Rendered as one line naming file and key."""

    def __init__(self, message: str, *, file: str | None = None, key: str | None = None,
                 line: int | None = None):
        super().__init__(message)
        self.message = message
        self.file = str(file) if file is not None else None
        self.key = key
        self.line = line

    def one_line(self) -> str:
        where = []
        if self.file:
            where.append(self.file + (f":{self.line}" if self.line else ""))
        if self.key:
            where.append(self.key)
        prefix = ": ".join(where)
        msg = " ".join(self.message.split())
        return f"{prefix}: {msg}" if prefix else msg

"""Which rooms a command passes through, and whether it re-enters one.

``python tools/room_trace.py segment fandisk OUT.ply`` runs the command in process under
a profile hook that keeps the stack of rooms (``pointatlas.<room>``) of the Python
frames and counts every call that enters a room already on the stack below the caller's
(A -> B -> A): a room revisited other than by returning (issue 29: "every command's path
from flags to kernels reads top to bottom"). Callbacks handed down (a progress bar's
``advance``, a kernel given to ``_core``'s chunk runner) count too: they are named in
the listing. numba's compile-event listener (`pointatlas.cli._compile_notice`, called
from whichever kernel compiles first) is not on the path and is left out.
"""

from __future__ import annotations

import collections
import sys

#: Modules called by events rather than by the path (numba's compile listener).
LISTENERS = ("pointatlas.cli._compile_notice",)


def _room(frame) -> str | None:
    name = frame.f_globals.get("__name__", "")
    if not name.startswith("pointatlas") or name in LISTENERS:
        return None
    parts = name.split(".")
    return parts[1] if len(parts) > 1 else "pointatlas"


def room_reentries(argv: list[str]) -> tuple[collections.Counter, list[str]]:
    """Run ``pointatlas *argv`` in process; returns the re-entries as (caller's room,
    re-entered room) -> count, and the rooms in the order they were entered."""
    from pointatlas.cli import main

    stack: list[str] = []
    entered: list[str] = []
    again: collections.Counter = collections.Counter()

    def hook(frame, event, arg):
        if event == "call":
            room = _room(frame)
            if room is None:
                return
            if not stack or stack[-1] != room:
                if room in stack:
                    again[(stack[-1], room)] += 1
                entered.append(room)
            stack.append(room)
        elif event == "return" and stack and _room(frame) is not None:
            stack.pop()

    saved = sys.argv
    sys.argv = ["pointatlas", *argv]
    sys.setprofile(hook)
    try:
        main()
    except SystemExit as exc:
        if exc.code not in (0, None):
            raise
    finally:
        sys.setprofile(None)
        sys.argv = saved
    return again, entered


if __name__ == "__main__":
    reentries, rooms = room_reentries(sys.argv[1:])
    print(f"room entries: {len(rooms)}, rooms: {len(set(rooms))}", file=sys.stderr)
    print(f"re-entries of a room on the stack: {sum(reentries.values())}", file=sys.stderr)
    for (caller, room), count in reentries.most_common():
        print(f"  {caller} -> {room}: {count}", file=sys.stderr)

"""A command's path from flags to kernels reads top to bottom: no room is entered again
while it is on the stack, other than by returning (issue 29; tools/room_trace.py)."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

_spec = importlib.util.spec_from_file_location(
    "room_trace", Path(__file__).resolve().parents[2] / "tools" / "room_trace.py"
)
room_trace = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(room_trace)


@pytest.mark.parametrize(
    "argv",
    [
        ["normals", "torus_coarse", "{tmp}/n.ply"],
        ["features", "torus_coarse", "{tmp}/f.ply"],
        ["segment", "torus_coarse", "{tmp}/s.ply"],
        ["simplify", "torus_coarse", "{tmp}/s.obj"],
    ],
    ids=lambda argv: argv[0],
)
def test_no_room_entered_again_on_the_way_down(tmp_path, argv):
    again, rooms = room_trace.room_reentries([a.format(tmp=tmp_path) for a in argv])
    assert {"cli", "io"} <= set(rooms)  # the hook saw the command's path
    assert not again, dict(again)

"""Assemble docs/decisions.md, docs/benchmarks.md and docs/reproduction.md from docs/parts/."""

from __future__ import annotations

import pathlib

ROOT = pathlib.Path(__file__).resolve().parent.parent
PARTS = ROOT / "docs" / "parts"
ORDER = [
    "neighbors", "io", "normals", "synth", "data", "viz", "cli", "batch",
    "features", "segment", "complex", "simplify",
]
HEADERS = {
    "decisions": (
        "# Decisions\n\nEach decision the thesis left open (or the GUIDE fixed), by room. "
        "The code's docstrings say the same at the place where it applies.\n"
    ),
    "benchmarks": (
        "# Benchmarks\n\nEvery number below was measured with the command beside it, "
        "ours and the peer in the same run. Machine: 2 cores, shared; see each section "
        "for the load at the time. Peers come from the `bench` extra "
        "(`make bench` installs it; Open3D needs Debian's `libusb-1.0-0`).\n"
    ),
    "reproduction": (
        "# Reproduction of the thesis' tables and figures\n\nThesis numbers beside ours, "
        "with the command that regenerates ours.\n"
    ),
}


def main() -> None:
    for kind, header in HEADERS.items():
        files = sorted(PARTS.glob(f"*-{kind}.md"))
        rank = {name: i for i, name in enumerate(ORDER)}
        files.sort(key=lambda p: (rank.get(p.name.split("-")[0], 99), p.name))
        body = [header]
        for f in files:
            body.append(f.read_text().strip() + "\n")
        (ROOT / "docs" / f"{kind}.md").write_text("\n".join(body))
        print(f"docs/{kind}.md <- {[f.name for f in files]}")


if __name__ == "__main__":
    main()

"""Former name of `pointatlas.experiments.neighborhoods` (deprecated).

Its former function names (``run_neighbourhoods``, ...) are the deprecated aliases
of `pointatlas.experiments`, which warn when called; every other name is the new
module's.
"""

from . import (
    aggregate_neighbourhoods,
    neighborhoods,
    neighbourhood_model,
    run_neighbourhoods,
    write_neighbourhood_outputs,
)

__all__ = [
    "aggregate_neighbourhoods",
    "neighbourhood_model",
    "run_neighbourhoods",
    "write_neighbourhood_outputs",
]


def __getattr__(name: str):
    return getattr(neighborhoods, name)

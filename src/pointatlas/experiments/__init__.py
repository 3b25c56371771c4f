"""Layer 5: the thesis' reproductions, one module per study.

Each study has a pure per-model (or per-case) function, an aggregate and a writer;
``pointatlas experiment ...`` (the CLI) wraps them. Nothing but the CLI imports
this package.

- `table_4_1`: Table 4.1 and Fig. 4.5 (region growing against VSA);
- `simplify_cases`: thesis 4.4.3, Figs. 4.10-4.14 (simplified meshes);
- `weightings`: Fig. 5.3 (`fig_5_3`: three weightings side by side);
- `neighborhoods`: Tables 5.1/5.2, Figs. 5.4-5.6, 6.3, 6.6-6.8;
- `denoise`: Table 5.3 and Fig. 6.9 (normal filtering, flatness denoising);
- `cloud_surfaces`: Chapter A, Figs. 2.2-2.21 (cloud surfaces);
- `write_experiment_report`: the HTML report of any study (its tables and pictures).

The names below are the entry points of each study; the CLI imports the study
modules inside its commands (``from pointatlas.experiments.table_4_1 import
run_vsa_experiment``), so ``pointatlas --help`` stays fast.
"""

from .._core import deprecated_alias
from ._report import experiment_tables, write_experiment_report
from .cloud_surfaces import run_cloud_surfaces
from .denoise import fig_6_9, table_5_3, write_denoise_outputs
from .neighborhoods import (
    aggregate_neighborhoods,
    decrease_cases,
    energy_histogram,
    neighborhood_model,
    run_neighborhoods,
    write_neighborhood_outputs,
)
from .simplify_cases import run_case, write_simplify_outputs
from .table_4_1 import aggregate_vsa, run_vsa_experiment, vsa_model, write_vsa_outputs
from .weightings import fig_5_3

__all__ = [
    "aggregate_neighborhoods",
    "aggregate_vsa",
    "decrease_cases",
    "energy_histogram",
    "experiment_tables",
    "fig_5_3",
    "fig_6_9",
    "neighborhood_model",
    "run_case",
    "run_cloud_surfaces",
    "run_neighborhoods",
    "run_vsa_experiment",
    "table_5_3",
    "vsa_model",
    "write_denoise_outputs",
    "write_experiment_report",
    "write_neighborhood_outputs",
    "write_simplify_outputs",
    "write_vsa_outputs",
]

# Former (British) names: they still work and warn, naming the new name (not in __all__).
aggregate_neighbourhoods = deprecated_alias(aggregate_neighborhoods, "aggregate_neighbourhoods")
neighbourhood_model = deprecated_alias(neighborhood_model, "neighbourhood_model")
run_neighbourhoods = deprecated_alias(run_neighborhoods, "run_neighbourhoods")
write_neighbourhood_outputs = deprecated_alias(
    write_neighborhood_outputs, "write_neighbourhood_outputs"
)

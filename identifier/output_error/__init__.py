"""Output-error refinement: fit the coefficients to whole simulated manoeuvres.

The one place to import the refinement from. Its modules, one job each:

``records``
    the settings and result records (frozen dataclasses);
``objective``
    the output-error objective J(θ) and its least-squares solve;
``initial_state``
    a log's execute sample and the model's state there;
``prediction``
    a log predicted open loop from there;
``covariance``
    the Newey–West sandwich covariance of the optimum;
``guards``
    virtual hard-over turns and the keep/reject rules;
``refine``
    :func:`refine_output_error`, which composes them.
"""

from identifier.output_error.covariance import newey_west_covariance
from identifier.output_error.guards import (
    HARD_OVER_RAD,
    centripetal_is_a_ships,
    covers_turn,
    turn_spread,
    virtual_turns,
)
from identifier.output_error.initial_state import execute_state, fit_initial_state
from identifier.output_error.prediction import predict_log, track_distance_m
from identifier.output_error.records import (
    FitSummary,
    RefinementResult,
    RefineSettings,
    VirtualTurn,
)
from identifier.output_error.refine import refine_output_error

__all__ = [
    "HARD_OVER_RAD",
    "FitSummary",
    "RefineSettings",
    "RefinementResult",
    "VirtualTurn",
    "centripetal_is_a_ships",
    "covers_turn",
    "execute_state",
    "fit_initial_state",
    "newey_west_covariance",
    "predict_log",
    "refine_output_error",
    "track_distance_m",
    "turn_spread",
    "virtual_turns",
]

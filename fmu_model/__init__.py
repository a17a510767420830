"""Ship manoeuvring models: the equations (once), parameter sets, simulation, FMU export."""

from fmu_model.integrate import n_substeps
from fmu_model.numeric import NumericModel, numeric_model
from fmu_model.params import (
    ModelParameters,
    ParamsFormatError,
    load_params,
    params_from_json_dict,
    save_params,
)
from fmu_model.simulate import euler_step, rk4_step, simulate
from fmu_model.structure import ModelStructure, Term
from fmu_model.variants import DEFAULT_MODEL, get_model, model_names, register_model

__all__ = [
    "DEFAULT_MODEL",
    "ModelParameters",
    "ModelStructure",
    "NumericModel",
    "ParamsFormatError",
    "Term",
    "euler_step",
    "get_model",
    "load_params",
    "model_names",
    "n_substeps",
    "numeric_model",
    "params_from_json_dict",
    "register_model",
    "rk4_step",
    "save_params",
    "simulate",
]

"""The registered manoeuvring-model variants.

Each variant is a :class:`~fmu_model.structure.ModelStructure`: the accelerations as
sums of coefficient × regressor. Register a new one with :func:`register_model`;
callers find it by name (``get_model``) and need no change.
"""

from __future__ import annotations

from fmu_model.structure import ModelStructure, Term, delta, n, r, u, v

_REGISTRY: dict[str, ModelStructure] = {}


def register_model(structure: ModelStructure) -> ModelStructure:
    """Add a structure to the registry under its name; returns it for chaining."""
    if structure.name in _REGISTRY:
        raise ValueError(f"model {structure.name!r} is already registered")
    _REGISTRY[structure.name] = structure
    return structure


def get_model(name: str) -> ModelStructure:
    """Return the registered structure called ``name``.

    Raises
    ------
    KeyError
        With the list of known names when ``name`` is not registered.

    """
    try:
        return _REGISTRY[name]
    except KeyError:
        known = ", ".join(sorted(_REGISTRY))
        raise KeyError(f"unknown model {name!r} (known: {known})") from None


def model_names() -> tuple[str, ...]:
    """Names of all registered structures, sorted."""
    return tuple(sorted(_REGISTRY))


SHI2009 = register_model(
    ModelStructure(
        name="shi2009",
        description="Shi et al. (2009) nonlinear 3-DOF model, 16 constant coefficients",
        reference=(
            "Shi, C., Zhao, D., Peng, J., Shen, C. (2009). Identification of ship "
            "maneuvering model using extended Kalman filters. TransNav 3(1), eq. (2)"
        ),
        # Shi et al. (2009), eq. (2), f_u: surge, second-order Taylor expansion with the
        # zero-, first- and second-order resistance terms in u merged into a1 u^2.
        surge=(
            Term("a1", u**2),
            Term("a2", v**2),
            Term("a3", r**2),
            Term("a4", delta**2),
            Term("a5", v * r),
            Term("a6", v * delta),
            Term("a7", r * delta),
            Term("a8", u * n),
            Term("a9", n**2),
        ),
        # Shi et al. (2009), eq. (2), f_v: sway.
        sway=(
            Term("b1", v),
            Term("b2", r),
            Term("b3", delta),
            Term("b4", u * r),
        ),
        # Shi et al. (2009), eq. (2), f_r: yaw.
        yaw=(
            Term("c1", v),
            Term("c2", r),
            Term("c3", delta),
        ),
    )
)

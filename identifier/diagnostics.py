"""What a fit's estimate or logs leave in doubt: the warnings and notes of ``identify``.

Pure judgements of an estimate (its propeller thrust, its centripetal surge term), of
what the logs determine (a hard turn and its surge force, the response to a rudder
reversal; a current their headings barely tell from the ship's speed), of a current
asked of a model's logs, and of an approach at a helm off the centre line that the model
family has no term for. Each returns its text, or None where there is nothing to say.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from fmu_model import DEFAULT_MODEL, ModelParameters
from fmu_model.variants import (
    NEUTRAL_RUDDER_OFFSET,
    STRAIGHTENING_ASYMMETRY,
    WAKE_ASYMMETRY,
    family_name,
    parse_family,
)
from identifier.conventions import MIN_COMMAND_RAD, MIN_TURN_RAD
from identifier.current import MIN_HEADING_SPAN_RAD, CurrentEstimate, heading_span_rad
from identifier.output_error import centripetal_is_a_ships
from identifier.preparation import SmoothedLogs
from identifier.smoothing import SmoothedTrack
from trials.conditions import (
    MODEL_SCALE_MAX_LENGTH_M,
    approach_helm_rad,
    maneuver_kind,
    steady_heading,
)
from trials.logs import ManeuverLog

NEUTRAL_HELM_NOTE_RAD = math.radians(0.5)
"""An approach helm [rad] beyond which ``identify`` notes the neutral-rudder family: above a
rudder indicator's resolution, below the Mariner's 1.1° (the HSVA runs approach within 0.02°)."""

ASYMMETRY_SHAPE = (STRAIGHTENING_ASYMMETRY, WAKE_ASYMMETRY, NEUTRAL_RUDDER_OFFSET)
"""The shape constants that make a family's turns to the two sides differ (Δγ, dwake, δ₀):
held at 0 where the logs turn to one side only (:func:`one_sided_model`)."""


def thrust_warning(params: ModelParameters) -> str | None:
    """Return a warning when the estimate's propeller thrust is not a propeller's, else None.

    The thrust of the prime families, X_nn·n²L + X_un·u·n, is a fixed-pitch propeller's
    only with a thrust at bollard (X_nn > 0) that falls as the ship gains speed (X_un < 0:
    K_T falls with the advance ratio J). Logs at one rpm fix the sum at the approach, not
    the split; split the other way the model loses its thrust as it slows in a hard turn
    and may stop there (benchmarks/hsva.md, "The propeller thrust is why";
    ``prime-rudder-thrust`` fixes the split). Families without both terms: None.
    """
    coefficients = params.as_dict()
    if "X_nn" not in coefficients or "X_un" not in coefficients:
        return None
    if coefficients["X_nn"] > 0.0 and coefficients["X_un"] < 0.0:
        return None
    return (
        f"the identified propeller thrust is not a propeller's (X_nn = {coefficients['X_nn']:.3g}, "
        f"X_un = {coefficients['X_un']:.3g}; a thrust at bollard needs X_nn > 0, one that "
        "falls with speed X_un < 0): logs at one rpm fix the thrust at the approach only, "
        "and turns, where the ship slows, extrapolate badly; add a run at another rpm "
        "(an acceleration or a stopping run) or a turning circle, or fit with --model "
        "prime-rudder-thrust (a thrust of fixed open-water slope)"
    )


TURN_SURGE_TERMS = ("X_vr", "X_vv", "X_rr")
"""The prime families' surge terms of a hard turn: the centripetal v·r and the drag of
drift and yaw, which set the speed a model keeps in a turn."""

TURN_EXTRAPOLATION_EVIDENCE = (
    "from 10 and 20 deg zig-zags the default fit's 35 deg turns of three synthetic "
    "reference ships came out up to 16 % too tight, from 10 deg ones alone 15-31 % too "
    "tight or spiralling in (at 1 m GNSS noise also up to 113 % too wide), and those "
    "fitted to the measured KVLCC2 model's zig-zags (HSVA) wider than its MMG reference's: "
    'benchmarks/fidelity.md, "How far a turn is extrapolated"'
)
"""What the benchmarks found of zig-zag-trained turns (:func:`turn_warning`): off either
way, the direction a matter of the hull."""


def turn_warning(
    weak: Sequence[str],
    *,
    turn_logged: bool,
    largest_rudder_rad: float,
    held: Sequence[str] = (),
) -> str | None:
    """Return a warning when no log turns through 180°: the turns are extrapolated.

    A hard turn predicted from zig-zags is an extrapolation in rudder angle, yaw rate and
    drift: on the synthetic reference ships it came out too tight, the more so the smaller
    the logs' rudder, and on the measured KVLCC2 model too wide
    (:data:`TURN_EXTRAPOLATION_EVIDENCE`); ``largest_rudder_rad`` is the logs' largest
    rudder angle [rad]. ``weak``: the coefficients the logs do not determine; zig-zags
    leave :data:`TURN_SURGE_TERMS` open, and those alone move the held-out 35° turn of a
    KVLCC2 fit by 30 points ("Where the KVLCC2 turn's error lives"); the warning names
    them. ``held``: the coefficients the family holds by a zero-mean prior (the
    default's X_vv, X_rr, ``fmu_model.variants.with_surge_drag_prior``); the warning says
    which of the open ones keep the prior's value rather than the logs'. None when a log
    turns through 180° (``turn_logged``: it fixes the turn).
    """
    if turn_logged:
        return None
    text = (
        "no log turns through 180 deg: the model's turning circles are extrapolated from "
        f"a rudder of at most {math.degrees(largest_rudder_rad):.1f} deg "
        f"({TURN_EXTRAPOLATION_EVIDENCE})"
    )
    open_terms = [name for name in TURN_SURGE_TERMS if name in weak]
    if open_terms:
        by_prior = [name for name in open_terms if name in held]
        keep = "keeps" if len(by_prior) == 1 else "keep"
        prior = (
            f"; {', '.join(by_prior)} {keep} the family's prior (near zero, a ship's size)"
            if by_prior
            else ""
        )
        text += (
            f"; the surge force of a hard turn ({', '.join(open_terms)}) is not determined "
            "by these logs, and it sets the speed the model keeps in a turn (on the KVLCC2 "
            f"reference these terms alone move a zig-zag fit's 35 deg tactical diameter by "
            f"30 points){prior}"
        )
    return text + "; add a turning circle to the logs"


def reversal_warning(logs: Sequence[ManeuverLog]) -> str | None:
    """Return a warning when no log reverses its rudder (turning circles only), else None.

    A turn holds its rudder to one side: it fixes the steady turn's balance of rudder
    and yaw damping, not the response to a reversal, which a zig-zag's overshoots are.
    Trained on the 35° turns to both sides (1 Hz, 1 m, 0.1°; by hand, 2026-12-07), the
    default fit of the KVLCC2 reference predicts the 10°/10° zig-zag's overshoots 3.3° /
    4.4° against 5.0° / 14.0° (its EKF estimate diverges in it), the Mariner's 1.1° / 0.2°
    against 6.4° / 5.6°; no envelope warns of it, for a 10° rudder is within a turn's 35°.
    The mirror of :func:`turn_warning`. When the turns are all to one side, the
    other side's turn is extrapolated too, as their mirror (:func:`one_sided_model`).
    """
    if any(maneuver_kind(log) == "zigzag" for log in logs):
        return None
    warning = (
        "no log reverses its rudder (turning circles only): the model's response to a "
        "rudder reversal, a zig-zag's overshoots, is not determined by these logs (on the "
        "KVLCC2 reference two 35 deg turns predict the 10/10 zig-zag's second overshoot at "
        "4.4 deg against 14.0)"
    )
    side = logged_side(logs)
    if side is None:
        return warning + "; add a zig-zag to the logs"
    other = "port" if side == "starboard" else "starboard"
    return warning + (
        f", and they turn to {side} only: the {other} turn is extrapolated too (as the "
        f"mirror of the {side} one); add a zig-zag and a turn to {other}"
    )


def logged_side(logs: Sequence[ManeuverLog]) -> str | None:
    """Return ``"starboard"`` or ``"port"`` when the logs turn the ship to that side only.

    A log turns to a side when its rudder goes there by
    :data:`~identifier.conventions.MIN_COMMAND_RAD` or more (a command) and its heading
    swings there by :data:`~identifier.conventions.MIN_TURN_RAD` or more (from its last
    extreme the other way; a five-sample median first, so that a compass spike is no
    swing): a turning circle turns to one side, a zig-zag to both, and the corrections
    of an approach held on course, rudder to the other side beyond 5° included, to
    neither. None when the logs turn both ways, or neither.
    """
    sides = set().union(*(_sides_turned(log) for log in logs))
    return sides.pop() if len(sides) == 1 else None


def _sides_turned(log: ManeuverLog) -> set[str]:
    """Return the sides ``log`` turns the ship to (:func:`logged_side`)."""
    heading = steady_heading(log)
    sides: set[str] = set()
    for side, sign in (("starboard", 1.0), ("port", -1.0)):
        swing = sign * heading - np.minimum.accumulate(sign * heading)
        if np.max(sign * log.rudder_rad) >= MIN_COMMAND_RAD and np.max(swing) >= MIN_TURN_RAD:
            sides.add(side)
    return sides


def one_sided_model(logs: Sequence[ManeuverLog], model: str) -> tuple[str, str] | None:
    """Hold a family's asymmetry at 0 where the logs turn to one side only; the model, a note.

    One side's turns cannot tell the family's asymmetric constants (:data:`ASYMMETRY_SHAPE`)
    from its others, and searched they made the other side's turn anything: from one
    starboard 35° turn (KVLCC2 seeds 1, 2, 5, the Mariner's and the tanker's 1, 2; by
    hand, 2026-12-07) the default fit's worse tactical diameter of the two sides came out
    2.2–76 % off, 257 points in sum over six and one port turn lost; held at 0 (the other
    side the logged one's mirror) 0.8–27 %, 44 in sum over all seven, within 5.7 % in six
    (δ₀ searched alone: 60 in sum, the Mariner's 24 %). Those the model name fixes stay as
    given. None when the logs turn both ways or the model has none of them free.
    """
    side = logged_side(logs)
    parsed = parse_family(model)
    if side is None or parsed is None:
        return None
    family, fixed = parsed
    held = [c.name for c in family.shape if c.symbol in ASYMMETRY_SHAPE and c.name not in fixed]
    if not held:
        return None
    name = family.structure_name({**fixed, **dict.fromkeys(held, 0.0)})
    note = (
        f"the logs turn to {side} only: {', '.join(held)} held at 0 ({name}), the other "
        "side's turn the mirror of theirs; one side does not determine them, and searched "
        "they put the other turn's tactical diameter up to 76 % off on the reference ships"
    )
    return name, note


def model_current_warning(length_m: float, current: CurrentEstimate | None) -> str | None:
    """Return a warning when a model's fit was asked for a current no speed log measures.

    Below ``MODEL_SCALE_MAX_LENGTH_M`` the logs are mostly a model's in a basin, whose
    water is still: a current estimated there is the structure's error (the HSVA runs:
    0.03–0.04 m/s at 1.18 m/s), traded against the hull's coefficients. Not for
    ``--current auto``, a model's default, which keeps a current only where the logs show
    one (``identifier.current.choose_current``). None otherwise.
    """
    if length_m >= MODEL_SCALE_MAX_LENGTH_M or current is None or current.measured:
        return None
    return (
        f"L = {length_m:g} m, a model's size: in a basin's still water the current found "
        f"here ({current.speed_mps:.3f} m/s) is the structure's error, and it trades against "
        "the hull's coefficients; fit tank tests with --current none (or auto, the default "
        "at this size)"
    )


def centripetal_warning(params: ModelParameters) -> str | None:
    """Return a warning when the estimate's surge v·r term has no ship's sign, else None.

    ``identifier.output_error.guards.centripetal_is_a_ships``: X_vr > 0, about 1–2 (the
    HSVA 10/10 pair fitted with a current estimated: −20, benchmarks/hsva.md, "Where the
    20°/10° second overshoots go wrong"). The refinement keeps no estimate that breaks
    it; a start that has it is warned of. Families without the term: None.
    """
    if centripetal_is_a_ships(params):
        return None
    return (
        f"the identified centripetal surge term X_vr = {params.as_dict()['X_vr']:.3g} is not "
        "positive, as a ship's is ((m + m_y)/(m + m_x), about 1 to 2): the speed the model "
        "keeps in harder manoeuvres than the logs' is not to be trusted; add a turning "
        "circle, or fit tank tests with --current none"
    )


def neutral_helm_note(data: SmoothedLogs, model: str) -> str | None:
    """Say when the logs approach at a helm off the centre line the model has no term for.

    A single-screw ship runs straight at a neutral helm off the centre line (the Mariner
    reference 1.1° to port); the default family and ``prime-rudder-offset`` model it, the
    other families explain it by their hull and rudder gains (benchmarks/fidelity.md, "A
    ship of another structure"). None when every log's approach helm is within
    :data:`NEUTRAL_HELM_NOTE_RAD` of amidships, or the model has the offset.
    """
    parsed = parse_family(model)
    if parsed is not None and parsed[0].has(NEUTRAL_RUDDER_OFFSET):
        return None
    helms = [approach_helm_rad(log) for log in data.logs]
    i = int(np.argmax(np.abs(helms)))
    if abs(helms[i]) <= NEUTRAL_HELM_NOTE_RAD:
        return None
    return (
        f"{data.names[i]} approaches at a helm of {math.degrees(helms[i]):+.2f} deg "
        f"(mean rudder before execute): a single screw's neutral helm, which "
        f"{family_name(model)} has no term for; --model {DEFAULT_MODEL} has one"
    )


def heading_span_warning(current: CurrentEstimate, tracks: Sequence[SmoothedTrack]) -> str | None:
    """Return a warning when the logs' headings barely tell a current from the ship's speed.

    A current along the course and the ship's own speed move the track alike; headings
    spanning less than ``MIN_HEADING_SPAN_RAD`` tell them apart poorly. Judged on the
    logs together, or with a current per log on each log alone; a current a speed log
    measures needs no span. None otherwise.
    """
    if current.logs:  # each current is told from its own log alone
        span_rad = min(
            (heading_span_rad([t]) for c, t in zip(current.logs, tracks, strict=True)
             if not c.measured),
            default=math.inf,
        )  # fmt: skip
    else:
        span_rad = math.inf if current.measured else heading_span_rad(tracks)
    if span_rad >= MIN_HEADING_SPAN_RAD:
        return None
    whose = "a log's" if current.logs else "the logs'"
    return (
        f"{whose} headings span {math.degrees(span_rad):.0f} deg: "
        "the current along the course is barely told apart from the ship's own "
        "speed (add a turning circle of 360 deg or more, or runs on other headings, "
        "or a speed log's column stw_mps, or fit with --current none if the water "
        "was still)"
    )

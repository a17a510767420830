"""The envelope of the logged manoeuvres, and where validation says a prediction leaves it.

The envelope of samples is checked by hand (``fmu_model.envelope``); a validation with an
envelope marks the manoeuvres beyond it in its table, report and JSON. (That the
identification records the envelope of its logs: ``test_identify``.)
"""

from __future__ import annotations

import json
import math
from dataclasses import replace

import numpy as np
import pytest

from fmu_model.envelope import (
    AXES,
    MARGIN,
    SPEED_RATIO_MARGIN,
    Envelope,
    ExtrapolationWatch,
    Sides,
    Span,
    envelope_of,
    instant_envelope,
    union,
)
from scenarios.records import Validation
from scenarios.report import comparison_table, render_markdown, validation_json
from tests.test_report_uncertainty import BANDS, _validation
from trials.trajectory import empty_trajectory

LOGGED = Envelope(
    rudder_max_rad=Sides(0.2, 0.3),
    yaw_rate_max=Sides(0.5, 0.4),
    speed_ratio_min=0.8,
    approach_speed_mps=Span(5.0, 6.0),
    propeller_rate_rps=Span(1.0, 1.0),
)
ANY_SPEED = Span(0.01, 100.0)
ANY_RATE = Span(0.0, 100.0)


def test_the_envelope_of_samples_by_hand() -> None:
    """L = 100 m; the last sample at 0.1 U0 is too slow for an r′ (it would be 1.0)."""
    rudder = np.array([0.0, 0.1, -0.2, 0.3])
    r = np.array([0.0, 0.01, -0.02, 0.005])
    speed = np.array([5.0, 5.0, 4.0, 0.5])
    n = np.array([1.5, 1.5, 1.0, 0.0])
    e = envelope_of(rudder, r, speed, n, 100.0)
    assert e.rudder_max_rad == pytest.approx(Sides(0.2, 0.3))
    assert e.yaw_rate_max == pytest.approx(Sides(0.02 * 100.0 / 4.0, 0.01 * 100.0 / 5.0))
    assert e.speed_ratio_min == pytest.approx(0.1)
    assert e.approach_speed_mps == Span(5.0, 5.0)
    assert e.propeller_rate_rps == Span(0.0, 1.5)
    ones = np.ones(2)
    one_sided = envelope_of(np.array([0.0, 0.2]), np.array([0.0, 0.01]), ones, ones, 10.0)
    assert one_sided.rudder_max_rad.port == 0.0 and one_sided.yaw_rate_max.port == 0.0


def test_union_is_the_widest_on_every_axis() -> None:
    other = Envelope(Sides(0.35, 0.1), Sides(0.2, 0.6), 0.9, Span(5.5, 7.0), Span(0.5, 0.8))
    widest = Envelope(Sides(0.35, 0.3), Sides(0.5, 0.6), 0.8, Span(5.0, 7.0), Span(0.5, 1.0))
    assert union([LOGGED, other]) == widest


@pytest.mark.parametrize(
    ("run", "reasons"),
    [
        (LOGGED, ()),
        (
            replace(LOGGED, rudder_max_rad=Sides(0.2 * (1 + MARGIN) * 0.999, 0.3)),
            (),
        ),
        (
            replace(LOGGED, rudder_max_rad=Sides(0.2 * (1 + MARGIN) * 1.001, 0.3)),
            (f"rudder {math.degrees(0.2 * (1 + MARGIN) * 1.001):.1f} deg to port",),
        ),
        (
            replace(LOGGED, yaw_rate_max=Sides(0.5, 0.45)),
            ("yaw rate r' 0.45 to starboard (logs: 0.40)",),
        ),
        (replace(LOGGED, speed_ratio_min=0.8 - 0.999 * SPEED_RATIO_MARGIN), ()),
        (
            replace(LOGGED, speed_ratio_min=0.6),
            ("speed down to 0.60 U0 (logs: 0.80 U0)",),
        ),
        (replace(LOGGED, approach_speed_mps=Span(4.76, 6.29)), ()),
        (
            replace(LOGGED, approach_speed_mps=Span(4.7, 4.7)),
            ("approach speed 4.7 m/s (logs: 5-6 m/s)",),
        ),
        (
            replace(LOGGED, approach_speed_mps=Span(5.0, 6.4)),
            ("approach speed 5-6.4 m/s (logs: 5-6 m/s)",),
        ),
        (replace(LOGGED, propeller_rate_rps=Span(0.951, 1.049)), ()),
        (
            replace(LOGGED, propeller_rate_rps=Span(1.2, 1.2)),
            ("propeller 72 rpm (logs: 60 rpm)",),
        ),
        (
            replace(LOGGED, propeller_rate_rps=Span(0.0, 1.0)),
            ("propeller 0-60 rpm (logs: 60 rpm)",),
        ),
        (
            Envelope(Sides(0.6, 0.6), Sides(0.9, 0.9), 0.4, Span(9.0, 9.0), Span(2.0, 2.0)),
            (
                "rudder",
                "rudder",
                "yaw rate",
                "yaw rate",
                "speed down",
                "approach speed",
                "propeller",
            ),
        ),
    ],
    ids=[
        "same",
        "rudder-inside-margin",
        "rudder-beyond",
        "yaw-rate-starboard",
        "speed-inside-margin",
        "speed-beyond",
        "approach-inside-margin",
        "approach-slower",
        "approach-faster",
        "rpm-inside-margin",
        "rpm-higher",
        "rpm-stopped",
        "every-axis",
    ],
)
def test_beyond_names_each_axis_and_side_past_its_margin(
    run: Envelope, reasons: tuple[str, ...]
) -> None:
    said = LOGGED.beyond(run)
    assert len(said) == len(reasons)
    assert all(s.startswith(r) for s, r in zip(said, reasons, strict=True))
    axes = [axis for axis, _ in LOGGED.beyond_by_axis(run)]
    assert axes == [axis for axis in AXES if axis in axes]  # named as, and in the order of, AXES


def test_every_axis_and_side_is_one_of_the_axes() -> None:
    """All seven at once, in AXES order: the FMU's warnings are keyed (bits) by them."""
    run = Envelope(Sides(0.6, 0.6), Sides(0.9, 0.9), 0.4, Span(9.0, 9.0), Span(2.0, 2.0))
    assert [axis for axis, _ in LOGGED.beyond_by_axis(run)] == list(AXES)


def test_describe_says_every_axis_in_the_units_of_the_logs() -> None:
    assert LOGGED.describe() == (
        "rudder 11.5 deg to port, 17.2 deg to starboard; r' 0.50 to port, 0.40 to starboard; "
        "speed down to 0.80 U0 from approach speeds of 5-6 m/s; propeller at 60 rpm"
    )
    assert Span(1.0, 1.0004).said(60.0, "rpm") == "60 rpm"  # ends that read the same: one


def test_an_instant_by_hand_and_the_watch_says_each_axis_once() -> None:
    """L = 100 m, U0 = 5 m/s: at u = 4, v = 3 (U = 5), r = 0.03 rad/s, r' = 0.6 > 0.4 × 1.05
    to starboard; the rudder 0.1 rad to port is inside 0.2; 1.2 rev/s is past 1.0 × 1.05."""
    instant = instant_envelope(-0.1, 1.2, [4.0, 3.0, 0.03], 5.0, 100.0)
    assert instant == Envelope(
        Sides(0.1, 0.0), Sides(0.0, 0.6), 1.0, Span(5.0, 5.0), Span(1.2, 1.2)
    )
    watch = ExtrapolationWatch(LOGGED)
    prefix = "fmi2DoStep: t = 2.5 s: beyond the identification logs, the model extrapolates: "
    assert watch.news("fmi2DoStep", 2.5, instant) == [
        prefix + "yaw rate r' 0.60 to starboard (logs: 0.40)",
        prefix + "propeller 72 rpm (logs: 60 rpm)",
    ]
    assert watch.news("fmi2DoStep", 3.0, instant) == []  # once per axis and side
    assert watch.warned == {"yaw rate to starboard", "propeller"}
    # Below 0.2 U0 there is no r'; from rest (U0 = 0) no speed ratio either.
    assert instant_envelope(0.0, 1.0, [0.5, 0.0, 0.1], 5.0, 100.0).yaw_rate_max == (0.0, 0.0)
    from_rest = instant_envelope(0.0, 1.0, [1.0, 0.0, 0.1], 0.0, 100.0)
    assert (from_rest.speed_ratio_min, from_rest.yaw_rate_max) == (1.0, (0.0, 0.0))


def test_the_record_survives_json_and_bad_records_are_none() -> None:
    record = json.loads(json.dumps(LOGGED.as_dict()))
    assert Envelope.from_dict(record) == LOGGED
    assert Envelope.from_dict({**record, "speed_ratio_min": math.nan}) is None
    assert Envelope.from_dict({**record, "yaw_rate_max": {"port": 0.1}}) is None
    assert Envelope.from_dict({**record, "rudder_max_rad": "wide"}) is None
    assert Envelope.from_dict({**record, "approach_speed_mps": {"low": 5.0, "high": "6"}}) is None
    assert Envelope.from_dict({**record, "propeller_rate_rps": None}) is None
    assert Envelope.from_dict({}) is None


def _sailed(validation: Validation) -> Validation:
    """The fabricated validation's predicted runs with trajectories: a 35° starboard turn
    (r′ 0.5 at half speed) and a 10° zig-zag (r′ ±0.3, no speed lost); L = 100 m."""
    turn, zz = validation.predicted
    t_turn, t_zz = empty_trajectory(3), empty_trajectory(3)
    t_turn["rudder_rad"] = [0.0, math.radians(35.0), math.radians(35.0)]
    t_turn["u_mps"] = [5.0, 4.0, 2.5]
    t_turn["r_radps"] = [0.0, 0.005, 0.0125]
    t_zz["rudder_rad"] = [0.0, math.radians(10.0), -math.radians(10.0)]
    t_zz["u_mps"] = [5.0, 5.0, 5.0]
    t_zz["r_radps"] = [0.0, 0.015, -0.015]
    return replace(
        validation,
        predicted=(replace(turn, trajectory=t_turn), replace(zz, trajectory=t_zz)),
    )


def test_a_validation_marks_the_manoeuvres_beyond_the_logs() -> None:
    """Logs of 10° zig-zags (r′ 0.3, speed 0.95 U0): the turn goes beyond on its side's
    rudder and yaw rate and in speed; the zig-zag stays inside."""
    ten_deg = Sides(math.radians(10.0), math.radians(10.0))
    logs = Envelope(ten_deg, Sides(0.3, 0.3), 0.95, ANY_SPEED, ANY_RATE)
    v = replace(_sailed(_validation(BANDS)), envelope=logs)
    assert v.extrapolation == {
        "turning-35-stbd": (
            "rudder 35.0 deg to starboard (logs: 10.0 deg)",
            "yaw rate r' 0.50 to starboard (logs: 0.30)",
            "speed down to 0.50 U0 (logs: 0.95 U0)",
        ),
        "zigzag-10-10-stbd": (),
    }
    header, rows = comparison_table(v.rows, v.extrapolation)
    assert header[-1] == "beyond the logs"
    assert [row[-1] for row in rows] == ["yes"] * 3 + ["no"] * 2
    text = render_markdown(v)
    assert "- turning-35-stbd: rudder 35.0 deg to starboard (logs: 10.0 deg); yaw rate" in text
    # BANDS: the zig-zag's first overshoot is outside, its second has no interval.
    assert "; of the manoeuvres within the logs' envelope: 0 of 1." in text
    record = validation_json(v)["extrapolation"]
    assert record["envelope"] == json.loads(json.dumps(logs.as_dict()))
    assert record["beyond"]["zigzag-10-10-stbd"] == []
    assert len(record["beyond"]["turning-35-stbd"]) == 3
    assert (record["n_in_interval_within"], record["n_with_interval_within"]) == (0, 1)


def test_without_an_envelope_nothing_is_judged() -> None:
    v = _sailed(_validation(None))
    assert v.extrapolation is None
    assert comparison_table(v.rows, v.extrapolation)[0][-1] == "difference"
    assert "beyond" not in render_markdown(v)
    assert validation_json(v)["extrapolation"] is None
    everything = Envelope(Sides(1.0, 1.0), Sides(1.0, 1.0), 0.1, ANY_SPEED, ANY_RATE)
    inside = replace(v, envelope=everything)
    assert "Every predicted manoeuvre stays within them." in render_markdown(inside)

"""Write an NMEA 0183 recording of KVLCC2 manoeuvres, as a ship's logger would.

Stands in for "your own trial data" in the README walkthrough: the KVLCC2 reference
ship plays a manoeuvre (``scenarios.synthesize``), and its noisy track is written as
GGA + RMC position fixes on WGS84 (through the inverse of the azimuthal equidistant
plane that ``identifier convert`` uses), HDT heading, RSA rudder angle and RPM shaft
speed, once per second, with checksums. At sea (``--current-mps C --current-to-deg D``)
also VBW from a two-axis Doppler log at ``--speed-log-x-m`` forward of midship (water
speeds only); with ``--gnss-x-m`` the fixes are those of an antenna that far forward
(negative: aft, as a bridge's); with ``--gnss-jump-pct P`` P % of them jump 50-1000 m, as
a receiver's glitches do (``scenarios.synthesize.with_gnss_jumps``).

    python examples/own_data/record_nmea.py --maneuver zigzag-10 -o recordings/zz10.nmea
    python examples/own_data/record_nmea.py --maneuver zigzag-10 --current-mps 0.5 \
        --current-to-deg 45 --gnss-x-m -128 --speed-log-x-m 128 --gnss-jump-pct 1 \
        -o recordings/sea.nmea
"""

from __future__ import annotations

import argparse
import datetime as dt
import math
import sys
from functools import reduce

import pyproj

from fmu_model.atomic import write_atomic
from scenarios.sea import SeaEnvironment
from scenarios.synthesize import (
    MANEUVERS,
    maneuver_seed,
    reference_ship,
    synthesize_log,
    with_gnss_jumps,
)

ORIGIN_LAT_DEG, ORIGIN_LON_DEG = 63.4305, 10.3951  # Trondheimsfjorden
START = dt.datetime(2024, 5, 17, 10, 0, 0, tzinfo=dt.UTC)
KNOT_MPS = 1852.0 / 3600.0


def _sentence(body: str) -> str:
    checksum = reduce(lambda acc, ch: acc ^ ord(ch), body, 0)
    return f"${body}*{checksum:02X}"


def _angle(value_deg: float, degree_digits: int, hemispheres: str) -> tuple[str, str]:
    hemisphere = hemispheres[0] if value_deg >= 0.0 else hemispheres[1]
    value = abs(value_deg)
    degrees = int(value)
    minutes = (value - degrees) * 60.0
    return f"{degrees:0{degree_digits}d}{minutes:010.7f}", hemisphere


def nmea_lines(
    maneuver: str,
    seed: int,
    *,
    sea: SeaEnvironment | None = None,
    gnss_x_m: float = 0.0,
    speed_log_x_m: float = 0.0,
    gnss_jump_fraction: float = 0.0,
) -> list[str]:
    """Return the NMEA sentences of one synthetic KVLCC2 manoeuvre.

    In ``sea`` with a two-axis speed log at ``speed_log_x_m`` forward of midship (VBW);
    the fixes at ``gnss_x_m`` forward of midship, ``gnss_jump_fraction`` of them jumped.
    """
    log = synthesize_log(
        reference_ship("kvlcc2", "full", sea),
        MANEUVERS[maneuver](),
        seed=seed,
        speed_log_axes=2 if sea is not None else 1,
        speed_log_x_m=speed_log_x_m,
        gnss_x_m=gnss_x_m,
    )
    if gnss_jump_fraction > 0.0:
        log = with_gnss_jumps(log, gnss_jump_fraction, maneuver_seed(seed, "gnss-jumps"))[0]
    plane = pyproj.Proj(
        f"+proj=aeqd +lat_0={ORIGIN_LAT_DEG} +lon_0={ORIGIN_LON_DEG} +datum=WGS84 +units=m"
    )
    lon, lat = plane(log.y_m, log.x_m, inverse=True)
    lines = []
    for k in range(log.n_samples):
        stamp = START + dt.timedelta(seconds=float(log.time_s[k]))
        hhmmss = stamp.strftime("%H%M%S.%f")[:9]
        lat_text, ns = _angle(float(lat[k]), 2, "NS")
        lon_text, ew = _angle(float(lon[k]), 3, "EW")
        heading = math.degrees(float(log.heading_rad[k])) % 360.0
        lines.append(
            _sentence(f"GPGGA,{hhmmss},{lat_text},{ns},{lon_text},{ew},1,10,0.8,5.0,M,40.0,M,,")
        )
        lines.append(
            _sentence(
                f"GPRMC,{hhmmss},A,{lat_text},{ns},{lon_text},{ew},15.5,{heading:.1f},"
                f"{stamp:%d%m%y},,,A"
            )
        )
        lines.append(_sentence(f"HEHDT,{heading:.2f},T"))
        lines.append(_sentence(f"IIRSA,{math.degrees(float(log.rudder_rad[k])):.2f},A,,V"))
        lines.append(_sentence(f"IIRPM,S,0,{float(log.n_rps[k]) * 60.0:.1f},,A"))
        if log.stw_mps is not None and log.stw_transverse_mps is not None:
            along, across = (float(z[k]) / KNOT_MPS for z in (log.stw_mps, log.stw_transverse_mps))
            lines.append(_sentence(f"VDVBW,{along:.3f},{across:.3f},A,,,V"))
    return lines


def main(argv: list[str] | None = None) -> int:
    """Write the recording; return the exit status."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--maneuver", choices=sorted(MANEUVERS), default="zigzag-10")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--current-mps", type=float, help="a current (at sea: VBW too) [m/s]")
    parser.add_argument("--current-to-deg", type=float, default=0.0, help="it sets towards")
    parser.add_argument("--gnss-x-m", type=float, default=0.0, help="antenna forward [m]")
    parser.add_argument("--speed-log-x-m", type=float, default=0.0, help="log forward [m]")
    parser.add_argument("--gnss-jump-pct", type=float, default=0.0, help="glitched fixes [%%]")
    parser.add_argument("-o", "--output", required=True)
    args = parser.parse_args(argv)
    sea = None
    if args.current_mps is not None:
        sea = SeaEnvironment(
            current_speed_mps=args.current_mps, current_to_rad=math.radians(args.current_to_deg)
        )
    lines = nmea_lines(
        args.maneuver,
        args.seed,
        sea=sea,
        gnss_x_m=args.gnss_x_m,
        speed_log_x_m=args.speed_log_x_m,
        gnss_jump_fraction=args.gnss_jump_pct / 100.0,
    )
    write_atomic(args.output, "\r\n".join(lines) + "\r\n")
    print(f"wrote {args.output}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

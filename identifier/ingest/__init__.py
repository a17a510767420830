"""Convert raw trial recordings (NMEA 0183, latitude/longitude CSV) into trial logs.

:func:`convert_file` (or :func:`convert_nmea`, :func:`convert_latlon_csv`) turns one
recording into :class:`~trials.logs.ManeuverLog` objects, which
``python -m identifier convert INPUT... -o DIR|FILE`` (:mod:`identifier.cli.convert`)
writes with :func:`~trials.logs.write_log`: ``DIR/<input stem>_<k>.csv``, or ``FILE``
when there is a single log (see :func:`output_paths`).

One job per module:

======================================= =============================================
:mod:`identifier.ingest.convert`        the public functions (this package's API)
:mod:`identifier.ingest.nmea`           the NMEA 0183 reader (its rules)
:mod:`identifier.ingest.latlon_csv`     the latitude/longitude CSV reader (its columns)
:mod:`identifier.ingest.assemble`       projection, gaps, resampling, log metadata
:mod:`identifier.ingest.geodesy`        the local tangent plane (:class:`TangentPlane`)
:mod:`identifier.ingest.recording`      the data passed between them
======================================= =============================================

What happens to a recording
---------------------------
1. Every sensor stream is read with its own sample times: position fixes (latitude,
   longitude), heading, rudder angle and propeller speed; from NMEA also, when the
   recording has them, the apparent wind (MWV) and the speed through the water (VHW,
   VBW).
2. The fixes are projected into a local tangent plane whose origin is the first
   valid fix (:class:`TangentPlane`): x North [m], y East [m]. Headings are turned
   from true North to the plane's x axis (meridian convergence, below 0.1 deg within
   5 km of the origin at 60 deg latitude).
3. Time 0 is the time of the first valid fix; ``time_origin_utc`` in the metadata
   says when that was (when the input gives a date).
4. Each stream is cut where it has no sample for longer than ``max_gap_s``; the
   recording is split into pieces where all four streams are present without such
   a gap. These gaps are reported in :attr:`ConversionResult.gaps` and the notes.
5. Each piece is resampled onto a common time base, by default the times of the
   position fixes in it, or a grid of ``rate_hz`` aligned to multiples of
   ``1 / rate_hz`` after the first fix. Heading, rudder and propeller speed are
   interpolated linearly (heading on the unwrapped angle), positions too on a
   ``rate_hz`` grid. A piece spans the time all streams have samples, widened by at
   most one time-base sample at each end: a stream whose first sample comes after a
   fix (grid time), by no more than one of the stream's own sample intervals and half
   of ``max_gap_s``, is extrapolated back to it along the line through its first two
   samples; the same after its last sample (noted, with the largest extrapolation of
   each stream). So the first fix of an NMEA recording is kept although its heading,
   rudder and RPM sentences follow it and get times just after it, and the last fix
   although the sentences after it have no later time stamp and are dropped.
   Positions are never extrapolated.
6. Pieces with fewer than ``min_samples`` samples are dropped with a note; the rest
   become logs, numbered in time order.
7. The optional streams (wind, speed through the water) do not split the recording:
   a log gets their columns (``wind_speed_mps``, ``wind_angle_deg``, ``stw_mps``,
   ``stw_transverse_mps``),
   resampled like the others, when the stream covers it without a gap longer than
   ``max_gap_s``; otherwise it has none (noted).

Metadata of the logs
--------------------
``vessel`` and ``length_m`` (when given), ``source`` (input file name and format,
which piece and its time span, the origin, the conventions applied, the counts of
skipped lines and checksum failures), ``origin_lat_deg``, ``origin_lon_deg``
(WGS84, full precision), ``time_origin_utc`` (ISO 8601 UTC time of time 0, when
known) and ``projection`` (the PROJ string of the plane, to map x/y back to
latitude/longitude).
"""

from __future__ import annotations

from identifier.ingest.convert import (
    convert_file,
    convert_latlon_csv,
    convert_nmea,
    detect_format,
    output_paths,
)
from identifier.ingest.geodesy import TangentPlane
from identifier.ingest.recording import (
    DEFAULT_MAX_GAP_S,
    MAX_RATE_HZ,
    MIN_RATE_HZ,
    ConversionResult,
)

__all__ = [
    "DEFAULT_MAX_GAP_S",
    "MAX_RATE_HZ",
    "MIN_RATE_HZ",
    "ConversionResult",
    "TangentPlane",
    "convert_file",
    "convert_latlon_csv",
    "convert_nmea",
    "detect_format",
    "output_paths",
]

"""Build the PID heading-autopilot FMU (``autopilot.py``) with pythonfmu.

    python examples/osp_autopilot/build_autopilot.py [-o build/osp_autopilot/autopilot.fmu]

The FMU holds pythonfmu's generic wrapper library (``binaries/linux64``, ``win64``) and,
in ``resources/``, ``autopilot.py`` and pythonfmu's Python sources. The importing tool
must be able to load a Python 3 interpreter (``needsExecutionTool="true"``); inside a
Python process (fmpy, libcosimpy) the running interpreter is used.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
SLAVE_SCRIPT = HERE / "autopilot.py"
DEFAULT_OUTPUT = Path("build") / "osp_autopilot" / "autopilot.fmu"


def build_autopilot_fmu(output: str | Path) -> Path:
    """Build the autopilot FMU and return its path.

    Parameters
    ----------
    output : str or pathlib.Path
        The ``.fmu`` file to write; parent folders are created. Its stem is free: the
        model identifier (and library name) is ``HeadingAutopilot``.

    Returns
    -------
    pathlib.Path
        ``output``.

    """
    from pythonfmu.builder import FmuBuilder

    output = Path(output)
    output.parent.mkdir(parents=True, exist_ok=True)
    # pythonfmu imports the script as a module by its name: keep this build from seeing
    # (or leaving behind) another ``autopilot`` module, so a host process that runs the
    # FMU later imports the FMU's own copy from its resources.
    saved_path = list(sys.path)
    saved_module = sys.modules.pop(SLAVE_SCRIPT.stem, None)
    try:
        # pythonfmu builds into ``dest`` (a file name ending in .fmu); build next to the
        # output and rename, so a reader never sees half an FMU.
        with tempfile.TemporaryDirectory(dir=output.parent, prefix=".autopilot-") as tmp:
            built = FmuBuilder.build_FMU(
                SLAVE_SCRIPT,
                dest=Path(tmp) / "autopilot.fmu",
                canGetAndSetFMUstate=True,
                canSerializeFMUstate=True,
            )
            Path(built).replace(output)
    finally:
        sys.path[:] = saved_path  # pythonfmu prepends the script's folder
        sys.modules.pop(SLAVE_SCRIPT.stem, None)
        if saved_module is not None:
            sys.modules[SLAVE_SCRIPT.stem] = saved_module
    return output


def main(argv: list[str] | None = None) -> int:
    """Command line: build the FMU and print its path."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("-o", "--output", type=Path, default=DEFAULT_OUTPUT, help="FMU to write")
    args = parser.parse_args(argv)
    print(build_autopilot_fmu(args.output))
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""Check, here, that the wheels in .whl/ and the GPU image's packages together hold everything
coopsat needs on CPython 3.12 for Linux x86_64, so that check.sh's install (``--no-deps``:
there is no registry there) does not fail on the device's time.

    python benchmarks/gpu/closure.py .whl KINDS.md

KINDS.md is the device tool's page of the image's packages (its "Packages:" line; wheels.sh
passes /work/.library/device/KINDS.md). Prints one line: what is missing, or that nothing is but the
packages carry.txt leaves out on purpose (the LMI solvers). Exit 1 when anything else is missing.
Names only: KINDS.md lists the image's packages without versions, so a requirement the image
holds at too old a version shows only there (``pip show NAME`` there costs little device time).
"""

import re
import sys
import zipfile
from pathlib import Path

from packaging.requirements import Requirement
from packaging.utils import canonicalize_name

# carry.txt leaves these out: coopsat imports them only in the design steps, which check.sh runs none of.
LEFT_OUT = {"cvxpy"}
# The device's python3 (KINDS.md: Python 3.12.3), as packaging's markers read it.
MARKERS = {"python_version": "3.12", "python_full_version": "3.12.3", "sys_platform": "linux",
           "platform_system": "Linux", "platform_machine": "x86_64", "implementation_name": "cpython",
           "platform_python_implementation": "CPython", "os_name": "posix"}


def image_packages(kinds_md):
    """Normalised names on the image's "Packages:" line of the device tool's KINDS.md."""
    line = Path(kinds_md).read_text().split("Packages: ", 1)[1].splitlines()[0]
    return {canonicalize_name(p.strip().rstrip(".")) for p in line.split(",") if p.strip()}


def wheel_requirements(folder):
    """{normalised name: [Requirement]} of every wheel in ``folder``, from its METADATA."""
    found = {}
    for wheel in Path(folder).glob("*.whl"):
        with zipfile.ZipFile(wheel) as z:
            meta = next(n for n in z.namelist() if n.endswith(".dist-info/METADATA"))
            text = z.read(meta).decode()
        name = canonicalize_name(re.search(r"^Name: (.+)$", text, re.M).group(1))
        found[name] = [Requirement(line.split(":", 1)[1]) for line in text.splitlines() if line.startswith("Requires-Dist:")]
    return found


def missing(carried, image):
    """(package, Requirement) pairs of the carried wheels (their base requirements: no extras)
    that neither the carried wheels nor the image hold."""
    have = set(carried) | image
    return [(name, req) for name, reqs in sorted(carried.items()) for req in reqs
            if (req.marker is None or req.marker.evaluate({**MARKERS, "extra": ""}))
            and canonicalize_name(req.name) not in have]


def main(folder, kinds_md):
    gaps = missing(wheel_requirements(folder), image_packages(kinds_md))
    unexpected = [(name, req) for name, req in gaps if canonicalize_name(req.name) not in LEFT_OUT]
    if unexpected:
        print("closure.py: missing on the device: " + "; ".join(f"{req} (for {name})" for name, req in unexpected))
        return 1
    print(f"closure.py: the carried wheels and the image hold all their requirements but {', '.join(sorted(LEFT_OUT))} (left out on purpose)")
    return 0


if __name__ == "__main__":
    sys.exit(main(*sys.argv[1:]))

#!/usr/bin/env bash
# Here, on a machine with the registry: the wheels benchmarks/gpu/check.sh needs on a lent GPU
# machine (no registry there), into .whl/ at the repository's root (git ignores it; the device
# call carries it). coopsat's wheel and oem's (published as an sdist only) are built here; the
# rest is what pip resolves for CPython 3.12 beside jax 0.11.2, kept to benchmarks/gpu/carry.txt.
#     bash benchmarks/gpu/wheels.sh        (PYTHON: the interpreter whose pip runs; .venv's)
set -euo pipefail
cd "$(dirname "$0")/../.."
py=${PYTHON:-.venv/bin/python}
grep -qx '/.whl/' .git/info/exclude 2>/dev/null || echo /.whl/ >> .git/info/exclude
rm -rf .whl .whl-build
mkdir -p .whl .whl-build/local
trap 'rm -rf .whl-build' EXIT
"$py" -m pip wheel -q --no-deps -w .whl-build/local . oem==0.4.5
plat=()
for p in manylinux_2_35 manylinux_2_34 manylinux_2_31 manylinux_2_28 manylinux_2_27 manylinux_2_24 manylinux_2_17 manylinux2014 manylinux1; do
  plat+=(--platform "${p}_x86_64")
done
"$py" -m pip download -q --only-binary=:all: --python-version 3.12 --implementation cp "${plat[@]}" \
  --find-links .whl-build/local -d .whl-build/all .whl-build/local/coopsat-*.whl jax==0.11.2 jaxlib==0.11.2
mapfile -t carry < <(grep -v '^#' benchmarks/gpu/carry.txt)
for f in .whl-build/all/*.whl; do
  name=$(basename "$f" | cut -d- -f1 | tr 'A-Z_.' 'a-z--')
  for c in "${carry[@]}"; do
    if [ "$name" = "$c" ]; then cp "$f" .whl/; fi
  done
done
found=$(ls .whl | wc -l)
[ "$found" -eq "${#carry[@]}" ] || { echo "wheels.sh: ${#carry[@]} packages in carry.txt, $found wheels found: $(ls .whl)" >&2; exit 1; }
# With the device tool's page of the image's packages at hand: nothing else is missing there.
kinds=${KINDS_MD:-/work/.library/device/KINDS.md}
if [ -f "$kinds" ]; then "$py" benchmarks/gpu/closure.py .whl "$kinds"; fi
echo "$found wheels in .whl ($(du -sh .whl | cut -f1)); carry it: run(command='bash benchmarks/gpu/check.sh', carry=['.whl'])"

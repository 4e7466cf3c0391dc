#!/usr/bin/env bash
# On a lent GPU machine (the device tool), from the repository's root, with .whl/ carried
# (benchmarks/gpu/wheels.sh makes it here): what issue 41 measures on a GPU, in one call of at most
# 9 minutes, each part under its own time limit so that a slow one leaves the others their figures:
#   1. the carried wheels installed beside the image's packages (about 20 s);
#   2. coopsat bench: N = 1000 at 2000 ticks on the GPU, then its GPU section (1e5 and 1e6
#      spacecraft, batches of 1e4 and 1e5 runs of N = 5), at most 240 s;
#   3. benchmarks/campaign_throughput.py: a campaign of RUNS (default 1e5) runs of
#      consensus-sync-a-stable, 100 s each, end to end on one worker, at most 200 s; then
#      run_batch of 200 runs (issue 41's CPU case), at most 60 s.
#     run(command="bash benchmarks/gpu/check.sh", carry=[".whl"], timeout_s=600)
# Everything it prints is also in $OUT/gpu-check.log. Here (no GPU), for a trial of the script:
#     PYTHON=.venv/bin/python RUNS=2000 BATCH=1000 bash benchmarks/gpu/check.sh
set -uo pipefail
cd "$(dirname "$0")/../.."
py=${PYTHON:-python3}
runs=${RUNS:-100000}
batch=${BATCH:-25000}
out=${OUT:-$(mktemp -d)}
mkdir -p "$out"
exec > >(tee "$out/gpu-check.log") 2>&1
if [ -z "${PYTHON:-}" ]; then
  "$py" -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade --target /tmp/site .whl/*.whl || exit
  export PYTHONPATH=/tmp/site
  export PATH=/tmp/site/bin:$PATH
else
  export PATH=$(dirname "$py"):$PATH
fi
export COOPSAT_JAX_CACHE=${COOPSAT_JAX_CACHE:-/tmp/coopsat-gpu-jax-cache}
command -v nvidia-smi >/dev/null && nvidia-smi --query-gpu=name,memory.total,driver_version --format=csv,noheader
"$py" -c "import jax, jaxlib, numpy, coopsat; print('jax', jax.__version__, 'jaxlib', jaxlib.__version__, 'numpy', numpy.__version__, jax.devices())"
echo "== coopsat bench"
SECONDS=0
timeout 240 coopsat bench --sizes 1000 --steps 2000 --batch 0 --orbit-sizes
echo "bench exit $? after $SECONDS s"
SECONDS=0
echo "== campaign throughput ($runs runs, batches of $batch)"
# Two processes: JAX takes 75 % of a GPU's memory in the first process that uses it, and the
# campaign's worker is a process of its own (its driver initialises no JAX backend).
timeout 200 "$py" benchmarks/campaign_throughput.py --runs "$runs" --workers 1 --batch-size "$batch" --t-final 100 --api-runs 0
echo "campaign exit $? after $SECONDS s"
SECONDS=0
timeout 60 "$py" benchmarks/campaign_throughput.py --runs --api-runs 200 --api-t-final 100
echo "run_batch exit $? after $SECONDS s"

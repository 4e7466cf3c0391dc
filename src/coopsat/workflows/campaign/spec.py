"""Campaign files: a scenario, a number of runs, a master seed and dispersions on its fields.

```toml
scenario = "consensus-sync-a-stable"   # bundled name, or a .toml path relative to this file
runs = 1000
master_seed = 2026
batch_size = 50                        # runs per task (one compiled, vmapped call)
overrides = ["sim.t_final_s=100"]      # applied to every run, before the dispersions
timeseries = ["omega"]                 # recorded outputs kept per run (Zarr), optional
decimate = 10                          # every 10th sample of them

[[dispersions]]
field = "spacecraft.*.inertia_kgm2"    # `*`: every element of that list
distribution = "normal"                # normal | uniform | choice
sigma = 0.05
mode = "relative"                      # relative: v·(1 + draw); absolute: v + draw; replace: draw
```

Run k draws from its own ``numpy.random.SeedSequence(master_seed).spawn(runs)[k]``: the
dispersions (in file order, one draw per number of the field), then the scenario ``seed`` of
the run (so noise and disturbance realisations differ between runs, and one run can be
replayed alone). The values applied are what the campaign stores with the run's results.
"""

import tomllib
from pathlib import Path
from typing import Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from coopsat.core.errors import InputError
from coopsat.scenarios.load import ScenarioError, clip_echo, format_validation_error, load_scenario, resolved_toml
from coopsat.workflows.campaign.catalogue import bundled_names as bundled_campaign_names
from coopsat.workflows.campaign.catalogue import bundled_path

MAX_RUNS = 10_000_000


class CampaignError(InputError):
    """A campaign file that cannot be run (one line naming the field)."""


class Dispersion(BaseModel):
    """One dispersed field."""

    model_config = ConfigDict(extra="forbid")

    field: str = Field(description="Scenario field path (`spacecraft.*.inertia_kgm2`, `controller.alpha`).")
    distribution: Literal["normal", "uniform", "choice"]
    mode: Literal["relative", "absolute", "replace"] = Field(
        "absolute", description="relative: v·(1 + draw); absolute: v + draw; replace: the draw itself."
    )
    mean: float = Field(0.0, description="normal: mean of the draw.")
    sigma: float | None = Field(None, description="normal: standard deviation of the draw (≥ 0).")
    low: float | None = Field(None, description="uniform: lower end of the draw.")
    high: float | None = Field(None, description="uniform: upper end of the draw.")
    values: list | None = Field(None, description="choice: the values to choose from (equally likely).")

    @model_validator(mode="after")
    def _parameters(self):
        if self.distribution == "normal":
            if self.sigma is None:
                raise ValueError("normal needs sigma")
            if not self.sigma >= 0:
                raise ValueError(f"sigma must be ≥ 0, got {self.sigma}")
        if self.distribution == "uniform":
            if self.low is None or self.high is None:
                raise ValueError("uniform needs low and high")
            if not self.high >= self.low:
                raise ValueError(f"uniform needs low ≤ high, got {self.low} > {self.high}")
        if self.distribution == "choice":
            if not self.values:
                raise ValueError("choice needs a non-empty list of values")
            if self.mode != "replace":
                raise ValueError('choice replaces the value: set mode = "replace"')
        return self


class Campaign(BaseModel):
    """A validated campaign file."""

    model_config = ConfigDict(extra="forbid")

    scenario: str
    runs: int = Field(gt=0, le=MAX_RUNS)
    master_seed: int = Field(ge=0, lt=2**63)
    batch_size: int = Field(64, gt=0, le=100_000, description="Runs per task (one compiled, vmapped call).")
    overrides: list[str] = Field(default_factory=list, description="`key.path=value` applied to every run first.")
    dispersions: list[Dispersion] = Field(default_factory=list)
    timeseries: list[str] = Field(
        default_factory=list, description="Recorded outputs to keep per run (Zarr), e.g. [\"omega\"]; none by default."
    )
    decimate: int = Field(1, gt=0, le=1_000_000, description="Keep every decimate-th sample of the time series.")
    description: str = ""


def bundled_campaign(name_or_path):
    """A campaign file's path: the path given, or a bundled campaign by name."""
    path = Path(name_or_path)
    if not path.exists() and str(name_or_path) in bundled_campaign_names():
        return Path(str(bundled_path(name_or_path)))
    return path


def load_campaign(path):
    """Read and validate a campaign file, and check every dispersion against its scenario.

    Parameters
    ----------
    path : str or Path
        A campaign file, or a bundled campaign's name (:func:`bundled_campaign_names`).

    Returns
    -------
    (Campaign, scenario_ref, fields)
        ``scenario_ref``: the bundled name or the resolved path; ``fields``: per dispersion,
        the concrete field paths it applies to (``*`` expanded).

    Raises
    ------
    CampaignError
    """
    path = bundled_campaign(path)
    if not path.exists() and path.suffix != ".toml" and len(path.parts) == 1:
        raise CampaignError(f"{clip_echo(str(path))}: neither a campaign file nor a bundled campaign "
                            "(`coopsat campaign list` names them)")
    try:
        raw = tomllib.loads(path.read_text())
    except OSError as err:
        raise CampaignError(f"{path}: {err.strerror or err}") from None
    except tomllib.TOMLDecodeError as err:
        raise CampaignError(f"{path}: not valid TOML ({err})") from None
    try:
        campaign = Campaign.model_validate(raw)
    except ValidationError as err:
        raise CampaignError(format_validation_error(err, model=Campaign)) from None
    ref = campaign.scenario
    if ref.endswith(".toml"):
        ref = str((path.parent / ref).resolve())
    try:
        base = load_scenario(ref, campaign.overrides)
    except ScenarioError as err:
        raise CampaignError(f"{path.name}: scenario '{clip_echo(campaign.scenario)}' with the overrides: {err}") from None
    resolved = tomllib.loads(resolved_toml(base))
    fields = [_expand(d, k, resolved) for k, d in enumerate(campaign.dispersions)]
    return campaign, ref, fields


def _expand(dispersion, k, resolved):
    """The concrete paths of a dispersion's field in the resolved scenario, each checked."""
    parts = dispersion.field.split(".")
    paths = [[]]
    for part in parts:
        nxt = []
        for p in paths:
            node = _get(resolved, p)
            if part == "*":
                if not isinstance(node, list):
                    raise CampaignError(f"dispersions[{k}].field: '{clip_echo(dispersion.field)}': `*` follows "
                                        f"'{'.'.join(p)}', which is not a list")
                nxt += [[*p, str(i)] for i in range(len(node))]
            else:
                nxt.append([*p, part])
        paths = nxt
    out = []
    for p in paths:
        value = _get(resolved, p)
        if value is _MISSING:
            raise CampaignError(f"dispersions[{k}].field: '{clip_echo('.'.join(p))}' is not a field of the scenario "
                                "(give it in the scenario or in `overrides` first)")
        if dispersion.distribution != "choice" and not _numeric(value):
            raise CampaignError(f"dispersions[{k}].field: '{clip_echo('.'.join(p))}' is {type(value).__name__} "
                                f"{clip_echo(value)}, not a number or a list of numbers")
        out.append(".".join(p))
    return out


_MISSING = object()


def _get(node, path):
    for part in path:
        if isinstance(node, dict) and part in node:
            node = node[part]
        elif isinstance(node, list) and part.isdigit() and int(part) < len(node):
            node = node[int(part)]
        else:
            return _MISSING
    return node


def _numeric(value):
    if isinstance(value, bool):
        return False
    if isinstance(value, (int, float)):
        return True
    return isinstance(value, list) and len(value) > 0 and all(_numeric(v) and not isinstance(v, list) for v in value)


def run_seed_sequences(master_seed, runs):
    """Every run's :class:`numpy.random.SeedSequence` (``SeedSequence(master).spawn(runs)``)."""
    return np.random.SeedSequence(master_seed).spawn(runs)


def draw_run(campaign, fields, bases, seq):
    """The values applied to one run, and its scenario seed.

    Parameters
    ----------
    fields : list of list of str
        Per dispersion, its concrete paths (:func:`load_campaign`).
    bases : dict of str -> value
        Each path's value in the undispersed scenario.
    seq : numpy.random.SeedSequence
        The run's.

    Returns
    -------
    (applied, seed)
        ``applied``: path -> value (float, or list of floats), in file order; ``seed``: the
        run's scenario seed.
    """
    rng = np.random.default_rng(seq)
    applied = {}
    for d, paths in zip(campaign.dispersions, fields):
        for path in paths:
            v = bases[path]
            shape = np.shape(v)
            if d.distribution == "choice":
                new = d.values[int(rng.integers(len(d.values)))]
            else:
                draw = rng.normal(d.mean, d.sigma, shape) if d.distribution == "normal" else rng.uniform(d.low, d.high, shape)
                v = np.asarray(v, dtype=float)
                new = v * (1.0 + draw) if d.mode == "relative" else v + draw if d.mode == "absolute" else draw
                new = new.tolist() if np.ndim(new) else float(new)
            applied[path] = new
    seed = int(rng.integers(0, 2**31 - 1))
    return applied, seed


def base_values(job):
    """Each dispersed path's value in the job's undispersed scenario."""
    resolved = tomllib.loads(job["scenario_toml"])
    return {p: _get(resolved, p.split(".")) for paths in job["fields"] for p in paths}


def overrides_for(applied, seed):
    """``--set`` strings that give a run its values and its seed."""
    import tomli_w

    out = []
    for path, value in applied.items():
        out.append(f"{path}={tomli_w.dumps({'v': value}).strip()[len('v = '):]}")
    return [*out, f"seed={seed}"]

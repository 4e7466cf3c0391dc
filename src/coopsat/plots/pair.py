"""Figure of a paired comparison (``coopsat pair``): each paired series of A and B over time,
and B − A, per seed.

A pure function of arrays (the pair layer sits above plots), object-oriented Matplotlib.
"""

import numpy as np
from matplotlib.figure import Figure


def pair_figure(names, series, spacecraft=None):
    """One row per paired series: A and B (left, log scale), B − A (right).

    Parameters
    ----------
    names : (str, str)
        Scenario names A and B.
    series : dict of str -> (DataArray, DataArray)
        Dims ``(seed, time, spacecraft)``, or ``(seed, time)`` for a formation-wide series; the
        spacecraft whose values are all NaN (the reference of a relative error) are left out.
        An attribute ``log_scale`` of 0 draws A and B on a linear axis (default log).
    spacecraft : str, optional
        Draw this spacecraft only.
    """
    fig = Figure(figsize=(10.0, 2.8 * max(len(series), 1) + 0.6), layout="constrained")
    axes = fig.subplots(max(len(series), 1), 2, squeeze=False)
    for row, (name, (sa, sb)) in enumerate(series.items()):
        if "spacecraft" not in sa.dims:  # one value for the formation: drawn as one "spacecraft"
            sa, sb = (x.expand_dims(spacecraft=["formation"], axis=-1) for x in (sa, sb))
        draw = axes[row, 0].semilogy if sa.attrs.get("log_scale", 1) else axes[row, 0].plot
        t = sa["time"].values
        scale = np.degrees(1.0) if sa.attrs.get("units") == "rad" else 1.0
        unit = "deg" if scale != 1.0 else sa.attrs.get("units", "")
        labels = list(names)  # A and B once in the legend, not once per spacecraft and seed
        for k, sc in enumerate(sa["spacecraft"].values):
            if (spacecraft is not None and sc not in (spacecraft, "formation")) or np.all(np.isnan(sa.values[:, :, k])):
                continue
            for s, seed in enumerate(sa["seed"].values):
                a, b = scale * sa.values[s, :, k], scale * sb.values[s, :, k]
                draw(t, a, lw=0.7, color="C0", alpha=0.8, label=labels[0])
                draw(t, b, lw=0.7, color="C1", alpha=0.8, label=labels[1])
                labels = [None, None]
                axes[row, 1].plot(t, b - a, lw=0.7, label=f"{sc}, seed {seed}")
        axes[row, 0].set_ylabel(f"{name} ({unit})")
        axes[row, 1].set_ylabel(f"B − A ({unit})")
        for ax in axes[row]:
            ax.grid(alpha=0.3, which="both")
        axes[row, 0].legend(fontsize="small")
        axes[row, 1].legend(fontsize="x-small")
    for ax in axes[-1]:
        ax.set_xlabel("time (s)")
    fig.suptitle(f"paired runs: B = {names[1]} against A = {names[0]}")
    return fig

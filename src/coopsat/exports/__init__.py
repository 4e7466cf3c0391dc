"""Standard exports of a finished run: CCSDS OEM (orbits), CCSDS AEM (attitudes), CZML (a
Cesium scene) — ``coopsat export`` and :func:`coopsat.export` (docs/export.md). The package is
``exports``, not ``export``: importing a subpackage ``coopsat.export`` would replace the public
function ``coopsat.export`` with the module.

Each format is a module with ``SUFFIX``, ``ONE_OBJECT_PER_FILE``, ``WHAT``, ``LIBRARY`` and
``render(run, name)``: the text of spacecraft ``name`` (one of ``run.names``) of ``run``, a
:class:`~coopsat.exports.run.RunStates`, or :class:`ExportError` for a run that lacks what the
format holds; a format of several objects per file is given ``run.names`` instead of one name.
:data:`FORMATS` names them, so a new format is a new module and a line here. The module and its
library (ccsds-ndm, czml3: the ``export`` extra, ``pip install 'coopsat[export]'``; ccsds-ndm is
GPL-3.0, so it stays out of a plain installation) are imported only when that format is asked for.

Where the output goes: a format of one object per file (OEM, AEM: the CCSDS messages describe
one object each) writes a file for a run of one spacecraft and a folder of ``<name>.<suffix>``
files for a formation; CZML writes one file. Everything is rendered before anything is
written, and written atomically, so a refusal or an interrupt leaves nothing behind.
"""

import importlib
import importlib.util
from pathlib import Path

from coopsat.exports.run import ExportError, read_states
from coopsat.workflows.folders import atomic_folder, unwritable_parent, write_text_atomically

FORMATS = {"oem": "coopsat.exports.oem", "aem": "coopsat.exports.aem", "czml": "coopsat.exports.czml"}
"""Format name -> the module that writes it."""

__all__ = ["FORMATS", "ExportError", "export_run"]


def _writer(fmt):
    if fmt not in FORMATS:
        raise ExportError(f"format {fmt!r}: choose one of {', '.join(FORMATS)}")
    writer = importlib.import_module(FORMATS[fmt])
    distribution, module = writer.LIBRARY
    if importlib.util.find_spec(module) is None:
        # an extra, not a dependency: ccsds-ndm is GPL-3.0, and a run needs neither library
        raise ExportError(f"{writer.WHAT} is written by {distribution}, which is not installed: pip install 'coopsat[export]'")
    return writer


def _default_out(source, run, fmt, writer, per_file):
    """``<scenario>.<suffix>`` (or the folder ``<scenario>-<format>``) in the run folder, or in
    the current folder for a run held in memory."""
    base = Path.cwd() if hasattr(source, "dataset") else Path(source)
    return base / (f"{run.scenario_name}-{fmt}" if per_file else f"{run.scenario_name}{writer.SUFFIX}")


def _check_target(out, folder, suffix):
    """Refuse a target that is the wrong kind of thing, or cannot be written, before rendering.

    An existing folder is replaced only when it is a previous export of this format (it holds
    nothing but ``*<suffix>`` files), so a mistyped ``--out`` never empties a folder.
    """
    if folder and out.exists() and not (out.is_dir() and all(p.is_file() and p.suffix == suffix for p in out.iterdir())):
        raise ExportError(f"{out}: exists and is not a folder of {suffix} files; choose another folder or remove it")
    if not folder and out.is_dir():
        raise ExportError(f"{out}: is a folder; name the file, e.g. {out / ('run' + suffix)}")
    parent = unwritable_parent(out)
    if parent is not None:
        raise ExportError(f"{out}: cannot write under {parent}")


def export_run(source, fmt, out=None):
    """Write a run in a standard format: :func:`coopsat.export` (``coopsat export``), whose
    docstring is the reference for the arguments (here ``source`` is its ``run`` and ``fmt`` its
    ``format``), the path returned and the :class:`ExportError` raised.
    """
    writer = _writer(fmt)
    run = read_states(source)
    per_file = writer.ONE_OBJECT_PER_FILE and len(run.names) > 1
    out = Path(out) if out is not None else _default_out(source, run, fmt, writer, per_file)
    _check_target(out, per_file, writer.SUFFIX)
    if not writer.ONE_OBJECT_PER_FILE:
        texts = {None: writer.render(run, run.names)}
    else:
        texts = {name: writer.render(run, name) for name in run.names}
    try:
        if per_file:
            with atomic_folder(out, ExportError) as tmp:
                for name, text in texts.items():
                    (tmp / f"{name}{writer.SUFFIX}").write_text(text, encoding="utf-8")
        else:
            out.parent.mkdir(parents=True, exist_ok=True)
            write_text_atomically(out, next(iter(texts.values())))
    except OSError as err:
        raise ExportError(f"{out}: cannot write it ({err.strerror or err})") from None
    return out

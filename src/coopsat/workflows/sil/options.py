"""The options of ``coopsat sil``, as data (the command line adds them; this module imports
only argparse, so building the parser stays quick)."""

import argparse

DESCRIPTION = ("run a scenario as software in the loop, one flight-software process per spacecraft; the plant, "
               "sensors, actuators and network stay here, the processes speak ZeroMQ and msgpack in lockstep, and the "
               "run folder is the one coopsat run writes, equal to it while every process answers (docs/sil.md)")

OPTIONS = (
    (("scenario",), {"help": "bundled scenario name or path to a .toml file"}),
    (("--out",), {"required": True, "metavar": "DIR", "help": "run folder"}),
    (("--kill",), {"action": "append", "default": [], "metavar": "SC@T_S",
                   "help": "kill that spacecraft's flight software at simulated time T_S (repeatable)"}),
    (("--pause",), {"action": "append", "default": [], "metavar": "SC@T_S:DURATION_S",
                    "help": "stop it at T_S for DURATION_S of simulated time (repeatable)"}),
    (("--external",), {"action": "append", "default": [], "metavar": 'SC="COMMAND"',
                       "help": "COMMAND is that spacecraft's flight software, speaking docs/sil.md's protocol (repeatable)"}),
    (("--fault-command",), {"choices": ("hold", "zero"), "default": None,
                            "help": "what a killed or paused spacecraft's actuators execute: its last command or zero "
                                    "(default: the scenario's sil.fault_command, hold)"}),
    (("--realtime",), {"type": float, "metavar": "FACTOR",
                       "help": "pace the run at FACTOR simulated seconds per second, each period's answers due within "
                               "its slot; deadline misses are counted and recorded, a late command held (default: "
                               "lockstep, as fast as it goes)"}),
    (("--answer-timeout",), {"type": float, "default": 10.0, "metavar": "S",
                             "help": "longest wait for a process's answer in one control period (default 10 s)"}),
    (("--start-timeout",), {"type": float, "default": 120.0, "metavar": "S",
                            "help": "longest wait for every process to start and answer the handshake (default 120 s)"}),
    (("--figures",), {"action": argparse.BooleanOptionalAction, "help": "also draw the PNG figures (or: coopsat plot)"}),
    (("--no-report",), {"action": "store_true", "help": "skip report.html (the interactive report)"}),
    (("--quiet", "-q"), {"action": "store_true",
                         "help": "print only warnings and errors (no process ids, events, folder line or metrics)"}),
)
"""``(flags, add_argument keywords)`` of each option, in the order ``--help`` lists them."""
